"""The simulation's own error against what a table encoder resolves.

A 26-bit table encoder resolves 2π/2^26 rad. The demo controller closing the loop on
the default table for 60 s of simulation time, at the default step, keeps the table
angle within one such count of the DOP853 reference re-integrating the inputs the run
applied (docs/model_notes.md §13 has the figures and what excites the error), and
check_run states the table angle's error in counts of that encoder.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from bag_runs import installed_check_run as check_run
from screwgear_ros.control import DemoController
from screwgear_ros.model import equilibrium_state
from screwgear_ros.reference import Segment, solve
from screwgear_ros.simulation import Simulation

DATA = Path(__file__).parent / 'data'
#: One count of a 26-bit table encoder, rad (written out here, not taken from check_run).
COUNT = 2.0 * math.pi / 2**26
DEMO_SECONDS = 60.0


def closed_loop_table_error(sim: Simulation, controller,
                            seconds: float) -> tuple[np.ndarray, int]:
    """|θ2 − θ2_ref| at every tick of a closed-loop run of ``sim``, and how many
    reversals (preload swaps) the run made: the reference (DOP853, rtol 1e-12)
    re-integrates the inputs the session applied, tick by tick."""
    observation = sim.reset()
    session = sim.session
    ticks = int(round(seconds / sim.tick_period))
    n = sim.settings.steps_per_publish
    table = np.empty(ticks + 1)
    table[0] = observation.position[1]
    segments: list[Segment] = []
    reversals = 0
    for i in range(ticks):
        observation = sim.step(controller(observation))
        drive = session.plant.input
        reversals += bool(segments) and segments[-1].drive.direction != drive.direction
        if not segments or segments[-1].drive != drive:
            segments.append(Segment(i * n, drive, sim.params))
        table[i + 1] = observation.position[1]
    reference = solve(equilibrium_state(sim.params), segments, sim.settings.dt,
                      np.arange(ticks + 1) * n, rtol=1e-12, atol=1e-14)
    return np.abs(table - reference[:, 1]), reversals


def test_the_demo_run_keeps_the_table_angle_within_one_encoder_count() -> None:
    sim = Simulation()                       # every default, the default step among them
    controller = DemoController(dt=sim.settings.dt)
    error, reversals = closed_loop_table_error(sim, controller, DEMO_SECONDS)
    assert reversals >= DEMO_SECONDS / controller.law.gains.dwell - 1   # a swap per target
    assert np.all(np.isfinite(error))
    assert error.max() < COUNT, f'table angle error {error.max():.3e} rad = ' \
        f'{error.max() / COUNT:.2f} counts of a 26-bit encoder'


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
