"""frequency_response: the response measured by simulation against the linear model (where
the plant is linear), against the rigid-body asymptote, with its resonance peaks located
from the measurement alone; parting from the linear curve where the backlash opens; the
executable's CSV, figure and refusals; the closed loop's margins against closed forms."""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from bag_runs import installed

from screwgear_ros.design.closed_loop import LOOP, SENSITIVITY, margins, measure_loop
from screwgear_ros.design.errors import UnknownOutput
from screwgear_ros.design.frequency import CSV_COLUMNS, measure
from screwgear_ros.design.linearize import linearize
from screwgear_ros.params.table import Mode, TableParams

#: The paper's table with backlash 0 and its preload, the mesh excitation (stiffness
#: fluctuation, STE) off: the plant is then the linear time-invariant system the model is.
LINEAR_TABLE = TableParams(backlash=0.0, mesh_stiffness_amplitude=0.0, ste_amplitudes=(0.0,))


def _db(a, b):
    return 20.0 * np.log10(np.abs(a) / np.abs(b))


def _deg(a, b):
    return np.degrees(np.angle(a / b))


def test_measured_agrees_with_linear_from_1_to_500_hz():
    outputs = ('table_angle', 'pinion_1_angle', 'pinion_3_speed', 'transmission_error')
    m = measure(LINEAR_TABLE, outputs=outputs, frequencies=np.geomspace(1.0, 500.0, 7),
                amplitude=10.0)
    assert m.model.point.contact[0].name == 'LINEAR' and m.model.point.torque == 20.0
    assert np.all(np.abs(_db(m.measured, m.linear)) <= 0.5)
    assert np.all(np.abs(_deg(m.measured, m.linear)) <= 3.0)
    assert np.all(m.coherence >= 0.98)
    # and through the load input, around the preload equilibrium
    load = measure(LINEAR_TABLE, input='load', outputs=('table_angle',),
                   frequencies=(2.0, 150.0), amplitude=100.0)
    assert load.model.point.torque == 0.0
    assert np.all(np.abs(_db(load.measured, load.linear)) <= 0.5)
    assert np.all(np.abs(_deg(load.measured, load.linear)) <= 3.0)


def test_below_the_first_resonance_torque_to_table_follows_the_rigid_body():
    p = LINEAR_TABLE
    ratio = p.radius_table / p.radius_pinion_1
    inertia = p.inertia_table + (p.inertia_pinion_1 + p.inertia_pinion_3) * ratio ** 2
    m = measure(p, outputs=('table_angle',), frequencies=(1.0, 3.0, 10.0), amplitude=10.0)
    omega = 2.0 * math.pi * m.frequency
    np.testing.assert_allclose(np.abs(m.measured[0]), ratio / (inertia * omega ** 2),
                               rtol=0.01)
    assert np.all(np.abs(np.abs(np.degrees(np.angle(m.measured[0]))) - 180.0) < 1.0)


def _peak(frequency: np.ndarray, magnitude: np.ndarray) -> float:
    """The peak of a sampled curve: a parabola through the largest sample and its
    neighbours, in log frequency and log magnitude."""
    k = int(np.argmax(magnitude))
    assert 0 < k < len(magnitude) - 1, 'the peak is at the edge of the sweep'
    x, y = np.log(frequency[k - 1:k + 2]), np.log(magnitude[k - 1:k + 2])
    a, b, _ = np.polyfit(x, y, 2)
    return float(np.exp(-b / (2.0 * a)))


def test_resonance_peaks_lie_within_one_percent_of_the_modes():
    modes = {m.shape: m.hz for m in linearize(LINEAR_TABLE, 20.0, 20.0 * LINEAR_TABLE.radius_table
                                              / LINEAR_TABLE.radius_pinion_1).modes()
             if m.oscillating}
    table_mode = modes['pinions against the table']
    pinion_mode = modes['pinions against each other (table nearly still)']
    band = np.linspace(0.9 * pinion_mode, 1.1 * table_mode, 15)
    m = measure(LINEAR_TABLE, outputs=('table_angle', 'pinion_1_angle', 'pinion_3_angle'),
                frequencies=band, amplitude=10.0)
    omega = 2.0 * math.pi * m.frequency
    # the table takes no part in the pinions' mode: its acceleration peaks at the other
    table_peak = _peak(m.frequency, np.abs(m.measured[0]) * omega ** 2)
    # the pinions' difference takes no part in the table's mode
    pinion_peak = _peak(m.frequency, np.abs(m.measured[1] - m.measured[2]))
    assert abs(table_peak - table_mode) <= 0.01 * table_mode
    assert abs(pinion_peak - pinion_mode) <= 0.01 * pinion_mode


