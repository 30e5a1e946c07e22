"""check_run's wall time, old against new, on the same recording: prints both and the ratio.

    SCREWGEAR_VENV=/tmp/venv_check . scripts/env.sh
    python benchmarks/bench_check.py --old-venv /tmp/venv_old [--repeat 2] [--keep DIR]

The run: 60 s of simulation at dt = 50 µs, 1 kHz publishing (60 000 samples), the
paper's table damping, 400 N·m with a reversal every 5 s and load steps of ±150 N·m in
between, recorded in-process by the node's own Session and RunIO
(``test/bag_runs.record_session``) into a temporary directory. ``check_run
--no-progress`` of this environment (PATH) and of ``--old-venv`` (a venv with the
package as it was before the compiled reference: make one with
``git worktree add /tmp/old <commit>`` and, from /tmp/old,
``SCREWGEAR_VENV=/tmp/venv_old bash scripts/setup_venv.sh``) each check that bag; both
must pass; the new one is also timed with ``--serial`` (its replay at dt/2 in the same
process, not in a second one meanwhile). The old package does not know the parameters
added since (it refuses a run_parameters naming one: ``contact_location``), so it checks
a copy of the bag whose run_parameters leave those out, message for message the same
otherwise; it then replays with its own RK4 (fixed step), which is the work it did on
such a run. With ``--repeat N`` each is timed N times and the best is kept. With
``--stages`` it also times check_run's stages in-process in each venv (reading the bag,
the RK4 replay at dt, the reference solve, the RK4 replay at dt/2, one after the other),
which shows where the remaining time goes.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
import yaml
from bag_runs import copy_bag, record_session

from screwgear_ros.bag.format import typestore
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.schedule import Schedule

SECONDS = 60.0
DT = 50e-6
RATE = 1000.0


def schedule() -> Schedule:
    """400 N·m, a reversal every 5 s, a load step 2.5 s after each reversal."""
    settings = SimSettings(dt=DT, publish_rate=RATE, command_timeout=0.0)
    steps = round(1.0 / DT)
    events = [Command('cmd_torque', 400.0, 0)]
    for k in range(1, 12):
        events.append(Command('cmd_direction', -1 if k % 2 else 1, k * 5 * steps))
    for k in range(12):
        load = (150.0, -150.0, 0.0)[k % 3]
        events.append(Command('load_torque', load, int((k * 5 + 2.5) * steps)))
    events.sort(key=lambda e: e.step)
    return Schedule(TableParams(table_damping=8867.0), settings, events,
                    end_step=round(SECONDS / DT))


def timed(exe: str, bag: Path, repeat: int, *options: str) -> tuple[float, str]:
    """Best wall time of ``exe --no-progress [options] bag`` over ``repeat`` runs; the
    last report."""
    best = float('inf')
    out = ''
    for _ in range(repeat):
        start = time.perf_counter()
        result = subprocess.run([exe, '--no-progress', *options, str(bag)],
                                capture_output=True, text=True, check=False)
        elapsed = time.perf_counter() - start
        if result.returncode != 0:
            sys.exit(f'{exe} exited {result.returncode}:\n{result.stdout}{result.stderr}')
        best = min(best, elapsed)
        out = result.stdout
    return best, out


#: Times check_run's stages in-process; run by each venv's python with the bag's path.
STAGES = r"""
import sys, time
t0 = time.perf_counter()
from screwgear_ros.bag.reader import read_run
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.runs import check
t = {'import': time.perf_counter() - t0}
s = time.perf_counter(); run = read_run(sys.argv[1]); t['read bag'] = time.perf_counter() - s
s = time.perf_counter(); rk4 = replay_in_process(run, 1); t['RK4 replay dt'] = time.perf_counter() - s
solve_piece, spent = check._solve_piece, [0.0]
def timed(*a, **k):
    s = time.perf_counter(); r = solve_piece(*a, **k); spent[0] += time.perf_counter() - s; return r
check._solve_piece = timed
s = time.perf_counter(); check.reference_outputs(run, rk4)
t['reference solve'] = spent[0]; t['reference outputs'] = time.perf_counter() - s - spent[0]
s = time.perf_counter(); replay_in_process(run, 2); t['RK4 replay dt/2'] = time.perf_counter() - s
print(repr(t))
"""


#: The run_parameters keys a venv's package reads; run by that venv's python.
KNOWN_KEYS = r"""
import json
try:
    from screwgear_ros.sim.parameter_set import default_values
except ImportError:                     # an older package: the set lived in params
    from screwgear_ros.sim.parameter_set import default_values
from screwgear_ros.sim.run_file import EXTRA_KEYS
print(json.dumps([*default_values(), *EXTRA_KEYS]))
"""


def for_old(bag: Path, dst: Path, python: str) -> Path:
    """A copy of ``bag`` whose run_parameters hold only the keys ``python``'s package knows."""
    out = subprocess.run([python, '-P', '-c', KNOWN_KEYS], capture_output=True, text=True,
                         check=True).stdout
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


def stages(python: str, bag: Path) -> dict[str, float]:
    out = subprocess.run([python, '-P', '-c', STAGES, str(bag)], capture_output=True,
                         text=True, check=True).stdout
    return eval(out.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--old-venv', default='/tmp/venv_old',
                        help='venv holding the check_run to compare with')
    parser.add_argument('--repeat', type=int, default=1, help='timings per check_run (best kept)')
    parser.add_argument('--keep', metavar='DIR', help='record the bag here and keep it')
    parser.add_argument('--stages', action='store_true',
                        help='also time the stages in-process, old and new side by side')
    args = parser.parse_args()
    new_exe = shutil.which('check_run')
    old_exe = Path(args.old_venv) / 'bin' / 'check_run'
    if new_exe is None or not old_exe.exists():
        sys.exit(f'need check_run on PATH ({new_exe}) and in {old_exe}')
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(args.keep) if args.keep else Path(tmp) / 'run60'
        start = time.perf_counter()
        record_session(bag, schedule())
        size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
        print(f'recorded {SECONDS:g} s at dt = {DT * 1e6:g} µs, {RATE:g} Hz '
              f'({size:.1f} MB) in {time.perf_counter() - start:.1f} s')
        old_python = str(Path(args.old_venv) / 'bin' / 'python')
        old_bag = for_old(bag, Path(tmp) / 'run60_old', old_python)
        t_new, report = timed(new_exe, bag, args.repeat)
        t_serial, _ = timed(new_exe, bag, args.repeat, '--serial')
        t_old, _ = timed(str(old_exe), old_bag, args.repeat)
        if args.stages:
            new_st = stages(sys.executable, bag)
            old_st = stages(old_python, old_bag)
            print(f'{"stage (in-process)":<22}{"old [s]":>9}{"new [s]":>9}{"old/new":>9}')
            for name in new_st:
                print(f'{name:<22}{old_st[name]:>9.2f}{new_st[name]:>9.2f}'
                      f'{old_st[name] / new_st[name]:>9.1f}')
    reference = next((line.strip() for line in report.splitlines() if 'reference:' in line), '')
    print(f'check_run, new ({new_exe}): {t_new:8.2f} s   [{reference}]')
    print(f'check_run --serial, new (replay at dt/2 in the same process): {t_serial:8.2f} s')
    print(f'check_run, old ({old_exe}): {t_old:8.2f} s')
    print(f'speed-up old/new: {t_old / t_new:.1f}x')
    return 0


if __name__ == '__main__':
    sys.exit(main())
