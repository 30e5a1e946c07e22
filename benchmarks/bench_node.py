"""How fast is the plant and how well does table_sim keep real time? Prints one table.

    . scripts/env.sh && ROS_DOMAIN_ID=<free id> python benchmarks/bench_node.py [--record]

Measures, in one run, on this machine:
* integrator steps per second on the 3-DOF model: compiled (numba) vs the very same
  source as plain Python (a subprocess with NUMBA_DISABLE_JIT=1), for long ticks
  and for the node's 20-step calls;
* table_sim (installed console script, real DDS) at dt = 50 µs and 20 µs with 1 kHz
  publishing: the real-time factor it reaches as fast as possible (factor 0), and at
  factor 1.0 the factor achieved, overruns, the CPU share of the node process (from
  /proc/<pid>/stat over the window), the period jitter of joint_states seen by a
  subscriber in this (other) process (p50/p99/max of |arrival gap − 1 ms|), the
  drift of simulation against wall time over the window, and the time to exit on
  SIGINT.
``--record`` repeats every node scenario with ``record`` on (a bag in a temporary
directory), to show what recording costs. Timings are noisy on a shared machine:
compare ratios, run twice.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import JointState

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test' / 'support'))
from ros_procs import STARTUP_TIMEOUT, Peer, RosProcess, stamp_ns, start_process

WINDOW = 10.0      # s of wall time measured per node scenario
WARMUP = 2.0       # s before the window opens

_STEPS_SCRIPT = """
import sys, time
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.session import Session
n, batch = int(sys.argv[1]), int(sys.argv[2])
session = Session(TableParams(), SimSettings(dt=50e-6, publish_rate=1.0 / (batch * 50e-6)))
session.tick()
t = time.perf_counter()
for _ in range(n // batch):
    session.tick()
print(n // batch * batch / (time.perf_counter() - t))
"""


def integrator_rate(n: int, batch: int, jit: bool) -> float:
    """RK4 steps per second of Session.tick (``batch`` steps a tick, outputs included),
    the node's own per-tick path, in a fresh interpreter."""
    env = dict(os.environ)
    if not jit:
        env['NUMBA_DISABLE_JIT'] = '1'
    # -P: the installed package (the node's code), never the sources in the working dir.
    out = subprocess.run([sys.executable, '-P', '-c', _STEPS_SCRIPT, str(n), str(batch)], env=env,
                         check=True, capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process, s."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


@dataclass
class Observed:
    """What a subscriber in this process saw of a publisher process over one window."""

    t0: float                 # time.monotonic() when the window opened
    t1: float                 # ... and closed
    cpu: float                # CPU share of one core of the process over the window
    arrivals: list[tuple[float, int]]   # (time.monotonic(), stamp ns) of joint_states in it
    diags: list[dict[str, str]]         # /diagnostics key → value received in it
    first: float              # s from the call to the first joint_states

    def factor(self) -> float:
        """Real-time factor from the joint_states stamps: simulation advanced / wall time
        between the first and the last message of the window."""
        if len(self.arrivals) < 2:
            return float('nan')
        (w0, s0), (w1, s1) = self.arrivals[0], self.arrivals[-1]
        return (s1 - s0) * 1e-9 / (w1 - w0)

    def jitter(self, period: float) -> tuple[float, float, float] | None:
        """p50, p99, max of |arrival gap − period|, s, over consecutive joint_states
        (stamps 1 ms apart: no message lost in between); None with too few."""
        if len(self.arrivals) <= 10:
            return None
        wall = np.array([w for w, _ in self.arrivals])
        sim = np.array([s for _, s in self.arrivals]) * 1e-9
        consecutive = np.diff(sim) < 1.5e-3
        dev = np.abs(np.diff(wall)[consecutive] - period)
        return (float(np.percentile(dev, 50)), float(np.percentile(dev, 99)),
                float(dev.max()))

    def drift(self, factor: float) -> float | None:
        """Change of (wall − sim/factor) over the window, s (medians of 100 messages)."""
        if len(self.arrivals) <= 200:
            return None
        lag = np.array([w - s * 1e-9 / factor for w, s in self.arrivals])
        return float(np.median(lag[-100:]) - np.median(lag[:100]))


def observe(proc: RosProcess, window: float, warmup: float = WARMUP,
            name: str = 'bench_node') -> Observed:
    """Subscribe to /joint_states (and /diagnostics) from a Peer in this process, wait
    for the first message from ``proc``, let ``warmup`` s pass, watch ``window`` s."""
    started = time.monotonic()
    with Peer(name) as peer:
        arrivals: list[tuple[float, int]] = []
        peer.node.create_subscription(
            JointState, '/joint_states',
            lambda m: arrivals.append((time.monotonic(), stamp_ns(m))), 100)
        diag = peer.subscribe(
            '/diagnostics', DiagnosticArray,
            transform=lambda m: (time.monotonic(),
                                 {kv.key: kv.value for kv in m.status[0].values}))
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while not arrivals and time.monotonic() < deadline and proc.alive():
            time.sleep(0.01)
        if not arrivals:
            raise RuntimeError(f'{proc.command[0]} published nothing:\n' + proc.output()[1])
        first = arrivals[0][0] - started
        time.sleep(warmup)
        t0, c0, n0 = time.monotonic(), cpu_seconds(proc.pid), len(arrivals)
        time.sleep(window)
        t1, c1, n1 = time.monotonic(), cpu_seconds(proc.pid), len(arrivals)
        diags = [v for t, v in diag.snapshot() if t0 <= t <= t1 + 0.5]
    return Observed(t0, t1, (c1 - c0) / (t1 - t0), arrivals[n0:n1], diags, first)


def stop(proc: RosProcess, timeout: float = 30.0) -> tuple[int, float]:
    """SIGINT, wait for the exit (SIGKILL after ``timeout``); (exit code, seconds)."""
    t_stop = time.monotonic()
    try:
        proc.popen.send_signal(signal.SIGINT)
        code = proc.popen.wait(timeout=timeout)
    finally:
        proc.kill()
    return code, time.monotonic() - t_stop


@dataclass
class NodeFigures:
    factor: float            # achieved real-time factor (median of 1 s windows)
    overruns: int            # during the window
    cpu: float               # share of one core
    jitter: tuple[float, float, float] | None   # p50, p99, max of |gap − period|, s
    drift: float | None      # (wall − sim/factor) change over the window, s
    exit_seconds: float
    exit_code: int


def run_node(dt: float, factor: float, record: bool) -> NodeFigures:
    params = {'dt': dt, 'publish_rate': 1000.0, 'real_time_factor': factor}
    with tempfile.TemporaryDirectory(prefix='bench_node_') as tmp:
        if record:
            params['record'] = str(Path(tmp) / 'bag')
        proc = start_process('table_sim', params=params, workdir=Path(tmp) / 'proc')
        try:
            seen = observe(proc, WINDOW)
        finally:
            code, exit_seconds = stop(proc)
    factors = [float(v['real_time_factor_achieved']) for v in seen.diags]
    overruns = (int(seen.diags[-1]['overruns']) - int(seen.diags[0]['overruns'])
                if seen.diags else -1)
    paced = factor > 0.0
    return NodeFigures(float(np.median(factors)) if factors else float('nan'), overruns,
                       seen.cpu, seen.jitter(1e-3 / factor) if paced else None,
                       seen.drift(factor) if paced else None, exit_seconds, code)


def main() -> None:
    global WINDOW
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--record', action='store_true',
                        help='repeat every node scenario with recording on')
    parser.add_argument('--window', type=float, default=WINDOW,
                        help='wall seconds measured per node scenario (default %(default)s; '
                             '60 shows the drift over a minute)')
    parser.add_argument('--quick', action='store_true', help='3 s windows')
    args = parser.parse_args()
    WINDOW = 3.0 if args.quick else args.window

    print('integrator (Session.tick, outputs included; paper parameters, dt = 50 µs)')
    rows = [('compiled (numba), 20,000-step ticks (1 s each, the longest)',
             integrator_rate(2_000_000, 20_000, True)),
            ('compiled (numba), 20-step ticks (the node at 1 kHz)', integrator_rate(2_000_000, 20, True)),
            ('plain Python (NUMBA_DISABLE_JIT=1), 20-step ticks',
             integrator_rate(40_000, 20, False))]
    for name, rate in rows:
        print(f'  {name:<52s} {rate / 1e6:8.3f} M steps/s')
    print(f'  compiled / plain Python: x{rows[1][1] / rows[2][1]:.0f}')

    print(f'\ntable_sim, 1 kHz publishing, {WINDOW:g} s windows (a subscriber in this process)')
    head = (f'  {"dt":>6s} {"rec":>4s} {"asked":>6s} {"achieved":>9s} {"overruns":>9s} '
            f'{"CPU":>6s} {"jitter p50/p99/max (ms)":>24s} {"drift":>9s} {"exit":>9s}')
    print(head)
    for record in ((False, True) if args.record else (False,)):
        for dt in (50e-6, 20e-6):
            for factor in (0.0, 1.0):
                f = run_node(dt, factor, record)
                jit = ('/'.join(f'{v * 1e3:.3f}' for v in f.jitter) if f.jitter else '-')
                drift = f'{f.drift * 1e3:+.3f} ms' if f.drift is not None else '-'
                print(f'  {dt * 1e6:4.0f}us {"on" if record else "off":>4s} '
                      f'{factor if factor else "max":>6} {f.factor:9.2f} {f.overruns:9d} '
                      f'{f.cpu * 100:5.0f}% {jit:>24s} {drift:>9s} '
                      f'{f.exit_seconds:5.2f}s/{f.exit_code}', flush=True)
    print('\nGoals: factor >= 1 at dt = 20 µs using at most half a core; '
          'joint_states p99 jitter <= 1 ms at 1 kHz.')


if __name__ == '__main__':
    main()
