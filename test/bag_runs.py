"""In-process recorded runs for the bag tests: Plant + RunRecorder + rclpy messages.

:func:`record_inprocess` writes what the node writes under the bag contract of
docs/recording.md (outputs every publish period, inputs as applied, run_parameters
and resets), with no DDS and no node, so the reader and check_run can be tested on
runs of known content. Messages are built with the ROS 2 message classes and
serialized by rclpy, exactly as the node does.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import yaml
from builtin_interfaces.msg import Time
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64, Float64MultiArray, Header, Int8, String

from screwgear_ros.commands import apply_command
from screwgear_ros.params import SimSettings, TableParams
from screwgear_ros.plant import Plant
from screwgear_ros.run_parameters import RunParameters, dump
from screwgear_ros.runs import RunRecorder, TopicSpec

INPUT_TYPES = {'cmd_torque': Float64, 'cmd_direction': Int8, 'cmd_effort': Float64MultiArray,
               'load_torque': Float64}


@dataclass(frozen=True)
class Action:
    """At simulation time ``time`` (s): an input command, a parameter change or a reset.

    ``kind`` is an input topic (value = the message's data), 'parameters' (value =
    a mapping of changed TableParams fields) or 'reset'.
    """

    time: float
    kind: str
    value: Any = None


def topic_specs(namespace: str = '', node: str = 'table_sim') -> list[TopicSpec]:
    """The node's recorded topics under ``namespace`` (e.g. '/axis_c')."""
    ns = namespace.rstrip('/')
    return [
        TopicSpec(f'{ns}/joint_states', 'sensor_msgs/msg/JointState'),
        TopicSpec(f'{ns}/transmission_error', 'std_msgs/msg/Float64'),
        TopicSpec(f'{ns}/mesh_state', 'sensor_msgs/msg/JointState'),
        TopicSpec(f'{ns}/active_path', 'std_msgs/msg/Int8', transient_local=True),
        TopicSpec('/clock', 'rosgraph_msgs/msg/Clock'),
        TopicSpec(f'{ns}/cmd_torque', 'std_msgs/msg/Float64'),
        TopicSpec(f'{ns}/cmd_direction', 'std_msgs/msg/Int8'),
        TopicSpec(f'{ns}/cmd_effort', 'std_msgs/msg/Float64MultiArray'),
        TopicSpec(f'{ns}/load_torque', 'std_msgs/msg/Float64'),
        TopicSpec(f'{ns}/{node}/run_parameters', 'std_msgs/msg/String'),
        TopicSpec(f'{ns}/{node}/reset', 'std_msgs/msg/Empty'),
    ]


def stamp(ns: int) -> Time:
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def record_inprocess(path: str | Path, params: TableParams, settings: SimSettings,
                     actions: Sequence[Action], duration: float, namespace: str = '',
                     **recorder_options: Any) -> RunRecorder:
    """Simulate ``duration`` seconds with ``actions`` and record it to ``path``.

    Returns the closed recorder (for its counters).
    """
    specs = topic_specs(namespace)
    name = {s.name.rsplit('/', 1)[-1]: s.name for s in specs}
    recorder = RunRecorder(path, specs, serialize_message, **recorder_options)
    dt = settings.dt
    spp = settings.steps_per_publish
    plant = Plant(params, dt)
    end = int(round(duration / dt))
    schedule = sorted(((int(round(a.time / dt)), k, a) for k, a in enumerate(actions)))

    def t_ns(step: int) -> int:
        return int(round(step * dt * 1e9))

    def publish() -> None:
        o = plant.outputs()
        t = t_ns(plant.step)
        recorder.write(name['joint_states'], t, JointState(
            header=Header(stamp=stamp(t)), name=list(settings.joint_names), position=list(o.position),
            velocity=list(o.velocity), effort=list(o.effort)))
        recorder.write(name['transmission_error'], t, Float64(data=o.transmission_error))
        recorder.write(name['mesh_state'], t, JointState(
            header=Header(stamp=stamp(t)), name=['mesh_1', 'mesh_3'], position=list(o.delta),
            velocity=list(o.delta_rate), effort=list(o.mesh_force)))
        recorder.write('/clock', t, Clock(clock=stamp(t)))

    initial = tuple(float(v) for v in plant.state)
    recorder.write(name['run_parameters'], 0, String(data=dump(RunParameters(
        params, settings, initial, 0))))
    path_in_force = plant.outputs().active_path
    recorder.write(name['active_path'], 0, Int8(data=path_in_force))
    publish()
    k = 0
    while plant.step < end:
        next_pub = (plant.step // spp + 1) * spp
        target = min(next_pub, end, schedule[k][0] if k < len(schedule) else end)
        if target > plant.step:
            plant.advance(target - plant.step)
        if plant.step % spp == 0:
            publish()
        while k < len(schedule) and schedule[k][0] <= plant.step:
            action = schedule[k][2]
            k += 1
            t = t_ns(plant.step)
            if action.kind == 'reset':
                plant.reset()
                recorder.write(name['reset'], t, Empty())
            elif action.kind == 'parameters':
                params = params.replace(**action.value)
                plant.set_params(params)
                recorder.write(name['run_parameters'], t, String(data=dump(RunParameters(
                    params, settings, initial, 0))))
            else:
                plant.set_input(apply_command(plant.input, action.kind, action.value, params))
                data = list(action.value) if action.kind == 'cmd_effort' else action.value
                recorder.write(name[action.kind], t, INPUT_TYPES[action.kind](data=data))
            new_path = plant.outputs().active_path
            if new_path != path_in_force:
                path_in_force = new_path
                recorder.write(name['active_path'], t, Int8(data=new_path))
    recorder.close()
    return recorder


Edit = Callable[[str, str, int, bytes], 'tuple[int, bytes] | None']


def copy_bag(src: Path, dst: Path, edit: Edit | None = None) -> int:
    """Rewrite the bag ``src`` to ``dst`` message by message, in file order.

    ``edit(topic, type, log_time, cdr)`` returns the (log_time, cdr) to write, or
    None to drop the message. Returns the number of messages written.
    """
    mcap_file, = Path(src).glob('*.mcap')
    schemas: dict[int, str] = {}
    channels: dict[int, TopicSpec] = {}
    messages: list[tuple[str, int, bytes]] = []
    with open(mcap_file, 'rb') as stream:
        for record in StreamReader(stream).records:
            if isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel):
                qos = yaml.safe_load(record.metadata['offered_qos_profiles'])
                channels[record.id] = TopicSpec(record.topic, schemas[record.schema_id],
                                                qos[0]['durability'] == 'transient_local')
            elif isinstance(record, Message):
                spec = channels[record.channel_id]
                kept = (record.log_time, record.data) if edit is None else edit(
                    spec.name, spec.msgtype, record.log_time, record.data)
                if kept is not None:
                    messages.append((spec.name, *kept))
    recorder = RunRecorder(dst, list(channels.values()), bytes)
    for topic, log_time, data in messages:
        recorder.write(topic, log_time, data)
    recorder.close()
    assert recorder.dropped == 0
    return recorder.written


__all__ = ['Action', 'topic_specs', 'record_inprocess', 'copy_bag', 'stamp', 'INPUT_TYPES']
