"""One declaration per parameter: the ROS descriptors, the kernel layout, the parameter
file and the docs/parameters.md table all come from the dataclass fields of params.py, and a
mismatch anywhere fails here."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest
import yaml
from paths import ROOT
from readme_blocks import generated_block

from screwgear_ros.params import docs as parameter_docs
from screwgear_ros.params import table as params
from screwgear_ros.params.declarations import (
    Kind,
    check,
    declared,
    parameter,
    plain,
    version_key,
    yaml_value,
)
from screwgear_ros.params.table import ParameterError, SimSettings, TableParams
from screwgear_ros.physics import packed as layout
from screwgear_ros.ros.parameters import (
    PARAMETERS,
    complete_harmonics,
    descriptor,
    dropped_harmonics,
)
from screwgear_ros.sim import parameter_set as parameter_sets
from screwgear_ros.sim.parameter_file import document_values


def test_every_field_is_declared_with_a_description_and_a_type():
    for cls in (TableParams, SimSettings):
        names = [f.name for f in fields(cls)]
        assert [p.name for p in declared(cls)] == names
        for p in declared(cls):
            assert p.declaration.description, p.name
    assert len({p.name for p in PARAMETERS}) == len(PARAMETERS)


def test_descriptors_carry_the_declared_ranges_and_read_only_flags():
    ranged = 0
    for p in PARAMETERS:
        d = descriptor(p)
        assert d.description and d.read_only == p.declaration.read_only
        low = p.declaration.low
        if p.kind is Kind.FLOAT and low is not None:
            ranged += 1
            (r,) = d.floating_point_range
            assert r.from_value == (0.0 if p.declaration.zero else low), p.name
            assert r.to_value == p.declaration.high, p.name
        elif p.kind is Kind.INTEGER:
            (r,) = d.integer_range
            assert r.from_value == (0 if p.declaration.zero else low), p.name
            assert r.to_value == p.declaration.high and low in (0, 1), p.name
        else:
            assert not d.floating_point_range and not d.integer_range, p.name
        if p.kind is Kind.CHOICE:
            assert all(c in d.additional_constraints for c in p.choices)
    assert ranged >= 20
    # the declared range is the validation's: the bound itself and just past it
    for p in PARAMETERS:
        d = p.declaration
        if p.kind is Kind.FLOAT and d.low is not None:
            cls = TableParams if p.name in {f.name for f in fields(TableParams)} else SimSettings
            for outside in (d.low - abs(d.low) - 1.0, d.high * 2.0 + 1.0):
                with pytest.raises(params.ParameterError) as exc:
                    cls(**{p.name: outside})
                assert d.range_text() in exc.value.rule, p.name
            for bound in (d.low, d.high) if not d.strict else (d.high,):
                try:     # the bound passes its own range; another rule may still refuse it
                    assert getattr(cls(**{p.name: bound}), p.name) == bound
                except params.ParameterError as error:
                    assert d.range_text() not in error.rule, (p.name, bound)


def test_the_kernel_layout_packs_every_kernel_field_by_name():
    p = TableParams(table_damping=12.5, preload_torque=321.0, mesh_frequency=7.0)
    packed = layout.pack(p).p
    assert len(packed) == layout.N_PACKED == len(layout.KERNEL) + 4     # k_eff and three enums
    for index, name in enumerate(layout.KERNEL):
        assert packed[index] == getattr(p, name), name
    assert (packed[layout.CT], packed[layout.TP], packed[layout.WE]) == (12.5, 321.0, 7.0)
    assert packed[layout.K_EFF] == params.effective_stiffness(p)
    assert packed[layout.FORMULATION] == layout.FORM_PAPER
    assert layout.pack(p.replace(mesh_formulation='energy_consistent')).p[
        layout.FORMULATION] == layout.FORM_ENERGY
    assert len(set(layout.KERNEL)) == len(layout.KERNEL)


def test_the_parameter_file_is_generated_from_the_declarations():
    text = (ROOT / 'config' / 'paper.yaml').read_text(encoding='utf-8')
    assert text == parameter_docs.paper_yaml(), \
        f'config/paper.yaml is stale: {parameter_docs.WRITE_COMMAND}'
    loaded = document_values(yaml.safe_load(text))
    assert loaded == parameter_sets.default_values()          # YAML 1.1 reads every value back


def test_the_readme_table_is_generated_from_the_declarations():
    assert generated_block('parameters') == parameter_docs.parameter_table(), \
        f'docs/parameters.md table is stale: {parameter_docs.WRITE_COMMAND}'


@pytest.mark.parametrize('value, text', [(1e-06, '1.0e-06'), (7.5e-05, '7.5e-05'),
                                         (1e7, '10000000.0'), (0.0, '0.0'), (3, '3'),
                                         (True, 'true'), ([1e-06, 2.0], '[1.0e-06, 2.0]')])
def test_yaml_values_read_back_as_what_they_are_in_yaml_1_1(value, text):
    assert yaml_value(value) == text
    assert yaml.safe_load(text) == value and type(yaml.safe_load(text)) is type(value)


def test_harmonics_are_completed_with_zeros_to_the_array_being_set():
    amps, phases, note = complete_harmonics([1e-6, 2e-7], [0.5], 'ste_amplitudes')
    assert (amps, phases) == ([1e-6, 2e-7], [0.5, 0.0]) and 'ste_phases' in note
    amps, phases, note = complete_harmonics([1e-6, 0.0], [0.5], 'ste_phases')
    assert (amps, phases) == ([1e-6], [0.5]) and 'ste_amplitudes' in note
    assert complete_harmonics([1.0], [2.0], 'ste_phases') == ([1.0], [2.0], None)
    TableParams(ste_amplitudes=amps, ste_phases=phases)      # a valid set again
    assert np.isfinite(layout.pack(TableParams()).p).all()


@pytest.mark.parametrize('amplitudes, phases, changed, lost', [
    ([1e-6, 2e-7], [0.5], 'ste_phases', '2e-07'),
    ([1e-6], [0.5, 0.25], 'ste_amplitudes', '0.25'),
    ([1e-6, 2e-7, 3e-8], [], 'ste_phases', '[1e-06, 2e-07, 3e-08]'),
])
def test_a_set_that_would_drop_a_nonzero_harmonic_is_not_completed(amplitudes, phases,
                                                                   changed, lost):
    """Completing may add zeros or cut zeros, never a value: the arrays come back as
    given (the validation then refuses their lengths) and the reason names the value."""
    assert complete_harmonics(amplitudes, phases, changed) == (amplitudes, phases, None)
    why = dropped_harmonics(amplitudes, phases, changed)
    assert why is not None and f'drop its nonzero {lost}' in why and why.startswith(changed)
    with pytest.raises(ParameterError, match='one phase per STE harmonic'):
        TableParams(ste_amplitudes=amplitudes, ste_phases=phases)


def test_the_normalized_coefficients_are_declared_once_too():
    from screwgear_ros.paper import batch, normalized
    text = (ROOT / 'config' / 'paper_normalized.yaml').read_text(encoding='utf-8')
    assert text == normalized.paper_yaml(), \
        'stale: python -m screwgear_ros.paper.normalized > config/paper_normalized.yaml'
    assert normalized.load_yaml(ROOT / 'config' / 'paper_normalized.yaml') == \
        normalized.NormalizedParams()
    assert {f.name for f in fields(batch.Coefficients)} == {
        f.name for f in fields(normalized.NormalizedParams)}
    p = normalized.NormalizedParams(damping_ratio=0.2, stiffness_ratio=1.5, mean_load=3.0)
    packed = p.packed()
    assert (packed[normalized.ZETA], packed[normalized.KAPPA], packed[normalized.F0]) == (
        0.2, 1.5, 3.0)
    assert len(packed) == len(normalized.KERNEL) == 8


def test_a_declared_history_is_a_version_and_a_valid_value():
    """``before`` must be a value the parameter accepts (old recordings load with it) and
    needs ``introduced``; ``introduced`` is an X.Y.Z version, compared as numbers."""
    introduced = [p for cls in (TableParams, SimSettings) for p in declared(cls)
                  if p.declaration.introduced]
    assert introduced
    for p in introduced:
        assert check(p, plain(p.declaration.before)) == p.declaration.before, p.name
    with pytest.raises(TypeError, match='needs introduced='):
        parameter(1.0, 'x', 'm', 'a length', before=0.0)
    with pytest.raises(ValueError, match='X.Y.Z'):
        parameter(1.0, 'x', 'm', 'a length', introduced='0.2')
    assert parameter(1.0, 'x', 'm', 'a length', introduced='0.3.0').metadata[
        'declaration'].before == 1.0                  # the default: the parameter changed nothing
    assert version_key('0.10.0') > version_key('0.9.1')       # not compared as text
    for text in ('0.2', '0.2.0rc1', '٠.٢.٠', 'unknown', ''):
        with pytest.raises(ValueError):
            version_key(text)
