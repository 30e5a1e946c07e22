"""Read a bag as identification takes it (:class:`~screwgear_ros.identification.samples.Recording`):
the measured joint angles and speeds at each tick, and the commands with the tick that
applies each.

Any rosbag2 bag serves (MCAP or sqlite3 storage, read with ``rosbags``): table_sim's own
recordings and ``ros2 bag record`` of a real table, which hold only ``joint_states`` and
the commands sent (``cmd_effort``, ``cmd_torque`` + ``cmd_direction``, ``load_torque``,
ros2_control's ``joint_commands``). Topics are matched on their relative name; every
other topic (``run_parameters``, ``mesh_state``, ...) is ignored, so both kinds of bag
are read the same way.

The samples of ``joint_states`` are the ticks: sample 0 is the start, sample i what tick
i made. A command takes effect as the node applies it: at the first step of the tick
after its log time, i.e. the tick that starts at the first sample logged at or after
it (the node records an applied command at the step it took effect, after that step's
outputs, so its own recordings map onto the same ticks). ``input_delay`` adds whole
ticks for hardware whose drive applies a command later.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..interface import CONTRACT, Input
from .adapter import carries_no_command, command_value, typestore
from .errors import RecordingError
from .samples import COMMANDS, JOINT_STATES, NODE_JOINTS, Recording


def _relative(topic: str) -> str:
    return topic.rstrip('/').rsplit('/', 1)[-1]


def parse_joints(text: str | None) -> dict[str, str]:
    """``--joints pinion_1=motor_a,table=axis_c``: node joint → the bag's name."""
    mapping: dict[str, str] = {}
    for part in filter(None, (p.strip() for p in (text or '').split(','))):
        node, sep, bag = part.partition('=')
        if not sep or node not in NODE_JOINTS or not bag:
            raise RecordingError(f'--joints: {part!r} is not NODE=BAG with NODE one of '
                                 f'{", ".join(NODE_JOINTS)}')
        mapping[node] = bag
    return mapping


def _namespace(topic: str) -> str:
    return topic.rstrip('/').rsplit('/', 1)[0] or '/'


def _chosen(path: Any, connections: Sequence[Any], namespace: str | None) -> list[Any]:
    """The connections of one table: those under ``namespace``, or, without one, all of
    them when the bag holds one table's topics (refused when it holds several)."""
    wanted = {JOINT_STATES, *COMMANDS}
    found = [c for c in connections if _relative(c.topic) in wanted]
    spaces = sorted({_namespace(c.topic) for c in found})
    if namespace is not None:
        space = '/' + namespace.strip('/') if namespace.strip('/') else '/'
        found = [c for c in found if _namespace(c.topic) == space]
        if not found:
            raise RecordingError(f'{path}: --namespace {namespace}: no joint_states or '
                                 f'commands there (the bag has {", ".join(spaces) or "none"})')
    elif len(spaces) > 1:
        raise RecordingError(f'{path}: holds the topics of {len(spaces)} tables '
                             f'({", ".join(spaces)}): choose one with --namespace')
    for c in found:
        expected = CONTRACT[_relative(c.topic)]
        if c.msgtype != expected:
            raise RecordingError(f'{path}: {c.topic} carries {c.msgtype}, not {expected}')
    return found


