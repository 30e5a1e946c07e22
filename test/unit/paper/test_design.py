"""Report section 12 (frequency response and modes): the averaged model's mode against the
closed forms (independent of T_p and k_a', √k_eff with k_p), the model frozen at the rest
angle against the resonance measured by simulation, ω0 against the 3-DOF modes, and the
rendered section."""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.paper import design
from screwgear_ros.params.table import TableParams, effective_stiffness
from screwgear_ros.physics.quantities import natural_frequency


@pytest.fixture(scope='module')
def study():
    return design.compute(quick=True)


def test_the_averaged_mode_is_the_closed_form(study):
    for case in study.preload + study.fluctuation + study.preload_stiffness:
        label = case.label
        p = TableParams()
        if label.startswith('k_p'):
            p = p.replace(preload_stiffness=float(label.split('= ')[1].split(' ')[0]
                                                  .replace('·10^', 'e')))
        k = effective_stiffness(p)
        omega = math.sqrt(k * p.radius_pinion_1 ** 2 / p.inertia_pinion_1
                          + 2.0 * k * p.radius_table ** 2 / p.inertia_table)
        assert case.linear_hz == pytest.approx(omega / (2.0 * math.pi), rel=1e-9), label


def test_the_model_frozen_at_rest_predicts_the_measured_resonance(study):
    for case in study.preload + study.fluctuation + study.preload_stiffness:
        assert abs(case.measured_hz - case.frozen_hz) <= 0.01 * case.frozen_hz, case
        # at rest the STE lever lowers it well below the averaged mode
        assert case.measured_hz < 0.9 * case.linear_hz, case
    # a larger k_a' stiffens the mesh at the rest angle (φ0 near 0: K ≈ k_eff + k_a)
    measured = [c.measured_hz for c in study.fluctuation]
    assert measured == sorted(measured) and measured[-1] > measured[0]


def test_omega0_is_the_rms_of_the_two_mesh_modes(study):
    w = [m.frequency for m in study.modes if m.oscillating]
    assert len(w) == 2
    assert natural_frequency(TableParams()) == pytest.approx(math.sqrt(np.mean(np.square(w))),
                                                             rel=1e-9)
    assert study.omega0 == pytest.approx(1393.0, rel=1e-3)    # the paper's number


def test_the_section_renders_with_its_figure(study, tmp_path):
    section = design.render(study, tmp_path)
    assert section.number == 12 and section.verdicts
    assert (tmp_path / section.figures[0]).stat().st_size > 20_000
    text = section.markdown()
    assert 'pinions against the table' in text and 'frozen at the rest angle' in text


def test_the_conventional_gear_has_the_papers_omega0(study):
    assert study.conventional == pytest.approx(natural_frequency(TableParams()), rel=1e-9)
