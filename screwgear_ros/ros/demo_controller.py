"""The demo_controller node: a PID position loop on the table angle, closed around table_sim.

Reads the table joint of ``joint_states`` and answers each new joint state with one
``cmd_effort`` (std_msgs/Float64MultiArray, one signed torque at the active pinion:
the sign is the direction, the magnitude the torque; each sign change is a
reversal: table_sim moves the drive to the other screw-gear path). The law, its
profile and its tuning are :class:`screwgear_ros.sim.control.DemoLaw` (its ROS parameters
are the fields of :class:`~screwgear_ros.sim.control.DemoGains`); the loop runs once per
joint state, on the stamps' simulation time, so it behaves the same at any real-time
factor the transport keeps up with.

Lockstep (table_sim ``lockstep:=true``): the node integrates its next tick only once
it has one answer to the last joint_states, and re-publishes that joint_states with
the same stamp every 0.5 s while it waits. The controller answers each stamp exactly
once and ignores a repeated stamp (answering it too would answer the next tick
early), so the run is bit-identical however busy the machine is. It does not answer
while nobody subscribes to ``cmd_effort`` (the answer would be lost and the node's
re-send ignored); the re-send of that stamp is then answered as a new one. A stamp
earlier than the last answered means a new simulation (a restarted node): the
controller says so and starts its profile again. With a free-running node the same
loop simply runs on whatever joint states arrive; a gap over ``control.MAX_GAP`` (lost
samples) is not integrated.

With each answer it may also send its target on ``setpoint`` (std_msgs/Float64, rad,
before the effort; :class:`~screwgear_ros.sim.control.SetpointNotes` says when): table_sim
only records it, so that ``plot_run`` shows the tracking error. It does so when the
controlled joint is the table (the second name of joint_states).

On SIGINT/SIGTERM it sends a zero effort, leaving the table unforced (in lockstep
that zero answers the pending tick, which then runs unforced, and the node waits).
Given a stop time (``stop_at``, simulated seconds) it answers no joint_states stamped at
or after it and says it is finished; in lockstep the table then stands at exactly that
stamp, since the node integrates no tick without an answer.
"""

from __future__ import annotations

import threading

from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from ..interface import Input
from ..sim.control import TABLE_JOINT, DemoGains, DemoLaw, SetpointNotes

LOG_PERIOD = 0.5   # s of simulation time between log lines


class DemoControllerNode(Node):
    """The demo PID node: one ``cmd_effort`` answer per new ``joint_states`` stamp.

    Its parameters are the fields of :class:`~screwgear_ros.sim.control.DemoGains`;
    ``use_sim_time`` is on.
    """

    def __init__(self, stop_at: float | None = None,
                 done: threading.Event | None = None) -> None:
        """``stop_at``: simulated seconds after which nothing is answered (None: never);
        ``done``: set then, with :attr:`finished`."""
        super().__init__('demo_controller',
                         parameter_overrides=[Parameter('use_sim_time', value=True)])
        self._stop_at = None if stop_at is None else round(stop_at * 1e9)
        self._done = done
        self.finished = False
        defaults = DemoGains()
        values = {name: self.declare_parameter(name, _ros_default(getattr(defaults, name))).value
                  for name in DemoGains.names()}
        self.law = DemoLaw(DemoGains(**values))
        self.joint = self.law.gains.joint
        self._pub = self.create_publisher(Float64MultiArray, Input.CMD_EFFORT, 10)
        self._setpoint = self.create_publisher(Float64, Input.SETPOINT, 10)
        self._notes = SetpointNotes()
        self.create_subscription(JointState, 'joint_states', self._on_joint_states, 10)
        self.restart()

    def restart(self) -> None:
        """Forget the run: the profile starts again at the next joint state."""
        self.law.restart()
        self._notes.restart()
        self._index = -1                 # target index last logged
        self._next_log = 0.0

    def _on_joint_states(self, msg: JointState) -> None:
        if self.joint not in msg.name:
            return
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if self._stop_at is not None and stamp >= self._stop_at:
            self._finish(stamp, self._stop_at)
            return
        last = self.law.last_stamp
        if last is not None and stamp <= last:
            if stamp == last:
                return                   # lockstep's re-send of a stamp already answered
            self.get_logger().warning(
                f'joint_states went back in time ({last * 1e-9:.3f} s -> '
                f'{stamp * 1e-9:.3f} s): a new simulation; the profile starts again')
            self.restart()
        if self._pub.get_subscription_count() == 0:
            return                       # nobody would get the answer
        i = list(msg.name).index(self.joint)
        angle, speed = msg.position[i], msg.velocity[i]
        effort, t = self.law.answer(stamp, angle, speed)
        if i == TABLE_JOINT:
            target = self.law.target(t)
            if self._setpoint.get_subscription_count() and self._notes.due(stamp, target):
                self._setpoint.publish(Float64(data=target))
        self._pub.publish(Float64MultiArray(data=[effort]))
        self._log(stamp * 1e-9, t, angle, effort)

    def _log(self, now: float, t: float, angle: float, effort: float) -> None:
        index = int(t // self.law.gains.dwell)
        if index == self._index and t < self._next_log:
            return
        target = self.law.target(t)
        if index != self._index:
            self._index = index
            self.get_logger().info(f't = {now:8.3f} s: new target {target:+.4f} rad')
        self._next_log = t + LOG_PERIOD
        self.get_logger().info(
            f't = {now:8.3f} s | target {target:+.5f} rad | actual {angle:+.5f} rad | '
            f'error {(target - angle) * 1e3:+8.3f} mrad | effort {effort:+7.1f} N·m')

    def _finish(self, stamp: int, stop_at: int) -> None:
        if not self.finished:
            self.finished = True
            self.get_logger().info(f't = {stamp * 1e-9:8.3f} s: the stop time '
                                   f'({stop_at * 1e-9:g} s) is reached: not answered')
        if self._done is not None:
            self._done.set()

    def stop_driving(self) -> None:
        """Send a zero effort: the torque goes to 0, the direction stays."""
        self._pub.publish(Float64MultiArray(data=[self.law.stop_effort()]))


def _ros_default(value: object) -> object:
    """A DemoGains default as a ROS parameter default (a list for the targets)."""
    return list(value) if isinstance(value, tuple) else value


__all__ = ['LOG_PERIOD', 'DemoControllerNode']
