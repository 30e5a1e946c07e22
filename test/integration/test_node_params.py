"""table_sim's parameters over real DDS, from a second process: one rule at start and
at run time, logs of what was applied, a pace change that takes effect at once, the
diagnostics before the first command, joint_names fixed for a run.

One node process, started as a user would: ``-p inertia_table:=46`` (a whole number
for a double) and a parameter file that gives two STE amplitudes and no phases.
"""

from __future__ import annotations

import itertools
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from ros_procs import STARTUP_TIMEOUT, Peer, stamp_ns, start_process, wait_until
from sensor_msgs.msg import JointState

from screwgear_ros.ros.parameters import HARMONICS

NODE = '/table_sim'
AMPLITUDES = [1.5384e-3, 1.0e-5]
TIMEOUT = 0.2          # command_timeout, s of simulation time


@pytest.fixture(scope='module')
def node():
    with start_process('table_sim', ros_args=['-p', 'inertia_table:=46'],
                       params={'ste_amplitudes': AMPLITUDES, 'command_timeout': TIMEOUT}) \
            as proc, Peer('test_node_params') as peer:
        states = peer.subscribe('/joint_states', JointState)
        diag = peer.subscribe('/diagnostics', DiagnosticArray)
        states.wait_for(lambda m: True, STARTUP_TIMEOUT, 'first joint_states')
        yield proc, peer, states, diag


def _set(peer: Peer, name: str, value) -> tuple[object, float]:
    t0 = time.monotonic()
    (result,) = peer.set_parameters(NODE, {name: value}, timeout=30.0)
    return result, time.monotonic() - t0


@pytest.mark.ros
def test_the_start_takes_the_run_time_rules_integers_and_one_ste_array(node):
    proc, peer, _, _ = node
    assert peer.get_parameters(NODE, ['inertia_table', *HARMONICS]) == {
        'inertia_table': 46.0, 'ste_amplitudes': AMPLITUDES, 'ste_phases': [0.0, 0.0]}
    assert 'ste_phases set to [0.0, 0.0] to match 2 STE harmonics' in proc.output()[1]


@pytest.mark.ros
def test_before_the_first_command_the_diagnostics_wait_for_one(node):
    _, _, states, diag = node
    # past command_timeout of simulation time since the start, no command sent yet
    wait_until(lambda: states.latest() is not None and
               stamp_ns(states.latest()) > 3 * TIMEOUT * 1e9, 30.0, 'the timeout passed')
    msg = diag.wait_next(lambda m: True, 10.0, 'diagnostics')
    values = {kv.key: kv.value for kv in msg.status[0].values}
    assert values['command_timed_out'] == 'false'
    assert values['waiting_for_first_command'] == 'true'
    assert 'waiting for the first command' in msg.status[0].message


@pytest.mark.ros
def test_a_refused_set_logs_nothing_and_an_accepted_one_logs_what_it_applied(node):
    proc, peer, _, _ = node
    note = 'ste_phases set to [0.0, 0.0, 0.0] to match 3 STE harmonics'
    # three harmonics whose STE slope passes the pinion radius: refused
    result, _ = _set(peer, 'ste_amplitudes', [1e-3, 1e-3, 1e-3])
    assert not result.successful and 'slope' in result.reason
    assert peer.get_parameters(NODE, HARMONICS)['ste_phases'] == [0.0, 0.0]
    time.sleep(0.5)
    assert note not in proc.output()[1]
    result, _ = _set(peer, 'ste_amplitudes', [1e-4, 1e-5, 1e-6])
    assert result.successful
    wait_until(lambda: note in proc.output()[1], 10.0, 'the completion in the log')
    assert _set(peer, 'ste_amplitudes', AMPLITUDES)[0].successful


@pytest.mark.ros
def test_a_set_of_one_ste_array_that_would_drop_a_nonzero_value_is_refused(node):
    """Two amplitudes in force: a single phase would cut the second amplitude (1e-05). The
    set is refused, both amplitudes stay, and the log says which value it would lose."""
    proc, peer, _, _ = node
    assert peer.get_parameters(NODE, HARMONICS)['ste_amplitudes'] == AMPLITUDES
    result, _ = _set(peer, 'ste_phases', [0.5])
    assert not result.successful and 'one phase per STE harmonic' in result.reason
    assert peer.get_parameters(NODE, HARMONICS) == {'ste_amplitudes': AMPLITUDES,
                                                    'ste_phases': [0.0, 0.0]}
    wait_until(lambda: 'drop its nonzero 1e-05' in proc.output()[1], 10.0,
               'the reason in the log')
    assert 'ste_amplitudes set to' not in proc.output()[1]


@pytest.mark.ros
def test_a_pace_set_back_takes_effect_at_once_not_at_the_old_deadline(node):
    proc, peer, states, _ = node
    # 1 Hz at 1/100 of real time: a tick lasts 100 s of wall time. The factor first: at
    # 1 kHz it makes a tick 0.1 s, so the rate is in force well within the pause below,
    # and the node then sleeps towards a deadline 100 s away
    assert _set(peer, 'real_time_factor', 0.01)[0].successful
    assert _set(peer, 'publish_rate', 1.0)[0].successful
    time.sleep(1.5)
    back = []
    for name, value in (('real_time_factor', 1.0), ('publish_rate', 1000.0)):
        result, seconds = _set(peer, name, value)
        assert result.successful
        back.append(seconds)
    set_back = time.monotonic()
    last = stamp_ns(states.latest())
    # at 1 kHz again: ten new samples 1 ms apart, long before the old 100 s deadline
    fresh = [states.wait_next(lambda m: stamp_ns(m) > last, 20.0, 'joint_states at 1 kHz')
             for _ in range(10)]
    waited = time.monotonic() - set_back
    assert waited < 20.0 and max(back) < 10.0, (waited, back)
    gaps = {stamp_ns(b) - stamp_ns(a) for a, b in itertools.pairwise(fresh)}
    assert 1_000_000 in gaps
    assert proc.alive()


@pytest.mark.ros
def test_joint_names_are_fixed_for_a_run(node):
    _, peer, _, _ = node
    result, _ = _set(peer, 'joint_names', ['a', 'b', 'c'])
    assert not result.successful and 'read-only' in result.reason