def read_recording(path: str | os.PathLike[str], joints: Mapping[str, str] | None = None,
                   input_delay: int = 0, namespace: str | None = None) -> Recording:
    """Read one bag (see the module docstring).

    Parameters
    ----------
    path : str or Path
        A rosbag2 directory (MCAP or sqlite3 storage).
    joints : mapping, optional
        Node joint name → the bag's joint name, where they differ.
    input_delay : int
        Ticks a command takes effect after the node would apply it.
    namespace : str, optional
        The table's namespace, for a bag holding several tables' topics.

    Returns
    -------
    Recording

    Raises
    ------
    RecordingError
        Not a bag, no joint_states, no commands, a joint missing, non-finite values,
        topics of several tables (without ``namespace``), a message of another type,
        commands logged before the first joint_states sample.
    """
    from rosbags.highlevel import AnyReader
    names = {j: (joints or {}).get(j, j) for j in NODE_JOINTS}
    times: list[int] = []
    rows: list[tuple[float, ...]] = []
    logged: list[tuple[int, Input, Any]] = []
    try:
        with AnyReader([Path(path)], default_typestore=typestore()) as reader:
            connections = _chosen(path, reader.connections, namespace)
            for connection, stamp, raw in reader.messages(connections=connections):
                rel = _relative(connection.topic)
                message = reader.deserialize(raw, connection.msgtype)
                if rel == JOINT_STATES:
                    times.append(int(stamp))
                    rows.append(_joint_row(path, message, names, len(times) - 1))
                else:
                    _command(path, Input(rel), message, names, int(stamp), logged)
    except RecordingError:
        raise
    except Exception as exc:  # noqa: BLE001 (rosbags has no common error base: any is "not a bag")
        raise RecordingError(f'{path}: cannot read as a rosbag2 bag: {exc}') from None
    if len(times) < 2:
        raise RecordingError(f'{path}: no joint_states (at least two samples are needed): '
                             'record the table\'s joint_states with its commands')
    if not logged:
        raise RecordingError(f'{path}: no commands ({", ".join(COMMANDS)}): the fit '
                             're-simulates the recorded commands, record them with the '
                             'joint states')
    order = np.argsort(np.asarray(times, dtype=np.int64), kind='stable')
    stamps = np.asarray(times, dtype=np.int64)[order]
    values = np.asarray(rows, dtype=np.float64)[order]
    if not np.isfinite(values[:, :3]).all():
        i = int(np.flatnonzero(~np.isfinite(values[:, :3]).all(axis=1))[0])
        raise RecordingError(f'{path}: joint_states sample {i} holds a position that is '
                             'not finite (NaN or inf)')
    speeds = values[:, 3:]
    if np.isinf(speeds).any():
        raise RecordingError(f'{path}: joint_states holds an infinite velocity')
    gaps = np.diff(stamps)
    period = int(np.median(gaps))
    odd = np.flatnonzero((gaps > 1.5 * period) | (gaps < 0.5 * period))
    if len(odd):
        i = int(odd[0]) + 1
        raise RecordingError(f'{path}: joint_states sample {i} comes {gaps[i - 1] * 1e-6:.4g} ms '
                             f'after the one before, the others every {period * 1e-6:.4g} ms: '
                             'the samples are the ticks, and a lost or repeated one cannot '
                             'be placed')
    tol = max(1, period // 1000)
    early = [stamp for stamp, _, _ in logged if stamp < stamps[0] - period]
    if early:
        # the model starts at rest at the first sample: a command more than a tick before
        # it acted on motion the recording does not show (one within a tick is the answer
        # to a sample the recorder missed as it started: tick 1 applies it)
        raise RecordingError(f'{path}: {len(early)} command(s) logged before the first '
                             f'joint_states sample (the earliest '
                             f'{(stamps[0] - min(early)) * 1e-6:.4g} ms before it): the fit '
                             'starts the model at rest at the first sample; record '
                             'joint_states from before the first command, or cut the bag '
                             'there')
    inputs = []
    for stamp, topic, value in logged:
        first = int(np.searchsorted(stamps, stamp - tol, side='left'))
        tick = first + 1 + int(input_delay)
        if tick < len(stamps):
            inputs.append((tick, topic, value))
    inputs.sort(key=lambda item: item[0])   # stable: logged order within a tick
    return Recording(str(path), stamps, values[:, :3], speeds, tuple(inputs))


def _joint_row(path: Any, message: Any, names: Mapping[str, str], index: int
               ) -> tuple[float, ...]:
    """θ(3), ω(3) of one joint_states message in node order (ω NaN where absent)."""
    where = {str(n): k for k, n in enumerate(message.name)}
    missing = [names[j] for j in NODE_JOINTS if names[j] not in where]
    if missing:
        raise RecordingError(f'{path}: joint_states sample {index} names joints '
                             f'{list(where)}, not {", ".join(missing)} '
                             '(map them with --joints NODE=BAG)')
    if len(message.position) != len(message.name):
        raise RecordingError(f'{path}: joint_states sample {index} names '
                             f'{len(message.name)} joints but holds {len(message.position)} '
                             'positions (one per name is needed)')
    position = [float(message.position[where[names[j]]]) for j in NODE_JOINTS]
    velocity = [float(message.velocity[where[names[j]]]) if len(message.velocity) > where[
        names[j]] else math.nan for j in NODE_JOINTS]
    return (*position, *velocity)


def _command(path: Any, topic: Input, message: Any, names: Mapping[str, str], stamp: int,
             logged: list[tuple[int, Input, Any]]) -> None:
    value = command_value(topic, message)
    if topic == Input.JOINT_COMMANDS:
        if carries_no_command(topic, value):
            return
        back = {bag: node for node, bag in names.items()}
        value = type(value)(tuple(back.get(n, n) for n in value.name), *(
            getattr(value, f) for f in ('position', 'velocity', 'effort')))
        numbers: Sequence[float] = value.values()
    else:
        numbers = value if isinstance(value, list) else [float(value)]
    if not all(math.isfinite(v) for v in numbers):
        raise RecordingError(f'{path}: a {topic} command at log time {stamp} ns is not '
                             f'finite ({value!r})')
    logged.append((stamp, topic, value))


def check_alike(recordings: Sequence[Recording], period: float) -> None:
    """Refuse recordings whose sample period is not the model's tick (1/publish_rate)."""
    for recording in recordings:
        if not math.isclose(recording.period, period, rel_tol=0.02):
            raise RecordingError(
                f'{recording.path}: joint_states come every {recording.period * 1e3:.4g} ms, '
                f'but the model ticks every {period * 1e3:.4g} ms: set publish_rate in the '
                'base parameter file to the recording\'s rate')


__all__ = ['check_alike', 'parse_joints', 'read_recording']
