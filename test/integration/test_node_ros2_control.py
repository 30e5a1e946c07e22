"""table_sim at the far end of ros2_control's stock topic hardware interface, and as a
machine RViz and Foxglove can show, with no ros2_control, RViz or Foxglove installed.

A test peer plays ``joint_state_topic_hardware_interface/JointStateTopicSystem`` as it
runs for the shipped URDF: every controller-manager cycle (the ``update_rate`` of
config/ros2_control.yaml, as ros2_control_node runs it) it publishes a
sensor_msgs/JointState naming every joint of the ``<ros2_control>`` block, with empty
``position`` and ``velocity`` (no such command interfaces) and one ``effort`` value
(pinion_1/effort), NaN until a controller wrote it; QoS as the plugin's (keep last 1,
reliable). The node runs in the namespace the shipped URDF points at.

No assertion depends on machine load: the node's reactions are waited for with generous
timeouts, deliveries are acknowledged (``wait_for_all_acked``) where a count matters,
markers are compared with joint_states of the same stamp (in the recording, and live in
lockstep, where the test paces the ticks), and never with a timing margin.
"""

from __future__ import annotations

import math
import signal
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_runs import record_session
from diagnostic_msgs.msg import DiagnosticArray
from model_laws import drive_line
from paths import ROOT
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, stamp_ns, start_process
from sensor_msgs.msg import JointState
from std_msgs.msg import Int8, String
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

from screwgear_ros.bag.reader import read_run
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.physics.packed import pack
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.sim.commands import JointCommand
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.schedule import Schedule
from screwgear_ros.view.layout import BASE_LINK, PALETTE, wheels
from screwgear_ros.view.markers import DISCS, MARKS, MESHES
from screwgear_ros.view.urdf import PLANT_NAMESPACE, shipped_description

NS = PLANT_NAMESPACE                   # where the shipped URDF's ros2_control block looks
NODE = f'{NS}/table_sim'
T_P = 350.0                            # default preload torque, N·m
JOINTS = list(SimSettings().joint_names)
WHEELS = wheels(TableParams(), JOINTS)
PLUGIN_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,      # rclcpp::QoS(1)
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
ACKED = Duration(seconds=10)
#: Hz of the controller manager, whose write() publishes the plugin's message
UPDATE_RATE = yaml.safe_load((ROOT / 'config/ros2_control.yaml')
                             .read_text())['controller_manager']['ros__parameters']['update_rate']


def plugin_message(effort: float, peer: Peer | None = None) -> JointState:
    """What JointStateTopicSystem publishes for urdf/screwgear_table.urdf."""
    msg = JointState(name=list(JOINTS), position=[], velocity=[], effort=[effort])
    if peer is not None:
        msg.header.stamp = peer.node.get_clock().now().to_msg()   # the manager's clock
    return msg


