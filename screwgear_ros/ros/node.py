"""table_sim's node: the real-time rotary table plant a controller closes its loop around.

A thin shell over :class:`screwgear_ros.sim.session.Session` (``shared/spec/interface.md``):

* subscriptions, the parameter callback and ``~/reset`` only turn what arrives into
  session events (:meth:`Session.submit`); the session applies them at the first
  step of its next tick and validates commands then;
* a dedicated pacing thread (:class:`screwgear_ros.ros.pacing_thread.PacingThread`) ticks
  the session, sleeps to each tick's absolute deadline and hands the tick to
  :class:`screwgear_ros.runs.run_io.RunIO`, which publishes and records;
* with ``lockstep`` the pacing thread starts tick k+1 only once the controller has
  answered tick k's ``joint_states`` (a ``cmd_effort`` or ``joint_commands``, or
  ``~/tick`` from a tool): :class:`screwgear_ros.sim.pacing.AnswerGate`; while anything
  publishes on ``~/tick``, only ``~/tick`` answers (commands are then applied but
  answer nothing, so a tool can send any number of them in one tick);
* a ``setpoint`` (the controller's target, informational) is submitted like a command
  and only recorded: it changes nothing and never answers a tick;
* a ``joint_commands`` message that carries no command yet (ros2_control's NaN before
  any controller wrote the interface) is not submitted: no command, no warning, no
  rejection; in lockstep it still answers the tick, as ``~/tick`` does;
* SIGINT/SIGTERM stop the pacing thread first, then the recorder, the node, rclpy.

Who owns what: ``_values`` (the parameter values in force on the ROS side) belongs to
the executor thread: :func:`screwgear_ros.cli.table_sim.main` spins one single-threaded
executor (:data:`NODE_EXECUTOR`), so the parameter callbacks never run concurrently. The
session's queue is guarded by its own lock; the session, the RunIO, the pacer, the rate
limiter and the health record belong to the pacing thread, except ``RunIO.prepare``,
which the parameter callback calls to render a change's YAML and URDF off the pacing
thread before it accepts the change (the texts are handed over under RunIO's own lock).
``_gate`` is thread-safe, and so are ``_wake`` (a threading.Event the parameter callback
sets to wake the pacer) and ``_stop`` (a threading.Event that the signal thread of
:func:`~screwgear_ros.ros.shutdown.stop_on_signals`, a failed pacing thread and
``close()`` set; never a signal handler). Nothing is ever set to None.
"""

from __future__ import annotations

import threading
import time
from functools import partial
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

from ..interface import (
    ANSWER_TOPICS,
    ANSWERS,
    BY_KEY,
    LATCHED_OUTPUTS,
    TICK_TOPIC,
    Input,
)
from ..numerics.kernels import compiled_now, loads_without_registries, without_blas_probe
from ..params.table import ParameterError, SimSettings, TableParams
from ..physics.packed import pack
from ..runs.run_io import RunIO
from ..sim.commands import carries_no_command
from ..sim.events import Command, ParameterChange, Reset, Setpoint
from ..sim.pacing import AnswerGate, wall_period
from ..sim.parameter_set import split_parameters
from ..sim.ratelimit import RateLimiter
from ..sim.session import Session
from . import inputs, parameters
from .messages import INFO_TYPES, INPUT_TYPES, OUTPUT_TYPES
from .pacing_thread import PacingThread

#: Exit status of a node whose recording failed (a full disk): it ran, and stopped as
#: asked, but the bag ends at the fault (the log's ERROR line says where).
EXIT_RECORDING_FAILED = 3
#: ~/reset keeps every request and answer until delivered (the default keeps the last
#: 10: a burst of calls lost all but those that one executor wake-up took in time).
SERVICE_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
#: s of wall time between the checks for another node of the same full name, and how
#: many: discovery needs a moment, and the first joint_states must not wait for it.
NAME_CHECK_PERIOD = 1.0
NAME_CHECKS = 5
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: The executor that serves the node's callbacks. rclpy's events executor takes each
#: arrival as it comes, in C++; the SingleThreadedExecutor rebuilds its wait set from
#: every entity of the node (and each one's QoS event handlers) in Python at every wait,
#: holding the interpreter lock that the pacing thread needs to tick and publish: in
#: lockstep, where every tick waits for one arrival, that work is most of a tick's.
NODE_EXECUTOR = EventsExecutor


