"""check_run's wall time against an anchor commit's, on the same recordings, in one run.

    . /tmp/helper_env.sh   # or SCREWGEAR_VENV=... . scripts/env.sh
    git archive fcb5436 | tar -x -C /tmp/anchor_fcb5436
    python benchmarks/bench_check.py [--anchor-src /tmp/anchor_fcb5436] [--repeat 3] [--stages]

The runs: 60 s of simulation at dt = 50 µs, 1 kHz publishing (60 000 samples), the
paper's table damping, 400 N·m with a reversal every 5 s and load steps of ±150 N·m in
between, recorded in-process by the node's own Session and RunIO
(``bag_runs.record_session``); once without bearing friction and once with the
realistic set's (config/realistic.yaml: the table and the pinions stick at every
reversal). ``check_run --no-progress`` of this environment checks each; the anchor
(the package source at ``--anchor-src``, run as ``python -m screwgear_ros.cli.check_run``
by this interpreter with that tree first on PYTHONPATH) checks the friction-free run (it
has no bearing friction): it does not know the parameters added since, so it checks a
copy whose run_parameters leave those out, message for message the same otherwise. All
must pass. Each figure is the best of ``--repeat`` timings, taken in turns (anchor,
new, ...) so a change of load hits both; the figure is simulated seconds per wall
second and the ratio to the anchor's, with the load average at the start and the end.
``--before-src`` adds a source tree of the code before a change on both runs. With
``--stages`` it also times this package's stages in-process, one after the other
(imports, reading the bag, loading the kernels, the RK4 replay at dt, each reference
solve and its outputs, the RK4 replay at dt/2, the replays' mesh_state); check_run runs
the replay at dt/2 and the looser reference in forked processes meanwhile.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test' / 'support'))
import yaml
from bag_runs import copy_bag, record_session

from screwgear_ros.bag.format import typestore
from screwgear_ros.interface import Input
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.events import Command, Event
from screwgear_ros.sim.schedule import Schedule

SECONDS = 60.0
DT = 50e-6
RATE = 1000.0


def schedule(friction: bool) -> Schedule:
    """400 N·m, a reversal every 5 s, a load step 2.5 s after each reversal."""
    settings = SimSettings(dt=DT, publish_rate=RATE, command_timeout=0.0)
    steps = round(1.0 / DT)
    events: list[Event] = [Command(Input.CMD_TORQUE, 400.0, 0)]
    for k in range(1, 12):
        events.append(Command(Input.CMD_DIRECTION, -1 if k % 2 else 1, k * 5 * steps))
    for k in range(12):
        load = (150.0, -150.0, 0.0)[k % 3]
        events.append(Command(Input.LOAD_TORQUE, load, int((k * 5 + 2.5) * steps)))
    events.sort(key=lambda e: e.step or 0)
    params = TableParams(table_damping=8867.0)
    if friction:                        # config/realistic.yaml's bearing friction
        params = replace(params, table_coulomb_torque=3.0, table_static_torque=4.0,
                         table_stribeck_speed=0.005, pinion_coulomb_torque=0.05,
                         pinion_static_torque=0.07, pinion_stribeck_speed=0.5)
    return Schedule(params, settings, events, end_step=round(SECONDS / DT))


def once(command: list[str], env: dict[str, str] | None = None) -> tuple[float, str]:
    """Wall time of one check (it must pass) and its report."""
    start = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, env=env, cwd='/',
                            check=False)
    elapsed = time.perf_counter() - start
    if result.returncode != 0:
        sys.exit(f'{command} exited {result.returncode}:\n{result.stdout}{result.stderr}')
    return elapsed, result.stdout


#: Times check_run's stages in-process, one after the other; run with the bag's path.
STAGES = r"""
import sys, time
t0 = time.perf_counter()
from screwgear_ros.bag.reader import read_run
from screwgear_ros.numerics.kernels import without_blas_probe
from screwgear_ros.numerics.reference import RTOL
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.runs.check import REFERENCE_REFINE, reference as check, verdict
t = {'import': time.perf_counter() - t0}
s = time.perf_counter(); run = read_run(sys.argv[1]); t['read bag'] = time.perf_counter() - s
solve_piece, spent = check._solve_piece, [0.0]
def timed(*a, **k):
    s = time.perf_counter(); r = solve_piece(*a, **k); spent[0] += time.perf_counter() - s; return r
check._solve_piece = timed
with without_blas_probe():
    s = time.perf_counter(); verdict._load_kernels(run); t['load kernels'] = time.perf_counter() - s
    s = time.perf_counter(); rk4 = replay_in_process(run, 1); t['RK4 replay dt'] = time.perf_counter() - s
    for rtol in (RTOL, RTOL / REFERENCE_REFINE):
        spent[0] = 0.0
        s = time.perf_counter(); check.reference_outputs(run, rk4, rtol=rtol)
        t[f'reference solve {rtol:g}'] = spent[0]
        t[f'reference outputs {rtol:g}'] = time.perf_counter() - s - spent[0]
    s = time.perf_counter(); fine = replay_in_process(run, 2); t['RK4 replay dt/2'] = time.perf_counter() - s
    s = time.perf_counter()
    check.mesh_of(run, rk4, rk4.joint_states), check.mesh_of(run, rk4, fine.joint_states)
    t['mesh_state of both replays'] = time.perf_counter() - s
