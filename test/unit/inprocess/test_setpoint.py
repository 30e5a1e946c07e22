"""The controller's setpoint: table_sim's ``setpoint`` input (std_msgs/Float64, rad, the
table joint), only recorded, so that plot_run can show the tracking error.

Over DDS: demo_controller around table_sim in lockstep; the bag is read with rosbags
(not the package's reader) and every recorded setpoint is checked against the demo
profile computed here from the controller's parameters. In-process: a scenario with a
setpoint profile records it as the node does (read with ``mcap`` and ``mcap_ros2``),
and the same run without the setpoint gives the same bits. The setpoint changes nothing
else: a session fed setpoints, finite or not, integrates bit for bit as one fed none,
and a bag with setpoints replays bit for bit (in-process and over DDS). plot_run draws
the setpoint and a tracking-error panel for a bag with one, and the old panels for a
bag without (read from the figure's axes and lines, not its pixels).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from bag_runs import installed
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from paths import DATA, ROOT
from ros_procs import record_lockstep_demo, stamp_ns
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag.reader import read_run
from screwgear_ros.inprocess.scenario import load_scenario
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.runs.plot import Mark, Panel, plt, run_figure
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.sim.control import SETPOINT_REPEAT
from screwgear_ros.sim.events import Command, Setpoint
from screwgear_ros.sim.session import Session, row_of

STORE = get_typestore(Stores.ROS2_JAZZY)
EXAMPLES = ROOT / 'docs' / 'examples'
VALUES = {'table_damping': 0.0, 'command_timeout': 0.0, 'publish_rate': 1000.0}
TARGETS, DWELL = (0.03, -0.03), 0.25
TICKS = 600                    # 0.6 s at 1 kHz: two target jumps
TICK_NS = 1_000_000
TOOL_TIMEOUT = 600.0


def demo_target(t_ns: int) -> float:
    """The demo profile at t_ns of simulation time (its first answer is at t = 0)."""
    return TARGETS[int((t_ns * 1e-9) // DWELL) % len(TARGETS)]


def rosbags_topic(bag: Path, name: str) -> list[tuple[int, object]]:
    """(log time ns, message) of every message on topic ``name``, read with rosbags."""
    with Reader(bag) as reader:
        connections = [c for c in reader.connections if c.topic == name]
        return [(t, STORE.deserialize_cdr(raw, c.msgtype))
                for c, t, raw in reader.messages(connections=connections)]


def table_angles(bag: Path) -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns, table angle rad) of every joint_states, read with rosbags."""
    rows = rosbags_topic(bag, '/joint_states')
    return (np.array([stamp_ns(m) for _, m in rows]),
            np.array([m.position[list(m.name).index('table')] for _, m in rows]))


@pytest.fixture(scope='module')
def demo_bag(tmp_path_factory) -> Path:
    """demo_controller (the rclpy node) around table_sim in lockstep for TICKS ticks,
    recorded by table_sim."""
    return record_lockstep_demo(tmp_path_factory.mktemp('setpoint_demo'), VALUES, TARGETS,
                                DWELL, TICKS, TICK_NS, 'test_setpoint')


