"""What recording costs and what it buys: prints one table, in one run, on this machine.

    . scripts/env.sh && ROS_DOMAIN_ID=<free id> python benchmarks/bench_recording.py

* table_sim (installed console script, real DDS) at dt = 50 µs, 1 kHz publishing,
  driven at 400 N·m: real-time factor reached as fast as possible (factor 0), and at
  factor 1.0 the factor achieved and the CPU share of the node process, each with
  recording off and on, side by side; messages written and dropped;
* check_run's wall time on a 60 s simulated run recorded by the node;
* how much simulation a kill -9 loses (last /clock seen vs last readable sample).

Timings are noisy on a shared 2-core machine: compare the ratios, run twice.

    python benchmarks/bench_recording.py --speed [--repeat N] [--window S]

measures only the two recording figures of ``bench_speed.py``, its way (its helpers:
the installed table_sim over real DDS, observed from this process), each beside its
anchor from the same run, the scenarios repeated and interleaved: flat out (dt 50 µs,
1 kHz) recording against not recording (cost in % of the real-time factor), and at
factor 1, dt 20 µs the CPU share recording adds (% of a core).
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
from ros_procs import STARTUP_TIMEOUT, Inbox, Peer, RosProcess, stamp_ns, start_process

from screwgear_ros.bag.reader import read_run

WINDOW = 8.0        # s of wall time per measurement
PARAMS = {'table_damping': 8867.0, 'dt': 50e-6, 'publish_rate': 1000.0}
TICKS = os.sysconf('SC_CLK_TCK')


def cpu_seconds(pid: int) -> float:
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


@contextmanager
def driven_node(workdir: Path, name: str, params: dict) -> Iterator[tuple[RosProcess, Inbox]]:
    """table_sim started with ``params`` and driven at 400 N·m; yields (node, /clock inbox).

    The node is stopped with SIGINT on the way out unless the body already ended it.
    """
    node = start_process('table_sim', params={**PARAMS, **params}, workdir=workdir / name)
    try:
        with Peer(f'bench_recording_{name}') as peer:
            clock = peer.subscribe('/clock', Clock, transform=stamp_ns, qos=10)
            torque = peer.publisher('cmd_torque', Float64, wait_matched=STARTUP_TIMEOUT)
            clock.wait_for(lambda t: t > 0, STARTUP_TIMEOUT)
            torque.publish(Float64(data=400.0))
            yield node, clock
    finally:
        if node.alive():
            node.stop(signal.SIGINT, timeout=60.0)
        node.kill()


def run_node(workdir: Path, factor: float, record: bool) -> dict[str, float]:
    """Start, drive, measure over WINDOW, stop with SIGINT."""
    params = {'real_time_factor': factor, **({'record': str(workdir / 'bag')} if record else {})}
    with driven_node(workdir, 'node', params) as (node, clock):
        time.sleep(1.0)
        t0, sim0, cpu0 = time.monotonic(), clock.latest(), cpu_seconds(node.pid)
        time.sleep(WINDOW)
        t1, sim1, cpu1 = time.monotonic(), clock.latest(), cpu_seconds(node.pid)
    out, err = node.output()
    written = re.search(r'recording closed: (\d+) messages written, (\d+) dropped', out + err)
    return {'factor': (sim1 - sim0) * 1e-9 / (t1 - t0), 'cpu': (cpu1 - cpu0) / (t1 - t0),
            'written': float(written.group(1)) if written else float('nan'),
            'dropped': float(written.group(2)) if written else float('nan')}


def record_60s(workdir: Path) -> Path:
    """A 60 s simulated run at 400 N·m against the table damping, recorded at factor 0."""
    bag = workdir / 'run60'
    with driven_node(workdir, 'n60', {'real_time_factor': 0.0, 'record': str(bag)}) as (_, clock):
        clock.wait_for(lambda t: t >= 60e9, 600.0, '60 s of simulation')
    return bag


def kill_9_loss(workdir: Path) -> tuple[float, float]:
    """(last /clock seen, last readable joint_states time), s, after kill -9 at factor 1."""
    bag = workdir / 'killed'
    with driven_node(workdir, 'nk', {'record': str(bag)}) as (node, clock):
        clock.wait_for(lambda t: t >= 4.3e9, 60.0)
        node.popen.send_signal(signal.SIGKILL)
        node.popen.wait()
        seen = clock.latest() * 1e-9
    run = read_run(bag, allow_truncated=True)
    return seen, float(run.joint_states.steps[-1] * run.dt)


def speed(repeat: int, window: float) -> None:
    """The recording figures only (module docstring), bench_speed's way."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_speed as bs
    recording = ('table_flat', 'table_flat_rec', 'table_f1', 'table_f1_rec')
    print(f'recording figures, {repeat} repeat(s) interleaved, {window:g} s windows, load '
          f'average {os.getloadavg()[0]:.2f}', flush=True)
    seen = bs.run_scenarios({k: bs.SCENARIOS[k] for k in recording}, repeat, window, 2.0)
    rows = bs.recording_rows(seen)
    print(f'load average at the end {os.getloadavg()[0]:.2f}')
    bs.print_table(rows)


def main() -> None:
    if '--speed' in sys.argv:
        import argparse
        parser = argparse.ArgumentParser(description='the recording figures of bench_speed')
        parser.add_argument('--speed', action='store_true')
        parser.add_argument('--repeat', type=int, default=3)
        parser.add_argument('--window', type=float, default=10.0)
        args = parser.parse_args()
        speed(args.repeat, args.window)
        return
    with tempfile.TemporaryDirectory(prefix='bench_recording_') as tmp:
        tmp_path = Path(tmp)
        print(f'table_sim, dt = 50 µs, 1 kHz publishing, 400 N·m drive; {WINDOW:g} s windows')
        print(f'{"":40}{"recording off":>16}{"recording on":>16}')
        rows = {}
        for factor in (0.0, 1.0):
            rows[factor] = [run_node(tmp_path / f'f{factor}_{rec}', factor, rec)
                            for rec in (False, True)]
        for factor, (off, on) in rows.items():
            label = 'as fast as possible' if factor == 0 else 'factor 1.0'
            print(f'{label + ": real-time factor":<40}{off["factor"]:>16.3f}{on["factor"]:>16.3f}')
            print(f'{label + ": CPU share of the node":<40}{off["cpu"]:>16.0%}{on["cpu"]:>16.0%}')
            print(f'{"  messages written / dropped":<40}{"-":>16}'
                  f'{on["written"]:>10.0f} / {on["dropped"]:.0f}')

        bag = record_60s(tmp_path)
        size = sum(f.stat().st_size for f in bag.iterdir())
        t0 = time.monotonic()
        result = subprocess.run([shutil.which('check_run'), '--no-progress', str(bag)],
                                capture_output=True, text=True, check=False)
        seconds = time.monotonic() - t0
        verdict = result.stdout.strip().splitlines()[-1].strip() if result.stdout else \
            result.stderr.strip()
        print(f'check_run on a 60 s simulated run ({size / 1e6:.1f} MB bag): {seconds:.1f} s '
              f'wall, exit {result.returncode} ({verdict})')

        seen, readable = kill_9_loss(tmp_path)
        print(f'kill -9 at factor 1: last /clock seen t = {seen:.3f} s, readable up to '
              f't = {readable:.3f} s: {seen - readable:.3f} s of simulation lost')


if __name__ == '__main__':
    main()
