"""What the node makes of a session's ticks: messages, published and recorded.

:class:`RunIO` serializes each output of a tick once, straight into CDR bytes
(:mod:`screwgear_ros.bag.cdr`: no message objects, no rclpy serializer), and hands the
same bytes to the topic's publisher (rclpy publishes ``bytes`` as a serialized
message) and to the recorder (which then only queues them); it records every event a
tick applied at the step it took effect at (the bag contract of docs/recording.md).
The node gives it rclpy publishers (anything with ``publish(bytes)`` and
``get_subscription_count()``); an in-process recording
(:mod:`screwgear_ros.runs.session_record`) gives it none and gets the node's own
recording of a session, with no DDS. Every message is CDR bytes written here
(:mod:`screwgear_ros.bag.messages`, the templates), so nothing here imports rclpy.

A tick's topic that no subscription has matched is not published to: DDS would deliver
its message to nobody, and no later subscriber could get it (they are volatile: a reader
matched later never receives an earlier sample), so skipping it changes nothing anybody
can see. Asking the publisher's count costs less than a publish to nobody; a topic found
matched is published without asking again until
``LISTENER_RECOUNT`` s of wall time have passed, so a subscriber gets every message from
the one after its match on, and a topic whose last subscriber left is published to for
at most that long.

Besides the simulation's outputs it publishes and records what a viewer needs: the
URDF on ``robot_description`` (at the start, and again when a parameter change alters
it) and ``table_markers`` at most every ``MARKER_PERIOD`` s of wall time (about 30 Hz
whatever the simulation rate), and only when they are recorded or somebody subscribes
(lockstep's wait re-sends them to a viewer that came meanwhile), so the tick's own cost
stays small; they too are CDR bytes, from a template per look
(:class:`~screwgear_ros.view.markers.MarkerEncoder`).

Threads: :meth:`submit_change` and its :meth:`prepare` run on the node's executor
thread (they render a parameter change's run_parameters YAML and URDF before the change
is submitted, and hand them over under ``_rendered_lock``); :meth:`topic_specs` and
:meth:`open_recorder` run before the session ticks; every other method runs on the one
thread that ticks the session (the node's pacing thread).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..bag import messages
from ..bag.tick_encoder import TickEncoder, topic_specs
from ..params.table import SimSettings, TableParams
from ..sim import run_file as run_parameters
from ..sim.events import Command, ParameterChange, Setpoint
from ..sim.plant import Outputs
from ..sim.session import Session, Tick
from ..view.markers import MarkerEncoder
from ..view.urdf import robot_description

if TYPE_CHECKING:
    from ..bag.recorder import RunRecorder, TopicGroup, TopicSpec
# The recorder (the MCAP writer) is imported where a recording
# needs it, not at the node's start: a node that does not record never loads it.

#: Wall time between two table_markers, s (about 30 Hz).
MARKER_PERIOD = 1.0 / 30.0
#: Wall time after which a tick's topic found matched is asked for its subscribers again, s.
LISTENER_RECOUNT = 1.0


def serialize(msg: Any) -> bytes:
    """The recorder's serializer of a message handed over as an object: RunIO hands over
    nothing but CDR bytes, so it is never called.

    Raises
    ------
    TypeError
        Always: ``msg`` is not CDR bytes.
    """
    raise TypeError(f'RunIO records CDR bytes, not {type(msg).__name__}')


class RunIO:
    """Outputs and recording of one session; see the module docstring."""

    def __init__(self, topics: Mapping[str, str], joint_names: Sequence[str],
                 publishers: Mapping[str, Any] | None = None) -> None:
        self.topics = dict(topics)            # key → resolved name (topic_names)
        self.joint_names = list(joint_names)
        self._publishers = dict(publishers or {})
        # What every tick sends, in this order: fixed once the endpoints exist
        # (publish_clock is read-only), so publish_outputs() looks nothing up per tick.
        self._encoder = TickEncoder(self.topics, self.joint_names)
        self._tick_keys = self._encoder.keys
        self._joint_states_at = self._encoder.joint_states_at
        self._tick_publishers = [self._publishers.get(k) for k in self._tick_keys]
        self._tick_topics = [self.topics[k] for k in self._tick_keys]
        self._matched = [False] * len(self._tick_keys)   # found matched since the recount
        self._next_recount = 0.0              # time.monotonic() of the next recount
        self.recorder: RunRecorder | None = None
        self._tick_group: TopicGroup | None = None    # the recorder's group of _tick_topics
        self.last_joint_states: Any = None    # for lockstep's re-send while waiting
        self._path = 0                        # active path last published
        self._next_markers = 0.0              # time.monotonic() of the next table_markers
        self._marker_encoder: MarkerEncoder | None = None   # of the parameters in force
        self.description = ''                 # robot_description last published
        # (params, settings) → (run_parameters YAML, URDF), rendered by prepare() on the
        # executor thread before it submits the change; taken by the pacing thread.
        self._rendered: dict[tuple[Any, Any], tuple[str, str]] = {}
        self._rendered_lock = threading.Lock()

    def topic_specs(self) -> list[TopicSpec]:
        """The recorded topics, with types and the latched one."""
        return topic_specs(self.topics)

    def open_recorder(self, path: str | os.PathLike[str], **options: Any) -> RunRecorder:
        """Record from now on to a new rosbag2 directory (FileExistsError if taken)."""
        from ..bag.recorder import RunRecorder
        self.recorder = RunRecorder(path, self.topic_specs(), serialize, **options)
        self._tick_group = self.recorder.group(self._tick_topics)
        return self.recorder

    def render(self, session: Session, params: TableParams,
               settings: SimSettings) -> tuple[str, str]:
        """What a run with these parameters records and publishes about itself: the
        run_parameters YAML ('' without that topic) and the URDF ('' without
        robot_description). Any thread: it reads only the session's constants."""
        text = '' if 'run_parameters' not in self.topics else run_parameters.dump(
            run_parameters.RunParameters(params, settings, session.initial_state,
                                         session.start_step))
        urdf = '' if 'robot_description' not in self.topics else robot_description(
            params, settings, self.topics['joint_commands'], self.topics['joint_states'])
        return text, urdf

    def prepare(self, session: Session, params: TableParams, settings: SimSettings) -> None:
        """Executor thread, before it submits a parameter change: render its texts
        (:meth:`render`: YAML and XML) there, so that the pacing thread only takes them
        when the change takes effect: no parameter bookkeeping on the real-time thread."""
        rendered = self.render(session, params, settings)
        with self._rendered_lock:
            self._rendered[(params, settings)] = rendered

    def submit_change(self, session: Session, change: ParameterChange) -> None:
        """Executor thread: :meth:`prepare` the change's texts, then submit it to the
        session (the one way a node submits a parameter change)."""
        self.prepare(session, change.params, change.settings)
        session.submit(change)

    def _texts(self, session: Session, params: TableParams,
               settings: SimSettings) -> tuple[str, str]:
        """The texts of these parameters: prepared, or rendered now (the start,
        in-process sessions)."""
        key = (params, settings)
        with self._rendered_lock:
            rendered = self._rendered.pop(key, None)
        return rendered if rendered is not None else self.render(session, *key)

    # ------------------------------------------------------------------ per tick

    def start(self, session: Session) -> None:
        """The start of a run: its parameters, the URDF, the active path and the first
        outputs."""
        out = session.last_outputs
        self._parameters(session, out.time_ns, session.plant.params, session.settings)
        self._publish_path(out.active_path, out.time_ns)
        self.publish_outputs(out, measured=session.measured)
        self._markers(session, time.monotonic())

    def tick(self, session: Session, tick: Tick, lossless: bool = True) -> None:
        """Record what the tick applied, publish a changed path, publish its outputs.
        ``lossless``: a caller with no deadline (in-process runs, the node flat out) lets
        the recorder make the tick wait for room rather than drop it; the node in real
        time passes False."""
        t_ns = tick.start_ns
        for event in tick.applied:
            if isinstance(event, ParameterChange):
                self._parameters(session, t_ns, event.params, event.settings)
                if list(session.settings.joint_names) != self.joint_names:
                    self.joint_names = list(session.settings.joint_names)
                    self._encoder.rename(self.joint_names)
            elif isinstance(event, (Command, Setpoint)):
                if self.recorder is None:
                    continue
                if isinstance(event, Command):
                    self.record(event.topic, t_ns, messages.input_message(event.topic,
                                                                          event.value, t_ns))
                else:
                    self.record('setpoint', t_ns, messages.float64(event.value))
            elif 'reset' in self.topics:
                self.send('reset', t_ns, messages.empty())
        if tick.outputs.active_path != self._path:
            self._publish_path(tick.outputs.active_path, t_ns)
        self.publish_outputs(tick.outputs, lossless, tick.measured)
        now = time.monotonic()
        if now >= self._next_recount:
            self._next_recount = now + LISTENER_RECOUNT
            self._matched = [False] * len(self._tick_keys)
        self._markers(session, now)

    def publish_outputs(self, out: Outputs, lossless: bool = True,
                        measured: Outputs | None = None) -> None:
        """/clock, joint_states (``measured``: what the sensors measure of ``out``; None:
        ``out`` itself), mesh_state, transmission_error and ~/true_joint_states (``out``,
        if its topic is named) of ``out``; ``lossless`` as for :meth:`tick`
        (:meth:`RunRecorder.write_group`'s)."""
        t_ns = out.time_ns
        tick = self._encoder.encode(out, measured)
        self.last_joint_states = tick[self._joint_states_at]
        matched = self._matched
        for i, (publisher, msg) in enumerate(zip(self._tick_publishers, tick, strict=False)):
            if publisher is None:
                continue
            if not matched[i]:                # the module docstring: nobody, no publish
                if not publisher.get_subscription_count():
                    continue
                matched[i] = True
            publisher.publish(msg)
        if self.recorder is not None and self._tick_group is not None:   # one queue put
            self.recorder.write_group(self._tick_group, t_ns, tick, lossless)

    def send(self, key: str, t_ns: int, msg: Any) -> None:
        """Publish ``msg`` on the topic ``key`` and record it at ``t_ns``."""
        self.resend(key, msg)
        self.record(key, t_ns, msg)

    def resend(self, key: str, msg: Any) -> None:
        """Publish ``msg`` on ``key`` again, unrecorded (lockstep's re-send while waiting)."""
        publisher = self._publishers.get(key)
        if publisher is not None and msg is not None:
            publisher.publish(msg)

    def record(self, key: str, t_ns: int, msg: Any) -> None:
        if self.recorder is not None:
            self.recorder.write(self.topics[key], t_ns, msg)

    def _publish_path(self, path: int, t_ns: int) -> None:
        self._path = path
        self.send('active_path', t_ns, messages.int8(path))

    def _parameters(self, session: Session, t_ns: int, params: TableParams,
                    settings: SimSettings) -> None:
        """Publish and record the parameters taking effect at simulation time ``t_ns``
        (each change of a tick its own, in order: a ``ros2 bag record`` of the topic gets
        what this recorder writes); publish and record their URDF if it changed."""
        text, urdf = self._texts(session, params, settings)
        if text:
            self.send('run_parameters', t_ns, messages.string(text))
        if urdf and urdf != self.description:
            self.description = urdf
            self.send('robot_description', t_ns, messages.string(urdf))

    def _markers(self, session: Session, now: float) -> None:
        """table_markers of the last outputs (``now``: time.monotonic()), once
        ``MARKER_PERIOD`` s of wall time passed, if they are recorded or somebody
        subscribes to them. They are encoded from a template (drawn once per look) because
        building and serializing the message objects on the pacing thread, once for the
        publisher and again for the recorder, is the largest part of the node's tick
        jitter (bench_speed measures it)."""
        if 'table_markers' not in self.topics or now < self._next_markers:
            return
        self._next_markers = now + MARKER_PERIOD
        if self.recorder is None and not self._watched('table_markers'):
            return
        self.send('table_markers', *self._marker_message(session))

    def resend_markers(self, session: Session) -> None:
        """Lockstep's re-send while waiting: the last outputs' table_markers to whoever
        subscribes now (a viewer opened while the table waits), unrecorded."""
        if 'table_markers' in self.topics and self._watched('table_markers'):
            self.resend('table_markers', self._marker_message(session)[1])

    def _watched(self, key: str) -> bool:
        publisher = self._publishers.get(key)
        return publisher is not None and publisher.get_subscription_count() > 0

    def _marker_message(self, session: Session) -> tuple[int, bytes]:
        """(log time, table_markers CDR) of the session's last outputs."""
        out, params = session.last_outputs, session.plant.params
        t_ns = out.time_ns
        encoder = self._marker_encoder
        if encoder is None or not encoder.draws(params, self.joint_names):
            encoder = self._marker_encoder = MarkerEncoder(params, self.joint_names)
        return t_ns, encoder.encode(out, t_ns)


__all__ = ['RunIO', 'serialize']
