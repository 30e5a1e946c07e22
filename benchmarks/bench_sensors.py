"""What the joint sensors cost a tick: the in-process closed loop with every sensor ideal
(the anchor) against the same loop with every sensor feature on, and with the whole
realistic preset on, in one run.

    . scripts/env.sh && python -P benchmarks/bench_sensors.py [--pairs 9] [--ticks 4000]

Both loops are ``Simulation.run`` closed by the same PD law on the measured table angle
(dt 50 µs, 1 kHz: 20 RK4 steps a tick). "Sensors on": a 26-bit table encoder and 20-bit
pinion encoders, position and speed noise on every joint, a one-tick delay on the
table and a 500 Hz speed filter on every joint. "Realistic": config/realistic.yaml, all
of it (bearing friction with stick-slip on all three bodies, its encoders, the 1 kHz
current loops). The three are measured ``--pairs`` times, in turn; each round gives
ratios to the ideal loop (the figures to compare between runs: a shared machine moves
the absolute times). Prints µs a tick of each, the difference (what the sensors add to
a tick) and the ratios, as medians with their range.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import yaml

from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.sim.parameter_file import document_values

PRESET = Path(__file__).resolve().parents[1] / 'config' / 'realistic.yaml'

BASE = {'command_timeout': 0.0, 'publish_rate': 1000.0}
SENSORS = {
    **{f'encoder_counts_{j}': 1 << 20 for j in ('pinion_1', 'pinion_3')},
    'encoder_counts_table': 1 << 26,
    **{f'position_noise_{j}': 1e-7 for j in ('pinion_1', 'table', 'pinion_3')},
    **{f'velocity_noise_{j}': 1e-4 for j in ('pinion_1', 'table', 'pinion_3')},
    **{f'velocity_filter_cutoff_{j}': 500.0 for j in ('pinion_1', 'table', 'pinion_3')},
    'measurement_delay_table': 1, 'sensor_seed': 1,
}


def pd(o) -> float:
    wanted = 3000.0 * (0.01 - o.position[1]) - 200.0 * o.velocity[1]
    return 300.0 if wanted > 300.0 else max(wanted, -300.0)


def per_tick(sim: Simulation, ticks: int) -> float:
    """µs of wall time a tick of the closed loop."""
    started = time.perf_counter()
    sim.run(pd, ticks * sim.tick_period)
    return (time.perf_counter() - started) / ticks * 1e6


def spread(values: list[float]) -> str:
    return f'{statistics.median(values):.2f} ({min(values):.2f} … {max(values):.2f})'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--pairs', type=int, default=9)
    parser.add_argument('--ticks', type=int, default=4000)
    args = parser.parse_args()
    ideal = Simulation.from_values(BASE)
    on = Simulation.from_values({**BASE, **SENSORS})
    with open(PRESET, encoding='utf-8') as stream:
        realistic = Simulation.from_values({**document_values(yaml.safe_load(stream)), **BASE})
    for sim in (ideal, on, realistic):
        per_tick(sim, 100)               # compiled kernels and first allocations
    plain, sensed, everything = [], [], []
    for _ in range(args.pairs):
        plain.append(per_tick(ideal, args.ticks))
        sensed.append(per_tick(on, args.ticks))
        everything.append(per_tick(realistic, args.ticks))
    print(f'closed loop, {args.ticks} ticks, {args.pairs} pairs (median, range)')
    print(f'  sensors ideal        {spread(plain)} µs/tick')
    print(f'  every sensor on      {spread(sensed)} µs/tick')
    print(f'  sensors add          {spread([b - a for a, b in zip(plain, sensed, strict=True)])} µs/tick')
    print(f'  ratio on / ideal     {spread([b / a for a, b in zip(plain, sensed, strict=True)])}')
    print(f'  realistic preset     {spread(everything)} µs/tick (friction, sensors, current '
          'loop)')
    print(f'  ratio preset / ideal {spread([b / a for a, b in zip(plain, everything, strict=True)])}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
