"""frequency_response's bounds: what cannot fit in memory is refused before any run, with
the limit; so is a number of frequencies beyond the bound; a long measurement is
announced with its estimate before it starts (and the estimate is its plan's size)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.design.budget import MAX_BYTES, MAX_POINTS, MAX_TICKS, Cost
from screwgear_ros.design.closed_loop import measure_loop
from screwgear_ros.design.errors import MeasurementRefused
from screwgear_ros.design.frequency import measure
from screwgear_ros.params.table import SimSettings, TableParams


class Announced(Exception):
    """Stops a measurement once it has said what it will cost."""


def _stop(cost: Cost) -> None:
    raise Announced(cost)


@pytest.mark.parametrize('method', ['sine', 'chirp'])
def test_a_run_that_cannot_fit_in_memory_is_refused_with_the_limit(method):
    with pytest.raises(MeasurementRefused) as info:
        measure(TableParams(), frequencies=(1e-4,), method=method, announce=_stop)
    text = str(info.value)
    assert f'the limit is {MAX_BYTES / 2**30:g} GiB' in text and '--from' in text


def test_too_many_frequencies_are_refused_before_any_plan():
    with pytest.raises(MeasurementRefused, match=str(MAX_POINTS)):
        measure(TableParams(), frequencies=np.geomspace(1.0, 100.0, MAX_POINTS + 1),
                announce=_stop)
    with pytest.raises(MeasurementRefused, match=str(MAX_POINTS)):
        measure_loop(TableParams(), None, lambda o: None,
                     frequencies=np.geomspace(1.0, 100.0, MAX_POINTS + 1))


def test_too_many_ticks_are_refused_with_the_limit():
    with pytest.raises(MeasurementRefused, match=f'{MAX_TICKS:,}'):
        measure(TableParams(), frequencies=np.geomspace(0.1, 0.15, 1000), announce=_stop)


def test_the_estimate_is_announced_before_the_runs_and_is_their_size():
    settings = SimSettings()
    with pytest.raises(Announced) as info:
        measure(TableParams(), settings, frequencies=(0.01,), announce=_stop)
    cost = info.value.args[0]
    # two periods of 0.01 Hz after the settling, one tick a step
    assert cost.ticks == cost.largest_run
    assert 200.0 <= cost.simulated <= 200.0 + 2.0 + settings.dt
    assert cost.ticks == round(cost.simulated / settings.dt)
    assert cost.wall_estimate > 60.0 and 'wall time' in cost.describe()
    with pytest.raises(Announced) as info:
        measure_loop(TableParams(), settings, lambda o: None, frequencies=(1.0, 2.0),
                     announce=_stop)
    loop = info.value.args[0]
    h = 1.0 / settings.publish_rate
    assert loop.ticks == loop.largest_run and math.isclose(loop.simulated, loop.ticks * h)
