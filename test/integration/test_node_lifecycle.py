"""table_sim processes: parameter files, namespaces, start-up refusals, signals."""

from __future__ import annotations

import signal

import pytest
from paths import ROOT
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, stamp_ns, start_process, wait_until
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Int8

PAPER_YAML = ROOT / 'config' / 'paper.yaml'
T_P = 350.0
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.mark.ros
def test_two_namespaced_tables_do_not_cross_talk_and_stop_cleanly(tmp_path):
    # /axis_a: the shipped paper.yaml with the preload edited to 320 N·m (so the file is
    # visibly what was loaded); /axis_b: paper.yaml verbatim, without /clock, and a
    # misspelt parameter that must be reported, not silently ignored.
    edited = tmp_path / 'paper_320.yaml'
    text = PAPER_YAML.read_text()
    assert 'preload_torque: 350.0' in text
    edited.write_text(text.replace('preload_torque: 350.0', 'preload_torque: 320.0'))
    a = start_process('table_sim', ['-r', '__ns:=/axis_a'], params_file=edited,
                      workdir=tmp_path / 'a')
    b = start_process('table_sim', ['-r', '__ns:=/axis_b'], params_file=PAPER_YAML,
                      params={'publish_clock': False, 'inertia_tabel': 3.0},   # a typo
                      workdir=tmp_path / 'b')
    try:
        with Peer('test_namespaces') as peer:
            js = {ns: peer.subscribe(f'/axis_{ns}/joint_states', JointState) for ns in 'ab'}
            path = {ns: peer.subscribe(f'/axis_{ns}/active_path', Int8, LATCHED)
                    for ns in 'ab'}
            clock = peer.subscribe('/clock', Clock)
            for ns in 'ab':
                js[ns].wait_for(lambda m: True, STARTUP_TIMEOUT, f'/axis_{ns}/joint_states')
            assert js['a'].latest().effort[0] == 320.0 and js['b'].latest().effort[0] == T_P
            assert peer.get_parameters('/axis_a/table_sim', ['preload_torque', 'dt']) == {
                'preload_torque': 320.0, 'dt': 5e-05}
            wait_until(lambda: peer.node.count_publishers('/clock') == 1, 10,
                       'one /clock publisher')

            torque_a = peer.publisher('/axis_a/cmd_torque', Float64)
            torque_b = peer.publisher('/axis_b/cmd_torque', Float64)
            direction_b = peer.publisher('/axis_b/cmd_direction', Int8)
            torque_a.publish(Float64(data=20.0))
            js['a'].wait_next(lambda m: m.position[1] > 1e-4, 10, 'table a turning')
            at_rest = js['b'].wait_next(lambda m: True, 10)
            assert abs(at_rest.position[1]) < 1e-12 and at_rest.effort[0] == T_P

            direction_b.publish(Int8(data=-1))
            torque_b.publish(Float64(data=20.0))
            js['b'].wait_next(lambda m: m.position[1] < -1e-4, 10, 'table b turning back')
            path['b'].wait_for(lambda m: m.data == 3, 10, 'path 3 on b')
            path['a'].wait_for(lambda m: True, 10, 'the latched path of a')
            assert [m.data for m in path['a'].snapshot()] == [1]
            assert js['a'].latest().effort[0] == 320.0 + 20.0   # a kept its own command
            # /clock is a's simulation time
            stamps_a = {stamp_ns(m) for m in js['a'].snapshot()}
            assert stamps_a & {stamp_ns(m) for m in clock.snapshot()}
        seconds_a = assert_clean_exit(a, signal.SIGINT)
        seconds_b = assert_clean_exit(b, signal.SIGTERM)
        assert seconds_a < 5.0 and seconds_b < 5.0    # a hang check; ~0.4 s measured
        assert "'inertia_tabel' is not a table_sim parameter" in b.output()[1]
    finally:
        a.kill()
        b.kill()


@pytest.mark.ros
@pytest.mark.parametrize('params, expected', [
    ({'inertia_table': -1.0}, 'inertia_table out of range Min: 1e-06'),
    ({'inertia_table': 0.0}, 'inertia_table out of range Min: 1e-06'),
    ({'inertia_table': 'heavy'}, 'inertia_table'),              # a string for a double
    ({'publish_rate': 300.0}, 'whole number'),
    ({'mode': 'sideways'}, "'mode' = 'sideways' refused"),
])
def test_a_bad_parameter_file_is_refused_at_start_with_the_reason(tmp_path, params, expected):
    proc = start_process('table_sim', params=params, workdir=tmp_path)
    try:
        code = proc.popen.wait(timeout=STARTUP_TIMEOUT)
    finally:
        proc.kill()
    stderr = proc.output()[1]
    assert code == 2, stderr
    assert expected in stderr and 'Traceback' not in stderr
