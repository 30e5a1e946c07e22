"""Validation of controller commands and how each folds into the input in force.

One function per input topic of ``shared/spec/interface.md``; each takes the input in
force and the raw value and returns the new :class:`DriveInput`, or raises
:class:`InputRejected` saying what was wrong and what is kept. The node uses this on
live commands; offline checks and replays use it on recorded ones, so both fold the
same command stream into the same inputs. :func:`command_value` turns a message (live
from rclpy, or decoded from a bag by rosbags) into the value a command carries, so
both see the same values.

``joint_commands`` is the joint command topic of ros2_control's stock
``joint_state_topic_hardware_interface/JointStateTopicSystem``: a sensor_msgs/JointState
naming every joint of the ``<ros2_control>`` block, with only the arrays of the command
interfaces that exist filled. The shipped URDF gives one joint, the first of
``joint_names`` (``pinion_1``), an effort command interface, so ``effort`` holds one
value: the signed drive torque at the active pinion, exactly as ``cmd_effort``. Before
any controller wrote that interface the plugin sends NaN: that message carries no
command (:func:`carries_no_command`) and the node drops it without a word.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from ..errors import ScrewgearError
from ..interface import COMMAND_TOPICS, Input
from ..params.table import SimSettings, TableParams
from .events import shown
from .plant import DriveInput

#: Input topics (relative names) and the ROS message type of each.
INPUT_TOPICS = COMMAND_TOPICS

#: Index in ``joint_names`` of the joint whose effort command is the drive torque on
#: ``joint_commands`` (pinion 1: the URDF's only command interface).
COMMANDED_JOINT = 0
#: The command interface of that joint.
COMMAND_INTERFACE = 'effort'


@dataclass(frozen=True)
class JointCommand:
    """The value of a ``joint_commands`` message: joint names and command arrays.

    An array is empty when no joint of the ``<ros2_control>`` block has that command
    interface (the plugin fills only those that exist).
    """

    name: tuple[str, ...]
    position: tuple[float, ...] = ()
    velocity: tuple[float, ...] = ()
    effort: tuple[float, ...] = ()

    def values(self) -> tuple[float, ...]:
        """Every number the message carries."""
        return (*self.position, *self.velocity, *self.effort)

    def __repr__(self) -> str:
        arrays = ''.join(f', {field}={list(getattr(self, field))}'
                         for field in ('position', 'velocity', 'effort')
                         if getattr(self, field))
        return f'JointState(name={list(self.name)}{arrays})'


class InputRejected(ScrewgearError, ValueError):
    """A command refused; the message names the topic, the value and the rule.

    Parameters
    ----------
    topic : str
        The input it came on (an :class:`~screwgear_ros.interface.Input` value).
    value : object
        The value refused.
    rule : str
        Why: the rule it breaks.

    Examples
    --------
    >>> from screwgear_ros import InputRejected, Simulation
    >>> sim = Simulation()
    >>> _ = sim.reset()
    >>> try:
    ...     sim.step(torque=-1.0)
    ... except InputRejected as exc:
    ...     print(exc.topic)
    cmd_torque
    """

    def __init__(self, topic: str, value: Any, rule: str) -> None:
        self.topic = topic
        self.value = value
        super().__init__(f'{topic}: rejected {shown(value, 200)}: {rule}; the last valid command '
                         'stays in force')


def finite_number(value: Any) -> bool:
    """``value`` is a real number (no bool) that float64 holds finite."""
    try:
        return (not isinstance(value, bool) and isinstance(value, (int, float))
                and math.isfinite(value))
    except OverflowError:                 # an int beyond float64
        return False


def _finite(topic: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputRejected(topic, value, 'must be a finite number')
    return float(value)


def _torque(topic: str, value: Any, max_torque: float) -> float:
    torque = _finite(topic, value)
    if not 0.0 <= torque <= max_torque:
        raise InputRejected(topic, value, f'drive torque must be within 0 … {max_torque:g} N·m '
                            '(max_torque)')
    return torque


def apply_torque(current: DriveInput, value: float, max_torque: float) -> DriveInput:
    """cmd_torque: drive torque magnitude T, N·m, finite and 0 ≤ T ≤ max_torque."""
    return DriveInput.of(_torque(Input.CMD_TORQUE, value, max_torque), current.direction,
                         current.load)


def apply_direction(current: DriveInput, value: int) -> DriveInput:
    """cmd_direction: +1 forward (path 1), −1 reverse (path 3)."""
    if isinstance(value, bool) or value not in (1, -1):
        raise InputRejected(Input.CMD_DIRECTION, value, 'direction must be +1 or -1')
    return replace(current, direction=int(value))


def _signed(topic: str, value: Any, max_torque: float, shown: Any,
            deadband: float, direction: int = 0, hysteresis: float = 0.0) -> tuple[float, int]:
    """A signed drive torque as (torque, direction): the sign sets the direction, |value|
    the torque. Within ``deadband`` (N·m, effort_deadband) it is zero torque and
    direction 0, which keeps the direction in force: a controller at rest whose effort
    flips sign by rounding noise commands no reversal. Against ``direction`` (the one in
    force; 0: none) and within ``hysteresis`` (N·m, direction_hysteresis) it is zero
    torque and direction 0 as well: a reversal needs an effort beyond the hysteresis, so
    noise on a near-zero effort does not switch the path back and forth."""
    effort = value
    # A float within the limit (so finite) is valid as it is: the common case, checked in
    # one comparison; anything else gets the full checks and their messages.
    if type(effort) is not float or not abs(effort) <= max_torque:
        try:
            effort = _finite(topic, value)
        except InputRejected:
            raise InputRejected(topic, shown, 'the effort must be a finite number') from None
        if abs(effort) > max_torque:
            raise InputRejected(topic, shown, f'|effort| must be <= {max_torque:g} N·m '
                                '(max_torque)')
    magnitude = abs(effort)
    if magnitude <= deadband:
        return 0.0, 0
    sign = 1 if effort > 0.0 else -1
    if magnitude <= hysteresis and sign != direction:
        return 0.0, 0
    return magnitude, sign


def _signed_drive(topic: str, current: DriveInput, value: Any, max_torque: float,
                  shown: Any, deadband: float, hysteresis: float = 0.0) -> DriveInput:
    """The input in force with a signed drive torque (:func:`_signed`) folded in."""
    torque, direction = _signed(topic, value, max_torque, shown, deadband,
                                current.direction, hysteresis)
    # DriveInput.of: a closed loop folds one of these into the input every tick.
    return DriveInput.of(torque, direction or current.direction, current.load)


def effort_drive(value: Any, max_torque: float, deadband: float = 0.0, direction: int = 0,
                 hysteresis: float = 0.0) -> tuple[float, int]:
    """cmd_effort's one value as (drive torque, direction; 0: the direction in force
    stays), validated as :func:`apply_effort` validates it (the same InputRejected): what
    a closed loop's answer folds into the input, without making the input itself.
    ``direction`` is the one in force, for the ``hysteresis``."""
    return _signed(Input.CMD_EFFORT, value, max_torque, [value], deadband, direction,
                   hysteresis)


def apply_effort(current: DriveInput, values: Sequence[float], max_torque: float,
                 deadband: float = 0.0, hysteresis: float = 0.0) -> DriveInput:
    """cmd_effort: one signed torque, N·m; the sign sets the direction, |value| the torque.

    |value| <= ``deadband`` is zero torque and keeps the direction in force (no
    reversal without a sign that means something); so is a value against the direction
    in force with |value| <= ``hysteresis`` (a reversal needs more than the hysteresis).
    """
    if len(values) != 1:
        raise InputRejected(Input.CMD_EFFORT, list(values),
                            f'expects exactly one value (the signed drive torque), got {len(values)}')
    return _signed_drive(Input.CMD_EFFORT, current, values[0], max_torque, list(values), deadband,
                         hysteresis)


def apply_joint_command(current: DriveInput, command: Any, max_torque: float,
                        joint_names: Sequence[str], deadband: float = 0.0,
                        hysteresis: float = 0.0) -> DriveInput:
    """joint_commands: the effort of ``joint_names[COMMANDED_JOINT]`` is a signed drive
    torque, N·m, exactly as cmd_effort's one value (with the same ``deadband`` and
    ``hysteresis``).

    The message must name that joint, name no joint joint_states does not have, carry
    no position or velocity command and exactly one effort value.
    """
    _joint_command_shape(command, joint_names)
    return _signed_drive(Input.JOINT_COMMANDS, current, command.effort[0], max_torque, command,
                         deadband, hysteresis)


def _joint_command_shape(command: Any, joint_names: Sequence[str]) -> None:
    """Refuse a joint_commands message whose names or arrays are not the plugin's
    (:func:`apply_joint_command`), whatever its values."""
    topic = Input.JOINT_COMMANDS
    if not isinstance(command, JointCommand):
        raise InputRejected(topic, command, 'expects a sensor_msgs/JointState of joint commands')
    joint = joint_names[COMMANDED_JOINT]
    unknown = [n for n in command.name if n not in joint_names]
    if unknown:
        raise InputRejected(topic, command, f'names joints {unknown} that joint_states does '
                            f'not have ({", ".join(joint_names)})')
    if joint not in command.name:
        raise InputRejected(topic, command, f'must name {joint}, whose effort is the drive '
                            'torque')
    if command.position or command.velocity:
        raise InputRejected(topic, command, f'takes only an effort command ({joint}/'
                            f'{COMMAND_INTERFACE}): position and velocity must be empty')
    if len(command.effort) != 1:
        raise InputRejected(topic, command, f'expects exactly one effort value ({joint}/'
                            f'{COMMAND_INTERFACE}, the signed drive torque), got '
                            f'{len(command.effort)}')


def apply_load(current: DriveInput, value: float, max_load: float) -> DriveInput:
    """load_torque: external table load, N·m, signed, |load| ≤ max_load."""
    load = _finite(Input.LOAD_TORQUE, value)
    if abs(load) > max_load:
        raise InputRejected(Input.LOAD_TORQUE, value,
                            f'|load| must be <= {max_load:g} N·m')
    return DriveInput.of(current.torque, current.direction, load)


def load_limit(max_torque: float, radius_pinion: float, radius_table: float) -> float:
    """Largest accepted |load|, N·m: what the drive could hold at the table, times ten."""
    return 10.0 * max_torque * radius_table / radius_pinion


def limit_input(current: DriveInput, params: TableParams) -> tuple[DriveInput, str | None]:
    """The input in force cut to the limits of newly applied ``params``.

    A parameter change can lower ``max_torque`` (and with it the load limit) below
    the input in force; that input is then cut to the new limit, as a drive's own
    torque limit would, and the second value says so. (None: nothing was cut.)
    """
    max_load = load_limit(params.max_torque, params.radius_pinion_1, params.radius_table)
    torque = min(current.torque, params.max_torque)
    load = max(-max_load, min(max_load, current.load))
    if (torque, load) == (current.torque, current.load):
        return current, None
    cut = []
    if torque != current.torque:
        cut.append(f'drive torque {current.torque:g} -> {torque:g} N·m')
    if load != current.load:
        cut.append(f'load {current.load:g} -> {load:g} N·m')
    return (replace(current, torque=torque, load=load),
            (f'max_torque is now {params.max_torque:g} N·m: the input in force is cut to the '
            f'new limits ({", ".join(cut)})'))


def apply_command(current: DriveInput, topic: str, value: Any, params: TableParams,
                  joint_names: Sequence[str] | None = None) -> DriveInput:
    """Fold one command on ``topic`` (a relative input topic name) into the input in force.

    ``value`` is :func:`command_value` of the message; ``joint_names`` are the
    joint_states names in force (default: the default names).
    """
    if topic == Input.CMD_EFFORT:            # first: a closed loop sends one a tick
        return apply_effort(current, value, params.max_torque, params.effort_deadband,
                            params.direction_hysteresis)
    if topic == Input.CMD_TORQUE:
        return apply_torque(current, value, params.max_torque)
    if topic == Input.CMD_DIRECTION:
        return apply_direction(current, value)
    if topic == Input.LOAD_TORQUE:
        return apply_load(current, value, load_limit(params.max_torque, params.radius_pinion_1,
                                                     params.radius_table))
    if topic == Input.JOINT_COMMANDS:
        names = SimSettings().joint_names if joint_names is None else joint_names
        return apply_joint_command(current, value, params.max_torque, names,
                                   params.effort_deadband, params.direction_hysteresis)
    raise InputRejected(topic, value, f'unknown input topic (known: {", ".join(INPUT_TOPICS)})')


def command_value(topic: str, msg: Any) -> Any:
    """The value a command on input ``topic`` carries, from its message.

    Scalars: ``data``; cmd_effort: ``data`` as a list of floats; joint_commands: a
    :class:`JointCommand`. Attribute access only, so rclpy messages and the bag
    reader's decoded ones give equal values.
    """
    if topic == Input.CMD_EFFORT:
        return [float(v) for v in msg.data]
    if topic == Input.JOINT_COMMANDS:
        return JointCommand(tuple(str(n) for n in msg.name),
                            tuple(float(v) for v in msg.position),
                            tuple(float(v) for v in msg.velocity),
                            tuple(float(v) for v in msg.effort))
    return msg.data


def timed_out_input(drive: DriveInput, command_timeout: float
                    ) -> tuple[DriveInput, str] | None:
    """What ``command_timeout`` (s) makes of the input in force ``drive`` when it comes due
    (:mod:`screwgear_ros.sim.session`): torque and load zero, the direction kept, and the
    notice that says so; None when both are zero already."""
    if not (drive.torque or drive.load):
        return None
    return (replace(drive, torque=0.0, load=0.0),
            (f'no command for {command_timeout:g} s of simulation time (command_timeout): '
             f'drive torque ({drive.torque:g} N·m) and load ({drive.load:g} N·m) set to zero '
             'until the next command'))


def carries_no_command(topic: str, value: Any, joint_names: Sequence[str] | None = None) -> bool:
    """True for a joint_commands message that commands nothing yet: ros2_control's
    command interfaces hold NaN until a controller writes them, and the plugin sends
    them as they are. Such a message is neither a command nor a bad one.

    Only a message the plugin could send is one: its names and arrays as
    :func:`apply_joint_command` requires (``joint_names``: those in force, default the
    default names), its one effort NaN. Any other message, NaN or not, is a command to
    validate, so a malformed one is refused and counted as every malformed one is.

    Examples
    --------
    >>> nan = float('nan')
    >>> carries_no_command('joint_commands', JointCommand(('pinion_1',), effort=(nan,)))
    True
    >>> carries_no_command('joint_commands', JointCommand(('pinion_1', 'table'),
    ...                                                   effort=(nan, nan)))
    False
    """
    if topic != Input.JOINT_COMMANDS or not isinstance(value, JointCommand):
        return False
    names = SimSettings().joint_names if joint_names is None else joint_names
    try:
        _joint_command_shape(value, names)
    except InputRejected:
        return False
    return math.isnan(value.effort[0])


__all__ = [
    'COMMANDED_JOINT',
    'COMMAND_INTERFACE',
    'INPUT_TOPICS',
    'InputRejected',
    'JointCommand',
    'apply_command',
    'apply_direction',
    'apply_effort',
    'apply_joint_command',
    'apply_load',
    'apply_torque',
    'carries_no_command',
    'command_value',
    'effort_drive',
    'finite_number',
    'limit_input',
    'load_limit',
    'timed_out_input',
]
