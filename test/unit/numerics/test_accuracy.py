"""The simulation's own error against what a table encoder resolves.

A 26-bit table encoder resolves 2π/2^26 rad. The demo controller closing the loop on
the default table for 60 s of simulation time, at the default step, keeps the table
angle within one such count of the DOP853 reference re-integrating the inputs the run
applied (docs/model_notes.md §13 has the figures and what excites the error);
check_run passes that run's recording, and states the table angle's error in counts of
that encoder.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from bag_runs import installed_check_run as check_run
from paths import DATA

from screwgear_ros.bag.reader import read_run
from screwgear_ros.inprocess.simulation import Run, Simulation
from screwgear_ros.numerics.reference import Segment, solve
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.runs import check
from screwgear_ros.sim.control import DemoController
from screwgear_ros.sim.plant import DriveInput

#: One count of a 26-bit table encoder, rad (written out here, not taken from check_run).
COUNT = 2.0 * math.pi / 2**26
DEMO_SECONDS = 60.0


@pytest.fixture(scope='module')
def demo_run(tmp_path_factory) -> tuple[Simulation, Run, list[DriveInput]]:
    """The demo controller closing the loop on the default table for DEMO_SECONDS,
    recorded as table_sim records it: the simulation, its run (``record`` the bag) and
    the input the session applied in each tick, in order."""
    sim = Simulation()                       # every default, the default step among them
    controller = DemoController(dt=sim.settings.dt)
    inputs: list[DriveInput] = []

    def answer(observation):
        if observation.step > 0:             # the input the tick that made it ran under
            inputs.append(sim.session.plant.input)
        return controller(observation)
    run = sim.run(answer, DEMO_SECONDS, record=tmp_path_factory.mktemp('demo') / 'demo')
    inputs.append(sim.session.plant.input)   # the last tick's (nobody answers it)
    return sim, run, inputs


def closed_loop_table_error(sim: Simulation, run: Run,
                            inputs: list[DriveInput]) -> tuple[np.ndarray, int]:
    """|θ2 − θ2_ref| at every tick of the closed-loop ``run`` of ``sim``, and how many
    reversals (preload swaps) it made: the reference (DOP853, rtol 1e-12)
    re-integrates the inputs the session applied, tick by tick."""
    n = sim.settings.steps_per_publish
    segments: list[Segment] = []
    reversals = 0
    for i, drive in enumerate(inputs):
        reversals += bool(segments) and segments[-1].drive.direction != drive.direction
        if not segments or segments[-1].drive != drive:
            segments.append(Segment(i * n, drive, sim.params))
    reference = solve(equilibrium_state(sim.params), segments, sim.settings.dt,
                      np.arange(len(inputs) + 1) * n, rtol=1e-12, atol=1e-14)
    return np.abs(run.position[:, 1] - reference[:, 1]), reversals


def test_the_demo_run_keeps_the_table_angle_within_one_encoder_count(demo_run) -> None:
    sim, run, inputs = demo_run
    assert len(inputs) == len(run.step) - 1 == round(DEMO_SECONDS / sim.tick_period)
    controller = DemoController(dt=sim.settings.dt)
    error, reversals = closed_loop_table_error(sim, run, inputs)
    assert reversals >= DEMO_SECONDS / controller.law.gains.dwell - 1   # a swap per target
    assert np.all(np.isfinite(error))
    assert error.max() < COUNT, f'table angle error {error.max():.3e} rad = ' \
        f'{error.max() / COUNT:.2f} counts of a 26-bit encoder'


def test_check_run_passes_the_recorded_demo_run(demo_run) -> None:
    """A minute of the demo run is right (above: within a small part of a count), so
    check_run must pass its recording, the table angle with it. Its tolerance there is
    1.5 × RK4's own Richardson estimate, far below a count, so this holds only while
    the reference's own error stays below that over the whole minute: a reference
    that integrates each input for its ticks' length rounded to the spacing of floats
    at the absolute time drifts linearly in the table angle, by more than that
    tolerance, and its two tolerances' solutions do not show it (both drift). So the
    reference's own error, as check_run estimates it, must also be a small part of
    the tolerance."""
    report = check.check_run(read_run(demo_run[1].record))
    table = report.table_angle
    assert report.ok, check.format_report(report)
    assert table.max_error + table.reference_error <= table.tolerance
    assert table.reference_error < 0.1 * table.tolerance, check.format_report(report)


@pytest.mark.ros
def test_check_run_states_the_table_angle_error_in_encoder_counts() -> None:
    result = check_run(DATA / 'reversals_anti_backlash')
    assert result.returncode == 0, result.stdout + result.stderr
    row, = [line for line in result.stdout.splitlines()
            if line.strip().startswith('table position')]
    max_error = float(row.split()[3])
    found = re.search(r'table angle error (\S+) rad = (\S+) counts of a 26-bit table '
                      r'encoder \((\S+) rad a count\)', result.stdout)
    assert found, result.stdout
    error, counts, count = (float(v) for v in found.groups())
    assert math.isclose(error, max_error, rel_tol=0.01)
    assert math.isclose(count, COUNT, rel_tol=0.01)
    assert math.isclose(counts, max_error / COUNT, rel_tol=0.01)
