"""What does a fit cost, and how much of it is simulation? Prints one table.

    . scripts/env.sh && python benchmarks/bench_identify.py [--duration 24] [--workers 1 2]

Records the shipped excitation (docs/examples/identification_excitation.yaml, cycled to
``--duration`` s at 1 kHz) on the realistic table with six values changed, in-process
with the preset's encoder noise, then fits those six from the preset's values
(``screwgear_ros.identify``, one starting point). Prints the simulations run, the wall
time, the time spent inside them and its share, and each parameter's error against the
truth with its ±2σ interval, once per ``--workers`` count given (the same recording,
one after the other: the 1-worker run is the 2-worker run's anchor, and the speed-up
their ratio). With one worker the share is of one process's time; with more, the
simulations' time is summed over the workers. Issue #46's goal: six parameters, 24 s,
``--workers 2`` on an idle 2-core machine, at most 3 minutes.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PRESET = ROOT / 'config' / 'realistic.yaml'
EXCITATION = ROOT / 'docs' / 'examples' / 'identification_excitation.yaml'
TRUTH = {'mesh_stiffness_mean': 1.15e7, 'mesh_damping': 800.0, 'inertia_table': 48.0,
         'preload_torque': 330.0, 'table_coulomb_torque': 3.4, 'drive_time_constant': 1.8e-4}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=24.0, help='s of recording')
    parser.add_argument('--workers', type=int, nargs='+', default=[1, 2])
    parser.add_argument('--max-evaluations', type=int, default=30)
    args = parser.parse_args()
    import screwgear_ros
    from screwgear_ros.inprocess.scenario import load_scenario
    from screwgear_ros.inprocess.simulation import Simulation, file_values

    scenario = dataclasses.replace(load_scenario(EXCITATION), duration=args.duration)
    truth = Simulation.from_values({**dict(scenario.values), **file_values(PRESET)}, **TRUTH)
    with tempfile.TemporaryDirectory() as directory:
        work = Path(directory)
        started = time.perf_counter()
        scenario.run(record=work / 'bag', simulation=truth)
        recorded = time.perf_counter() - started
        base = work / 'base.yaml'
        base.write_text(PRESET.read_text(encoding='utf-8') + '    command_timeout: 0.0\n',
                        encoding='utf-8')
        walls = {}
        for workers in args.workers:
            load = os.getloadavg()[0]
            result = screwgear_ros.identify([work / 'bag'], base, list(TRUTH), starts_count=1,
                                            workers=workers,
                                            max_evaluations=args.max_evaluations)
            walls[workers] = result.seconds
            _table(args, recorded, workers, result, load)
    if len(walls) > 1:
        anchor = walls[min(walls)]
        print(', '.join(f'{w} worker(s): {t:.1f} s ({anchor / t:.2f}× the {min(walls)}-worker '
                        'run)' for w, t in walls.items()))


def _table(args: argparse.Namespace, recorded: float, workers: int, result, load: float
           ) -> None:
    print(f'recording: {args.duration:g} s of excitation recorded in {recorded:.1f} s')
    print(f'fit of {len(TRUTH)} parameters on {workers} worker(s): '
          f'{result.simulations} simulations, {result.seconds:.1f} s of wall time, '
          f'{result.sim_seconds:.1f} s simulating '
          f'({100 * result.sim_seconds / result.seconds:.0f} % of the time; '
          f'{result.sim_seconds / max(1, result.simulations):.2f} s a simulation); '
          f'load average {load:.1f} → {os.getloadavg()[0]:.1f}')
    print(f'{"parameter":<22} {"truth":>12} {"fitted":>14} {"error %":>9} {"±2σ %":>8}  truth inside')
    for e in result.estimates:
        t = TRUTH[e.name]
        half = 100 * (e.high - e.low) / 2 / e.value
        print(f'{e.name:<22} {t:>12.6g} {e.value:>14.8g} {100 * (e.value / t - 1):>9.4f} '
              f'{half:>8.3g}  {e.low <= t <= e.high}')
    if result.analysis is not None:
        print('verdict:', result.analysis.verdict())

if __name__ == '__main__':
    main()
