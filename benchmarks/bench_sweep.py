"""How fast does a sweep go, and what does its engine cost? Prints one table.

    . scripts/env.sh && python benchmarks/bench_sweep.py [--runs 32] [--workers 2]

Runs of 2 s of simulation at 1 kHz with the demo controller (a reversal in the middle),
over a grid of backlash values, measured in one run on this machine:
* the anchor: each run's own time, ``worker.execute`` called in a plain loop here;
* the sweep engine in this process (``--workers 1``: the runs, the per-run result files);
* the sweep engine on a Dask LocalCluster of N single-threaded worker processes.
For each: throughput in steady state (runs/s between the first and the last result, so
cluster start and warm-up stand apart) and the per-run overhead against the anchor
(wall time × workers / runs − run time, as % of the run time), also against the runs'
own time on the workers (which a busy machine stretches as much as the wall time). The
scaling figure is the N-worker throughput over the 1-worker throughput. Timings are
noisy on a shared machine: compare ratios, run twice.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

SCENARIO = """\
parameters: {command_timeout: 0.0}
duration: 2.0
controller:
  use: demo
setpoint: {profile: steps, points: [[0.0, 0.02], [1.0, -0.02]]}
"""


def sweep_file(directory: Path, runs: int) -> Path:
    (directory / 'scenario.yaml').write_text(SCENARIO)
    values = ', '.join(f'{100e-6 * k / max(runs - 1, 1):.6e}' for k in range(runs))
    path = directory / 'sweep.yaml'
    path.write_text('scenario: scenario.yaml\nmetrics: [max_lost_motion_rad, max_abs_te_m]\n'
                    f'grid:\n  backlash: [{values}]\n')
    return path


def engine(path: Path, out: Path, workers: int) -> tuple[float, float, float]:
    """(s from the call to the first result, steady runs/s, mean run time on workers)."""
    from screwgear_ros.sweep import load_sweep
    from screwgear_ros.sweep.engine import outcomes
    from screwgear_ros.sweep.store import Store

    sweep = load_sweep(path)
    store = Store(out, sweep)
    store.open()
    started = time.perf_counter()
    arrivals, own = [], []
    for outcome in outcomes(sweep.bundle, sweep.runs, workers, None):
        store.add(outcome)
        arrivals.append(time.perf_counter())
        own.append(outcome.wall_time)
        assert outcome.status.value == 'ok', outcome.reason
    store.write_results(store.finished())
    steady = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0])
    return arrivals[0] - started, steady, statistics.fmean(own)


def anchor(path: Path) -> float:
    """Mean s per run of the runs themselves, called in a loop in this process."""
    from screwgear_ros.sweep import load_sweep
    from screwgear_ros.sweep.worker import execute, warm_up

    sweep = load_sweep(path)
    warm_up()
    execute(sweep.bundle, sweep.runs[0])
    started = time.perf_counter()
    for spec in sweep.runs:
        execute(sweep.bundle, spec)
    return (time.perf_counter() - started) / len(sweep.runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=32)
    parser.add_argument('--workers', type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix='bench_sweep_') as scratch:
        scratch = Path(scratch)
        path = sweep_file(scratch, args.runs)
        run_time = anchor(path)
        first_1, rate_1, own_1 = engine(path, scratch / 'one', 1)
        first_n, rate_n, own_n = engine(path, scratch / 'many', args.workers)
        run_time_after = anchor(path)
    run_time = min(run_time, run_time_after)
    overhead_1 = 100.0 * (1.0 / rate_1 - run_time) / run_time
    overhead_n = 100.0 * (args.workers / rate_n - run_time) / run_time
    # against the runs' own time on the workers, measured under the same load
    engine_1 = 100.0 * (1.0 / rate_1 - own_1) / own_1
    engine_n = 100.0 * (args.workers / rate_n - own_n) / own_n
    print(f'sweep benchmark: {args.runs} runs of 2 s simulated at 1 kHz, demo controller; '
          f'{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}')
    print(f'{"figure":48s} {"value":>10s}   anchor / goal')
    print(f'{"a run alone, in a plain loop (anchor)":48s} {run_time:9.3f}s')
    print(f'{"1 worker: throughput, steady":48s} {rate_1:7.2f}/s   '
          f'{1.0 / run_time:.2f}/s (1 / anchor)')
    print(f'{"1 worker: per-run overhead vs the run":48s} {overhead_1:8.1f} %   goal <= 10 %')
    print(f'{"1 worker: first result after":48s} {first_1:9.2f}s')
    print(f'{f"{args.workers} workers: throughput, steady":48s} {rate_n:7.2f}/s   '
          f'{rate_1:.2f}/s (1 worker)')
    print(f'{f"{args.workers} workers / 1 worker (scaling)":48s} {rate_n / rate_1:8.2f}x   '
          f'goal >= {0.9 * args.workers:.1f}x')
    print(f'{f"{args.workers} workers: per-run overhead vs the run":48s} {overhead_n:8.1f} %   '
          f'goal <= 10 %')
    print(f'{f"{args.workers} workers: run time on a worker":48s} {own_n:9.3f}s   '
          f'{own_1:.3f}s (1 worker)')
    print(f'{"engine overhead vs run time on the worker, 1":48s} {engine_1:8.1f} %   '
          'goal <= 10 %')
    print(f'{f"engine overhead vs run time on the worker, {args.workers}":48s} '
          f'{engine_n:8.1f} %   goal <= 10 %')
    print(f'{f"{args.workers} workers: cluster start to first result":48s} {first_n:9.2f}s')
    print(f'10,000 runs like these: {10_000 / rate_n / 3600:.2f} h on {args.workers} workers '
          f'here; {10_000 * run_time * (1 + max(overhead_n, 0.0) / 100) / 3600 / 64:.2f} h on '
          '64 such cores')


if __name__ == '__main__':
    main()
