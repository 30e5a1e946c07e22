"""table_sim: the real-time rotary table plant a controller closes its loop around.

A thin shell over :class:`screwgear_ros.plant.Plant` (``shared/spec/interface.md``):

* a dedicated pacing thread integrates each publish tick's steps in one compiled
  ``Plant.advance(n)`` call, sleeps to the tick's absolute deadline
  (:class:`screwgear_ros.pacing.Pacer`) and publishes; the executor only serves
  subscriptions, parameters and the reset service;
* command callbacks validate (:mod:`screwgear_ros.commands`) and store the latest
  input under a lock; the pacing thread applies everything accepted since the last
  tick at the first step of its next batch, so the step a command took effect at is
  one integer (written to the recording, if any);
* parameter changes are validated by the core and applied the same way;
* SIGINT/SIGTERM stop the pacing thread first, then the recorder, the node and rclpy.
"""

from __future__ import annotations

import threading
import time
import traceback
from functools import partial
from typing import Any

import rclpy
import rclpy.logging
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64, Float64MultiArray, Int8, String
from std_srvs.srv import Trigger

from ..commands import INPUT_TOPICS, InputRejected, apply_command
from ..model import active_path
from ..pacing import FactorMeter, Pacer, sim_time_ns
from ..params import ParameterError, split_parameters
from ..plant import DriveInput, Outputs, Plant
from ..ratelimit import RateLimiter
from .. import run_parameters
from ..ros import messages, parameters
from ..ros.shutdown import spin_until, stop_on_signals
from ..status import (MAX_PHASE_PER_STEP, Health, diagnostic_values, mesh_phase_per_step,
                      status_line)

INPUT_TYPES = {'cmd_torque': Float64, 'cmd_direction': Int8, 'cmd_effort': Float64MultiArray,
               'load_torque': Float64}
DIAGNOSTICS_PERIOD = 1.0    # s of wall time between /diagnostics
STATUS_PERIOD = 5.0         # s of wall time between status log lines
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