def wrapped(angle: float) -> float:
    """``angle`` in (−π, π]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def mark_direction(marker) -> float:
    """Direction of a mark (an ARROW from the axis to the rim), rad from +x."""
    start, end = marker.points
    return math.atan2(end.y - start.y, end.x - start.x)


def by_key(markers) -> dict[tuple[str, int], object]:
    return {(m.ns, m.id): m for m in markers}


def assert_markers_show(markers, position, active_path: int) -> None:
    """The markers of one instant show joint angles ``position`` (θ1, θ2, θ3) and path."""
    found = by_key(markers)
    assert set(found) == {*((DISCS, i) for i in range(3)), *((MARKS, i) for i in range(3)),
                          (MESHES, 0), (MESHES, 1)}
    assert all(m.header.frame_id == BASE_LINK for m in markers)
    for wheel in WHEELS:
        disc, mark = found[(DISCS, wheel.index)], found[(MARKS, wheel.index)]
        assert disc.type == Marker.CYLINDER and mark.type == Marker.ARROW
        assert (disc.pose.position.x, disc.pose.position.y) == pytest.approx(wheel.centre)
        assert disc.scale.x == pytest.approx(2 * wheel.radius)
        assert (mark.points[0].x, mark.points[0].y) == pytest.approx(wheel.centre)
        # the mark turns with the joint: with the table (clockwise), with each pinion
        # (counterclockwise), as the URDF's joint axes say
        assert wrapped(mark_direction(mark) - wheel.turn * position[wheel.index]) == \
            pytest.approx(0.0, abs=1e-9)
    active = found[(DISCS, 0 if active_path == 1 else 2)].color
    assert (active.r, active.g, active.b, active.a) == pytest.approx(PALETTE['pinion_active'])


# ---------------------------------------------------------------- without DDS

def test_the_marks_turn_as_the_urdf_links_do():
    """Markers and URDF agree: the URDF's forward kinematics (yourdfpy) turns each
    link's +x, where its mark visual sits, to the direction of the marker's mark."""
    import yourdfpy

    from screwgear_ros.ros.messages import stamp
    from screwgear_ros.sim.plant import Plant
    from screwgear_ros.view.markers import table_markers
    urdf = yourdfpy.URDF.load(ROOT / 'urdf/screwgear_table.urdf',
                              load_meshes=False, build_scene_graph=True)
    rng = np.random.default_rng(7)
    base = Plant(TableParams(), 5e-5).compute_outputs()
    for _ in range(5):
        angles = tuple(float(a) for a in rng.uniform(-20.0, 20.0, 3))
        urdf.update_cfg(dict(zip(JOINTS, angles, strict=True)))
        out = replace(base, position=angles)
        found = by_key(table_markers(TableParams(), JOINTS, out, stamp(0)).markers)
        for wheel in WHEELS:
            pose = urdf.get_transform(wheel.link)
            assert pose[:2, 3] == pytest.approx(wheel.centre)
            x_axis = pose[:3, 0]
            assert wrapped(mark_direction(found[(MARKS, wheel.index)])
                           - math.atan2(x_axis[1], x_axis[0])) == pytest.approx(0.0, abs=1e-9)


def test_contact_colours_follow_the_meshes():
    from screwgear_ros.ros.messages import stamp
    from screwgear_ros.sim.plant import DriveInput, Plant
    from screwgear_ros.view.markers import table_markers
    params = TableParams()
    out = Plant(params, 5e-5).compute_outputs()                     # preload: both on a flank

    def colours(p, o):
        found = by_key(table_markers(p, JOINTS, o, stamp(0)).markers)
        return [tuple(pytest.approx(c) for c in (m.color.r, m.color.g, m.color.b, m.color.a))
                for m in (found[(MESHES, 0)], found[(MESHES, 1)])]
    assert colours(params, out) == [PALETTE['contact'], PALETTE['contact']]
    # a conventional reversal: mesh 1 leaves its flank and crosses the backlash gap
    conventional = params.replace(mode='conventional', preload_torque=0.0)
    plant = Plant(conventional, 5e-5)
    plant.set_input(DriveInput(200.0, 1, 0.0))
    plant.advance(2000)
    plant.set_input(DriveInput(200.0, -1, 0.0))
    gap = next(o for o in (plant.advance_outputs(1) for _ in range(20000))
               if abs(o.delta[0]) <= params.backlash)
    assert colours(conventional, gap) == [PALETTE['gap'], PALETTE['disengaged']]


@pytest.mark.parametrize('period, expected', [(3600.0, 1), (0.0, 'every tick')])
def test_markers_are_throttled_by_wall_time_not_by_ticks(tmp_path, monkeypatch, period,
                                                         expected):
    """RunIO's marker period: an hour gives the start's markers only, zero gives one per
    tick; both are recorded with the URDF, which the bag reader ignores."""
    from rosbags.rosbag2 import Reader

    from screwgear_ros.runs import run_io
    schedule = Schedule(TableParams(), SimSettings(), [
        Command('joint_commands', JointCommand(tuple(JOINTS), effort=(30.0,)), 200)],
        end_step=2_000)
    monkeypatch.setattr(run_io, 'MARKER_PERIOD', period)
    record_session(tmp_path / 'run', schedule)
    with Reader(tmp_path / 'run') as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    ticks = 2_000 // schedule.settings.steps_per_publish + 1
    assert counts['/table_markers'] == (ticks if expected == 'every tick' else expected)
    assert counts['/robot_description'] == 1
    run = read_run(tmp_path / 'run')
    assert [e for _, e in run.events if isinstance(e, Command)] == schedule.events
    assert np.array_equal(replay_in_process(run).joint_states, run.joint_states.values)


@pytest.mark.ros
def test_recorded_markers_follow_a_change_of_the_tables_geometry(tmp_path, monkeypatch):
    """A marker per tick, through a parameter change that resizes the table: each one
    decodes (rosbags, from the bag) to the disc and marks of the parameters in force at
    its stamp, with the mark of every wheel where that tick's joint_states puts it."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    from screwgear_ros.runs import run_io
    from screwgear_ros.sim.events import ParameterChange
    before = TableParams()
    after = before.replace(radius_table=1.5 * before.radius_table)
    schedule = Schedule(before, SimSettings(), [
        Command('joint_commands', JointCommand(tuple(JOINTS), effort=(30.0,)), 100),
        ParameterChange(after, SimSettings(), 600)], end_step=1_200)
    monkeypatch.setattr(run_io, 'MARKER_PERIOD', 0.0)
    record_session(tmp_path / 'run', schedule)
    store = get_typestore(Stores.ROS2_JAZZY)
    positions, arrays = {}, {}
    with Reader(tmp_path / 'run') as reader:
        for c, t, raw in reader.messages():
            if c.topic == '/joint_states':
                positions[t] = list(store.deserialize_cdr(raw, c.msgtype).position)
            elif c.topic == '/table_markers':
                arrays[t] = store.deserialize_cdr(raw, c.msgtype).markers
    assert len(arrays) == 1_200 // schedule.settings.steps_per_publish + 1
    step_ns = round(schedule.settings.dt * 1e9)
    for t, markers in arrays.items():
        params = after if t > 600 * step_ns else before     # the tick ending at 600: before
        found = by_key(markers)
        table = found[(DISCS, 1)]
        assert table.scale.x == pytest.approx(2.0 * params.radius_table)
        for wheel in wheels(params, JOINTS):
            mark = found[(MARKS, wheel.index)]
            assert (mark.points[0].x, mark.points[0].y) == pytest.approx(wheel.centre)
            assert wrapped(mark_direction(mark) - wheel.turn * positions[t][wheel.index]) == \
                pytest.approx(0.0, abs=1e-9)