@pytest.mark.ros
def test_the_demo_controllers_setpoint_reaches_the_bag(demo_bag):
    with Reader(demo_bag) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
    assert types['/setpoint'] == 'std_msgs/msg/Float64'
    setpoints = rosbags_topic(demo_bag, '/setpoint')
    assert setpoints, 'no setpoint recorded'
    # The controller sends the target it computed for a joint state with its answer;
    # the node records it at the first step of the tick that answer starts, or (when
    # the effort was taken first) of the next one.
    for t, msg in setpoints:
        assert msg.data in (demo_target(t), demo_target(t - TICK_NS)), (t, msg.data)
    times = [t for t, _ in setpoints]
    assert times == sorted(times) and times[0] < DWELL * 1e9
    # sent when it changes: once per target, at the jump (a tick late at most)
    # (the run goes on past TICKS until the node is stopped: its jumps are the bag's)
    stamps, angle = table_angles(demo_bag)
    end = int(stamps[-1])
    changes = [t for k, (t, m) in enumerate(setpoints)
               if k == 0 or m.data != setpoints[k - 1][1].data]
    jumps = [round(k * DWELL * 1e9) for k in range(1, int(end * 1e-9 // DWELL) + 1)
             if k * DWELL * 1e9 <= end - 2 * TICK_NS]
    assert len(jumps) >= 2 and len(jumps) + 1 <= len(changes) <= len(jumps) + 2, changes
    assert all(0 <= t - j <= TICK_NS for t, j in zip(changes[1:], jumps, strict=False)), (changes, jumps)
    assert len(setpoints) <= len(changes) + end // SETPOINT_REPEAT + 1
    # what it is for: the recorded setpoint minus the recorded angle is the tracking
    # error, under a tenth of the step at the end of each dwell (the loop settles in
    # about 0.3 s)
    step = abs(TARGETS[1] - TARGETS[0])
    for end in jumps:
        k = int(np.searchsorted(stamps, end)) - 1
        assert abs(demo_target(int(stamps[k])) - angle[k]) < 0.1 * step, (end, angle[k])


@pytest.mark.ros
def test_a_bag_with_a_setpoint_checks_and_replays_bit_for_bit(demo_bag, tmp_path):
    run = read_run(demo_bag)
    assert len(run.setpoint)
    replay = replay_in_process(run)
    assert np.array_equal(replay.joint_states, run.joint_states.values)
    assert np.array_equal(replay.transmission_error, run.transmission_error.values[:, 0])
    checked = installed('check_run', '--no-progress', demo_bag, timeout=TOOL_TIMEOUT)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    new = tmp_path / 'again'
    result = installed('replay_run', demo_bag, '--record', new, '--compare',
                       timeout=TOOL_TIMEOUT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'IDENTICAL' in result.stdout, result.stdout
    # only recorded, not replayed: the replay's own bag has the channel and no setpoint
    assert len(read_run(new).setpoint) == 0


def axes_by_label(fig) -> dict[str, object]:
    return {ax.get_label(): ax for ax in fig.axes if ax.get_label()}


def with_gid(ax, gid: Mark) -> list:
    return [a for a in ax.get_children() if a.get_gid() == gid]


@pytest.mark.ros
def test_plot_run_draws_the_setpoint_and_the_tracking_error(demo_bag, tmp_path):
    fig = run_figure(read_run(demo_bag))
    try:
        panels = axes_by_label(fig)
        assert list(panels) == list(Panel)
        line, = with_gid(panels[Panel.TABLE_ANGLE], Mark.SETPOINT)
        setpoints = rosbags_topic(demo_bag, '/setpoint')
        assert list(line.get_ydata()[:-1]) == [m.data for _, m in setpoints]
        assert list(line.get_xdata()[:-1]) == pytest.approx([t * 1e-9 for t, _ in setpoints])
        # the error panel: the recorded setpoint held from each recorded time on, minus
        # the recorded angle, in mrad, at every joint_states sample from the first one
        error, = with_gid(panels[Panel.TRACKING], Mark.TRACKING_ERROR)
        stamps, angle = table_angles(demo_bag)
        times = np.array([t for t, _ in setpoints])
        values = np.array([m.data for _, m in setpoints])
        held = np.array([values[times <= s][-1] if (times <= s).any() else math.nan
                         for s in stamps])
        known = np.isfinite(held)
        np.testing.assert_allclose(error.get_xdata(), stamps[known] * 1e-9)
        np.testing.assert_allclose(error.get_ydata(), (held[known] - angle[known]) * 1e3,
                                   rtol=0, atol=1e-12)
        assert panels[Panel.TRACKING].get_ylabel() == 'tracking error [mrad]'
    finally:
        plt.close(fig)
    out = tmp_path / 'plot.png'
    result = installed('plot_run', demo_bag, '-o', out, timeout=TOOL_TIMEOUT)
    assert result.returncode == 0 and out.stat().st_size > 0, result.stderr


def test_a_bag_without_a_setpoint_plots_as_before():
    run = read_run(DATA / 'realtime_demo')        # demo_controller, before the setpoint
    assert len(run.setpoint) == 0
    fig = run_figure(run)
    try:
        panels = axes_by_label(fig)
        assert list(panels) == [p for p in Panel if p is not Panel.TRACKING]
        assert not with_gid(panels[Panel.TABLE_ANGLE], Mark.SETPOINT)
    finally:
        plt.close(fig)


def mcap_topic(bag: Path, name: str) -> list[tuple[int, object]]:
    """(log time ns, message) on topic ``name``, read with mcap and mcap_ros2."""
    mcap_file, = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [(message.log_time, decoded) for _, channel, message, decoded
                in reader.iter_decoded_messages(topics=[name])]


def test_an_in_process_scenario_records_its_setpoint_and_it_changes_nothing(tmp_path):
    scenario = load_scenario(EXAMPLES / 'demo_position_steps.yaml')
    profile = scenario.setpoint
    bag = tmp_path / 'scenario'
    recorded = scenario.run(record=bag)
    setpoints = mcap_topic(bag, '/setpoint')
    assert setpoints and setpoints[0][0] == 0
    for t, msg in setpoints:          # the profile's value at the step it is recorded at
        assert msg.data == profile(t * 1e-9), (t, msg.data)
    times = [t for t, _ in setpoints]
    assert np.diff(times).max() <= SETPOINT_REPEAT    # sent again while it stands still
    for jump, _, after in profile.steps(scenario.duration):
        assert (round(jump * 1e9), after) in [(t, m.data) for t, m in setpoints]
    values = [m.data for _, m in setpoints]
    changes = sum(a != b for a, b in itertools.pairwise(values))
    assert changes == len(profile.steps(scenario.duration))
    # the same run with no setpoint: the same bits, and no setpoint in its bag
    simulation = scenario.simulation()
    controller = scenario.controller.make(simulation, profile)
    plain = simulation.run(controller, scenario.duration, tmp_path / 'plain',
                           events=scenario.events(simulation))
    assert plain.observed.tobytes() == recorded.observed.tobytes()
    assert mcap_topic(tmp_path / 'plain', '/setpoint') == []
    assert len(read_run(bag).setpoint) == len(setpoints)


def test_a_demo_scenario_without_a_profile_records_the_demos_own_targets(tmp_path):
    """The demo controller's targets and dwell are its setpoint when the scenario gives
    no profile: recorded at t = 0 and at every dwell."""
    path = tmp_path / 'demo.yaml'
    path.write_text('parameters: {command_timeout: 0.0}\nduration: 1.0\n'
                    'controller: {use: demo, parameters: {targets: [0.02, -0.01], '
                    'dwell: 0.4}}\n', encoding='utf-8')
    bag = tmp_path / 'bag'
    load_scenario(path).run(record=bag)
    assert [(t, m.data) for t, m in mcap_topic(bag, '/setpoint')] == [
        (0, 0.02), (400_000_000, -0.01), (800_000_000, 0.02)]


def bits(outputs) -> bytes:
    return np.array([*row_of(outputs), *outputs.delta, *outputs.delta_rate,
                     *outputs.mesh_force, outputs.active_path]).tobytes()


def test_setpoints_change_nothing_in_the_session_and_bad_ones_are_refused():
    """Seeded: efforts now and then, a setpoint (finite or not a finite number) every
    tick to one of two sessions; command_timeout on, so a setpoint that counted as a
    command would show."""
    params, settings = TableParams(table_damping=8867.0), SimSettings(publish_rate=1000.0,
                                                                      command_timeout=0.05)
    plain, noted = Session(params, settings), Session(params, settings)
    rng = np.random.default_rng(26)
    bad = [math.nan, math.inf, -math.inf, True, 'x', None]
    refused = timeouts = 0
    for k in range(300):
        if k % 97 == 0:
            effort = float(rng.uniform(-300.0, 300.0))
            for session in (plain, noted):
                session.submit(Command('cmd_effort', [effort]))
        value = (float(rng.normal()) if rng.random() < 0.8
                 else bad[int(rng.integers(len(bad)))])
        noted.submit(Setpoint(value))
        a, b = plain.tick(), noted.tick()
        assert bits(a.outputs) == bits(b.outputs), k
        assert a.drive == b.drive and a.notices == b.notices
        assert plain.timed_out == noted.timed_out
        timeouts += bool(a.notices)
        good = isinstance(value, float) and math.isfinite(value)
        assert [e for e in b.applied if isinstance(e, Setpoint)] == (
            [Setpoint(value, b.start)] if good else [])
        if not good:
            refused += 1
            assert [e.topic for e in b.rejected] == ['setpoint']
            assert 'finite angle' in str(b.rejected[0])
    assert noted.rejected['setpoint'] == refused > 0
    assert timeouts > 0, 'command_timeout never fired: nothing showed it ignores setpoints'
    assert plain.plant.state.tobytes() == noted.plant.state.tobytes()
