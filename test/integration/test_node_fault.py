"""table_sim when the model itself diverges: it stops integrating, reports the cause
once, keeps publishing the last finite state, and recovers on ~/reset.

Every parameter set that passes validation is RK4-stable at its dt (stability.check_step),
so the trigger is physical: with b = 0 and the `time` mesh phase the single-mesh model
is a linear periodic system, and pumping the stiffness (k_a' = 0.5, c = 0) at twice the
mesh natural frequency ω0 is the principal parametric resonance (a Mathieu tongue). The
state grows like exp(k_a'·ω0·t/4) ≈ exp(174 t/s) and overflows after a few seconds of
simulated time.
"""

from __future__ import annotations

import math
import signal

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from ros_procs import Peer, assert_clean_exit, stamp_ns, start_process
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.quantities import natural_frequency

UNSTABLE = TableParams(mode='conventional', backlash=0.0, mesh_phase='time',
                       mesh_stiffness_amplitude=5.0e6, mesh_damping=0.0)
OMEGA_0 = natural_frequency(UNSTABLE)     # rad/s, single-mesh natural frequency


def _finite(msg: JointState) -> bool:
    return all(math.isfinite(v) for v in (*msg.position, *msg.velocity, *msg.effort))


@pytest.mark.ros
def test_a_diverging_model_halts_integration_not_publishing(tmp_path):
    from screwgear_ros.bag.reader import Reset, read_run
    from screwgear_ros.runs.replay_in_process import replay_in_process

    bag = tmp_path / 'run'
    proc = start_process('table_sim', params={
        'mode': 'conventional', 'backlash': 0.0, 'mesh_phase': 'time',
        'mesh_stiffness_amplitude': 5.0e6, 'mesh_damping': 0.0,
        'mesh_frequency': 2.0 * OMEGA_0, 'real_time_factor': 5.0, 'record': str(bag),
        # an ideal torque source: the halted state's speeds are far past any drive line,
        # where the torque applied to pinion 1 (its effort) would not be the command
        'drive_no_load_speed': 0.0})
    peer = Peer('test_node_fault')
    try:
        js = peer.subscribe('/joint_states', JointState)
        diag = peer.subscribe('/diagnostics', DiagnosticArray)
        torque = peer.publisher('/cmd_torque', Float64)

        def fault(msg: DiagnosticArray) -> str:
            return {kv.key: kv.value for kv in msg.status[0].values}['fault']

        diag.wait_for(lambda m: 'non-finite' in fault(m), 60.0, 'the fault in /diagnostics')
        halted = [js.wait_next(timeout=10.0) for _ in range(20)]
        assert all(_finite(m) for m in halted)                  # never NaN on the wire
        assert len({stamp_ns(m) for m in halted}) == 1           # simulation time stands
        assert all(list(m.position) == list(halted[0].position) for m in halted)
        assert proc.output()[1].count('non-finite') == 1        # reported once
        # a command arriving meanwhile is taken and in force after the recovery
        torque.publish(Float64(data=5.0))
        js.wait_next(lambda m: m.effort[0] == 5.0, 10.0, 'the command taken while halted')
        # detune the pump (a valid run-time change), then reset: integration resumes
        results = peer.set_parameters('/table_sim', {'mesh_stiffness_amplitude': 1.0e6,
                                                     'mesh_damping': 717.0})
        assert all(r.successful for r in results)
        assert peer.call(Trigger, '/table_sim/reset').success
        diag.wait_next(lambda m: fault(m) == '', 15.0, 'the fault cleared')
        moving = js.wait_next(lambda m: stamp_ns(m) > stamp_ns(halted[-1]) and m.velocity[1] > 0,
                              10.0, 'the table driven again')
        assert _finite(moving)
    finally:
        peer.close()
        if proc.alive():
            assert_clean_exit(proc, signal.SIGINT)
        proc.kill()
    # the recording of the fault and the recovery replays in-process bit for bit
    run = read_run(bag)
    assert any(isinstance(e, Reset) for _, e in run.events)
    replayed = replay_in_process(run)
    assert np.array_equal(replayed.joint_states, run.joint_states.values)