# ---------------------------------------------------------------- the node over DDS

class TopicSystem:
    """The peer's stand-in for JointStateTopicSystem: publishes the plugin's message
    every cycle (NaN until :meth:`command` is first called), as the controller manager's
    write() does, from its own thread."""

    def __init__(self, peer: Peer, topic: str, period: float = 1.0 / UPDATE_RATE) -> None:
        self.peer = peer
        self.pub = peer.publisher(topic, JointState, PLUGIN_QOS)
        self.effort = math.nan
        self.sent = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._period = period
        self._thread = threading.Thread(target=self._run, daemon=True, name='topic system')
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            with self._lock:
                self.pub.publish(plugin_message(self.effort, self.peer))
                self.sent += 1

    def command(self, effort: float) -> None:
        """What a controller writing ``effort`` to pinion_1/effort makes the plugin send."""
        with self._lock:
            self.effort = effort
            self.pub.publish(plugin_message(effort, self.peer))
            assert self.pub.wait_for_all_acked(ACKED)

    def send_once(self, msg: JointState) -> None:
        """One message, delivered (acknowledged) before the next cycle's."""
        with self._lock:
            self.pub.publish(msg)
            assert self.pub.wait_for_all_acked(ACKED)

    def wait_sent(self, n: int, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while self.sent < n:
            assert time.monotonic() < deadline, f'the topic system sent {self.sent} < {n}'
            time.sleep(0.01)
        with self._lock:
            assert self.pub.wait_for_all_acked(ACKED)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)


