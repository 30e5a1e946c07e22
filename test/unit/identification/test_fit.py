"""Identification against generated ground truth (conftest.TRUTH): from the preset's
values, the well-excited parameters come back within 1 % (stiffness, inertia, preload)
or 5 % (friction, damping), every ±2σ interval holds the truth, the fitted file loads
as the node's parameter file, and a recording that never reverses names backlash as
undetermined."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from identify_truth import PRESET, TRUTH, record_excitation, truth_simulation, write_base

import screwgear_ros
from screwgear_ros import Simulation
from screwgear_ros.identification.errors import TooShortError
from screwgear_ros.inprocess.simulation import file_values

STIFF = ('mesh_stiffness_mean', 'inertia_table', 'preload_torque')
LOOSE = ('mesh_damping', 'table_coulomb_torque')


@pytest.fixture(scope='module')
def fitted(recordings):
    """One fit of five parameters to the plain bag, validated on another excitation."""
    root = recordings['root']
    check = record_excitation(root / 'check', duration=1.5, seed=2)
    base = write_base(root / 'base.yaml', STIFF + LOOSE)
    result = screwgear_ros.identify([recordings['plain']], base, list(STIFF + LOOSE),
                                    validate=[check], output=root / 'fitted.yaml',
                                    starts_count=1)
    return result, base


def test_the_well_excited_parameters_come_back(fitted):
    result, _ = fitted
    assert result.finished
    for e in result.estimates:
        error = abs(e.value / TRUTH[e.name] - 1)
        assert error < (0.01 if e.name in STIFF else 0.05), (e.name, e.value, TRUTH[e.name])
        assert abs(e.base / TRUTH[e.name] - 1) > 0.02, 'the fit started at the truth'
        assert e.low <= TRUTH[e.name] <= e.high, (e.name, e.low, e.high, TRUTH[e.name])
        assert not e.undetermined
    assert result.undetermined == []
    fits = result.fit_percent('validate')
    assert fits.shape == (1, 3) and (fits > 99.0).all()
    assert (result.fit_percent('fit', 'before') < fits.min()).all()
    correlation = result.correlation
    assert correlation.shape == (5, 5)
    np.testing.assert_allclose(np.diag(correlation), 1.0)
    np.testing.assert_allclose(correlation, correlation.T, atol=1e-12)


def test_the_fitted_file_is_the_base_file_with_the_fitted_values(fitted):
    result, base = fitted
    written = file_values(result.output)
    assert written == {**file_values(base), **result.values}
    simulation = Simulation.from_yaml(result.output)
    assert simulation.params.inertia_table == result.values['inertia_table']
    text = result.output.read_text(encoding='utf-8')
    assert 'UNFINISHED' not in text and '±2σ' in text
    assert yaml.safe_load(text)['/**']['ros__parameters']['encoder_counts_table'] == 2 ** 26
    report = result.report.read_text(encoding='utf-8')
    for name in STIFF + LOOSE:
        assert f'`{name}`' in report
    assert 'validate' in report and result.figure.stat().st_size > 10_000


def test_a_recording_that_never_reverses_leaves_backlash_undetermined(tmp_path):
    def forward(o):      # the drive torque never crosses zero: no reversal
        return 5.0 + 2.5 * math.sin(2 * math.pi * (0.5 + 10.0 * o.time) * o.time)
    bag = tmp_path / 'forward'
    truth_simulation().run(forward, 1.0, record=bag)
    base = write_base(tmp_path / 'base.yaml', ['backlash', 'inertia_table'])
    result = screwgear_ros.identify([bag], base, ['backlash', 'inertia_table'],
                                    starts_count=1, max_evaluations=6)
    assert 'backlash' in result.undetermined
    assert 'inertia_table' not in result.undetermined
    backlash, = (e for e in result.estimates if e.name == 'backlash')
    assert 'reversal' in backlash.excitation


def test_a_recording_too_short_for_the_parameters_is_refused(recordings, tmp_path):
    bag = tmp_path / 'short'
    truth_simulation().run(lambda o: 5.0, 0.2, record=bag)
    names = ['inertia_table', 'mesh_stiffness_mean', 'preload_torque']
    with pytest.raises(TooShortError, match='too short to fit 3 parameter'):
        screwgear_ros.identify([bag], PRESET, names)


def test_speeds_are_compared_when_asked(recordings, tmp_path):
    from screwgear_ros.identification.adapter import base_values
    from screwgear_ros.identification.parameters import fit_parameters, start_point
    from screwgear_ros.identification.problem import Problem, fit_percent
    from screwgear_ros.identification.recording import read_recording
    base = base_values(write_base(tmp_path / 'base.yaml', []))      # the truth itself
    fitted = fit_parameters(['inertia_table'], base)
    recording = read_recording(recordings['plain'])
    problem = Problem(base, fitted, (recording,), speeds=True)
    residual = problem.residual(start_point(fitted)).reshape(-1, 6)
    assert residual.shape == (recording.samples, 6)
    prediction = problem.predict(base, recording)
    fits = fit_percent(problem.measured(recording), prediction)
    assert (fits[:3] > 99.99).all() and (fits[3:] > 99.0).all(), fits