def test_conventional_backlash_parts_from_the_linear_curve_once_the_gap_opens():
    """Conventional mode, bias 20 N·m against the load that holds it: 5 N·m keeps the
    flank in contact and follows the linear model; 60 N·m pulls the pinion off its flank
    through the gap every period, and the measured response parts from the linear one."""
    params = LINEAR_TABLE.replace(mode=Mode.CONVENTIONAL, backlash=75e-6)
    frequencies = (5.0, 40.0, 120.0)
    small = measure(params, outputs=('table_angle',), frequencies=frequencies, amplitude=5.0,
                    torque=20.0)
    assert small.model.point.contact[0].name == 'FORWARD'
    assert np.all(np.abs(_db(small.measured, small.linear)) <= 0.5)
    assert np.all(np.abs(_deg(small.measured, small.linear)) <= 3.0)
    large = measure(params, outputs=('table_angle',), frequencies=frequencies, amplitude=60.0,
                    torque=20.0)
    parted = (np.abs(_db(large.measured, large.linear)) > 1.0) | \
        (np.abs(_deg(large.measured, large.linear)) > 5.0) | (large.coherence < 0.99)
    assert parted.any()


@pytest.mark.ros
def test_the_executable_writes_the_csv_and_the_bode_plot(tmp_path):
    stem = tmp_path / 'response'
    proc = installed('frequency_response', '--from', '2', '--to', '300', '--points', '3',
                     '--output', 'table_angle', 'transmission_error', '-o', stem)
    assert proc.returncode == 0, proc.stderr
    assert 'pinions against the table' in proc.stdout and 'coherence' in proc.stdout
    with open(tmp_path / 'response.csv', newline='') as stream:
        rows = list(csv.reader(stream))
    assert tuple(rows[0]) == CSV_COLUMNS
    assert len(rows) == 1 + 3 * 2
    assert {r[1] for r in rows[1:]} == {'table_angle', 'transmission_error'}
    assert all(0.0 <= float(r[6]) <= 1.0 for r in rows[1:])
    assert (tmp_path / 'response.png').stat().st_size > 20_000
    launcher = Path(sys.prefix) / 'lib' / 'screwgear_ros' / 'frequency_response'
    assert launcher.is_file() and '/../../bin/frequency_response"' in launcher.read_text()


def test_the_chirp_agrees_with_linear_away_from_the_lowest_frequency(tmp_path):
    m = measure(LINEAR_TABLE, outputs=('table_speed',), frequencies=(10.0, 100.0, 400.0),
                amplitude=10.0, method='chirp')
    assert np.all(np.abs(_db(m.measured, m.linear)) <= 0.5)
    assert np.all(np.abs(_deg(m.measured, m.linear)) <= 3.0)


@pytest.mark.ros
@pytest.mark.parametrize('args, says', [
    (['--to', '2000'], 'Nyquist'),
    (['--amplitude', '0'], 'amplitude'),
    (['--amplitude', '300'], 'max_torque'),
    (['--from', '10', '--to', '5'], 'from'),
    (['--points', '0'], 'points'),
    (['--points', '100000000'], '2000'),
    (['--from', '1e-4', '--to', '1e-4', '--points', '1'], 'GiB'),
    (['--from', '1e-4', '--to', '1e-4', '--points', '1', '--method', 'chirp'], 'GiB'),
    (['--controller', 'demo', '--to', '460'], 'Nyquist'),
    (['--params', '/no/such.yaml'], 'cannot read'),
    (['--torque', '10', '--load', '0', '--params', 'IDEAL'], 'accelerates the table forever'),
    (['--torque', '30', '--load', '0'], 'torque–speed line'),
])
def test_bad_requests_exit_2_with_the_reason(tmp_path, args, says):
    ideal = tmp_path / 'ideal.yaml'
    ideal.write_text('/**:\n  ros__parameters:\n    drive_no_load_speed: 0.0\n')
    args = [str(ideal) if a == 'IDEAL' else a for a in args]
    proc = installed('frequency_response', '--points', '2', *args, '-o', tmp_path / 'r')
    assert proc.returncode == 2, proc.stdout
    assert says in proc.stderr and 'Traceback' not in proc.stderr + proc.stdout
    assert not (tmp_path / 'r.csv').exists()


def test_an_unknown_output_is_refused():
    with pytest.raises(UnknownOutput, match='unknown output'):
        measure(LINEAR_TABLE, outputs=('table_angel',))


# ---------------------------------------------------------------- closed loop

