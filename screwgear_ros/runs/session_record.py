"""In-process recorded runs: the node's own session and RunIO, with no DDS, no node and
no rclpy.

:class:`SessionRecording` records a :class:`~screwgear_ros.sim.session.Session` that the
caller ticks, with the node's :class:`~screwgear_ros.runs.run_io.RunIO` (publishers none),
so a bag is written exactly as table_sim writes it, tick by tick, as fast as the machine
goes and dropping nothing (the recorder makes a tick wait for room rather than drop
it). :func:`record_session` plays a :class:`~screwgear_ros.sim.schedule.Schedule` into a
fresh session that way. RunIO writes the node's messages as CDR bytes itself, so
recording needs no ROS message package; the core's
:class:`~screwgear_ros.inprocess.simulation.Simulation` imports this module only when asked to
record (it loads the bag writer).
"""

from __future__ import annotations

import os
from typing import Any, Self

from ..bag.recorder import RunRecorder
from ..interface import topic_names
from ..sim.events import ParameterChange
from ..sim.schedule import Schedule
from ..sim.session import Session, Tick
from .run_io import RunIO


class SessionRecording:
    """The node's recording of ``session``, from its current outputs on: create it
    before the first tick, hand it every tick (:meth:`tick`), then :meth:`close` (or use
    it as a context manager; closing twice is harmless). ``namespace``: the namespace the
    recorded topics are in, as a node started in it would name them."""

    def __init__(self, path: str | os.PathLike[str], session: Session, namespace: str = '',
                 **recorder_options: Any) -> None:
        self.session = session
        self.io = RunIO(topic_names(namespace, clock=session.settings.publish_clock,
                                    true_states=not session.settings.sensors.ideal),
                        session.settings.joint_names)
        self.recorder: RunRecorder = self.io.open_recorder(path, **recorder_options)
        try:
            self.io.start(session)
        except BaseException:          # Ctrl-C included: the bag opened is still closed
            self.recorder.close()
            raise

    def submit_change(self, change: ParameterChange) -> None:
        """Submit a parameter change to the session with its texts rendered first, as the
        node's executor does (RunIO.submit_change)."""
        self.io.submit_change(self.session, change)

    def tick(self, tick: Tick | None) -> None:
        """Record what the session's last tick did and made (a full tick: a recorded
        advance never takes the fast path that makes no Tick).

        Raises
        ------
        ValueError
            If ``tick`` is None.
        """
        if tick is None:
            raise ValueError('a recording needs every tick in full: advance with '
                             'mode=AdvanceMode.TICKS')
        self.io.tick(self.session, tick)

    def close(self) -> RunRecorder:
        """Close the bag (waits until every message is written); the closed recorder."""
        self.recorder.close()
        return self.recorder

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def record_session(path: str | os.PathLike[str], schedule: Schedule, namespace: str = '',
                   prepare: bool = False, **recorder_options: Any) -> RunRecorder:
    """Run ``schedule`` in-process, recording to ``path`` as the node would; each event
    is submitted once the outputs of its step are out (it takes effect at the next
    tick's first step). ``prepare``: render each parameter change's texts before it is
    submitted, as the node's executor does (RunIO.prepare). Returns the closed recorder
    (for its counters)."""
    session = Session(schedule.params, schedule.settings)
    with SessionRecording(path, session, namespace, **recorder_options) as recording:
        session.advance(until=schedule.end_step, events=schedule.events,
                        changes=recording.submit_change if prepare else None,
                        monitor=recording.tick)
    return recording.recorder


__all__ = ['SessionRecording', 'record_session']
