"""What an in-process run gives a controller and gives back: the :class:`Observation` of
each tick and the :class:`Run` of all of them, on one column layout (the plant's observed
vector).

``position``/``velocity`` mean, on both, what joint_states carries: the joint sensors'
measurement (the exact state when every sensor is ideal). The exact state is
``true_position``/``true_velocity`` (the node's ~/true_joint_states).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..params.table import SimSettings, TableParams
from ..sim.plant import OBSERVED_DELTA, OBSERVED_JOINTS


@dataclass(slots=True)
class Observation:
    """What one tick publishes, SI units. Read-only by convention (slotted, not frozen:
    one is made a tick). ``position``, ``velocity`` and ``effort`` are per joint in
    joint_states order (pinion 1, table, pinion 3): what the joint sensors measure
    (:mod:`screwgear_ros.physics.sensors`; the exact state when they are ideal), and
    ``true_position``, ``true_velocity`` the exact state (~/true_joint_states);
    ``delta``, ``delta_rate`` and ``mesh_force`` are mesh_state's values (mesh 1,
    mesh 3).

    Examples
    --------
    >>> from screwgear_ros import Simulation
    >>> sim = Simulation()
    >>> first = sim.reset()
    >>> first.step, len(first.position)
    (0, 3)
    """

    time: float                                # simulation time, s (step·dt)
    step: int                                  # integration steps since the start
    position: tuple[float, float, float]       # rad
    velocity: tuple[float, float, float]       # rad/s
    effort: tuple[float, float, float]         # N·m
    transmission_error: float                  # δ of the active path, m
    delta: tuple[float, float]                 # δ1, δ3, m
    delta_rate: tuple[float, float]            # δ̇1, δ̇3, m/s
    mesh_force: tuple[float, float]            # F1, F3, N
    active_path: int                           # 1 or 3
    fault: str | None                          # why the plant stands still, if it does
    true_position: tuple[float, float, float] = (0.0, 0.0, 0.0)   # rad, exact
    true_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)   # rad/s, exact


def observation_of(tick_outputs: Any, fault: str | None, measured: Any = None) -> Observation:
    """The observation of a tick's outputs (``measured``: what the sensors measured of
    them; None: the outputs themselves)."""
    o = tick_outputs
    m = o if measured is None else measured
    return Observation(o.time, o.step, m.position, m.velocity, o.effort,
                       o.delta[0] if o.active_path == 1 else o.delta[1], o.delta,
                       o.delta_rate, o.mesh_force, o.active_path, fault, o.position,
                       o.velocity)


#: Columns of :attr:`Run.observed`, the plant's observed vector of each sample
#: (:data:`~screwgear_ros.numerics.integrator.OBSERVED` wide): θ, ω and effort of the three joints
#: (a joint_states row), then δ, δ̇ and F of mesh 1 and of mesh 3 (mesh_state's values).
JOINTS = OBSERVED_JOINTS
MESH_1, MESH_3 = OBSERVED_DELTA[1], OBSERVED_DELTA[3]
DELTA, DELTA_RATE, MESH_FORCE = [MESH_1, MESH_3], [MESH_1 + 1, MESH_3 + 1], \
    [MESH_1 + 2, MESH_3 + 2]


@dataclass
class Run:
    """The samples of a closed-loop run: sample 0 is the start (what :meth:`Simulation.reset`
    returned), sample i > 0 what tick i made. ``command[i]`` is the effort the controller
    answered sample i with (NaN: no command; the last sample is not answered).

    As on :class:`Observation`, ``position``, ``velocity`` and ``joint_states`` are what
    joint_states carries (measured by the joint sensors; the exact state when they are
    ideal) and ``true_position``, ``true_velocity``, ``true_joint_states`` the exact
    state (the node's ~/true_joint_states).

    Examples
    --------
    >>> from screwgear_ros import Simulation
    >>> run = Simulation().run(lambda observation: 10.0, 0.005)
    >>> run.position.shape[1], bool((run.time[1:] > run.time[:-1]).all())
    (3, True)
    """

    params: TableParams
    settings: SimSettings
    step: np.ndarray          # (n,) int64
    observed: np.ndarray      # (n, OBSERVED) float64, columns above
    path: np.ndarray          # (n,) int8: the active path, 1 or 3
    direction: np.ndarray     # (n,) int8: the commanded direction during the sample's tick
    command: np.ndarray       # (n,) float64, N·m
    fault: str | None = None  # why the plant stood still, if it faulted
    record: Path | None = None
    #: Scheduled commands the session refused when they were to take effect (the node
    #: logs these and keeps the last valid command in force), as (step, message).
    rejected: list[tuple[int, str]] = field(default_factory=list)
    #: (n, 6): θ and ω of the three joints as joint_states published them, measured by
    #: the joint sensors (None: the sensors are ideal, the exact :attr:`observed` ones)
    measured: np.ndarray | None = None

    @property
    def time(self) -> np.ndarray:
        """Simulation time of each sample, s."""
        return self.step * self.settings.dt

    @property
    def joint_states(self) -> np.ndarray:
        """(n, 9): θ, ω, effort of the three joints as joint_states carries them: θ and ω
        measured by the joint sensors (:attr:`position`, :attr:`velocity`)."""
        if self.measured is None:
            return self.observed[:, JOINTS]
        return np.hstack([self.measured, self.effort])

    @property
    def true_joint_states(self) -> np.ndarray:
        """(n, 9): the exact θ, ω, effort of the three joints (~/true_joint_states)."""
        return self.observed[:, JOINTS]

    @property
    def position(self) -> np.ndarray:
        """(n, 3): θ of the three joints as joint_states carries it (measured), rad."""
        return self.true_position if self.measured is None else self.measured[:, 0:3]

    @property
    def velocity(self) -> np.ndarray:
        """(n, 3): ω of the three joints as joint_states carries it (measured), rad/s."""
        return self.true_velocity if self.measured is None else self.measured[:, 3:6]

    @property
    def true_position(self) -> np.ndarray:
        """(n, 3): the exact θ of the three joints (~/true_joint_states), rad."""
        return self.observed[:, 0:3]

    @property
    def true_velocity(self) -> np.ndarray:
        """(n, 3): the exact ω of the three joints (~/true_joint_states), rad/s."""
        return self.observed[:, 3:6]

    @property
    def effort(self) -> np.ndarray:
        return self.observed[:, 6:9]

    @property
    def delta(self) -> np.ndarray:
        """(n, 2): δ1, δ3, m."""
        return self.observed[:, DELTA]

    @property
    def delta_rate(self) -> np.ndarray:
        return self.observed[:, DELTA_RATE]

    @property
    def mesh_force(self) -> np.ndarray:
        return self.observed[:, MESH_FORCE]

    @property
    def transmission_error(self) -> np.ndarray:
        """δ of the active path, m (the transmission_error topic)."""
        return np.where(self.path == 1, self.observed[:, MESH_1], self.observed[:, MESH_3])

    @property
    def active_path(self) -> np.ndarray:
        return self.path

    def __len__(self) -> int:
        return len(self.step)


__all__ = ['DELTA', 'DELTA_RATE', 'JOINTS', 'MESH_1', 'MESH_3', 'MESH_FORCE', 'Observation',
           'Run', 'observation_of']
