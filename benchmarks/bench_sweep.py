"""How fast does a sweep go, and what does its engine cost? Prints one table.

    . scripts/env.sh && python benchmarks/bench_sweep.py [--runs 64] [--workers 2]

Runs of 2 s of simulation at 1 kHz with the demo controller (a reversal in the middle),
over a grid of backlash values, measured in one run on this machine:
* the anchor: each run's own time, ``worker.execute`` called in a plain loop here;
* the scaling anchor: the same loop in N plain processes at once (no Dask): what N
  processes of these runs get from this machine right now, which is the most any engine
  can scale to here;
* N threads of this process running the loop (no Dask): whether threads in one process
  beat processes for short runs (the engine uses processes: see the table);
* the sweep engine in this process (``--workers 1``: the runs, the per-run result files);
* the sweep engine on a Dask LocalCluster of N single-threaded worker processes.
For each: throughput in steady state (runs/s between the first and the last result, so
cluster start and warm-up stand apart), the runs' own wall and CPU time (their thread's)
and the engine's overhead: per run, wall time × workers / runs − run time, against the
anchor and against the runs' own time on the workers; and in CPU time, what all the
sweep's processes (client, scheduler, nannies, workers) spent beyond the runs' own CPU
time. CPU times hold on a busy machine (this one is shared), wall-time ratios do not:
the table says the load average before and after. Compare ratios, run twice.
"""

from __future__ import annotations

import argparse
import contextlib
import multiprocessing
import os
import statistics
import tempfile
import time
from dataclasses import dataclass
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


@dataclass
class Phase:
    """One way of running the sweep's runs, measured."""

    first: float            # s from the start to the first result
    rate: float             # runs/s in steady state
    wall: float             # mean s of wall time of a run where it ran
    cpu: float              # mean s of CPU time of a run (its thread's)
    engine_cpu: float       # s of CPU time per run of all the sweep's processes beyond it
    engine_cores: float = 0.0   # the same, as cores busy while the runs went on


def _tree_cpu() -> float:
    """s of CPU time of this process and all its children (a LocalCluster's workers)."""
    import psutil

    me = psutil.Process()
    total = sum(me.cpu_times()[:2])
    for child in me.children(recursive=True):
        with contextlib.suppress(psutil.Error):       # a child that ended meanwhile
            total += sum(child.cpu_times()[:2])
    return total


def engine(path: Path, out: Path, workers: int) -> Phase:
    """The sweep engine with results stored as ``sweep`` stores them. The steady window
    opens at the first result (the first batches are one run each)."""
    from screwgear_ros.sweep import load_sweep
    from screwgear_ros.sweep.engine import outcomes
    from screwgear_ros.sweep.store import Store

    sweep = load_sweep(path)
    store = Store(out, sweep)
    store.open()
    started = time.perf_counter()
    arrivals, wall, cpu, tree = [], [], [], 0.0
    for outcome in outcomes(sweep.bundle, sweep.runs, workers, None):
        store.add(outcome)
        arrivals.append(time.perf_counter())
        if len(arrivals) == 1:
            tree = _tree_cpu()
        else:
            cpu.append(outcome.cpu_time)
        if len(arrivals) == len(sweep.runs):        # before the cluster closes
            tree = _tree_cpu() - tree
        wall.append(outcome.wall_time)
        assert outcome.status.value == 'ok', outcome.reason
    store.write_results(store.finished())
    steady = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0])
    return Phase(arrivals[0] - started, steady, statistics.fmean(wall), statistics.fmean(cpu),
                 (tree - sum(cpu)) / len(cpu),
                 (tree - sum(cpu)) / (arrivals[-1] - arrivals[0]))


def _loop(path: Path, share: int = 0, of: int = 1, barrier=None, queue=None) -> Phase:
    """The runs (every ``of``-th from ``share``) in a plain loop in this process."""
    from screwgear_ros.sweep import load_sweep
    from screwgear_ros.sweep.worker import execute, warm_up

    sweep = load_sweep(path)
    warm_up()
    execute(sweep.bundle, sweep.runs[0])
    if barrier is not None:
        barrier.wait()
    started, cpu_started = time.perf_counter(), time.thread_time()
    wall, cpu = [], []
    for spec in sweep.runs[share::of]:
        outcome = execute(sweep.bundle, spec)
        wall.append(outcome.wall_time)
        cpu.append(outcome.cpu_time)
    elapsed = time.perf_counter() - started
    phase = Phase(0.0, len(wall) / elapsed, statistics.fmean(wall), statistics.fmean(cpu),
                  (time.thread_time() - cpu_started - sum(cpu)) / len(cpu))
    if queue is not None:
        queue.put(phase)
    return phase