def diag_values(msg: DiagnosticArray) -> dict[str, str]:
    return {kv.key: kv.value for kv in msg.status[0].values}


class Table:
    """The node in NS as the test sees it."""

    def __init__(self, peer: Peer, proc) -> None:
        self.peer, self.proc = peer, proc
        self.js = peer.subscribe(f'{NS}/joint_states', JointState)
        self.path = peer.subscribe(f'{NS}/active_path', Int8, LATCHED)
        self.diag = peer.subscribe('/diagnostics', DiagnosticArray)
        self.markers = peer.subscribe(f'{NS}/table_markers', MarkerArray, LATCHED)
        self.js.wait_for(lambda m: True, STARTUP_TIMEOUT, 'first joint_states')
        self.plugin = TopicSystem(peer, f'{NS}/joint_commands')

    def next_js(self, predicate=lambda m: True, what='joint_states', timeout=10.0):
        return self.js.wait_next(predicate, timeout, what)

    def next_diag(self, predicate=lambda v: True, timeout=15.0) -> dict[str, str]:
        return diag_values(self.diag.wait_next(lambda m: predicate(diag_values(m)), timeout,
                                               'matching diagnostics'))

    def path_becomes(self, path: int) -> None:
        self.path.wait_for(lambda m: m is self.path.latest() and m.data == path, 10,
                           f'active_path {path}')

    def fresh(self) -> None:
        """No drive, back at the preload equilibrium."""
        self.plugin.command(0.0)
        self.next_js(lambda m: m.effort[0] == T_P and m.effort[2] == -T_P, 'no drive')
        assert self.peer.call(Trigger, f'{NODE}/reset').success
        self.next_js(lambda m: abs(m.position[1]) < 1e-12 and abs(m.velocity[1]) < 1e-12,
                     'the table at rest after the reset')


@pytest.fixture(scope='module')
def table(tmp_path_factory):
    bag = tmp_path_factory.mktemp('ros2_control') / 'run'
    with start_process('table_sim', ros_args=['-r', f'__ns:={NS}'],
                       params={'real_time_factor': 1.0, 'record': str(bag)}) as proc, \
            Peer('test_ros2_control') as peer:
        t = Table(peer, proc)
        try:
            t.bag = bag
            yield t
        finally:
            t.plugin.close()


@pytest.mark.ros
def test_joint_states_always_fill_all_three_arrays_with_the_urdf_joint_names(table):
    import yourdfpy
    urdf = yourdfpy.URDF.load(ROOT / 'urdf/screwgear_table.urdf',
                              load_meshes=False)
    msgs = [table.next_js() for _ in range(50)]
    for m in msgs:
        assert list(m.name) == urdf.actuated_joint_names == JOINTS
        assert len(m.position) == len(m.velocity) == len(m.effort) == 3
        assert all(math.isfinite(v) for v in (*m.position, *m.velocity, *m.effort))


@pytest.mark.ros
def test_nan_before_the_first_command_is_no_command_and_silent(table):
    before = table.next_diag()
    table.plugin.wait_sent(100)                        # 100 cycles of NaN, delivered
    assert table.next_js().effort[0] == T_P            # no drive
    table.plugin.command(5.0)                          # the first command, after them
    table.next_js(lambda m: m.effort[0] == T_P + 5.0, 'the first command applied')
    after = table.next_diag()
    assert after['rejected_joint_commands'] == before['rejected_joint_commands'] == '0'
    assert after['rejected_inputs'] == before['rejected_inputs']
    assert 'joint_commands' not in table.proc.output()[1]   # no warning in the node's log


