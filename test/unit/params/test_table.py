"""Parameters: validation messages, YAML files, derived quantities, the RK4 step limit.

Independent references: the numbers of shared/spec/model.md §6 (decoded from the
paper), the generalized eigenproblem of the undamped 3-DOF model solved by SciPy and
RK4's imaginary-axis limit 2√2, and the integrator itself run just below and above
the step limit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from paths import ROOT

from screwgear_ros.numerics import stability as S
from screwgear_ros.numerics.integrator import advance
from screwgear_ros.params import table as P
from screwgear_ros.params.declarations import excerpt
from screwgear_ros.params.table import ParameterError, SimSettings, TableParams
from screwgear_ros.physics import quantities as Q
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.packed import Drive, pack
from screwgear_ros.sim import parameter_set as PS
from screwgear_ros.sim.parameter_file import load_yaml

CONFIG = ROOT / 'config'


def refused(exc: pytest.ExceptionInfo, name: str, value: object, rule_word: str) -> None:
    """The ParameterError names the parameter, shows the value and states the rule."""
    err = exc.value
    assert err.name == name
    text = str(err)
    assert repr(name) in text
    assert repr(value) in text or str(value) in text or excerpt(value) in text
    assert rule_word in err.rule, err.rule


# ---------------------------------------------------------------- validation

@pytest.mark.parametrize('name, value, rule_word', [
    ('inertia_pinion_1', -1e-3, '1e-06 … 1e+06'),
    ('inertia_table', 0.0, '1e-06 … 1e+06'),
    ('inertia_pinion_1', 5e-324, 'every derived quantity stays finite'),
    ('radius_pinion_1', 0.0, '0.0001 … 100'),
    ('radius_table', -0.5, '0.0001 … 100'),
    ('radius_table', 1e-200, 'every derived quantity stays finite'),
    ('mesh_stiffness_mean', float('nan'), 'finite'),
    ('mesh_damping', float('inf'), 'finite'),
    ('mesh_damping', -1.0, '0 … 1e+09'),
    ('backlash', -1e-6, '0 … 0.01'),
    ('preload_torque', float('-inf'), 'finite'),
    ('teeth_pinion_1', 24.5, 'whole number'),
    ('teeth_table', float('nan'), 'whole number'),
    ('teeth_pinion_3', float('inf'), 'whole number'),
    ('teeth_pinion_3', 0, '1 … 100000'),
    ('teeth_pinion_1', '24', 'whole number'),
    ('max_torque', 0.0, '0.001 … 1e+07'),
    ('drive_no_load_speed', 5e-324, '0 or 0.001 … 1e+06'),
    ('ste_amplitudes', (1e-6,) * (P.MAX_HARMONICS + 1), f'at most {P.MAX_HARMONICS}'),
    ('ste_phases', 1.0, 'list of numbers'),
    ('inertia_table', '46.1', 'number'),
    ('inertia_table', True, 'number'),
])
def test_invalid_value_refused_naming_parameter_value_and_rule(name, value, rule_word):
    with pytest.raises(ParameterError) as exc:
        TableParams(**{name: value})
    refused(exc, name, value, rule_word)


def damping_for_ratio(p: TableParams, zeta: float) -> float:
    """Mesh damping c, N·s/m, that gives damping ratio ζ."""
    return 2.0 * zeta * Q.equivalent_mass(p) * Q.natural_frequency(p)


def test_unknown_mode_and_mesh_phase_refused():
    with pytest.raises(ParameterError) as exc:
        TableParams(mode='zero_backlash')
    refused(exc, 'mode', 'zero_backlash', 'anti_backlash')
    assert 'conventional' in exc.value.rule
    with pytest.raises(ParameterError) as exc:
        TableParams(mesh_phase='angular')
    refused(exc, 'mesh_phase', 'angular', 'angle')
    assert 'time' in exc.value.rule


def test_mismatched_ste_lists_refused():
    with pytest.raises(ParameterError) as exc:
        TableParams(ste_amplitudes=(1e-3, 2e-4), ste_phases=(0.0,))
    assert exc.value.name == 'ste_phases'
    assert '2 amplitudes' in exc.value.rule
    with pytest.raises(ParameterError) as exc:
        TableParams(ste_amplitudes='0.001')
    assert exc.value.name == 'ste_amplitudes'
    with pytest.raises(ParameterError) as exc:            # the offending element is named
        TableParams(ste_amplitudes=(1e-3, float('nan')), ste_phases=(0.0, 0.0))
    assert exc.value.name == 'ste_amplitudes' and 'nan' in str(exc.value)
    assert 'finite' in exc.value.rule


def test_stiffness_amplitude_must_stay_below_effective_stiffness():
    """K = k_eff + k_a·cos φ ≥ k_eff − k_a must stay positive; k_eff includes k_p and α·ΔT."""
    with pytest.raises(ParameterError) as exc:
        TableParams(mesh_stiffness_amplitude=1.0e7)           # k_a = k_m, K reaches 0
    refused(exc, 'mesh_stiffness_amplitude', 1.0e7, 'could go negative')
    assert '1e+07' in exc.value.rule                          # states k_eff
    # thermal derating lowers k_eff below k_a: refused ...
    with pytest.raises(ParameterError) as exc:
        TableParams(mesh_stiffness_amplitude=6e6, thermal_coefficient=1e-2, temperature_rise=50.0)
    assert exc.value.name == 'mesh_stiffness_amplitude' and '5e+06' in exc.value.rule
    # ... and a preload stiffness k_p raises it again: accepted.
    TableParams(mesh_stiffness_amplitude=6e6, thermal_coefficient=1e-2, temperature_rise=50.0,
                preload_stiffness=2e6)
    with pytest.raises(ParameterError) as exc:
        TableParams(thermal_coefficient=1e-2, temperature_rise=100.0)
    assert exc.value.name == 'temperature_rise'


def test_preload_needs_equal_pinions_in_anti_backlash_mode():
    """T1 = +T_p, T3 = −T_p balance at the table only for r1 = r3."""
    with pytest.raises(ParameterError) as exc:
        TableParams(radius_pinion_3=0.06)
    refused(exc, 'radius_pinion_3', 0.06, 'r1 = r3')
    TableParams(radius_pinion_3=0.06, mode='conventional')
    TableParams(radius_pinion_3=0.06, preload_torque=0.0)


def test_params_are_immutable_and_replace_validates():
    p = TableParams()
    with pytest.raises(AttributeError):
        p.inertia_table = 1.0  # type: ignore[misc]
    with pytest.raises(ParameterError):
        p.replace(inertia_table=-1.0)
    assert p.replace(inertia_table=2.0).inertia_table == 2.0


@pytest.mark.parametrize('name, value, rule_word', [
    ('dt', 0.0, '1e-07 … 0.01'),
    ('dt', float('nan'), 'finite'),
    ('publish_rate', -1.0, '1 … 1e+06'),
    ('publish_rate', 1e-300, '1 … 1e+06'),
    ('real_time_factor', -0.5, '0 or 0.01 … 1000'),
    ('real_time_factor', 1e-20, '0 or 0.01 … 1000'),
    ('real_time_factor', 1e-6, '0 or 0.01 … 1000'),
    ('publish_rate', 3000.0, 'whole number'),    # 1/3000 s is not a multiple of 50 µs
    ('record', 3, 'string'),
    ('publish_clock', 1, 'true or false'),
    ('joint_names', ('a', 'a', 'b'), 'distinct'),
])
def test_invalid_settings_refused(name, value, rule_word):
    with pytest.raises(ParameterError) as exc:
        SimSettings(**{name: value})
    assert exc.value.name == name
    assert rule_word in exc.value.rule


# ---------------------------------------------------------------- RK4 step limit

def undamped_omega_max(p: TableParams) -> float:
    """Highest natural frequency, rad/s, of the undamped 3-DOF model at K = k_eff + k_a.

    Assembled here from the mesh geometry (δ_i = r_i·θ_i − r2·θ2) and solved as the
    generalized symmetric eigenproblem K·v = ω²·M·v.
    """
    k = P.effective_stiffness(p) + p.mesh_stiffness_amplitude
    mass = np.diag([p.inertia_pinion_1, p.inertia_table, p.inertia_pinion_3])
    stiffness = np.zeros((3, 3))
    meshes = [(0, p.radius_pinion_1)]
    if p.mode == 'anti_backlash':
        meshes.append((2, p.radius_pinion_3))
    for body, radius in meshes:
        g = np.zeros(3)
        g[body], g[1] = radius, -p.radius_table
        stiffness += k * np.outer(g, g)
    return math.sqrt(scipy.linalg.eigh(stiffness, mass, eigvals_only=True).max())


@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
def test_max_stable_dt_is_rk4_imaginary_axis_limit_when_undamped(mode):
    """Undamped modes have λ = ±iω: RK4 is stable for ω·dt ≤ 2√2.

    |R(iy)|² = 1 − y⁶/72 + y⁸/576 for R(z) = 1 + z + z²/2 + z³/6 + z⁴/24: = 1 at y = 2√2.
    """
    p = TableParams(mode=mode, mesh_damping=0.0, ste_amplitudes=(), ste_phases=(),
                    drive_no_load_speed=0.0)            # an ideal torque source: no damping
    expected = 2.0 * math.sqrt(2.0) / undamped_omega_max(p)
    assert S.max_stable_dt(p) == pytest.approx(expected, rel=1e-9)
    # For scale: the paper's stiffness allows ~1.9 ms, 38× the default 50 µs step.
    assert 1.8e-3 < expected < 2.0e-3


def test_max_stable_dt_takes_the_ste_lever_of_angle_phase():
    """In `angle` phase δ̇ = (r − z·ε')·θ̇ − r2·θ̇2: the pinion's lever reaches r + z·Σn|ε_n|.

    The limit must be that of a pinion with this longer radius; in `time` phase the STE
    moves with time, not with θ, and the plain radius stands.
    """
    eps = (1.5384e-3, 2e-4)
    slope = 24 * (1 * eps[0] + 2 * eps[1])
    p = TableParams(mesh_damping=0.0, ste_amplitudes=eps, ste_phases=(0.0, 0.3),
                    drive_no_load_speed=0.0)
    assert P.ste_slope(p, '1') == pytest.approx(slope, rel=1e-15)
    levered = TableParams(mesh_damping=0.0, ste_amplitudes=(), ste_phases=(),
                          drive_no_load_speed=0.0, radius_pinion_1=0.078 + slope, radius_pinion_3=0.078 + slope)
    assert S.max_stable_dt(p) == pytest.approx(
        2.0 * math.sqrt(2.0) / undamped_omega_max(levered), rel=1e-9)
    timed = p.replace(mesh_phase='time')
    assert S.max_stable_dt(timed) == pytest.approx(
        S.max_stable_dt(p.replace(ste_amplitudes=(), ste_phases=())), rel=1e-12)


def test_an_ste_slope_past_the_pinion_radius_is_refused():
    """z·Σn|ε_n| ≥ r would make the mesh run backwards against the pinion's rotation."""
    with pytest.raises(ParameterError) as error:
        TableParams(ste_amplitudes=(0.005,))
    assert error.value.name == 'ste_amplitudes' and 'r1 = 0.078' in str(error.value)
    TableParams(ste_amplitudes=(0.005,), mesh_phase='time')   # a time-driven STE has no lever


@pytest.mark.parametrize('mode, drive', [('anti_backlash', False), ('conventional', False),
                                         ('conventional', True), ('anti_backlash', True)])
def test_max_stable_dt_with_damping_matches_the_integrator(mode, drive):
    """Just below the limit RK4 stays bounded, just above a perturbation grows without bound.

    Linear regime (k_a = 0, no STE, b = 0) so the linearization max_stable_dt uses is exact;
    ``drive``: a strong drive line (its slope −T_s/ω_nl damps the driven pinion) with a
    command above it, so the drive stays on the line. The perturbation is the difference
    of a kicked and an unkicked run. In `anti_backlash` only one pinion is driven at a
    time while the limit assumes both: there it must only be safe, in both directions.
    """
    p = TableParams(mode=mode, preload_torque=0.0 if mode == 'conventional' else 350.0,
                    mesh_stiffness_amplitude=0.0, ste_amplitudes=(), ste_phases=(),
                    backlash=0.0, table_damping=8867.0,
                    drive_stall_torque=2e5 if drive else 1600.0,
                    drive_no_load_speed=25.0 if drive else 0.0)
    limit = S.max_stable_dt(p)
    if not drive:     # damping moves the limit a little past 2√2/ω (the region bulges there)
        assert 2.8 < limit * undamped_omega_max(p) < 3.0
    else:             # the drive's damping (8000 N·m·s/rad on I = 0.033) sets the limit
        assert limit < 0.9 * S.max_stable_dt(p.replace(drive_no_load_speed=0.0))
    m = pack(p)
    torque = 2.0 * p.drive_stall_torque if drive else 0.0

    def growth(dt: float, direction: float) -> float:
        runs = []
        for kick in (0.0, 1e-3):
            y = equilibrium_state(p)
            y[3] += kick                                   # kick pinion 1
            advance(y, 0, 2000, dt, m, Drive(torque, direction, 0.0))
            runs.append(y)
        return float(np.max(np.abs(runs[1][3:] - runs[0][3:])))
    directions = (1.0, -1.0) if mode == 'anti_backlash' else (1.0,)
    for direction in directions:
        assert growth(0.98 * limit, direction) < 1e-3
    if mode == 'conventional' or not drive:
        above = growth(1.02 * limit, 1.0)
        assert not np.isfinite(above) or above > 1.0      # the kick grew 1000-fold or more


def test_check_step_and_split_parameters_refuse_unstable_dt():
    p = TableParams()
    limit = S.max_stable_dt(p)
    S.check_step(p, 50e-6)
    with pytest.raises(ParameterError) as exc:
        S.check_step(p, 1.01 * limit)
    assert exc.value.name == 'dt' and 'RK4 is unstable above' in exc.value.rule
    # A stiffer mesh makes a formerly fine step unstable; the message gives the stiffness.
    values = {**PS.default_values(), 'mesh_stiffness_mean': 1e10, 'dt': 1e-4,
              'publish_rate': 1000.0}
    with pytest.raises(ParameterError) as exc:
        PS.split_parameters(values)
    assert exc.value.name == 'dt' and exc.value.value == 1e-4
    assert '1.0001e+10 N/m' in exc.value.rule          # k_eff + k_a


# ---------------------------------------------------------------- YAML

def test_config_files_load_to_the_defaults():
    params, settings = load_yaml(CONFIG / 'paper.yaml')
    assert params == TableParams()
    assert settings == SimSettings()
    from screwgear_ros.paper import normalized
    assert normalized.load_yaml(CONFIG / 'paper_normalized.yaml') == normalized.NormalizedParams()


def test_unknown_parameter_in_yaml_refused(tmp_path):
    text = (CONFIG / 'paper.yaml').read_text(encoding='utf-8')
    bad = tmp_path / 'typo.yaml'
    bad.write_text(text.replace('backlash: 7.5e-05', 'backlesh: 7.5e-05'), encoding='utf-8')
    with pytest.raises(ParameterError) as exc:
        load_yaml(bad)
    refused(exc, 'backlesh', 7.5e-05, 'not a parameter')


def test_yaml_forms_accepted(tmp_path):
    """Node-name key, /** key and a bare mapping all work; values override defaults."""
    for body in ('table_sim:\n  ros__parameters:\n    backlash: 1.0e-5\n',
                 '/**:\n  ros__parameters:\n    backlash: 1.0e-5\n',
                 'backlash: 1.0e-5\n'):
        f = tmp_path / 'p.yaml'
        f.write_text(body, encoding='utf-8')
        params, _ = load_yaml(f)
        assert params == TableParams(backlash=1e-5)


def test_default_values_round_trip():
    assert PS.split_parameters(PS.default_values()) == (TableParams(), SimSettings())


# ---------------------------------------------------------------- derived quantities

def test_derived_quantities_reproduce_the_papers_example():
    """model.md §6: m_e = 5.1477 kg (paper 5.150), F_m = 5128 N, ω_e = 60.319 rad/s, Ω ≈ 0.0433."""
    p = TableParams()
    assert Q.equivalent_mass(p) == pytest.approx(5.1477, abs=5e-5)
    assert Q.mean_mesh_force(p) == pytest.approx(5128.2, abs=0.05)
    assert Q.mesh_frequency_at(p) == pytest.approx(60.319, abs=5e-4)
    assert p.mesh_frequency == pytest.approx(60.319, abs=5e-4)
    w0 = Q.natural_frequency(p)
    assert w0 == pytest.approx(math.sqrt(1e7 / 5.1477), rel=1e-4)
    # §6 quotes Ω = 0.04329 from the paper's rounded m_e = 5.150 kg; with m_e = 5.1477 it
    # is 0.043277: agreement to the paper's precision.
    assert p.mesh_frequency / w0 == pytest.approx(0.04329, abs=2e-5)
    assert Q.damping_ratio(p) == pytest.approx(0.05, rel=1e-12)
    assert damping_for_ratio(p, 0.1) == pytest.approx(2 * p.mesh_damping, rel=1e-12)
    assert Q.stiffness_fluctuation(p) == pytest.approx(0.1)
    assert Q.mean_mesh_force(p) / (p.mesh_stiffness_mean * 1e-6) == pytest.approx(512.8, abs=0.05)
    assert p.ste_amplitudes[0] / 1e-6 == pytest.approx(1538.4)
    # P = (ζ/k_a')·√k_m: 3162 for ζ = 0.1, k_a' = 0.1 only with k_m = 1e7 (model.md §6)
    assert Q.performance_index(0.1, 0.1, 1e7) == pytest.approx(3162.3, abs=0.05)
    assert Q.performance_index(0.1, 0.0, 1e7) == math.inf


def test_effective_stiffness_derating_and_preload_stiffness():
    p = TableParams(thermal_coefficient=2e-3, temperature_rise=25.0, preload_stiffness=3e5)
    assert P.effective_stiffness(p) == pytest.approx(1e7 * (1 - 0.05) + 3e5, rel=1e-15)
