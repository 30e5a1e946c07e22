"""The design tools' Bode plots: magnitudes in dB, phases from their low-frequency
asymptote (a double integrator at −180°, never +180°; no jump to about +15° above the
resonance), low-coherence points grey; the loop plot names its controller, explains
L = −c/u, marks the gain margin and the peak |S| and keeps each label clear of its mark."""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.design.bode import GREY, asymptotic_phase, measured_phase
from screwgear_ros.design.closed_loop import LoopMeasurement
from screwgear_ros.design.frequency import measure
from screwgear_ros.design.margins import margins
from screwgear_ros.params.table import TableParams

pytest.importorskip('matplotlib')

#: The paper's table without backlash and mesh excitation: a linear plant.
LINEAR_TABLE = TableParams(backlash=0.0, mesh_stiffness_amplitude=0.0, ste_amplitudes=(0.0,))


def _resonant(f: np.ndarray) -> np.ndarray:
    """A double integrator with a lightly damped resonance at 200 Hz."""
    s = 2j * math.pi * f
    w = 2.0 * math.pi * 200.0
    return 1.0 / (s * s * (1.0 + 0.04 * s / w + (s / w) ** 2))


def test_a_double_integrator_starts_at_minus_180_and_falls_through_the_resonance():
    f = np.geomspace(1.0, 500.0, 300)
    phase = asymptotic_phase(_resonant(f))
    assert phase[0] == pytest.approx(-180.0, abs=0.5)
    assert phase[-1] == pytest.approx(-360.0, abs=5.0)
    assert np.all(np.diff(phase) <= 1e-9)


def test_measured_phases_follow_on_from_the_asymptote_and_grey_ones_sit_beside_them():
    guide = np.geomspace(1.0, 500.0, 600)
    f = np.geomspace(1.0, 500.0, 25)
    measured = _resonant(f) * np.exp(1j * np.radians(2.0))     # a measurement 2° off
    trusted = np.ones(len(f), dtype=bool)
    trusted[[3, 20]] = False
    measured[3] *= -1.0                                          # one scattered by 180°
    phase = measured_phase(f, measured, trusted, guide, asymptotic_phase(_resonant(guide)))
    good = phase[trusted]
    assert good[0] == pytest.approx(-178.0, abs=0.5)
    assert np.all(good <= -170.0) and good[-1] < -300.0          # no jump to about +15°
    truth = asymptotic_phase(_resonant(f)) + 2.0
    assert phase[20] == pytest.approx(truth[20], abs=0.5)          # grey, on its branch
    assert abs(abs(phase[3] - phase[2]) - 180.0) < 5.0            # on the branch beside


def test_the_open_loop_plot_is_in_db_from_the_asymptote_with_low_coherence_grey():
    m = measure(LINEAR_TABLE, outputs=('table_angle',), frequencies=(2.0, 20.0, 300.0))
    m.coherence[0, 1] = 0.2
    fig = m.figure()
    mag, ph = fig.axes[0], fig.axes[1]
    assert 'dB' in mag.get_ylabel()
    line = mag.get_lines()[0]
    expected = 20.0 * np.log10(np.abs(m.model.response(line.get_xdata())[0, 0]))
    np.testing.assert_allclose(line.get_ydata(), expected)
    assert ph.get_lines()[0].get_ydata()[0] == pytest.approx(-180.0, abs=1.0)
    grey = [ln for ln in mag.get_lines() if ln.get_markeredgecolor() == GREY]
    assert len(grey) == 1 and list(grey[0].get_xdata()) == [m.frequency[1]]


def test_the_loop_plot_names_the_controller_and_marks_its_margins_clear_of_the_labels():
    m = measure(LINEAR_TABLE, outputs=('table_angle',), frequencies=(2.0, 20.0, 300.0))
    f = np.geomspace(1.0, 450.0, 80)
    h = 1e-3
    s = 2j * math.pi * f
    loop = 5e3 * (1.0 + s / 60.0) * _resonant(f) * 40.0 * np.exp(-s * h)
    m.frequency, m.measured = f, np.vstack([loop, 1.0 / (1.0 + loop)])
    m.linear, m.coherence = m.measured.copy(), np.ones((2, len(f)))
    lm = LoopMeasurement(m, margins(f, loop), margins(f, loop), 'my_ctl:make')
    # this loop's phase crossover has |L| > 1: its gain margin is the lower one
    gain, gain_hz = lm.margins.gain or lm.margins.lower_gain, (lm.margins.gain_at_hz
                                                               or lm.margins.lower_gain_at_hz)
    assert gain is not None and lm.margins.peak_sensitivity is not None
    fig = lm.figure()
    texts = [t.get_text() for t in fig.texts] + [a.get_title() for a in fig.axes]
    assert any('my_ctl:make' in t for t in texts)
    assert any('L = −c/u' in t and 'u = c + d' in t for t in texts)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = {}
    for ax in fig.axes:
        for child in ax.texts:
            if child.get_text():
                labels[child.get_text().split()[0] + ' ' + child.get_text().split()[1]] = \
                    (ax, child)
    assert {'gain margin', 'phase margin', 'peak |S|'} <= set(labels)
    marks = {'gain margin': (gain_hz, -20 * math.log10(gain)),
             'phase margin': (lm.margins.phase_at_hz, -180.0 + lm.margins.phase),
             'peak |S|': (lm.margins.peak_at_hz,
                          20 * math.log10(lm.margins.peak_sensitivity))}
    for name, point in marks.items():
        ax, text = labels[name]
        x, y = ax.transData.transform(point)
        box = text.get_window_extent(renderer)
        assert not box.contains(x, y), name