class TableSim(Node):
    """The node. ``start()`` launches the pacing thread, ``close()`` stops everything."""

    def __init__(self, stop: threading.Event) -> None:
        super().__init__('table_sim')
        self._stop = stop
        self._values = parameters.declare(self)
        params, settings = split_parameters(self._values)   # ParameterError: refuse to start
        self._accepted = params          # what the next command is validated against
        self.plant = Plant(params, settings.dt)
        self._settings = settings         # pacing thread's copy
        self._lock = threading.Lock()     # guards _drive, _events, _rejected
        self._drive = DriveInput()
        self._events: list[tuple[Any, ...]] = []
        self._rejected = {topic: 0 for topic in INPUT_TOPICS}
        self._warnings = RateLimiter(1.0)
        self.failed = False
        self._fault_reported = False

        self._pub_joints = self.create_publisher(JointState, 'joint_states', 10)
        self._pub_mesh = self.create_publisher(JointState, 'mesh_state', 10)
        self._pub_te = self.create_publisher(Float64, 'transmission_error', 10)
        self._pub_path = self.create_publisher(Int8, 'active_path', LATCHED)
        self._pub_clock = (self.create_publisher(Clock, '/clock', 10) if settings.publish_clock
                           else None)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._subs = [self.create_subscription(kind, topic, partial(self._on_command, topic), 10)
                      for topic, kind in INPUT_TYPES.items()]
        self._input_topic = {topic: sub.topic_name for topic, sub in zip(INPUT_TYPES, self._subs)}
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._fqn = self.get_fully_qualified_name()
        self._start_state = tuple(float(v) for v in self.plant.state)
        self._recorder = self._open_recorder(settings.record) if settings.record else None
        self._thread = threading.Thread(target=self._run, name='table_sim pacing', daemon=True)

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        s = self._settings
        for name in parameters.unknown_overrides(self):
            self.get_logger().warning(f'parameter {name!r} is not a table_sim parameter; '
                                      'ignored (a typo?)')
        self.get_logger().info(
            f'{self.plant.params.mode} mode, mesh phase {self.plant.params.mesh_phase}, '
            f'dt = {s.dt * 1e6:g} us, {s.publish_rate:g} Hz ({s.steps_per_publish} steps per '
            f'tick), real-time factor {s.real_time_factor:g}'
            + (f', recording to {s.record}' if s.record else ''))
        self._thread.start()

    def close(self) -> None:
        """Stop and join the pacing thread, then close the recorder (idempotent)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        if self._recorder is not None:
            recorder, self._recorder = self._recorder, None
            recorder.close()
            self.get_logger().info(f'recording closed: {recorder.written} messages written, '
                                   f'{recorder.dropped} dropped')

    def _open_recorder(self, path: str) -> Any:
        from ..runs.recorder import RunRecorder, TopicSpec
        topics = [TopicSpec(pub.topic_name, _msgtype(pub.msg_type),
                            pub is self._pub_path)
                  for pub in (self._pub_joints, self._pub_mesh, self._pub_te, self._pub_path,
                              self._pub_clock, self._pub_diag) if pub is not None]
        topics += [TopicSpec(sub.topic_name, _msgtype(sub.msg_type)) for sub in self._subs]
        topics += [TopicSpec(self._fqn + '/run_parameters', 'std_msgs/msg/String'),
                   TopicSpec(self._fqn + '/reset', 'std_msgs/msg/Empty')]
        return RunRecorder(path, topics, serialize_message)

    # ------------------------------------------------------------------ executor side

    def _on_command(self, topic: str, msg: Any) -> None:
        value = list(msg.data) if topic == 'cmd_effort' else msg.data
        rejected = None
        with self._lock:
            try:
                self._drive = apply_command(self._drive, topic, value, self._accepted)
            except InputRejected as error:
                self._rejected[topic] += 1
                rejected = error
            else:
                if self._recorder is not None:
                    self._events.append(('input', topic, msg))
        if rejected is not None:
            emit, held = self._warnings.allow(topic)
            if emit:
                more = f' ({held} more rejected since the last warning)' if held else ''
                self.get_logger().warning(f'{rejected}{more}')

    def _on_set_parameters(self, changed: list[Any]) -> SetParametersResult:
        candidate = parameters.changed_values(self._values, changed)
        if candidate == self._values:
            return SetParametersResult(successful=True)
        try:
            params, settings = split_parameters(candidate)
        except ParameterError as error:
            return SetParametersResult(successful=False, reason=str(error))
        self._values, self._accepted = candidate, params
        with self._lock:
            self._events.append(('params', params, settings))
        return SetParametersResult(successful=True)

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        done: dict[str, Any] = {'event': threading.Event()}
        with self._lock:
            self._events.append(('reset', done))
        if done['event'].wait(timeout=2.0):
            response.success = True
            response.message = (f'reset to the preload equilibrium at t = {done["time"]:.6f} s '
                                f'(step {done["step"]})')
        else:
            response.success = True
            response.message = 'reset requested; it takes effect at the next step'
        return response

    # ------------------------------------------------------------------ pacing thread

    def _run(self) -> None:
        try:
            self._loop()
        except Exception:  # a bug: say so loudly, then let main() end the process
            self.failed = True
            self.get_logger().fatal('pacing thread failed:\n' + traceback.format_exc())
            self._stop.set()

    def _loop(self) -> None:
        plant, s = self.plant, self._settings
        pacer = Pacer(s.steps_per_publish * s.dt, s.real_time_factor)
        meter = FactorMeter()
        self._health = Health(s.real_time_factor, float('nan'), pacer.stats,
                              dict(self._rejected), dt=s.dt)
        self._record_parameters(plant.step)
        path = active_path(plant.params.mode, plant.input.direction)
        self._publish_path(path, plant.step)
        self._publish_outputs(plant.outputs())
        next_status = time.monotonic() + STATUS_PERIOD
        while not self._stop.is_set():
            pacer = self._apply_events(pacer)
            # After a fault the plant stands still (state and time) until ~/reset; the
            # node keeps publishing that last finite state every tick.
            if not plant.advance(self._settings.steps_per_publish):
                self._report_fault()
            out = plant.outputs()
            if not pacer.wait(self._stop):
                break
            self._publish_outputs(out)
            if meter.elapsed() >= DIAGNOSTICS_PERIOD:
                self._health.achieved_factor = meter.update(out.time)
                self._publish_diagnostics(out)
                if time.monotonic() >= next_status:
                    next_status += STATUS_PERIOD
                    self.get_logger().info(status_line(out, self._health.achieved_factor))

    def _apply_events(self, pacer: Pacer) -> Pacer:
        """Apply everything accepted since the last batch, in order, at plant.step."""
        plant = self.plant
        with self._lock:
            events, self._events = self._events, []
            drive = self._drive
        step = plant.step
        for event in events:
            kind = event[0]
            if kind == 'input':
                self._record(self._input_topic[event[1]], step, event[2])
            elif kind == 'params':
                params, settings = event[1], event[2]
                plant.set_params(params)
                if (settings.steps_per_publish != self._settings.steps_per_publish
                        or settings.real_time_factor != self._settings.real_time_factor):
                    pacer.restart(settings.steps_per_publish * settings.dt,
                                  settings.real_time_factor)
                    self._health.requested_factor = settings.real_time_factor
                self._settings = settings
                self._record_parameters(step)
            else:
                plant.reset()
                self._fault_reported = False
                self._record(self._fqn + '/reset', step, Empty())
                event[1].update(time=plant.time, step=step)
                event[1]['event'].set()
                self.get_logger().info(f'reset to the preload equilibrium at t = '
                                       f'{plant.time:.6f} s')
        if drive != plant.input:
            old_path = active_path(plant.params.mode, plant.input.direction)
            if drive.direction != plant.input.direction:
                new_path = active_path(plant.params.mode, drive.direction)
                self.get_logger().info(
                    f'reversal at t = {plant.time:.6f} s: direction {drive.direction:+d}, '
                    f'active path {old_path} -> {new_path}')
                if new_path != old_path:
                    self._publish_path(new_path, step)
            plant.set_input(drive)
        return pacer

    def _report_fault(self) -> None:
        if not self._fault_reported:
            self._fault_reported = True
            self.get_logger().error(f'{self.plant.fault}; simulation halted, publishing the '
                                    'last finite state; call ~/reset to restart from '
                                    'equilibrium')

    def _record(self, topic: str, step: int, msg: Any) -> None:
        if self._recorder is not None:
            self._recorder.write(topic, sim_time_ns(step, self.plant.dt), msg)

    def _record_parameters(self, step: int) -> None:
        if self._recorder is not None:
            text = run_parameters.dump(run_parameters.RunParameters(
                self.plant.params, self._settings, self._start_state, 0))
            self._record(self._fqn + '/run_parameters', step, String(data=text))

    def _publish_path(self, path: int, step: int) -> None:
        msg = messages.active_path(path)
        self._pub_path.publish(msg)
        self._record(self._pub_path.topic_name, step, msg)

    def _publish_outputs(self, out: Outputs) -> None:
        t_ns = sim_time_ns(out.step, self.plant.dt)
        batch = []
        if self._pub_clock is not None:
            batch.append((self._pub_clock, messages.clock(t_ns)))
        batch += [(self._pub_joints, messages.joint_states(out, list(self._settings.joint_names),
                                                           t_ns)),
                  (self._pub_mesh, messages.mesh_state(out, t_ns)),
                  (self._pub_te, messages.transmission_error(out))]
        for pub, msg in batch:
            pub.publish(msg)
        if self._recorder is not None:
            for pub, msg in batch:
                self._recorder.write(pub.topic_name, t_ns, msg)

    def _publish_diagnostics(self, out: Outputs) -> None:
        health = self._health
        with self._lock:
            health.rejected = dict(self._rejected)
        health.fault = self.plant.fault
        if self._recorder is not None:
            health.recorder = (self._recorder.written, self._recorder.dropped)
            health.recorder_error = self._recorder.error
        params = self.plant.params
        level, text, values = diagnostic_values(params, out, health)
        msg = messages.diagnostics(f'{self._fqn}: simulation', 'screwgear_ros/table_sim',
                                   level, text, values, sim_time_ns(out.step, self.plant.dt))
        self._pub_diag.publish(msg)
        self._record(self._pub_diag.topic_name, out.step, msg)
        phase_step = mesh_phase_per_step(params, out, health.dt)
        if phase_step > MAX_PHASE_PER_STEP and self._warnings.allow('mesh_phase')[0]:
            self.get_logger().warning(
                f'mesh phase advances {phase_step:.3f} rad per step at t = {out.time:.3f} s '
                f'(> {MAX_PHASE_PER_STEP:.3f}): dt = {health.dt:g} s no longer resolves the '
                'tooth mesh at this speed; lower dt or the speed')


def _msgtype(cls: type) -> str:
    """'sensor_msgs/msg/JointState' for sensor_msgs.msg.JointState."""
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT or SIGTERM; 0 on a clean stop, 2 on bad parameters."""
    stop = stop_on_signals()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node: TableSim | None = None
    try:
        try:
            node = TableSim(stop)
        except (ValueError, OSError, ImportError, ParameterException) as error:
            rclpy.logging.get_logger('table_sim').fatal(f'cannot start: {error}')
            return 2
        node.start()
        spin_until(node, stop)
        return 1 if node.failed else 0
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()


__all__ = ['TableSim', 'main']
