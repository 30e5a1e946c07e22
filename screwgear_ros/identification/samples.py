"""A recording as identification holds it: the measured joint states at each tick and
the commands with the tick that applies each (:mod:`~screwgear_ros.identification.recording`
reads one from a bag)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..interface import Input

#: The node's joints, in joint_states order.
NODE_JOINTS = ('pinion_1', 'table', 'pinion_3')
#: The inputs a recording's commands come on (the setpoint is only informational).
COMMANDS = (Input.CMD_EFFORT, Input.CMD_TORQUE, Input.CMD_DIRECTION, Input.LOAD_TORQUE,
            Input.JOINT_COMMANDS)
JOINT_STATES = 'joint_states'


@dataclass(frozen=True, eq=False)
class Recording:
    """One bag, read: ``position``, ``velocity`` and ``effort`` (n, 3) in the node's joint
    order (NaN speeds or efforts where the bag has none), ``times`` each sample's own
    time (ns, on the log clock: :mod:`~screwgear_ros.identification.retiming`),
    ``inputs`` (time from which it acts, ns, input, value) in time order (logged order
    at equal times), ``start`` the time the simulation starts at (ns), and ``timing``
    what the placing of the samples found (lines for the report)."""

    path: str
    times: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    inputs: tuple[tuple[int, Input, Any], ...]
    effort: np.ndarray | None = None
    start: int | None = None
    timing: tuple[str, ...] = ()

    @property
    def origin(self) -> int:
        """The simulation's start, ns: ``start``, else the first sample's time."""
        return int(self.times[0]) if self.start is None else int(self.start)

    @property
    def samples(self) -> int:
        return len(self.times)

    @property
    def period(self) -> float:
        """The median time between samples, s."""
        return float(np.median(np.diff(self.times))) * 1e-9 if self.samples > 1 else math.nan

    @property
    def reversals(self) -> int:
        """Changes of the commanded direction between consecutive commands that set one
        (cmd_effort's sign, cmd_direction, joint_commands' drive effort's sign)."""
        signs = [s for s in (_direction(topic, value) for _, topic, value in self.inputs) if s]
        return sum(a != b for a, b in itertools.pairwise(signs))

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0]) * 1e-9 if self.samples else 0.0


def _direction(topic: Input, value: Any) -> int:
    """The direction a command sets (0: none)."""
    if topic == Input.CMD_DIRECTION:
        return int(value)
    if topic == Input.CMD_EFFORT:
        effort = value[0] if value else 0.0
    elif topic == Input.JOINT_COMMANDS:
        effort = value.effort[0] if value.effort else 0.0
    else:
        return 0
    return (effort > 0) - (effort < 0)



__all__ = ['COMMANDS', 'JOINT_STATES', 'NODE_JOINTS', 'Recording']
