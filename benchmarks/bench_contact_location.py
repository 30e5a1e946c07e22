"""What locating contact changes costs the node: RK4 steps per second of Session.tick
(the node's per-tick path, outputs included) with ``contact_location`` on and off, side
by side in one process, on runs without impacts and with them. Prints one table.

    . scripts/env.sh && python -P benchmarks/bench_contact_location.py [--seconds 2]

Runs (paper parameters, dt = 50 µs, 20-step ticks as at 1 kHz, c_t = 8867 N·m·s/rad so
400 N·m holds the paper's speed):
* anti-backlash, 400 N·m forward then reversed every 0.5 s: the preload keeps both
  flanks, no contact change (the node's default gear);
* conventional, the same reversals: every reversal crosses the gap (about a dozen
  located changes each).
The two settings alternate in short rounds and each keeps its fastest round, so a busy
machine slows both alike; the ratio is the figure. The goal: at most +20 % cost
(ratio ≥ 0.83) on runs without impacts.
"""

from __future__ import annotations

import argparse
import time

from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.session import Session

DT = 50e-6
TICK = 20                  # steps per tick: 1 kHz publishing at 50 µs
REVERSAL_TICKS = 500       # 0.5 s


def _session(mode: str, locate: bool) -> Session:
    session = Session(TableParams(mode=mode, table_damping=8867.0),
                      SimSettings(dt=DT, publish_rate=1.0 / (TICK * DT),
                                  contact_location=locate, command_timeout=0.0))
    session.submit(Command('cmd_torque', 400.0))
    return session


def _round(session: Session, ticks: int) -> float:
    """Wall seconds for ``ticks`` ticks, reversing every REVERSAL_TICKS."""
    start = time.perf_counter()
    for _ in range(ticks):
        if (session.step // TICK) % REVERSAL_TICKS == 0:
            direction = -1 if (session.step // TICK // REVERSAL_TICKS) % 2 else 1
            session.submit(Command('cmd_direction', direction))
        session.tick()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=2.0,
                        help='simulated seconds per round (default %(default)s)')
    parser.add_argument('--rounds', type=int, default=15)
    args = parser.parse_args()
    ticks = round(args.seconds / (TICK * DT))
    print(f'Session.tick, {TICK}-step ticks at dt = {DT * 1e6:g} µs, best of {args.rounds} '
          f'alternating rounds of {args.seconds:g} s simulated, reversals every '
          f'{REVERSAL_TICKS * TICK * DT:g} s')
    print(f'  {"run":<40s}{"located":>12s}{"fixed step":>12s}{"ratio":>8s}{"changes":>9s}')
    for mode, label in (('anti_backlash', 'anti-backlash (no contact change)'),
                        ('conventional', 'conventional (impacts at reversals)')):
        sessions = {locate: _session(mode, locate) for locate in (True, False)}
        for session in sessions.values():
            _round(session, 10)                       # compiled code loaded, caches warm
        best = {locate: float('inf') for locate in sessions}
        for _ in range(args.rounds):
            for locate, session in sessions.items():
                best[locate] = min(best[locate], _round(session, ticks))
        rate = {locate: ticks * TICK / best[locate] / 1e6 for locate in sessions}
        print(f'  {label:<40s}{rate[True]:9.3f} M/s{rate[False]:9.3f} M/s'
              f'{rate[True] / rate[False]:8.3f}{sessions[True].plant.contact_changes:9d}')


if __name__ == '__main__':
    main()