@pytest.mark.ros
def test_the_plugins_efforts_drive_the_table_both_ways_like_cmd_effort(table):
    table.fresh()
    table.plugin.command(20.0)
    m = table.next_js(lambda m: m.effort[0] == T_P + 20.0, 'the forward drive on path 1')
    assert m.effort[2] == -T_P                         # pinion 3 keeps its preload
    table.path_becomes(1)
    table.next_js(lambda m: m.position[1] > 0.05 and m.velocity[1] > 0.0,
                  'the table turning forward')
    table.plugin.command(-20.0)
    table.path_becomes(3)
    m = table.next_js(lambda m: m.effort[2] == -T_P - 20.0, 'the drive on path 3')
    assert m.effort[0] == T_P
    table.next_js(lambda m: m.velocity[1] < 0.0, 'the table turning back')
    table.plugin.command(0.0)      # zero (also what the effort controller writes when it
    #                                is deactivated): no torque, direction kept
    table.next_js(lambda m: m.effort[0] == T_P and m.effort[2] == -T_P, 'no drive')
    assert table.path.latest().data == 3
    table.plugin.command(15.0)
    table.path_becomes(1)
    assert 'reversal at t = ' in table.proc.output()[1]


def _bad(**fields) -> JointState:
    msg = plugin_message(10.0)
    for key, value in fields.items():
        setattr(msg, key, value)
    return msg


BAD_COMMANDS = [
    ('two efforts', _bad(effort=[10.0, 10.0])), ('no effort', _bad(effort=[])),
    ('a position command', _bad(position=[0.1])),
    ('a velocity command', _bad(velocity=[0.1, 0.1, 0.1])),
    ('an unknown joint', _bad(name=['joint_1', 'pinion_1'])),
    ('pinion_1 missing', _bad(name=['table', 'pinion_3'])),
    ('infinite', _bad(effort=[math.inf])), ('over max_torque', _bad(effort=[-400.5])),
    # NaN in a message the plugin could not send is no "not yet commanded": refused and
    # counted as its finite twin
    ('two NaN efforts', _bad(effort=[math.nan, math.nan])),
    ('NaN with an unknown joint', _bad(effort=[math.nan], name=['joint_1', 'pinion_1'])),
]


@pytest.mark.ros
def test_a_joint_command_the_table_cannot_take_is_rejected_counted_and_changes_nothing(table):
    table.fresh()
    table.plugin.command(10.0)
    table.next_js(lambda m: m.effort[0] == T_P + 10.0, 'drive 10 N·m')
    before = table.next_diag()
    for _, msg in BAD_COMMANDS:
        table.plugin.send_once(msg)
    key = 'rejected_joint_commands'
    after = table.next_diag(lambda v: int(v[key]) - int(before[key]) >= len(BAD_COMMANDS))
    assert int(after[key]) - int(before[key]) == len(BAD_COMMANDS)
    msgs = [table.next_js() for _ in range(20)]
    # still the 10 N·m command, as the drive's torque–speed line delivers it at the
    # pinion's speed (the table speeds up for seconds meanwhile: past the line's corner
    # the applied torque falls below the command)
    line = pack(TableParams()).p
    assert [(m.effort[0], m.effort[2]) for m in msgs] == [
        (T_P + drive_line(10.0, m.velocity[0], line), -T_P) for m in msgs]
    assert table.path.latest().data == 1
    log = table.proc.output()[1]
    assert "joint_commands: rejected JointState(name=['pinion_1', 'table', 'pinion_3'], " \
           "effort=[10.0, 10.0]): expects exactly one effort value" in log


@pytest.mark.ros
def test_robot_description_is_latched_and_is_the_shipped_urdf(table):
    import sys
    installed = Path(sys.prefix) / 'share/screwgear_ros/urdf/screwgear_table.urdf'
    late = table.peer.subscribe(f'{NS}/robot_description', String, LATCHED)
    text = late.wait_for(lambda m: True, 10, 'robot_description').data
    assert text == installed.read_text(encoding='utf-8') == shipped_description()