def test_margins_of_an_integrator_with_a_delay_are_the_closed_forms():
    """L = (ω_c/jω)·e^(−jωτ): gain crossover at ω_c with phase margin 90° − ω_c·τ, phase
    crossover at π/(2τ) with gain margin π/(2τ·ω_c)."""
    w_c, tau = 2.0 * math.pi * 5.0, 0.02
    f = np.geomspace(0.5, 100.0, 400)
    w = 2.0 * math.pi * f
    m = margins(f, w_c / (1j * w) * np.exp(-1j * w * tau))
    assert m.phase_at_hz == pytest.approx(5.0, rel=1e-3)
    assert m.phase == pytest.approx(90.0 - math.degrees(w_c * tau), abs=0.05)
    assert m.gain_at_hz == pytest.approx(1.0 / (4.0 * tau), rel=1e-3)
    assert m.gain == pytest.approx(math.pi / (2.0 * tau * w_c), rel=1e-3)


def test_the_measured_loop_of_a_pd_law_has_the_margins_of_its_closed_form():
    """The demo law with no integral is c = −(Kp + Kd·s)·θ2, sampled at the tick and held
    for the next: around the linear plant, L = (Kp + jω·Kd)·P(jω)·e^(−jωh/2)·sinc(ωh/2)."""
    from scipy.optimize import brentq

    from screwgear_ros.inprocess.scenario import SetpointProfile
    from screwgear_ros.params.table import SimSettings
    from screwgear_ros.sim.control import DemoController, DemoGains
    settings = SimSettings()
    gains = DemoGains(ki=0.0)
    controller = DemoController(gains, dt=settings.dt,
                                setpoint=SetpointProfile('steps', points=((0.0, 0.0),)))
    f = np.geomspace(1.0, 40.0, 10)
    lm = measure_loop(LINEAR_TABLE, settings, controller, frequencies=f, amplitude=5.0)
    assert np.all(lm.response.coherence >= 0.99)
    h = 1.0 / settings.publish_rate
    model = lm.response.model

    def loop(hz):
        w = 2.0 * math.pi * hz
        p = model.response([hz])[0, 0, 0]
        return (gains.kp + 1j * w * gains.kd) * p * np.exp(-0.5j * w * h) \
            * math.sin(0.5 * w * h) / (0.5 * w * h)

    crossover = brentq(lambda x: abs(loop(math.exp(x))) - 1.0, 0.0, math.log(40.0))
    hz = math.exp(crossover)
    phase = math.degrees(np.angle(loop(hz)))
    phase -= 360.0 * math.ceil(phase / 360.0)
    assert lm.margins.phase_at_hz == pytest.approx(hz, rel=0.02)
    assert lm.margins.phase == pytest.approx(180.0 + phase, abs=1.0)
    # S = 1/(1 + L) from the same measurement
    np.testing.assert_allclose(lm.response.measured[1], 1.0 / (1.0 + lm.response.measured[0]),
                               rtol=0.02)


@pytest.mark.ros
def test_the_executable_closes_the_loop_with_the_demo(tmp_path):
    proc = installed('frequency_response', '--controller', 'demo', '--from', '1', '--to', '30',
                     '--points', '5', '-o', tmp_path / 'loop')
    assert proc.returncode == 0, proc.stderr
    assert 'phase margin' in proc.stdout
    with open(tmp_path / 'loop.csv', newline='') as stream:
        names = {row['output'] for row in csv.DictReader(stream)}
    assert names == {LOOP, SENSITIVITY, 'table_angle'}
    assert (tmp_path / 'loop.png').stat().st_size > 20_000
    bad = installed('frequency_response', '--controller', 'no_such_module:law', '--to', '30',
                    '--points', '2', '-o', tmp_path / 'bad')
    assert bad.returncode == 2 and 'no_such_module' in bad.stderr
    assert 'Traceback' not in bad.stderr + bad.stdout


def test_the_paper_table_at_rest_follows_the_frozen_model():
    """The paper's full table (STE, k_a' = 0.1, backlash) standing still: where the motion
    stays small against a tooth (above the lowest frequencies) the measurement follows the
    model frozen at the rest angle, and the averaged model's resonance is not where it is."""
    paper = TableParams()
    m = measure(paper, outputs=('table_angle', 'transmission_error'),
                frequencies=(20.0, 100.0, 180.0, 300.0), mesh='frozen')
    assert np.all(np.abs(_db(m.measured, m.linear)) <= 0.5)
    assert np.all(np.abs(_deg(m.measured, m.linear)) <= 3.0)
    average = measure(paper, outputs=('table_angle',), frequencies=(180.0,))
    assert np.abs(_db(average.measured, average.linear)).max() > 3.0


def test_the_default_bias_holds_twice_the_amplitude_for_either_spelling_of_the_input():
    from screwgear_ros.design.frequency import Input, default_bias
    p = TableParams()
    expected = (20.0, 20.0 * p.radius_table / p.radius_pinion_1)
    assert default_bias(p, 'torque', 10.0, None, None, 1) == pytest.approx(expected)
    assert default_bias(p, Input.TORQUE, 10.0, None, None, 1) == pytest.approx(expected)
    assert default_bias(p, 'load', 10.0, None, None, 1) == (0.0, 0.0)