def anchor(path: Path) -> Phase:
    """Each run's own time, called in a loop in this process."""
    return _loop(path)


def plain_processes(path: Path, n: int) -> Phase:
    """The runs shared out over ``n`` plain processes started at once (no Dask): their
    summed throughput and their runs' mean times."""
    context = multiprocessing.get_context('spawn')
    barrier, queue = context.Barrier(n), context.Queue()
    procs = [context.Process(target=_loop, args=(path, k, n, barrier, queue))
             for k in range(n)]
    for proc in procs:
        proc.start()
    phases = [queue.get() for _ in procs]
    for proc in procs:
        proc.join()
    return Phase(0.0, sum(p.rate for p in phases), statistics.fmean(p.wall for p in phases),
                 statistics.fmean(p.cpu for p in phases), 0.0)


def threads(path: Path, n: int) -> Phase:
    """The runs shared out over ``n`` threads of this process (no Dask): what one
    process gets from threads, against :func:`plain_processes`. The compiled kernels
    hold the GIL (they are not compiled ``nogil``) and every tick passes through Python
    (the controller, the deadline check), so threads share one core's worth of Python."""
    from concurrent.futures import ThreadPoolExecutor

    from screwgear_ros.sweep import load_sweep
    from screwgear_ros.sweep.worker import execute, warm_up

    sweep = load_sweep(path)
    warm_up()
    execute(sweep.bundle, sweep.runs[0])

    def share(k: int) -> list[tuple[float, float]]:
        return [(o.wall_time, o.cpu_time) for o in
                (execute(sweep.bundle, spec) for spec in sweep.runs[k::n])]

    started = time.perf_counter()
    with ThreadPoolExecutor(n) as pool:
        times = [t for part in pool.map(share, range(n)) for t in part]
    elapsed = time.perf_counter() - started
    return Phase(0.0, len(times) / elapsed, statistics.fmean(t[0] for t in times),
                 statistics.fmean(t[1] for t in times), 0.0)


