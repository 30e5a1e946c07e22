"""What one tick of a :class:`~screwgear_ros.sim.session.Session` did (:class:`Tick`),
and the row of numbers a tick's outputs make where only they are kept (replays)."""

from __future__ import annotations

from dataclasses import dataclass

from ..params.table import TableParams
from .commands import InputRejected
from .events import Event
from .plant import DriveInput, Outputs

#: Columns of an output row (:meth:`Session.advance` with ``rows``, replays; :func:`row_of`): the
#: joint_states row (θ, ω, effort of the three joints), the transmission error, the step.
ROW_JOINTS, ROW_TE, ROW_STEP = slice(0, 9), 9, 10
ROW = ROW_STEP + 1


def row_of(o: Outputs) -> tuple[float, ...]:
    """The ``ROW`` columns of ``o``."""
    return (*o.position, *o.velocity, *o.effort, o.transmission_error, o.step)


@dataclass(slots=True)
class Tick:
    """What one tick did. Read-only by convention, like :class:`~screwgear_ros.sim.plant.Outputs`
    and for the same reason not ``frozen``: one is made a tick."""

    start: int                          # step its events took effect at
    applied: tuple[Event, ...]          # those events, in order, ``step`` set
    rejected: tuple[InputRejected, ...]  # commands refused when they were to take effect
    notices: tuple[str, ...]            # inputs cut by a parameter change, for the log
    drive: DriveInput                   # input in force during the tick
    params: TableParams                 # parameters in force during the tick
    outputs: Outputs                    # at the tick's last step
    previous: Outputs                   # at its first step, before its events
    previous_direction: int             # commanded direction before the tick's events
    fault: str | None                   # why the plant stands still, if it does
    new_fault: bool                     # the model diverged during this tick
    measured: Outputs | None = None     # what the sensors measure of ``outputs`` (None:
    #                                     ``outputs`` itself, every sensor ideal)

    @property
    def start_ns(self) -> int:
        """Simulation time of ``start``, ns: the stamp of what took effect then."""
        return self.previous.time_ns

    @property
    def previous_path(self) -> int:
        """Active path before the tick's events."""
        return self.previous.active_path

    @property
    def reversal(self) -> bool:
        """The commanded direction changed at the tick's start."""
        return self.drive.direction != self.previous_direction

    @property
    def path_changed(self) -> bool:
        return self.outputs.active_path != self.previous_path


__all__ = ['ROW', 'ROW_JOINTS', 'ROW_STEP', 'ROW_TE', 'Tick', 'row_of']
