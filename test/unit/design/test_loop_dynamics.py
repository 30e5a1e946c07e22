"""The sensor and drive dynamics of a linear model (design/loop_dynamics.py) and the
margins read through them, against python-control built independently here, and against
the simulated loop.

Independent construction: the mechanics' A, B, C, D (``linearize``) as a
``control.StateSpace``, the drive lag as the transfer function 1/(τs + 1) in series,
``control.c2d(…, 'zoh')`` at the tick, then the sensors as exact discrete transfer
functions at the same tick: the delay z^−k, the low-pass α·z/(z − (1 − α)), the backward
difference (z − 1)/(h·z). Both sides are exact discretizations of one linear system, so
their responses agree to the accuracy of the matrix exponential and the solves: a
relative 1e-6 is far above that and far below any modelling difference (one tick of
delay is 3.6° at 10 Hz). The margins: python-control's (root finding) against
:func:`margins` on 4000 log-spaced points, whose linear interpolation errs by about
(Δ ln f)²/8 times the curvature: bounds 0.05° and 0.5 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.design.closed_loop import measure_loop
from screwgear_ros.design.frequency import Input, default_bias
from screwgear_ros.design.linear_model import OUTPUTS
from screwgear_ros.design.linearize import linearize
from screwgear_ros.design.loop_dynamics import declares_dynamics, loop_plant, with_dynamics
from screwgear_ros.design.margins import held_response, margins
from screwgear_ros.params.table import SimSettings, TableParams

control = pytest.importorskip('control')

TAU = 1.5915494309189535e-04
SENSORS = {'measurement_delay_table': 1, 'velocity_filter_cutoff_table': 500.0,
           'encoder_counts_table': 2 ** 26, 'measurement_delay_pinion_1': 2,
           'velocity_filter_cutoff_pinion_1': 300.0}
KP, KD = 2.0e4, 300.0


def _setup():
    params = TableParams().replace(drive_time_constant=TAU)
    settings = SimSettings(**SENSORS)
    torque, load = default_bias(params, Input.TORQUE, 10.0, None, None, 1)
    mechanics = linearize(params, torque, load, 1)
    return params, settings, mechanics


def _independent(mechanics, h: float, row: str, delay: int, cutoff: float,
                 differenced: bool):
    """python-control's sampled plant from drive_torque to the measured ``row``."""
    plant = mechanics.to_control()[OUTPUTS.index(row if not differenced else
                                                 row.replace('speed', 'angle')), 0]
    lagged = plant * control.tf2ss(control.tf([1.0], [TAU, 1.0]))   # in state space:
    sampled = control.c2d(lagged, h, 'zoh')                # a 7th-order tf is ill-conditioned
    sensor = control.tf([1.0], [1.0] + [0.0] * delay, h)
    if cutoff:
        alpha = 1.0 - math.exp(-2.0 * math.pi * cutoff * h)
        sensor = sensor * control.tf([alpha, 0.0], [1.0, -(1.0 - alpha)], h)
    if differenced:
        sensor = sensor * control.tf([1.0, -1.0], [h, 0.0], h)
    return sampled * sensor


def test_a_file_with_a_drive_lag_or_sensors_declares_dynamics_and_the_paper_does_not():
    params, settings, _ = _setup()
    assert declares_dynamics(params, settings)
    assert not declares_dynamics(TableParams(), SimSettings())


def test_the_drive_lag_is_one_exact_state_in_the_continuous_response():
    params, settings, mechanics = _setup()
    model = with_dynamics(mechanics, params, settings)
    f = np.geomspace(1.0, 2000.0, 40)
    lagged = model.response(f)[:, 0, :]
    closed_form = mechanics.response(f)[:, 0, :] / (1.0 + 2j * math.pi * f * TAU)
    assert np.allclose(lagged, closed_form, rtol=1e-9, atol=0.0)
    assert model.states[-1] == 'drive_torque_delivered' and model.a.shape == (7, 7)
    assert any('drive lag' in note for note in model.notes)
    assert any(abs(m.hz - 1.0 / (2 * math.pi * TAU)) < 1e-6 * m.hz and 'lag' in m.shape
               for m in model.modes())


@pytest.mark.parametrize('row, delay, cutoff, differenced', [
    ('table_angle', 1, 0.0, False),
    ('table_speed', 1, 500.0, True),            # 26-bit encoder: differenced angles
    ('pinion_1_speed', 2, 300.0, False),        # no encoder: exact speed, filtered
    ('pinion_1_angle', 2, 0.0, False),
    ('pinion_3_speed', 0, 0.0, False),          # ideal
])
def test_the_sampled_response_through_the_sensors_is_python_controls(row, delay, cutoff,
                                                                      differenced):
    params, settings, mechanics = _setup()
    model = with_dynamics(mechanics, params, settings)
    h = 1.0 / settings.publish_rate
    f = np.geomspace(0.5, 0.45 / h, 60)
    ours = held_response(model, f, h)[OUTPUTS.index(row), 0, :]
    theirs = _independent(mechanics, h, row, delay, cutoff, differenced)(
        np.exp(2j * math.pi * f * h))
    assert np.allclose(ours, theirs, rtol=1e-6, atol=0.0), row


