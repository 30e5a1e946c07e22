"""The table angle's own error against one count of a 26-bit table encoder: what the
default step gives a closed-loop demo run, and what excites the error. Prints tables.

    . scripts/env.sh && python -P benchmarks/bench_accuracy.py [--seconds 60] [--quick]

* **demo**: the demo controller (default gains) closing the loop in-process on the
  default table at the default step for ``--seconds``; the table angle against DOP853
  (rtol 1e-12) re-integrating the inputs the session applied, and RK4's own share (the
  same efforts stepped at dt/4: Richardson, 256/255 of the difference);
* **drive**: constant torque from rest for 2 s (1 s with ``--quick``), the table running
  up to the drive line's speed, RK4 at several steps against dt/16 of the smallest: the
  table angle error, its growth over the second half, and what a minute at that growth
  costs in counts;
* **controls**: the same at 300 N·m with one cause taken away at a time (mesh damping
  ×4, an ideal torque source with a bearing loss giving the same speed, no STE, a
  command above the stall torque so the drive stays on its line, off its corner).

docs/model_notes.md §13 explains the figures. Every figure is measured in this run.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.numerics.reference import Segment, solve
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.runs.check import TABLE_ENCODER_BITS, TABLE_ENCODER_COUNT
from screwgear_ros.sim.control import DemoController

COUNT = TABLE_ENCODER_COUNT


def demo(seconds: float) -> None:
    sim = Simulation()
    dt = sim.settings.dt
    controller = DemoController(dt=dt)
    observation = sim.reset()
    session = sim.session
    n = sim.settings.steps_per_publish
    ticks = round(seconds / sim.tick_period)
    efforts, table, segments, reversals, fastest = [], [observation.position[1]], [], 0, 0.0
    start = time.perf_counter()
    for i in range(ticks):
        effort = controller(observation)
        observation = sim.step(effort)
        efforts.append(effort)
        table.append(observation.position[1])
        fastest = max(fastest, abs(observation.velocity[0]))
        drive = session.plant.input
        reversals += bool(segments) and segments[-1].drive.direction != drive.direction
        if not segments or segments[-1].drive != drive:
            segments.append(Segment(i * n, drive, sim.params))
    loop = time.perf_counter() - start
    reference = solve(equilibrium_state(sim.params), segments, dt, np.arange(ticks + 1) * n,
                      rtol=1e-12, atol=1e-14)[:, 1]
    fine = sim.with_values(dt=dt / 4)
    fine_table = [fine.reset().position[1]]
    fine_table += [fine.step(effort).position[1] for effort in efforts]
    error = np.abs(np.array(table) - reference)
    rk4 = np.abs(np.array(table) - np.array(fine_table)) * 256 / 255
    print(f'demo: {seconds:g} s closed loop at dt = {dt * 1e6:g} µs ({loop:.1f} s wall), '
          f'{reversals} reversals, max |ω1| {fastest:.1f} rad/s')
    print(f'  table angle vs DOP853: max {error.max():.2e} rad = {error.max() / COUNT:.2g} '
          f'counts of a {TABLE_ENCODER_BITS}-bit encoder ({COUNT:.2e} rad)')
    print(f'  RK4 alone (dt vs dt/4): max {rk4.max():.2e} rad, at the end {rk4[-1]:.2e} rad')


def drive_run(values: dict, torque: float, dt: float, seconds: float) -> np.ndarray:
    """Table angle and pinion 1 speed after every tick of a constant-torque run from rest."""
    sim = Simulation.from_values(values, dt=dt, command_timeout=0.0)
    sim.reset()
    sim.step(effort=torque)
    ticks = round(seconds / sim.tick_period)
    rows = [(o.position[1], o.velocity[0], o.velocity[1])
            for o in (sim.step() for _ in range(ticks - 1))]
    return np.array(rows)


def growth(values: dict, torque: float, dt: float, exact: np.ndarray,
           seconds: float) -> tuple[float, float]:
    """(table angle error at the end, its growth over the second half, rad/s)."""
    error = np.abs(drive_run(values, torque, dt, seconds)[:, 0] - exact[:, 0])
    half = len(error) // 2
    return error[-1], (error[-1] - error[half]) / (seconds - half * seconds / len(error))


def drive(seconds: float) -> None:
    steps = (50e-6, 25e-6, 20e-6, 12.5e-6)
    print(f'\ndrive: constant torque from rest for {seconds:g} s, RK4 against dt = '
          f'{steps[-1] / 16 * 1e6:g} µs')
    print(f'  {"torque":>8} {"dt":>8} {"table":>10} {"ω1 range":>14} {"error":>10} '
          f'{"growth":>12} {"counts/min":>11}')
    for torque in (300.0, 150.0):
        exact = drive_run({}, torque, steps[-1] / 16, seconds)
        for dt in steps:
            end, rate = growth({}, torque, dt, exact, seconds)
            half = exact[len(exact) // 2:]
            print(f'  {torque:>6g}Nm {dt * 1e6:>6g}µs {exact[-1, 2]:>7.2f}r/s '
                  f'{half[:, 1].min():>6.1f}–{half[:, 1].max():<5.1f}r/s {end:>10.2e} '
                  f'{rate:>9.2e}r/s {max(rate, 0.0) * 60 / COUNT:>11.3g}')


def controls(seconds: float) -> None:
    dt = 50e-6
    base = Simulation().params
    cases = [('defaults', {}, 300.0),
             ('mesh damping ×4', {'mesh_damping': 4 * base.mesh_damping}, 300.0),
             ('ideal source, c_t = 700', {'drive_no_load_speed': 0.0, 'table_damping': 700.0},
              300.0),
             ('no STE', {'ste_amplitudes': [0.0]}, 300.0),
             ('always on the line', {'max_torque': 2000.0}, 1700.0)]
    print(f'\ncontrols: 300 N·m for {seconds:g} s, dt = {dt * 1e6:g} µs against dt/16 (always '
          'on the line: 1700 N·m, above the stall torque, so the drive never meets its corner)')
    for name, values, torque in cases:
        exact = drive_run(values, torque, dt / 16, seconds)
        end, rate = growth(values, torque, dt, exact, seconds)
        print(f'  {name:<26} table {exact[-1, 2]:.2f} rad/s: error {end:.2e} rad, '
              f'growth {rate:.2e} rad/s')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=60.0, help='demo run, s (60)')
    parser.add_argument('--quick', action='store_true', help='1 s drive runs instead of 2 s')
    args = parser.parse_args()
    if not (math.isfinite(args.seconds) and args.seconds > 0.0):
        parser.error('--seconds must be a number > 0')
    drive_seconds = 1.0 if args.quick else 2.0
    demo(args.seconds)
    drive(drive_seconds)
    controls(drive_seconds)


if __name__ == '__main__':
    main()
