"""Read a bag as identification takes it (:class:`~screwgear_ros.identification.samples.Recording`):
the measured joint angles and speeds at each tick, and the commands with the tick that
applies each.

Any rosbag2 bag serves (MCAP or sqlite3 storage, read with ``rosbags``): table_sim's own
recordings and ``ros2 bag record`` of a real table, which hold only ``joint_states`` and
the commands sent (``cmd_effort``, ``cmd_torque`` + ``cmd_direction``, ``load_torque``,
ros2_control's ``joint_commands``). Topics are matched on their relative name; every
other topic (``run_parameters``, ``mesh_state``, ...) is ignored, so both kinds of bag
are read the same way.

Each ``joint_states`` sample is compared at its own time (its header stamp, or its log
time on request: :mod:`~screwgear_ros.identification.retiming` places them, drops
repeats, counts losses, gaps and jitter), so any rate, jitter or loss a recorder leaves
is taken as it is. A command acts from its log time (plus ``input_delay``), held until
the next: the simulation applies it at the first integration step at or after that time
(the node records an applied command at the step it took effect, so its own recordings
map onto the same steps). The simulation starts at rest at the first sample; a command
logged up to one tick before it (the answer to a sample the recorder missed as it
started) applies at the first step, an earlier one is refused.
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
from .retiming import place
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
                   input_delay: float = 0.0, clock: str = 'stamp',
                   tick: float | None = None, namespace: str | None = None) -> Recording:
    """Read one bag (see the module docstring).

    Parameters
    ----------
    path : str or Path
        A rosbag2 directory (MCAP or sqlite3 storage).
    joints : mapping, optional
        Node joint name → the bag's joint name, where they differ.
    input_delay : float
        Ticks of the model (``tick`` s each; may be a fraction) by which the drive applies
        a command after its log time.
    clock : str
        ``'stamp'`` (default): a sample is at its header stamp; ``'log'``: at its log time.
    tick : float, optional
        The model's tick, s (default: the recording's median period).
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
    logs: list[int] = []
    stamps: list[int] = []
    rows: list[tuple[float, ...]] = []
    logged: list[tuple[int, Input, Any]] = []
    try:
        with AnyReader([Path(path)], default_typestore=typestore()) as reader:
            connections = _chosen(path, reader.connections, namespace)
            for connection, stamp, raw in reader.messages(connections=connections):
                rel = _relative(connection.topic)
                message = reader.deserialize(raw, connection.msgtype)
                if rel == JOINT_STATES:
                    logs.append(int(stamp))
                    stamps.append(_stamp(message))
                    rows.append(_joint_row(path, message, names, len(logs) - 1))
                else:
                    _command(path, Input(rel), message, names, int(stamp), logged)
    except RecordingError:
        raise
    except Exception as exc:  # noqa: BLE001 (rosbags has no common error base: any is "not a bag")
        raise RecordingError(f'{path}: cannot read as a rosbag2 bag: {exc}') from None
    if len(logs) < 2:
        raise RecordingError(f'{path}: no joint_states (at least two samples are needed): '
                             'record the table\'s joint_states with its commands')
    if not logged:
        raise RecordingError(f'{path}: no commands ({", ".join(COMMANDS)}): the fit '
                             're-simulates the recorded commands, record them with the '
                             'joint states')
    placed = place(np.asarray(stamps), np.asarray(logs), clock)
    values = np.asarray(rows, dtype=np.float64)[placed.order]
    if not np.isfinite(values[:, :3]).all():
        i = int(placed.order[np.flatnonzero(~np.isfinite(values[:, :3]).all(axis=1))[0]])
        raise RecordingError(f'{path}: joint_states sample {i} holds a position that is '
                             'not finite (NaN or inf)')
    speeds = values[:, 3:6]
    if np.isinf(speeds).any():
        raise RecordingError(f'{path}: joint_states holds an infinite velocity')
    times = placed.times
    period_ns = (placed.period if tick is None else tick) * 1e9
    early = [stamp for stamp, _, _ in logged if stamp < times[0] - period_ns]
    if early:
        # the model starts at rest at the first sample: a command more than a tick before
        # it acted on motion the recording does not show (one within a tick is the answer
        # to a sample the recorder missed as it started: the first step applies it)
        raise RecordingError(f'{path}: {len(early)} command(s) logged before the first '
                             f'joint_states sample (the earliest '
                             f'{(times[0] - min(early)) * 1e-6:.4g} ms before it): the fit '
                             'starts the model at rest at the first sample; record '
                             'joint_states from before the first command, or cut the bag '
                             'there')
    delay = round(float(input_delay) * period_ns)
    inputs = sorted(((max(stamp, int(times[0])) + delay, topic, value)
                     for stamp, topic, value in logged),
                    key=lambda item: item[0])   # stable: logged order at one time
    inputs = [item for item in inputs if item[0] <= times[-1]]
    notes = placed.notes()
    if delay:
        notes.append(f'commands act {delay * 1e-6:.4g} ms after their log times (input delay)')
    return Recording(str(path), times, values[:, :3], speeds, tuple(inputs),
                     values[:, 6:9], int(times[0]), tuple(notes))


def _stamp(message: Any) -> int:
    """The header stamp of a message, ns."""
    head = message.header.stamp
    return int(head.sec) * 1_000_000_000 + int(head.nanosec)


def _joint_row(path: Any, message: Any, names: Mapping[str, str], index: int
               ) -> tuple[float, ...]:
    """θ(3), ω(3), effort(3) of one joint_states message in node order (ω, effort NaN
    where absent)."""
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
    effort = [float(message.effort[where[names[j]]]) if len(message.effort) > where[
        names[j]] else math.nan for j in NODE_JOINTS]
    return (*position, *velocity, *effort)


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


#: Parameters that act through the mesh's vibration: a rate below the mesh mode cannot
#: see them.
MESH_PARAMETERS = ('mesh_stiffness_mean', 'mesh_damping', 'inertia_pinion_1',
                   'inertia_pinion_3')


def check_rate(recordings: Sequence[Recording], fit: Sequence[str], mesh_hz: float
               ) -> list[str]:
    """Refuse a fit of :data:`MESH_PARAMETERS` to recordings sampled below the mesh mode
    at ``mesh_hz`` (fewer than one sample per period of its vibration), naming them;
    the notes for recordings whose Nyquist frequency is below it (the mode aliases: those
    parameters then rest on the meshes' windup under load more than on the vibration)."""
    blind = [name for name in fit if name in MESH_PARAMETERS]
    notes = []
    for recording in recordings:
        rate = 1.0 / recording.period
        if not blind or not math.isfinite(mesh_hz) or rate >= 2 * mesh_hz:
            continue
        if rate < mesh_hz:
            raise RecordingError(
                f'{recording.path}: joint_states at {rate:.4g} Hz cannot see the mesh mode at '
                f'{mesh_hz:.4g} Hz (fewer than one sample per period), so the recording '
                f'cannot determine {", ".join(blind)}: record at {2 * mesh_hz:.4g} Hz or more, '
                'or fix them')
        notes.append(f'{recording.path}: at {rate:.4g} Hz the mesh mode ({mesh_hz:.4g} Hz) is '
                     f'above the Nyquist frequency and aliases: {", ".join(blind)} rest more on '
                     'the meshes\' windup under load')
    return notes


__all__ = ['MESH_PARAMETERS', 'check_rate', 'parse_joints', 'read_recording']
