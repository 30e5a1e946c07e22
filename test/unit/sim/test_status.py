"""What the node reports: contact per mesh, mesh phase per step, diagnostic levels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.params.table import TableParams
from screwgear_ros.sim.pacing import PacerStats
from screwgear_ros.sim.plant import DriveInput, Outputs, Plant
from screwgear_ros.sim.simtime import sim_time_ns
from screwgear_ros.sim.status import (
    ERROR,
    MAX_PHASE_PER_STEP,
    OK,
    WARN,
    AnswerCount,
    Health,
    contact_states,
    diagnostic_values,
    mesh_frequency_ratio,
    mesh_phase_per_step,
    status_line,
)

P = TableParams()
DT = 50e-6


def outputs(delta=(1e-4, -1e-4), velocity=(0.0, 0.0, 0.0), time=1.0, path=1) -> Outputs:
    step = round(time / DT)
    return Outputs(time=time, time_ns=sim_time_ns(step, DT), step=step, position=(0.0, 0.0, 0.0),
                   velocity=velocity, effort=(0.0, 0.0, 0.0), delta=delta,
                   delta_rate=(0.0, 0.0), mesh_force=(0.0, 0.0), active_path=path)


def law(delta: float, force: float, b: float) -> str:
    """model.md §2's contact law, restated on a recorded δ and F: the gap for |δ| ≤ b,
    else the flank, lifting off it while the force is zero (it never pulls)."""
    if b == 0.0:
        return 'in contact (no backlash)'
    if abs(delta) <= b:
        return 'in the gap'
    flank = 'forward flank' if delta > b else 'reverse flank'
    return flank if force != 0.0 else f'lifting off the {flank}'


@pytest.mark.parametrize('backlash', [P.backlash, 0.0])
def test_contact_states_follow_the_backlash_law(backlash):
    """Through conventional reversals (mesh 1 crosses the gap and hits both flanks) and
    anti-backlash ones, every reported contact is the law's reading of δ and F."""
    seen = set()
    for mode in ('conventional', 'anti_backlash'):
        p = P.replace(mode=mode, backlash=backlash, table_damping=8867.0,
                      preload_torque=0.0 if mode == 'conventional' else P.preload_torque)
        plant = Plant(p, DT)
        for k in range(600):
            plant.set_input(DriveInput(200.0, 1 if (k // 150) % 2 == 0 else -1, 0.0))
            out = plant.advance_outputs(20)
            mesh_1, mesh_3 = contact_states(p, out)
            assert mesh_1 == law(out.delta[0], out.mesh_force[0], backlash)
            if mode == 'conventional':
                assert mesh_3 == 'disengaged' and not mesh_3.touching
            else:
                assert mesh_3 == law(out.delta[1], out.mesh_force[1], backlash)
            seen.update((mesh_1, mesh_3))
    expected = ({'forward flank', 'reverse flank', 'in the gap', 'disengaged'} if backlash
                else {'in contact (no backlash)', 'disengaged'})
    assert expected <= seen


def test_the_preload_equilibrium_holds_both_flanks():
    assert contact_states(P, Plant(P, DT).compute_outputs()) == ('forward flank', 'reverse flank')


def test_mesh_phase_per_step_is_teeth_times_pinion_speed_times_dt():
    out = outputs(velocity=(10.0, 1.34, -12.0))
    assert mesh_phase_per_step(P, out, DT) == pytest.approx(24 * 12.0 * DT)
    timed = P.replace(mesh_phase='time')
    assert mesh_phase_per_step(timed, out, DT) == pytest.approx(P.mesh_frequency * DT)
    # the paper's speed (24 r/min at the pinion) is ω_e = 60.3 rad/s: Ω = 0.043
    paper = outputs(velocity=(24 * 2 * math.pi / 60, 0.0, 0.0))
    assert mesh_frequency_ratio(P, paper) == pytest.approx(0.0433, abs=1e-4)


def health(**changes) -> Health:
    h = Health(requested_factor=1.0, achieved_factor=1.0, pacer=PacerStats(),
               rejected={'cmd_torque': 2, 'cmd_direction': 1}, dt=DT, commanded=True)
    for k, v in changes.items():
        setattr(h, k, v)
    return h


def test_a_healthy_run_is_ok_and_reports_counts():
    level, message, values = diagnostic_values(P, outputs(), health())
    v = dict(values)
    assert level == OK and message == 'running'
    assert v['rejected_inputs'] == '3' and v['rejected_cmd_torque'] == '2'
    assert v['fault'] == ''
    v = dict(diagnostic_values(P, Plant(P, DT).compute_outputs(), health())[2])
    assert v['mesh_1_contact'] == 'forward flank' and v['mesh_3_contact'] == 'reverse flank'


def test_falling_behind_too_fast_a_mesh_and_faults_raise_the_level():
    level, message, _ = diagnostic_values(P, outputs(), health(achieved_factor=0.7))
    assert level == WARN and 'cannot keep up' in message
    fast = MAX_PHASE_PER_STEP / (24 * DT) * 1.1                 # pinion speed, rad/s
    level, message, _ = diagnostic_values(P, outputs(velocity=(fast, 0.0, 0.0)), health())
    assert level == WARN and 'mesh phase' in message
    level, message, values = diagnostic_values(P, outputs(), health(fault='state non-finite'))
    assert level == ERROR and message == 'state non-finite'
    assert dict(values)['fault'] == 'state non-finite'
    level, message, _ = diagnostic_values(P, outputs(), health(recorder=(10, 3)))
    assert level == WARN and 'dropped 3' in message
    # factor 0 (as fast as possible) never counts as falling behind
    level, _, _ = diagnostic_values(P, outputs(), health(requested_factor=0.0,
                                                         achieved_factor=12.0))
    assert level == OK


def test_lockstep_waiting_and_command_timeout_are_reported():
    level, message, values = diagnostic_values(P, outputs(), health(command_timed_out=True))
    assert level == OK and 'command_timeout' in message
    assert dict(values)['command_timed_out'] == 'true'
    level, message, values = diagnostic_values(P, outputs(), health(lockstep=True, waiting=4.0,
                                                                    achieved_factor=0.0))
    assert level == WARN and message.startswith('lockstep: waiting 4 s')   # not "cannot keep up"
    assert dict(values)['lockstep'] == 'true' and dict(values)['lockstep_waiting_s'] == '4.0'


def test_before_the_first_command_nothing_has_timed_out_it_waits_for_one():
    # command_timeout runs from the start, so the session says timed out one timeout
    # after a start without commands; the diagnostics say what is true: none came yet.
    for timed_out in (False, True):
        level, message, values = diagnostic_values(
            P, outputs(), health(commanded=False, command_timed_out=timed_out))
        v = dict(values)
        assert level == OK and message.startswith('waiting for the first command')
        assert 'command_timeout' not in message
        assert v['command_timed_out'] == 'false' and v['waiting_for_first_command'] == 'true'
    v = dict(diagnostic_values(P, outputs(), health(command_timed_out=True))[2])
    assert v['waiting_for_first_command'] == 'false' and v['command_timed_out'] == 'true'


def test_status_line_shows_time_factor_angle_speed_path_and_te():
    plant = Plant(P, DT)
    plant.set_input(DriveInput(100.0, -1, 0.0))
    plant.advance(2000)
    line = status_line(plant.compute_outputs(), 0.998)
    out = plant.compute_outputs()
    for part in ('t =     0.100 s', 'x 1.00', f'{out.position[1]:+.6f} rad', 'path 3',
                 f'{out.transmission_error * 1e6:+9.3f} um'):
        assert part in line


@pytest.mark.parametrize('seed', range(20))
def test_missed_answers_are_counted_over_the_windows_a_controller_answered(seed):
    """A seeded family of answer patterns (some windows with no controller at all):
    the totals are the pattern's own counts over the windows with an answer, the rate the
    last such window's share, and the level WARN exactly when it is below the threshold."""
    rng = np.random.default_rng(seed)
    threshold = float(rng.uniform(0.0, 1.0))
    count = AnswerCount(threshold)
    answered = missed = 0
    last = math.nan
    for _ in range(int(rng.integers(1, 8))):
        share = 0.0 if rng.random() < 0.3 else float(rng.uniform(0.0, 1.0))
        pattern = rng.random(int(rng.integers(1, 300))) < share
        for in_time in pattern:
            count.tick(bool(in_time))
        low = count.close()
        if pattern.any():
            answered += int(pattern.sum())
            missed += int((~pattern).sum())
            last = pattern.mean()
        assert low == (pattern.any() and last < threshold), f'seed {seed}'
    assert (count.answered, count.missed) == (answered, missed), f'seed {seed}'
    assert count.rate == last or (math.isnan(last) and math.isnan(count.rate)), f'seed {seed}'
    level, message, values = diagnostic_values(P, outputs(), health(answers=count))
    v = dict(values)
    assert v['answers_missed'] == str(missed) and v['answers_in_time'] == str(answered)
    assert (level == WARN) == (last < threshold), f'seed {seed}: {message}'
    assert ('min_answer_rate' in message) == (last < threshold), f'seed {seed}'
    line = status_line(outputs(), 1.0, count)
    assert (f'{missed} missed since start' in line) == (not math.isnan(last)), f'seed {seed}'


def test_lockstep_reports_no_answer_counts():
    v = dict(diagnostic_values(P, outputs(), health(lockstep=True))[2])
    assert 'answer_rate' not in v and 'answers_missed' not in v