class TableSim(Node):
    """The node. ``start()`` launches the pacing thread, ``close()`` stops everything."""

    def __init__(self, stop: threading.Event) -> None:
        super().__init__('table_sim')
        self._stop = stop
        self._values, completed = parameters.declare(self, self.get_logger().info)
        # the validation's stability limit already calls the model's kernels: loaded as
        # the session's are below (without SciPy's BLAS or numba's registries)
        with without_blas_probe(), loads_without_registries():
            params, settings = split_parameters(self._values)   # ParameterError: refuse
        self._gate = AnswerGate()
        self._wake = threading.Event()     # set when a parameter change is submitted
        self._refusals = RateLimiter(1.0)          # inputs refused unread (executor thread)
        self._refused: dict[str, int] = {}         # their count per topic (executor thread)
        self.recording_failed = False

        # Endpoints before the session: DDS discovers them on its own threads while the
        # session loads its compiled kernels (no callback runs before main() spins).
        publishers = {key: self.create_publisher(
            kind, topic, LATCHED if key in LATCHED_OUTPUTS else 10)
            for key, (topic, kind) in OUTPUT_TYPES.items()
            if (key != 'clock' or settings.publish_clock)
            and (key != 'true_joint_states' or not settings.sensors.ideal)}
        # The setpoint first and answers last: the events executor serves arrivals in
        # their order, and an executor that serves the ready subscriptions of one wait in
        # creation order (the SingleThreadedExecutor) then also applies a setpoint or a
        # command that arrived with an answer.
        notes = {topic: self.create_subscription(INFO_TYPES[topic], topic,
                                                 partial(self._on_setpoint, topic), 10)
                 for topic in INFO_TYPES}
        ordered = sorted(INPUT_TYPES, key=lambda topic: topic in ANSWER_TOPICS)
        # Raw: a message's size is looked at before it is decoded (ros/inputs.py).
        subs = {topic: self.create_subscription(INPUT_TYPES[topic], topic,
                                                partial(self._on_command, topic), 10, raw=True)
                for topic in ordered}
        self._tick_sub = self.create_subscription(Empty, f'~/{TICK_TOPIC}', self._on_tick, 10)
        self.create_service(Trigger, BY_KEY['reset_service'].name, self._on_reset,
                            qos_profile=SERVICE_QOS)
        self._name_checks = 0
        self._name_timer = self.create_timer(NAME_CHECK_PERIOD, self._check_name)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        started = time.perf_counter()
        # numba's first loads, without SciPy's BLAS or the registries only a compile uses
        with without_blas_probe(), loads_without_registries():
            self.session = Session(params, settings)
            self.session.plant.advance(0)    # load (or compile) the integrator now, not in tick 1
        if compiled_now():
            self.get_logger().info(
                f'compiled the numba model in {time.perf_counter() - started:.1f} s: its cache '
                'was missing (ros2 run screwgear_ros warmup after an install avoids this)')
        self._fqn = self.get_fully_qualified_name()
        topics = {key: pub.topic_name for key, pub in publishers.items()}
        topics.update({topic: sub.topic_name for topic, sub in subs.items()})
        topics.update({topic: sub.topic_name for topic, sub in notes.items()})
        self.io = RunIO(topics, settings.joint_names, publishers)
        self._derive(params, settings, keep=False)   # ParameterError: refuse to start
        if completed:
            self.get_logger().info(completed)
        if settings.record:
            self.io.open_recorder(settings.record, on_error=self._recording_failed)
        self._pacing = PacingThread(self.session, self.io, self._gate, stop, self._wake,
                                    self.get_logger(), self._fqn, self._refused)

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        s, p = self.session.settings, self.session.plant.params
        line = (f'{p.mode} mode, mesh phase {p.mesh_phase}, dt = {s.dt * 1e6:g} us, '
                f'{s.publish_rate:g} Hz ({s.steps_per_publish} steps per tick), real-time '
                f'factor {s.real_time_factor:g}'
                + (', lockstep: each tick waits for the controller\'s answer '
                   f'({ANSWERS}) to the last joint_states' if s.lockstep else '')
                + (f', recording to {s.record}' if s.record else '')
                + (f', stops at t = {s.duration:g} s (duration)' if s.duration else ''))
        # The first tick before the start's log lines: rclpy's first log call in a process
        # looks up the source file of every module loaded (inspect.getmodule), and the
        # first joint_states need not wait for that.
        self._pacing.start()
        for name in parameters.unknown_overrides(self):
            self.get_logger().warning(f'parameter {name!r} is not a table_sim parameter; '
                                      'ignored (a typo?)')
        self.get_logger().info(line)

    def close(self) -> None:
        """Stop and join the pacing thread, then close the recorder (idempotent).

        The recorder is closed even if the pacing thread did not end in time: a
        message it writes after that is counted as dropped, never lost silently.
        """
        self._stop.set()
        self._wake.set()
        self._gate.release()
        if not self._pacing.join(timeout=5.0):
            self.get_logger().error('the pacing thread did not stop within 5 s')
        recorder = self.io.recorder
        if recorder is not None and not recorder.closed:
            recorder.close()
            self.get_logger().info(f'recording closed: {recorder.written} messages written, '
                                   f'{recorder.dropped} dropped')

    def exit_code(self) -> int:
        """1 after a bug in the pacing thread, EXIT_RECORDING_FAILED after a failed
        recording, else 0."""
        return 1 if self.failed else EXIT_RECORDING_FAILED if self.recording_failed else 0

    @property
    def failed(self) -> bool:
        """Whether the pacing thread ended in a bug."""
        return self._pacing.failed

    def _recording_failed(self, what: str) -> None:
        """The recorder's writer thread, once, after it closed the bag at a write error:
        the simulation goes on (a controller may depend on it), unrecorded."""
        self.recording_failed = True
        self.get_logger().error(what)

    # ------------------------------------------------------------------ executor side

    def _on_command(self, topic: str, data: bytes) -> None:
        refused = inputs.oversized(topic, data)
        if refused is not None:
            self._refused[topic] = self._refused.get(topic, 0) + 1
            emit, held = self._refusals.allow(topic)
            if emit:
                self.get_logger().warning(
                    refused + (f' ({held} more refused since the last warning)' if held else ''))
        else:
            self._command(topic, inputs.value(topic, data))
        if refused is not None and self._answers(topic):
            self._gate.answer()         # an answer, if a bad one, as a rejected command is

    def _command(self, topic: str, value: Any) -> None:
        if not carries_no_command(topic, value, self.session.settings.joint_names):
            self.session.submit(Command.of(topic, value))
        if self._answers(topic):
            self._gate.answer()

    def _on_setpoint(self, topic: str, msg: Any) -> None:
        """The controller's setpoint: recorded at the next tick's first step (the session
        refuses a non-finite one), never an answer."""
        self.session.submit(Setpoint(msg.data))

    def _answers(self, topic: str) -> bool:
        """Whether a message on ``topic`` answers the last tick in lockstep. A tool that
        answers with ~/tick owns the ticks: while anything publishes there, commands are
        only applied, so a replay can send several in one tick. Free-running, the answers
        are only counted (min_answer_rate), and ros2_control's joint_commands are none:
        its controller manager writes them on its own update clock, not per joint_states,
        so their timing says nothing about a late controller."""
        if topic == Input.JOINT_COMMANDS and not self.session.settings.lockstep:
            return False
        return topic in ANSWER_TOPICS and not self._tick_sub.get_publisher_count()

    def _on_tick(self, msg: Empty) -> None:
        self._gate.answer()

    def _on_set_parameters(self, changed: list[Any]) -> SetParametersResult:
        candidate = parameters.changed_values(self._values, changed)
        if candidate == self._values:
            return SetParametersResult(successful=True)
        try:
            params, settings = split_parameters(candidate)
            self._derive(params, settings)
        except ParameterError as error:
            return SetParametersResult(successful=False, reason=str(error))
        self._values = candidate
        self.session.submit(ParameterChange(params, settings))
        self._wake.set()                     # the pacer runs the tick that applies it now
        return SetParametersResult(successful=True)

    def _check_name(self) -> None:
        """Warn once if another node of this full name runs in the domain: both would
        publish on the same topics, and a subscriber would see two tables' stamps."""
        self._name_checks += 1
        ours = (self.get_name(), self.get_namespace())
        same = sum(1 for node in self.get_node_names_and_namespaces() if node == ours)
        if same > 1:
            self.get_logger().warning(
                f'another node named {self._fqn} runs in this ROS domain: both publish on '
                'the same topics, and a subscriber gets both tables\' messages (stamps going '
                'back and forth); give each its own namespace (--ros-args -r __ns:=/axis_b)')
        if same > 1 or self._name_checks >= NAME_CHECKS:
            self._name_timer.cancel()

    def _derive(self, params: TableParams, settings: SimSettings, keep: bool = True) -> None:
        """Derive everything a parameter set needs before it is accepted: the pace, the
        compiled model's packed parameters, the run_parameters text and the URDF
        (with ``keep``, prepared here for the pacing thread; the start renders them again
        once its recorder is open; the stability limit is split_parameters'). A failure
        refuses the set with the reason instead of failing where it takes effect."""
        try:
            wall_period(settings.steps_per_publish * settings.dt, settings.real_time_factor)
            pack(params)
            if keep:
                self.io.prepare(self.session, params, settings)
            else:
                self.io.render(self.session, params, settings)
        except (ArithmeticError, ValueError) as error:
            if isinstance(error, ParameterError):
                raise
            raise ParameterError('parameters', '…', 'what the node derives from them cannot '
                                 f'be computed ({type(error).__name__}: {error})') from None

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.session.submit(Reset())
        response.success = True
        response.message = ('reset queued: the table returns to the preload equilibrium at '
                            'the first step of the next tick (the log says when)')
        return response


__all__ = ['EXIT_RECORDING_FAILED', 'NODE_EXECUTOR', 'TableSim']
