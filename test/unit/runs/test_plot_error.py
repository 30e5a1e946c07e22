"""plot_run's tracking error in encoder counts with a tolerance band (issue #45, 13).

A run of the realistic table (26-bit table encoder) recorded in-process with a PD law and
a constant target; the expected error is computed here from the bag as ``rosbags``
decodes it and from the target the test chose, never from the plotting code. The figure
data (:func:`error_view`) are checked first, then what the figure draws from them.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from screwgear_ros import Simulation, config_path
from screwgear_ros.bag.reader import read_run
from screwgear_ros.cli import plot_run
from screwgear_ros.runs.plot import Mark, Panel, plt, run_figure
from screwgear_ros.runs.plot_error import (
    ErrorOptions,
    ErrorViewError,
    error_view,
    inside_from,
)

TARGET = 1e-3            # rad
STORE = get_typestore(Stores.ROS2_JAZZY)


@pytest.fixture(scope='module')
def recorded(tmp_path_factory) -> Path:
    bag = tmp_path_factory.mktemp('plot_error') / 'run'
    sim = Simulation.from_yaml(config_path('realistic.yaml'))

    def pd(o):
        return max(-300.0, min(300.0, 2000.0 * (TARGET - o.position[1]) - 300.0 * o.velocity[1]))

    sim.run(pd, duration=0.4, record=bag, setpoint=lambda t: TARGET)
    return bag


def decoded_exact_angle(bag: Path) -> tuple[np.ndarray, np.ndarray]:
    """(log times ns, θ2 rad) of ~/true_joint_states as rosbags decodes them."""
    times, angles = [], []
    with Reader(bag) as reader:
        for c, t, raw in reader.messages():
            if c.topic.endswith('/true_joint_states'):
                msg = STORE.deserialize_cdr(raw, c.msgtype)
                times.append(t)
                angles.append(msg.position[list(msg.name).index('table')])
    return np.array(times), np.array(angles)


def test_the_error_in_counts_is_the_angle_the_bag_holds_against_the_target(recorded):
    run = read_run(recorded)
    counts = run.parameters.settings.encoder_counts_table
    assert counts == 2 ** 26                    # the preset's table encoder
    times, angle = decoded_exact_angle(recorded)
    expected = (TARGET - angle) * counts / (2.0 * math.pi)
    for options in (ErrorOptions(counts=0), ErrorOptions(counts=0, target=TARGET)):
        view = error_view(run, options)
        assert view.unit == 'counts'
        stamps = np.rint(view.times * 1e9).astype(np.int64)
        at = np.searchsorted(times, stamps)
        assert np.array_equal(times[at], stamps)
        # rounding of θ2 only: 1e-9 rad is 0.01 counts at 2^26 per turn
        np.testing.assert_allclose(view.error, expected[at], rtol=0, atol=1e-6)
        assert view.measured_error is not None and len(view.measured_error)
    # the PD sticks short of the target: hundreds of counts at the end, not ~0 mrad
    assert abs(view.error[-1]) > 100.0
    mrad = error_view(run, ErrorOptions())
    np.testing.assert_allclose(mrad.error * counts / (2e3 * math.pi), view.error, atol=1e-6)


def test_the_band_says_from_when_the_error_stays_inside(recorded):
    run = read_run(recorded)
    times, angle = decoded_exact_angle(recorded)
    error = (TARGET - angle) * 4096 / (2.0 * math.pi)         # a 12-bit encoder
    band = float(np.quantile(np.abs(error), 0.5))
    outside = [k for k in range(len(error)) if abs(error[k]) > band]
    expected = times[outside[-1] + 1] if outside and outside[-1] + 1 < len(times) else None
    view = error_view(run, ErrorOptions(counts=4096, band=band, target=TARGET))
    assert expected is not None          # the median band: the run ends inside it
    assert round(view.inside_from * 1e9) == expected
    expected = expected * 1e-9
    with warnings.catch_warnings():
        warnings.simplefilter('error', UserWarning)
        fig = run_figure(run, error=ErrorOptions(counts=4096, band=band, target=TARGET))
    try:
        ax = {a.get_label(): a for a in fig.axes}[Panel.TRACKING]
        assert ax.get_ylabel() == 'tracking error [counts]'
        shaded = [a for a in ax.get_children() if a.get_gid() == Mark.BAND]
        assert len(shaded) == 1
        low, high = shaded[0].get_y(), shaded[0].get_y() + shaded[0].get_height()
        assert (low, high) == pytest.approx((-band, band))
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        when = 'outside at the end' if expected is None else f'inside from t = {expected:.4g} s'
        assert any(when in label for label in labels), labels
    finally:
        plt.close(fig)


def test_inside_from_against_a_brute_force_scan():
    rng = np.random.default_rng(45)
    for case in range(200):
        n = int(rng.integers(1, 40))
        times = np.cumsum(rng.uniform(0.1, 1.0, n))
        error = rng.normal(0.0, 1.0, n)
        band = float(rng.uniform(0.1, 2.0))
        expected = None
        for k in range(n):
            if all(abs(e) <= band for e in error[k:]):
                expected = float(times[k])
                break
        assert inside_from(times, error, band) == expected, f'case {case}'


@pytest.mark.parametrize('seed', range(12))
def test_hostile_error_options_are_refused_naming_the_option(recorded, seed):
    """A seeded family of option sets, valid and not: each either draws or is refused
    with a message that names the option and its rule, never another error."""
    rng = np.random.default_rng(seed)
    run = read_run(recorded)
    counts = [None, 0, 1, 4096, -1, 2 ** 31, 1.5, True, 'many']
    bands = [None, 2.0, 1e-300, 0.0, -1.0, math.nan, math.inf, 'wide']
    targets = [None, TARGET, -1e5, math.nan, math.inf, '0.1']
    for _ in range(8):
        options = ErrorOptions(counts[rng.integers(len(counts))],
                               bands[rng.integers(len(bands))],
                               targets[rng.integers(len(targets))])
        try:
            view = error_view(run, options)
        except ErrorViewError as exc:
            text = str(exc)
            assert any(name in text for name in ('--counts', '--band', '--target')), \
                f'seed {seed}: {options}: {text}'
            assert 'must' in text or 'needs' in text, f'seed {seed}: {text}'
            continue
        assert np.all(np.isfinite(view.error)), f'seed {seed}: {options}'
        assert view.unit == ('mrad' if options.counts is None else 'counts'), f'seed {seed}'


@pytest.mark.parametrize('argv, named', [
    (['--band', 'nan'], '--band'), (['--band', '-2'], '--band'), (['--band', 'x'], '--band'),
    (['--counts', '0'], '--counts'), (['--counts', '1e3'], '--counts'),
    (['--target', 'inf'], '--target')])
def test_the_tool_refuses_bad_options_with_exit_2_naming_them(recorded, capsys, argv, named):
    with pytest.raises(SystemExit) as stop:
        plot_run.main([str(recorded), *argv])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert named in err and 'Traceback' not in err, err


def test_the_tool_refuses_counts_of_an_ideal_encoder(tmp_path, capsys):
    bag = tmp_path / 'ideal'
    Simulation.from_yaml(config_path('paper.yaml'), publish_rate=500.0).run(
        lambda o: 10.0, duration=0.02, record=bag)
    assert plot_run.main([str(bag), '--counts', '-o', str(tmp_path / 'p.png')]) == 2
    err = capsys.readouterr().err
    assert 'no setpoint' in err and '--target' in err, err
    assert plot_run.main([str(bag), '--counts', '--target', '0.0',
                          '-o', str(tmp_path / 'p.png')]) == 2
    assert 'encoder_counts_table 0' in capsys.readouterr().err
    assert not (tmp_path / 'p.png').exists()
