"""The worked sweep of docs/sweeps.md, as a user runs it: 1 worker, 2 workers, ``auto``, and a rerun.

    . scripts/env.sh && python benchmarks/bench_sweep_example.py [--scale 4] [--workers 2]

``docs/examples/tolerance_sweep.yaml`` with its Monte Carlo count times ``--scale`` (the
issue's figure: 4, 1,200 runs), run through the installed ``sweep`` command, each into a
fresh results directory, timed from the command's start to its end (interpreter,
validation, cluster start and the report included):

* ``--workers 1``: the anchor;
* ``--workers N``: N worker processes on a Dask LocalCluster, against the anchor;
* ``--workers auto`` (the default), against the anchor: on a machine whose load leaves
  no free core it picks one worker, and must never lose to it;
* the same command again on the finished N-worker directory: nothing left to run, against
  the N-worker run that made it.

Each line says the 1-minute load average before it started; wall-time ratios only hold
when that stays low. Compare ratios, run it three times. ``--busy N`` runs N processes
that spin beside all of it: the busy machine ``auto`` must not lose on.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / 'docs' / 'examples' / 'tolerance_sweep.yaml'


def scaled_example(directory: Path, scale: int) -> Path:
    """The worked example with ``scale`` times its runs, its files named absolutely."""
    text = EXAMPLE.read_text()
    text = text.replace('../../config/paper.yaml', str(ROOT / 'config' / 'paper.yaml'))
    text = text.replace('scenario: tolerance_scenario.yaml',
                        f'scenario: {EXAMPLE.parent / "tolerance_scenario.yaml"}')
    count = int(re.search(r'count: (\d+)', text).group(1))
    text = re.sub(r'count: \d+', f'count: {count * scale}', text)
    path = directory / 'sweep.yaml'
    path.write_text(text)
    return path


def timed_sweep(path: Path, out: Path, workers: str) -> tuple[float, str, float]:
    """Wall time of ``sweep path --out out --workers workers``, its output, and the load
    average before it started."""
    load = os.getloadavg()[0]
    started = time.perf_counter()
    done = subprocess.run(['sweep', str(path), '--out', str(out), '--workers', workers,
                           '--no-plot'], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        sys.exit(f'sweep --workers {workers} returned {done.returncode}:\n'
                 f'{done.stdout[-2000:]}\n{done.stderr[-2000:]}')
    return wall, done.stdout, load


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scale', type=int, default=4)
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--busy', type=int, default=0, help='spinning processes beside it')
    args = parser.parse_args()
    n = str(args.workers)
    spinners = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
                for _ in range(args.busy)]
    try:
        rows = measure(args, n)
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()
    print(f'the worked sweep x{args.scale} ({300 * args.scale} runs), {os.cpu_count()} cores, '
          f'{args.busy} spinning processes beside it; wall time of the `sweep` command, '
          'start to end')
    print(f'{"figure":44s} {"wall":>8s} {"vs anchor":>10s}  load before  goal')
    for name, wall, ratio, load, goal in rows:
        kind = 'x faster' if not name.startswith('rerun') else ' of it'
        print(f'{name:44s} {wall:7.2f}s {ratio:8.3f}{kind:8s} {load:5.1f}  {goal}')


def measure(args: argparse.Namespace, n: str) -> list[tuple[str, float, float, float, str]]:
    """The four timings, as table rows."""
    with tempfile.TemporaryDirectory(prefix='bench_sweep_example_') as scratch:
        scratch = Path(scratch)
        path = scaled_example(scratch, args.scale)
        one, _, load_one = timed_sweep(path, scratch / 'one', '1')
        many, _, load_many = timed_sweep(path, scratch / 'many', n)
        auto, said, load_auto = timed_sweep(path, scratch / 'auto', 'auto')
        again, _, load_again = timed_sweep(path, scratch / 'many', 'auto')
    picked = re.search(r'--workers auto: (\d+)', said)
    return [
        ('--workers 1 (anchor)', one, 1.0, load_one, ''),
        (f'--workers {n}', many, one / many, load_many, '>= 1.8x faster (idle)'),
        (f'--workers auto (picked {picked.group(1) if picked else "?"})', auto, one / auto,
         load_auto, 'never slower than 1 worker'),
        (f'rerun of the finished {n}-worker sweep', again, again / many, load_again,
         f'<= 0.05 of the {n}-worker run'),
    ]


if __name__ == '__main__':
    main()
