"""demo_controller: a PID position loop on the table angle, closed around table_sim.

Reads the table joint of ``joint_states``, computes a torque at pinion level and
sends its magnitude on ``cmd_torque`` and its sign on ``cmd_direction`` (each sign
change is a reversal: table_sim moves the drive to the other screw-gear path). The
target steps through ``targets`` (rad), holding each for ``dwell`` s of simulation
time, from the first joint state seen; the loop runs once per joint state, on the
stamps' simulation time, so it behaves the same at any real-time factor the
transport keeps up with.

Tuned for the paper's table (pure inertia I ≈ 46.1 + 2·0.0326·7.46² ≈ 49.7 kg·m² at
the table, gear ratio r2/r1 = 7.46): proportional and derivative gains place the
closed-loop poles near ω_n = 20 rad/s with ζ ≈ 0.8 (Kp = I·ω_n²/7.46, Kd =
2ζω_n·I/7.46); the integral acts only within ``integral_zone`` of the target
(conditional integration: no windup over a step). A direction change needs the
wanted torque to exceed ``hysteresis`` the other way, so the path does not chatter
at rest.
"""

from __future__ import annotations

import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Int8

from ..ros.shutdown import spin_until, stop_on_signals

LOG_PERIOD = 0.5   # s of simulation time between log lines
MAX_GAP = 0.01     # s: a longer gap between joint states is not integrated


class DemoController(Node):
    def __init__(self) -> None:
        super().__init__('demo_controller',
                         parameter_overrides=[Parameter('use_sim_time', value=True)])
        declare = self.declare_parameter
        self.joint = declare('joint', 'table').value
        self.targets = list(declare('targets', [0.05, -0.05]).value)   # rad
        self.dwell = declare('dwell', 1.5).value                       # s
        self.kp = declare('kp', 2665.0).value                          # N·m/rad
        self.ki = declare('ki', 8000.0).value                          # N·m/(rad·s)
        self.kd = declare('kd', 213.0).value                           # N·m·s/rad
        self.max_torque = declare('max_torque', 300.0).value           # N·m
        self.hysteresis = declare('hysteresis', 1.0).value             # N·m
        self.integral_zone = declare('integral_zone', 0.002).value     # rad
        self._pub_torque = self.create_publisher(Float64, 'cmd_torque', 10)
        self._pub_direction = self.create_publisher(Int8, 'cmd_direction', 10)
        self.create_subscription(JointState, 'joint_states', self._on_joint_states, 10)
        self._t0: float | None = None
        self._t_last = 0.0
        self._next_log = 0.0
        self._integral = 0.0
        self._direction = 0          # 0 until the first command is sent
        self._index = -1

    def target(self, t: float) -> float:
        """Target angle, rad, at simulation time t (s) since the first joint state."""
        return self.targets[int(t // self.dwell) % len(self.targets)]

    def _on_joint_states(self, msg: JointState) -> None:
        if self.joint not in msg.name:
            return
        i = list(msg.name).index(self.joint)
        angle, speed = msg.position[i], msg.velocity[i]
        now = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        if self._t0 is None:
            self._t0 = self._t_last = now
        t = now - self._t0
        gap = now - self._t_last
        self._t_last = now
        target = self.target(t)
        error = target - angle
        if abs(error) < self.integral_zone and 0.0 < gap <= MAX_GAP:
            self._integral += error * gap
        if self.ki > 0.0:
            limit = 0.5 * self.max_torque / self.ki
            self._integral = min(limit, max(-limit, self._integral))
        wanted = self.kp * error + self.ki * self._integral - self.kd * speed
        if self._direction == 0:
            self._direction = 1 if wanted >= 0.0 else -1
            self._pub_direction.publish(Int8(data=self._direction))
        elif wanted * self._direction < 0.0 and abs(wanted) > self.hysteresis:
            self._direction = -self._direction
            self._pub_direction.publish(Int8(data=self._direction))
        torque = min(self.max_torque, max(0.0, wanted * self._direction))
        self._pub_torque.publish(Float64(data=torque))
        index = int(t // self.dwell)
        if index != self._index or t >= self._next_log:
            if index != self._index:
                self._index = index
                self.get_logger().info(f't = {now:8.3f} s: new target {target:+.4f} rad')
            self._next_log = t + LOG_PERIOD
            self.get_logger().info(
                f't = {now:8.3f} s | target {target:+.5f} rad | actual {angle:+.5f} rad | '
                f'error {error * 1e3:+8.3f} mrad | torque {self._direction * torque:+7.1f} N·m')


def main(args: list[str] | None = None) -> int:
    """Run until SIGINT or SIGTERM; exit 0."""
    stop = stop_on_signals()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        node = DemoController()
        spin_until(node, stop)
        node._pub_torque.publish(Float64(data=0.0))   # leave the table unforced
        return 0
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


__all__ = ['DemoController', 'main']