@pytest.mark.ros
def test_table_markers_are_live_in_a_fixed_frame(table):
    late = table.peer.subscribe(f'{NS}/table_markers', MarkerArray, LATCHED)
    assert late.wait_for(lambda m: True, 10, 'the latched table_markers')
    arrays = [table.markers.wait_next(lambda m: True, 10, 'table_markers') for _ in range(3)]
    stamps = [stamp_ns(a.markers[0]) for a in arrays]
    assert stamps == sorted(stamps) and len(set(stamps)) == 3
    for array in arrays:
        assert {(m.ns, m.id) for m in array.markers} == {
            *((DISCS, i) for i in range(3)), *((MARKS, i) for i in range(3)),
            (MESHES, 0), (MESHES, 1)}
        assert {m.header.frame_id for m in array.markers} == {BASE_LINK}
        assert len({stamp_ns(m) for m in array.markers}) == 1


@pytest.mark.ros
def test_the_recording_holds_the_model_and_the_markers_turning_with_the_joints(table):
    """Runs last: stops the node and reads its bag with rosbags."""
    from rosbags.rosbag2 import Reader

    from screwgear_ros.bag.format import typestore
    table.plugin.command(0.0)
    table.plugin.close()
    assert_clean_exit(table.proc, signal.SIGINT)
    store = typestore()
    joint_states, markers, descriptions = {}, [], []
    with Reader(table.bag) as reader:
        for conn, t, raw in reader.messages():
            if conn.topic == f'{NS}/joint_states':
                joint_states[t] = store.deserialize_cdr(raw, conn.msgtype)
            elif conn.topic == f'{NS}/table_markers':
                markers.append((t, store.deserialize_cdr(raw, conn.msgtype)))
            elif conn.topic == f'{NS}/robot_description':
                descriptions.append(store.deserialize_cdr(raw, conn.msgtype).data)
    meta = yaml.safe_load((table.bag / 'metadata.yaml').read_text())
    qos = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles']
           for t in meta['rosbag2_bagfile_information']['topics_with_message_count']}
    assert qos[f'{NS}/robot_description'][0]['durability'] == 'transient_local'
    assert descriptions == [shipped_description()]        # Foxglove loads the model from it
    # the bag reader ignores the model and the markers
    run = read_run(table.bag)
    path_steps, paths = run.active_path.steps, run.active_path.values[:, 0]
    assert len(markers) > 10
    table_angles = []
    for t, array in markers:
        js = joint_states[t]                               # written in the same tick
        step = round(t / (run.dt * 1e9))
        # The markers show the outputs of the tick that ended at `step`: a path change
        # recorded at `step` took effect there, in the tick that starts at it (markers
        # are throttled by wall time, so one lands on such a step now and then).
        path = int(paths[max(np.searchsorted(path_steps, step, side='left') - 1, 0)])
        assert_markers_show(array.markers, js.position, path)
        assert all(stamp_ns(m) == t for m in array.markers)
        table_angles.append(js.position[1])
    assert max(table_angles) - min(table_angles) > 0.05  # the marks turned
    # the plugin's commands as the node applied them: no NaN, no rejected message
    commands = [e for _, e in run.events if isinstance(e, Command) and
                e.topic == 'joint_commands']
    efforts = [c.value.effort for c in commands]
    assert efforts[:1] == [(5.0,)] and (20.0,) in efforts and (-20.0,) in efforts
    assert all(c.value == JointCommand(tuple(JOINTS), (), (), c.value.effort) and
               math.isfinite(c.value.effort[0]) and abs(c.value.effort[0]) <= 400.0
               for c in commands)
    replayed = replay_in_process(run)
    assert np.array_equal(replayed.joint_states, run.joint_states.values)