def test_margins_through_the_sensors_are_python_controls():
    params, settings, mechanics = _setup()
    model = with_dynamics(mechanics, params, settings)
    h = 1.0 / settings.publish_rate
    f = np.geomspace(0.5, 0.49 / h, 4000)
    law = control.tf([KP + KD / h, -KD / h], [1.0, 0.0], h)
    loop = law(np.exp(2j * math.pi * f * h)) * held_response(model, f, h)[0, 0, :]
    ours = margins(f, loop)
    theirs = law * _independent(mechanics, h, 'table_angle', 1, 0.0, False)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(theirs)
    assert ours.phase == pytest.approx(pm, abs=0.05)
    assert ours.phase_at_hz == pytest.approx(wgc / (2 * math.pi), rel=0.005)
    assert ours.gain == pytest.approx(gm, rel=0.005)
    assert ours.gain_at_hz == pytest.approx(wpc / (2 * math.pi), rel=0.005)
    bare = law(np.exp(2j * math.pi * f * h)) * held_response(mechanics, f, h)[0, 0, :]
    assert margins(f, bare).phase - ours.phase > 2.0     # the delay and lag cost phase


def test_a_conditionally_stable_loop_names_its_lower_gain_margin_as_python_control_does():
    f = np.geomspace(0.01, 100.0, 4000)
    s = 2j * np.pi * f
    loop = 30.0 * (s + 1.0) ** 2 / s ** 3 / (s / 50.0 + 1.0) ** 2
    ours = margins(f, loop)
    system = control.tf([30.0, 60.0, 30.0], [1.0, 0.0, 0.0, 0.0]) * \
        control.tf([1.0], [1.0 / 50.0, 1.0]) ** 2
    gms = sorted(control.stability_margins(system, returnall=True)[0])
    assert ours.lower_gain == pytest.approx(gms[0], rel=0.005)
    assert ours.gain == pytest.approx(gms[1], rel=0.005)
    text = ours.describe()
    assert 'conditionally stable' in text and 'drops by' in text


def test_the_measured_loop_agrees_with_the_plant_that_holds_the_declared_dynamics():
    """The demo PID around a table with the realistic drive lag and sensors (no friction,
    no noise): the phase margin of the linear plant with its dynamics within 1° of the
    measured one; the mechanics alone is optimistic by more than that."""
    values = {'drive_time_constant': TAU, **{f'{k}_{j}': v for j in ('table', 'pinion_1',
                                                                      'pinion_3')
                                             for k, v in (('measurement_delay', 1),
                                                          ('velocity_filter_cutoff', 500.0),
                                                          ('encoder_counts', 2 ** 20))}}
    params = TableParams().replace(drive_time_constant=TAU)
    settings = SimSettings(**{k: v for k, v in values.items() if k != 'drive_time_constant'})
    from screwgear_ros.design.closed_loop import make_controller
    loop = measure_loop(params, settings, make_controller('demo', settings),
                        frequencies=np.geomspace(3.0, 14.0, 8))
    assert loop.margins.phase is not None and loop.margins_linear.phase is not None
    assert loop.margins_linear.phase == pytest.approx(loop.margins.phase, abs=1.0)
    bare = loop_plant(params, settings, *default_bias(params, Input.TORQUE, 10.0, None,
                                                      None, 1), 1, 'average', dynamics=False)
    assert bare.sensors is None and bare.a.shape == (6, 6)
    f, h = loop.response.frequency, 1.0 / settings.publish_rate
    full = loop.response.model
    angle = OUTPUTS.index('table_angle')
    ratio = held_response(bare, f, h)[angle, 0] / held_response(full, f, h)[angle, 0]
    optimistic = margins(f, loop.response.linear[0] * ratio)
    assert optimistic.phase - loop.margins.phase > 1.5


@pytest.mark.parametrize('body, words', [
    ("def c(observation):\n    return 'left'\n", ["answered 'left' (str)", 'real number']),
    ('def c(observation):\n    return [1, 2][5]\n', ['raised IndexError', 'ctl_fr.py, line 2']),
    ('def c(setpoint):\n    raise KeyError("gain")\n', ['its factory raised KeyError',
                                                          'returns the controller']),
])
def test_frequency_response_names_a_controller_that_fails(tmp_path, monkeypatch, capsys,
                                                          body, words):
    """A controller of frequency_response that raises or answers text (issue #43): exit
    2, a message naming --controller and the rule, never the bare internal text."""
    import sys

    from screwgear_ros.cli.frequency_response import main
    (tmp_path / 'ctl_fr.py').write_text(body, encoding='utf-8')
    monkeypatch.chdir(tmp_path)
    sys.modules.pop('ctl_fr', None)
    assert main(['--controller', 'ctl_fr:c', '--points', '1', '--from', '5', '--to', '5',
                 '-o', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err
    assert '--controller ctl_fr:c' in err and all(w in err for w in words), err
    assert 'Traceback' not in err


def test_the_saved_model_carries_its_dynamics(tmp_path):
    params, settings, mechanics = _setup()
    model = with_dynamics(mechanics, params, settings)
    model.save(tmp_path / 'm.npz')
    saved = np.load(tmp_path / 'm.npz')
    assert list(saved['states'])[-1] == 'drive_torque_delivered'
    assert list(saved['state_units'])[-1] == 'N·m'
    assert list(saved['sensor_delay_ticks']) == [2, 1, 0]
    assert list(saved['sensor_speed_differenced']) == [False, True, False]
    assert any('drive lag' in note for note in saved['dynamics'])
    assert 'dynamics' not in np.load(_save(mechanics, tmp_path))


def _save(model, directory):
    path = directory / 'bare.npz'
    model.save(path)
    return path
