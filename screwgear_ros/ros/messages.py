"""The node's output messages, built fresh from the plant's Outputs each tick.

Fresh objects (a few µs each) rather than reused ones: a recorder serializes them
later on its own thread, so a message handed over must never change afterwards.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Int8

from ..plant import Outputs

MESH_NAMES = ['mesh_1', 'mesh_3']


def stamp(time_ns: int) -> Time:
    """builtin_interfaces/Time of a simulation time in integer nanoseconds."""
    sec, nanosec = divmod(time_ns, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def _joint_state(names: list[str], position: tuple[float, ...], velocity: tuple[float, ...],
                 effort: tuple[float, ...], time_ns: int) -> JointState:
    msg = JointState()
    msg.header.stamp = stamp(time_ns)
    msg.name = names
    msg.position, msg.velocity, msg.effort = list(position), list(velocity), list(effort)
    return msg


def joint_states(out: Outputs, names: list[str], time_ns: int) -> JointState:
    """Pinion 1, table, pinion 3: angle rad, speed rad/s, applied torque N·m."""
    return _joint_state(names, out.position, out.velocity, out.effort, time_ns)


def mesh_state(out: Outputs, time_ns: int) -> JointState:
    """mesh_1, mesh_3: δ in m, δ̇ in m/s, mesh force F in N."""
    return _joint_state(MESH_NAMES, out.delta, out.delta_rate, out.mesh_force, time_ns)


def transmission_error(out: Outputs) -> Float64:
    """Total transmission error δ of the active path, m."""
    return Float64(data=out.transmission_error)


def active_path(path: int) -> Int8:
    return Int8(data=path)


def clock(time_ns: int) -> Clock:
    return Clock(clock=stamp(time_ns))


def diagnostics(name: str, hardware_id: str, level: int, message: str,
                values: list[tuple[str, str]], time_ns: int) -> DiagnosticArray:
    """A DiagnosticArray with the node's one status."""
    status = DiagnosticStatus(level=bytes([level]), name=name, message=message,
                              hardware_id=hardware_id,
                              values=[KeyValue(key=k, value=v) for k, v in values])
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp(time_ns)
    return msg


__all__ = ['MESH_NAMES', 'stamp', 'joint_states', 'mesh_state', 'transmission_error',
           'active_path', 'clock', 'diagnostics']