def _load() -> str:
    return ' '.join(f'{v:.1f}' for v in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=64)
    parser.add_argument('--workers', type=int, default=2)
    args = parser.parse_args()
    n = args.workers
    busy = os.getloadavg()[0] > 0.5 * (os.cpu_count() or 1)
    load_before = _load()
    with tempfile.TemporaryDirectory(prefix='bench_sweep_') as scratch:
        scratch = Path(scratch)
        path = sweep_file(scratch, args.runs)
        alone = anchor(path)
        plain = plain_processes(path, n)
        threaded = threads(path, n)
        one = engine(path, scratch / 'one', 1)
        many = engine(path, scratch / 'many', n)
        alone_after = anchor(path)
    load_after = _load()
    run_time = min(alone.wall, alone_after.wall)
    run_cpu = min(alone.cpu, alone_after.cpu)
    overhead_1 = 100.0 * (1.0 / one.rate - run_time) / run_time
    overhead_n = 100.0 * (n / many.rate - run_time) / run_time
    # against the runs' own time on the workers, measured under the same load
    engine_1 = 100.0 * (1.0 / one.rate - one.wall) / one.wall
    engine_n = 100.0 * (n / many.rate - many.wall) / many.wall
    # the scaling the engine's own CPU time allows if the cores are the sweep's alone
    # and a run costs the same CPU on either: its processes take their share of core
    # time (most of it goes with time, not with runs), the workers the rest
    cpu_scaling = (n - many.engine_cores) * (1.0 + one.engine_cpu / one.cpu)
    rows = [
        ('a run alone, in a plain loop (anchor)', f'{run_time:9.3f}s',
         f'CPU {run_cpu:.3f}s'),
        ('1 worker: throughput, steady', f'{one.rate:7.2f}/s',
         f'{1.0 / run_time:.2f}/s (1 / anchor)'),
        ('1 worker: per-run overhead vs the run', f'{overhead_1:8.1f} %', 'goal <= 10 %'),
        ('1 worker: engine CPU per run beyond the run', f'{100 * one.engine_cpu / one.cpu:8.1f} %',
         f'of the run\'s CPU {one.cpu:.3f}s'),
        ('1 worker: first result after', f'{one.first:9.2f}s', ''),
        (f'{n} plain processes at once: throughput', f'{plain.rate:7.2f}/s',
         f'{plain.rate * run_time:.2f}x the anchor: what this machine gives now'),
        (f'{n} threads in one process: throughput', f'{threaded.rate:7.2f}/s',
         (f'{threaded.rate * run_time:.2f}x the anchor (one thread), '
         f'{threaded.rate / plain.rate:.2f}x {n} plain processes')),
        (f'{n} workers: throughput, steady', f'{many.rate:7.2f}/s',
         f'{one.rate:.2f}/s (1 worker)'),
        (f'{n} workers / 1 worker (scaling)', f'{many.rate / one.rate:8.2f}x',
         f'anchor: {n} plain processes {plain.rate * run_time:.2f}x; goal >= {0.9 * n:.1f}x'),
        (f'{n} workers / {n} plain processes', f'{many.rate / plain.rate:8.2f}x',
         'the engine\'s share of the scaling; 1.00 = all of it'),
        (f'{n} workers: per-run overhead vs the run', f'{overhead_n:8.1f} %', 'goal <= 10 %'),
        (f'{n} workers: run time on a worker', f'{many.wall:9.3f}s',
         f'{one.wall:.3f}s (1 worker), {plain.wall:.3f}s ({n} plain processes)'),
        (f'{n} workers: run CPU time on a worker', f'{many.cpu:9.3f}s',
         f'{one.cpu:.3f}s (1 worker), {plain.cpu:.3f}s ({n} plain processes)'),
        ('engine overhead vs run time on the worker, 1', f'{engine_1:8.1f} %', 'goal <= 10 %'),
        (f'engine overhead vs run time on the worker, {n}', f'{engine_n:8.1f} %',
         'goal <= 10 %'),
        (f'{n} workers: engine CPU per run beyond the run',
         f'{100 * many.engine_cpu / many.cpu:8.1f} %',
         'client, scheduler, nannies, workers; goal <= 10 %'),
        (f'{n} workers: engine CPU beyond the runs', f'{many.engine_cores:8.3f}  ',
         'cores busy, mostly with time, not with runs'),
        (f'{n} workers / 1 worker from CPU time', f'{cpu_scaling:8.2f}x',
         'if the cores were the sweep\'s alone and runs no dearer on N'),
        (f'run CPU time, {n} workers / 1 worker', f'{many.cpu / one.cpu:8.2f}x',
         f'{n} plain processes / 1: {plain.cpu / run_cpu:.2f}x (cores that slow each other)'),
        (f'{n} workers: cluster start to first result', f'{many.first:9.2f}s', ''),
    ]
    print(f'sweep benchmark: {args.runs} runs of 2 s simulated at 1 kHz, demo controller; '
          f'{os.cpu_count()} cores')
    print(f'load average (1, 5, 15 min): {load_before} before, {load_after} after (this '
          f'benchmark adds up to {n + 1} while it runs)')
    if busy:
        print('note: the machine was busy before this started: the wall-time figures '
              '(the scaling too) show what the other load left to this benchmark; the '
              'CPU-time figures hold better')
    print(f'{"figure":48s} {"value":>10s}   anchor / goal')
    for name, value, note in rows:
        print(f'{name:48s} {value:>10s}   {note}')
    print(f'10,000 runs like these: {10_000 / many.rate / 3600:.2f} h on {n} workers '
          f'here; from CPU time {10_000 * many.cpu / (n - many.engine_cores) / 3600:.2f} h '
          f'on {n} cores of its own; '
          f'{10_000 * run_time * (1 + max(overhead_n, 0.0) / 100) / 3600 / 64:.2f} h on '
          '64 such cores')


if __name__ == '__main__':
    main()