@pytest.mark.ros
def test_lockstep_takes_the_plugins_message_as_the_answer_and_shows_every_tick(tmp_path):
    """The test is the controller manager: it answers each joint_states stamp with one
    plugin message, a NaN first (a tick, no command). It waits for each tick's markers
    (latched: a late subscription still gets them), then 50 ms before answering, so
    every tick comes more than the marker period (33 ms of wall time) after the last
    markers: each tick has its markers, and their marks are compared with that tick's
    joint angles, live."""
    bag = tmp_path / 'run'
    sim = start_process('table_sim', params={'lockstep': True, 'real_time_factor': 0.0,
                                             'record': str(bag)}, workdir=tmp_path / 'sim')
    answers = [math.nan, *([150.0] * 6), *([-150.0] * 6)]
    try:
        with Peer('test_lockstep_plugin') as peer:
            js = peer.subscribe('/joint_states', JointState)
            markers = peer.subscribe('/table_markers', MarkerArray, LATCHED)
            pub = peer.publisher('/joint_commands', JointState, PLUGIN_QOS)
            shown = []
            for k in range(len(answers) + 1):
                state = js.wait_for(lambda m, k=k: stamp_ns(m) == k * 1_000_000,
                                    STARTUP_TIMEOUT, f'tick {k}')
                array = markers.wait_for(lambda a, k=k: stamp_ns(a.markers[0]) ==
                                         k * 1_000_000, 30.0, f'the markers of tick {k}')
                assert_markers_show(array.markers, state.position,
                                    3 if state.effort[2] < -T_P else 1)
                shown.append(mark_direction(by_key(array.markers)[(MARKS, 0)]))
                if k == len(answers):
                    break
                time.sleep(0.05)
                pub.publish(plugin_message(answers[k], peer))
            assert js.latest().effort[2] == -T_P - 150.0        # the last answer: reverse
            assert shown[1] == shown[0]                         # the NaN tick: no drive
            assert shown[7] > shown[2]                          # pinion 1 turned forward
        assert_clean_exit(sim, signal.SIGINT)
    finally:
        sim.kill()
    log = sim.output()[1]
    assert 'joint_commands' not in log.replace('cmd_effort, joint_commands or ~/tick', '')
    run = read_run(bag)
    commands = [e for _, e in run.events if isinstance(e, Command)]
    # one tick per answer; the NaN answered tick 0 and commanded nothing
    assert [(c.step, c.value.effort) for c in commands] == [
        (k * 20, (answers[k],)) for k in range(1, len(answers))]
    assert list(run.joint_states.steps) == [k * 20 for k in range(len(answers) + 1)]


@pytest.mark.ros
def test_markers_reach_a_viewer_that_comes_while_the_node_waits(tmp_path):
    """Not recording, the node builds table_markers only for a subscriber. One that
    subscribes while the node waits in lockstep (no marker published yet: nobody was
    listening) gets the waiting tick's markers from the re-send, and the next tick's
    after it answers."""
    sim = start_process('table_sim', params={'lockstep': True, 'real_time_factor': 0.0},
                        workdir=tmp_path / 'sim')
    try:
        with Peer('test_markers_viewer') as peer:
            js = peer.subscribe('/joint_states', JointState)
            pub = peer.publisher('/joint_commands', JointState, PLUGIN_QOS)
            first = js.wait_for(lambda m: stamp_ns(m) == 0, STARTUP_TIMEOUT, 'tick 0')
            markers = peer.subscribe('/table_markers', MarkerArray, LATCHED)
            array = markers.wait_for(lambda a: True, 30.0, 'the waiting tick\'s markers')
            assert stamp_ns(array.markers[0]) == 0
            assert_markers_show(array.markers, first.position, 1)
            time.sleep(0.05)                        # past the marker period
            pub.publish(plugin_message(100.0, peer))
            state = js.wait_for(lambda m: stamp_ns(m) == 1_000_000, 30.0, 'tick 1')
            array = markers.wait_for(lambda a: stamp_ns(a.markers[0]) == 1_000_000, 30.0,
                                     'the markers of tick 1')
            assert_markers_show(array.markers, state.position, 1)
        assert_clean_exit(sim, signal.SIGINT)
    finally:
        sim.kill()
