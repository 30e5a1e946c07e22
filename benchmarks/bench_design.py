"""frequency_response's stepped sine: wall time of a 60-point response, 1 Hz to 500 Hz.

    SCREWGEAR_VENV=/work/venvs/NAME . scripts/env.sh
    python benchmarks/bench_design.py [--points 60] [--outputs table_angle ...]

The paper's table (config defaults) around the default operating point (a 20 N·m bias
torque against the load that holds it, 10 N·m amplitude), drive torque in, the table angle
out. Prints the wall time, the simulated time it needed, and the anchor measured in the
same run: the same simulated time ticked by the node's session with no input change
(one step per tick, as the measurement ticks), so the ratio says what commanding the
input at every step and fitting cost on top of integrating. The issue's goal: under 60 s
on the 2-core machine.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from screwgear_ros.design.frequency import measure
from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.params.table import SimSettings, TableParams

GOAL = 60.0     # s, the issue's


def anchor(simulated: float, settings: SimSettings) -> float:
    """Wall time, s, of ``simulated`` s ticked one step per tick with nothing commanded."""
    sim = Simulation.from_values({**TableParams().as_dict(), **settings.as_dict()},
                                 publish_rate=1.0 / settings.dt, command_timeout=0.0)
    sim.reset()
    session = sim.session
    ticks = round(simulated / settings.dt)
    started = time.perf_counter()
    for _ in range(ticks):
        session.tick()
    return time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--points', type=int, default=60)
    parser.add_argument('--outputs', nargs='+', default=['table_angle'])
    args = parser.parse_args()
    settings = SimSettings()
    measure(TableParams(), settings, frequencies=(100.0,))      # compiled code loaded
    started = time.perf_counter()
    result = measure(TableParams(), settings, outputs=args.outputs,
                     frequencies=np.geomspace(1.0, 500.0, args.points))
    wall = time.perf_counter() - started
    base = anchor(result.simulated, settings)
    print(f'stepped sine, {args.points} points 1–500 Hz, outputs {", ".join(args.outputs)}: '
          f'{wall:.2f} s wall for {result.simulated:.3f} s simulated '
          f'({result.simulated / settings.dt:.0f} steps, {wall / result.simulated:.2f} s '
          'wall per simulated s)')
    print(f'anchor, the same simulated time ticked with no input change: {base:.2f} s; '
          f'ratio {wall / base:.2f}')
    print(f'goal: under {GOAL:g} s: {"met" if wall < GOAL else "NOT met"}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
