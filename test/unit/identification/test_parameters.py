"""The parameters to fit: refused names and bounds, scaled coordinates, starting points."""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.errors import ScrewgearError
from screwgear_ros.identification.errors import FitParameterError
from screwgear_ros.identification.parameters import (
    Scale,
    fit_parameters,
    parse_bounds,
    start_point,
    starts,
)
from screwgear_ros.params.table import TableParams


@pytest.mark.parametrize('name, problem', [
    ('inertia_tabel', 'not a parameter of table_sim'),
    ('mode', 'read-only'),
    ('dt', 'setting of the simulation'),
    ('teeth_table', 'not a real number'),
    ('table_damping', 'no range: give one with --bounds'),    # 0 in the base: no default range
])
def test_names_that_cannot_be_fitted_are_refused(name, problem):
    with pytest.raises(FitParameterError, match=problem) as caught:
        fit_parameters([name], {})
    assert isinstance(caught.value, ScrewgearError) and isinstance(caught.value, ValueError)


def test_bounds_outside_the_declared_range_are_refused():
    with pytest.raises(FitParameterError, match='outside its declared range'):
        fit_parameters(['backlash'], {}, parse_bounds(['backlash=0:0.02']))   # high: 0.01
    with pytest.raises(FitParameterError, match='outside its declared range'):
        fit_parameters(['drive_time_constant'], {}, {'drive_time_constant': (0.0, 1e-3)})
    with pytest.raises(FitParameterError, match='not among the parameters to fit'):
        fit_parameters(['backlash'], {}, {'inertia_table': (1.0, 2.0)})
    for text in ('backlash', 'backlash=1:0', 'backlash=a:b', 'backlash=0:inf'):
        with pytest.raises(FitParameterError):
            parse_bounds([text])


def test_default_bounds_and_scales():
    inertia, = fit_parameters(['inertia_table'], {})
    assert inertia.base == TableParams().inertia_table and inertia.scale is Scale.LOG
    assert math.isclose(inertia.low, inertia.base / 10) and math.isclose(inertia.high,
                                                                           inertia.base * 10)
    damping, = fit_parameters(['table_damping'], {}, {'table_damping': (0.0, 100.0)})
    assert damping.scale is Scale.LINEAR
    assert damping.to_value(damping.to_x(37.5)) == pytest.approx(37.5)
    assert start_point([damping])[0] == 0.0


def test_starting_points_are_seeded_and_inside_the_bounds():
    fitted = fit_parameters(['inertia_table', 'preload_torque'], {})
    a, b = starts(fitted, 3, seed=7), starts(fitted, 3, seed=7)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    np.testing.assert_array_equal(a[0], start_point(fitted))
    for x in a:
        for p, v in zip(fitted, x, strict=True):
            assert p.low <= p.to_value(v) <= p.high
    assert not np.array_equal(a[1], starts(fitted, 3, seed=8)[1])