print(repr(t))
"""


#: The run_parameters keys the anchor's package reads; run with its tree on PYTHONPATH.
KNOWN_KEYS = r"""
import json
try:
    from screwgear_ros.sim.parameter_set import default_values
    from screwgear_ros.sim.run_file import EXTRA_KEYS
except ImportError:                     # an older package: one params module
    from screwgear_ros.params import default_values
    from screwgear_ros.run_parameters import EXTRA_KEYS
print(json.dumps([*default_values(), *EXTRA_KEYS]))
"""


def for_anchor(bag: Path, dst: Path, env: dict[str, str]) -> Path:
    """A copy of ``bag`` whose run_parameters hold only the keys the anchor knows."""
    out = subprocess.run([sys.executable, '-c', KNOWN_KEYS], capture_output=True, text=True,
                         check=True, env=env, cwd='/').stdout
    known = set(json.loads(out.strip().splitlines()[-1]))
    store = typestore()

    def only_known(topic: str, msgtype: str, log_time: int, raw: bytes) -> tuple[int, bytes]:
        if topic.endswith('/run_parameters'):
            document = yaml.safe_load(store.deserialize_cdr(raw, msgtype).data)
            text = yaml.safe_dump({k: v for k, v in document.items() if k in known},
                                  sort_keys=False)
            raw = bytes(store.serialize_cdr(store.types[msgtype](data=text), msgtype))
        return log_time, raw

    copy_bag(bag, dst, only_known)
    return dst


def stages(bag: Path) -> dict[str, float]:
    out = subprocess.run([sys.executable, '-P', '-c', STAGES, str(bag)], capture_output=True,
                         text=True, check=True).stdout
    return eval(out.strip().splitlines()[-1])


def load() -> str:
    return ' '.join(f'{x:.1f}' for x in os.getloadavg())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--anchor-src', default='/tmp/anchor_fcb5436',
                        help='source tree of the anchor commit (git archive of it)')
    parser.add_argument('--before-src', help='also time this source tree (the code before '
                        'a change) on both runs')
    parser.add_argument('--repeat', type=int, default=3, help='timings per check (best kept)')
    parser.add_argument('--stages', action='store_true', help='also time the stages in-process')
    args = parser.parse_args()
    exe = shutil.which('check_run')
    anchor = Path(args.anchor_src)
    if exe is None or not (anchor / 'screwgear_ros').is_dir():
        sys.exit(f'need check_run on PATH ({exe}) and a source tree at {anchor}')
    anchor_env = {**os.environ, 'PYTHONPATH': str(anchor)}
    print(f'load at the start: {load()}', flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        bags = {}
        for friction in (False, True):
            bag = Path(tmp) / f'run60_{"friction" if friction else "plain"}'
            record_session(bag, schedule(friction))
            bags[friction] = bag
        old_bag = for_anchor(bags[False], Path(tmp) / 'run60_anchor', anchor_env)
        runs = {
            'anchor, no friction': ([sys.executable, '-m', 'screwgear_ros.cli.check_run',
                                     '--no-progress', str(old_bag)], anchor_env),
            'new, no friction': ([exe, '--no-progress', str(bags[False])], None),
            'new, friction': ([exe, '--no-progress', str(bags[True])], None),
        }
        if args.before_src:
            before_env = {**os.environ, 'PYTHONPATH': args.before_src}
            for friction, label in ((False, 'no friction'), (True, 'friction')):
                runs[f'before, {label}'] = ([sys.executable, '-m', 'screwgear_ros.cli.check_run',
                                             '--no-progress', str(bags[friction])], before_env)
        best = dict.fromkeys(runs, float('inf'))
        reports = {}
        for _ in range(args.repeat):
            for name, (command, env) in runs.items():
                elapsed, reports[name] = once(command, env)
                best[name] = min(best[name], elapsed)
                print(f'  {name}: {elapsed:.2f} s (load {load()})', flush=True)
        if args.stages:
            for friction, bag in bags.items():
                print(f'stages, friction {friction}:',
                      {k: round(v, 2) for k, v in stages(bag).items()})
    print(f'load at the end: {load()}')
    for name, t in best.items():
        ref = next((line.strip() for line in reports[name].splitlines()
                    if 'reference:' in line), '')
        print(f'check_run, {name:<22} {t:7.2f} s  {SECONDS / t:6.1f} sim s/s  '
              f'x{best["anchor, no friction"] / t:5.1f} of the anchor   [{ref}]')
    return 0


if __name__ == '__main__':
    sys.exit(main())
