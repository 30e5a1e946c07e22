"""Closed loops around the table: in-process against DDS, side by side, in one run.

    . scripts/env.sh && ROS_DOMAIN_ID=<free id> python -P benchmarks/bench_loop.py [--repeat 3]

Prints, measured in this run, interleaved ``--repeat`` times (median, and the range):

* **physics alone**: the ticks of the in-process loop below integrated with no
  controller, in one compiled call per chunk (``Session.advance`` in ``AdvanceMode.ROWS``): the anchor;
* **in-process**: ``Simulation.run`` closed with a Python PD law on the table angle
  (each tick's answer applied at the next tick's first step), ticks/s and its ratio to
  the physics alone;
* **DDS lockstep**: ``table_sim`` (lockstep, real-time factor 0, not recording) with a
  minimal rclpy controller in this process answering each new ``joint_states`` stamp
  with one ``cmd_effort`` (the same PD law), ticks/s;
* **ping-pong floor**: a bare rclpy round trip between two processes (one JointState
  out, one Float64MultiArray back, no physics), round trips/s: what any DDS loop written
  with rclpy costs at least. Each side spins the executor its counterpart in the
  lockstep loop spins: the ping the controller's (a SingleThreadedExecutor), the echo
  table_sim's (``NODE_EXECUTOR``), so the ratio compares the node's own cost of a tick
  and not the executors; the floor with a SingleThreadedExecutor echo is printed too;
* **hand-off floor**: the same round trip with an echo built like table_sim: its
  ``NODE_EXECUTOR``'s callback only hands the message to a second thread, which answers,
  woken by an eventfd as the node's answer gate wakes its pacing thread, at the node's
  switch interval: the thread structure without the physics. Per round, the gap of a
  lockstep tick over the single-threaded round trip is split into the executor's part
  (the ``NODE_EXECUTOR`` echo against the single-threaded one), the thread structure's
  (the hand-off echo against the ``NODE_EXECUTOR`` echo) and the node's own (lockstep
  against the hand-off echo);
* **table_sim alone**: the node flat out (real-time factor 0, no lockstep), ticks/s from
  the stamps a subscriber here receives: the node's own cost of a tick, publishing
  included (a lockstep tick costs that, plus a round trip, plus the hand-offs).

Ratios are the goal figures (in-process ≥ 0.8 of the physics alone and ≥ 30× lockstep;
lockstep against the floor). Timings on a shared machine are noisy. In each DDS round
the lockstep loop and the three echoes run side by side, each idle while not measured
(table_sim waits for its answer, an echo for its ping), and are measured in turns of
``SLICE`` s until each has run ``--window`` s: a load that comes and goes falls on all
four alike, so the ratios of one round compare loops under the same load. The in-process pair
(physics alone, then in-process) is measured ``--pairs`` times, alternating, and each
pair gives a ratio; both are also timed in this thread's CPU time, which does not count
the time other processes take the core from it (the ratio a quiet machine would show,
less its cache effects), and their difference is what the Python around the physics (the
controller, the tick's bookkeeping, the samples kept) costs a tick. Compare the ratios of
one run, run twice.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test' / 'support'))
from ros_procs import STARTUP_TIMEOUT, start_process

VALUES = {'table_damping': 8867.0, 'command_timeout': 0.0, 'publish_rate': 1000.0}
IN_PROCESS_TICKS = 4000
PAIRS = 15
WINDOW = 5.0        # s of wall time per DDS measurement
SLICE = 0.25        # s of wall time of one turn of a loop among those measured together


def pd(o) -> float:
    """The benchmark's controller: PD on the table angle towards 10 mrad."""
    wanted = 3000.0 * (0.01 - o.position[1]) - 200.0 * o.velocity[1]
    return 300.0 if wanted > 300.0 else max(wanted, -300.0)


def physics_alone(ticks: int) -> tuple[float, float]:
    """Ticks/s of the same ticks with no controller: one compiled call per chunk; by the
    wall clock and by this thread's CPU time."""
    from screwgear_ros import Simulation
    from screwgear_ros.sim.session import ROW, AdvanceMode
    sim = Simulation.from_values(VALUES)
    sim.reset()
    sim.step(150.0)                      # a moving table, as in the closed loop
    rows = np.empty((ticks, ROW))
    started, cpu = time.perf_counter(), time.thread_time()
    done = sim.session.advance(ticks, mode=AdvanceMode.ROWS, rows=rows)
    return done / (time.perf_counter() - started), done / (time.thread_time() - cpu)


def in_process(ticks: int) -> tuple[float, float]:
    """Ticks/s of Simulation.run closed by the PD law; wall clock and thread CPU time."""
    from screwgear_ros import Simulation
    sim = Simulation.from_values(VALUES)
    period = sim.tick_period
    started, cpu = time.perf_counter(), time.thread_time()
    run = sim.run(pd, ticks * period)
    return ((len(run) - 1) / (time.perf_counter() - started),
            (len(run) - 1) / (time.thread_time() - cpu))


@contextlib.contextmanager
def _lockstep_loop(node) -> Iterator[Callable[[], int]]:
    """table_sim in lockstep answered by a minimal rclpy controller on ``node``; yields
    the count of ticks answered, once 200 are."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from screwgear_ros.inprocess.simulation import Observation
    sim = start_process('table_sim', params={**VALUES, 'lockstep': True,
                                             'real_time_factor': 0.0})
    try:
        publisher = node.create_publisher(Float64MultiArray, '/cmd_effort', 10)
        seen = {'last': -1, 'count': 0, 'matched': False}
        nan = float('nan')

        def answer(msg: JointState) -> None:
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            if stamp <= seen['last']:
                return
            if not seen['matched']:       # an answer before the node listens is lost
                if publisher.get_subscription_count() == 0:
                    return
                seen['matched'] = True    # (asked once: the ping asks nothing a message)
            seen['last'] = stamp
            seen['count'] += 1
            o = Observation(stamp * 1e-9, 0, msg.position, msg.velocity, msg.effort, nan,
                            (nan, nan), (nan, nan), (nan, nan), 1, None)
            publisher.publish(Float64MultiArray(data=[pd(o)]))

        node.create_subscription(JointState, '/joint_states', answer, 10)
        yield lambda: seen['count']
    finally:
        sim.stop()
        sim.kill()


def flat_out(window: float) -> float:
    """Ticks/s of table_sim alone (no lockstep, real-time factor 0), from the stamps of
    the joint_states this process receives: what the node's own tick costs."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    sim = start_process('table_sim', params={**VALUES, 'real_time_factor': 0.0})
    rclpy.init()
    node = rclpy.create_node('bench_loop_watch')
    try:
        stamps: list[tuple[float, int]] = []
        node.create_subscription(
            JointState, '/joint_states',
            lambda m: stamps.append((time.perf_counter(),
                                     m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec)),
            100)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while len(stamps) < 200 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        n0 = len(stamps)
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < window:
            executor.spin_once(timeout_sec=0.1)
        (w0, s0), (w1, s1) = stamps[n0], stamps[-1]
        executor.shutdown()
        return (s1 - s0) * 1e-6 / (w1 - w0)       # 1 kHz: one tick per ms of simulation
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        sim.stop()
        sim.kill()


_ECHO = textwrap.dedent('''
    import os
    import select
    import sys
    import threading
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    from screwgear_ros.cli.table_sim import SWITCH_INTERVAL
    from screwgear_ros.ros.node import NODE_EXECUTOR
    rclpy.init()
    node = rclpy.create_node('bench_loop_echo')
    pub = node.create_publisher(Float64MultiArray, f'/bench_loop/{sys.argv[1]}/answer', 10)
    if sys.argv[1] == 'handoff':
        # table_sim's structure: the callback only hands the message over; a second
        # thread, woken by it, answers (as the pacing thread ticks and publishes)
        # (woken as the node's gate wakes it: an eventfd, rung and polled without the
        # interpreter lock)
        sys.setswitchinterval(SWITCH_INTERVAL)
        bell = os.eventfd(0, os.EFD_NONBLOCK)
        poll = select.poll()
        poll.register(bell, select.POLLIN)
        last = []

        def answer():
            try:
                while rclpy.ok():
                    if poll.poll(100):
                        os.eventfd_read(bell)
                        pub.publish(Float64MultiArray(data=[last[-1].position[1]]))
            except BaseException:       # a publish racing the shutdown
                pass

        def hand_over(m):
            last[:] = [m]
            os.eventfd_write(bell, 1)

        node.create_subscription(JointState, f'/bench_loop/{sys.argv[1]}/state', hand_over,
                                 10)
        threading.Thread(target=answer, daemon=True).start()
    else:
        node.create_subscription(
            JointState, f'/bench_loop/{sys.argv[1]}/state',
            lambda m: pub.publish(Float64MultiArray(data=[m.position[1]])), 10)
    executor = SingleThreadedExecutor() if sys.argv[1] == 'single' else NODE_EXECUTOR()
    executor.add_node(node)
    try:
        while rclpy.ok():       # spin() of the events executor does not see SIGTERM
            executor.spin_once(timeout_sec=0.1)
    except BaseException:
        pass
''')


@contextlib.contextmanager
def _ping_loop(node, echo_executor: str) -> Iterator[Callable[[], int]]:
    """A bare rclpy ping on ``node`` against an echo process spinning ``NODE_EXECUTOR``
    ('node') or a SingleThreadedExecutor ('single'), or spinning ``NODE_EXECUTOR`` and
    answering from a second thread its callback wakes ('handoff'), on topics of its
    own; yields the count of round trips."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    echo = subprocess.Popen([sys.executable, '-P', '-c', _ECHO, echo_executor])
    try:
        pub = node.create_publisher(JointState, f'/bench_loop/{echo_executor}/state', 10)
        count = {'n': 0}
        names = ['pinion_1', 'table', 'pinion_3']

        def send() -> None:
            msg = JointState(name=names, position=[0.0, float(count['n']), 0.0],
                             velocity=[0.0] * 3, effort=[0.0] * 3)
            pub.publish(msg)

        def on_answer(msg: Float64MultiArray) -> None:
            count['n'] += 1
            send()

        node.create_subscription(Float64MultiArray, f'/bench_loop/{echo_executor}/answer',
                                 on_answer, 10)
        node.create_timer(0.1, lambda: send() if count['n'] == 0 else None)  # until it answers
        yield lambda: count['n']
    finally:
        echo.terminate()
        echo.wait(10)


def rates(window: float, loops: Sequence[str]) -> list[float]:
    """Events/s of each loop ('lockstep', or an echo of :func:`_ping_loop`), all started
    together and measured in turns of ``SLICE`` s until each ran ``window`` s, so that
    what the machine's load does to one it does to the others alike. A loop not spun
    waits: table_sim for its answer, an echo for its ping."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    rclpy.init()
    try:
        with contextlib.ExitStack() as stack:
            spun = []
            for k, kind in enumerate(loops):
                node = rclpy.create_node(f'bench_loop_{k}')
                stack.callback(node.destroy_node)
                count = stack.enter_context(_lockstep_loop(node) if kind == 'lockstep'
                                            else _ping_loop(node, kind))
                executor = SingleThreadedExecutor()
                executor.add_node(node)
                stack.callback(executor.shutdown)
                spun.append((kind, executor, count))
            for kind, executor, count in spun:
                deadline = time.monotonic() + STARTUP_TIMEOUT
                while count() < 200 and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.1)
                if count() < 200:
                    raise RuntimeError(f'{kind}: no loop ran')
            done = [0] * len(spun)
            took = [0.0] * len(spun)
            while min(took) < window:
                for i, (_, executor, count) in enumerate(spun):
                    for _ in range(20):         # the turn's first round trips re-start it
                        executor.spin_once(timeout_sec=0.1)
                    n0, t0 = count(), time.perf_counter()
                    while time.perf_counter() - t0 < SLICE:
                        executor.spin_once(timeout_sec=0.1)
                    done[i] += count() - n0
                    took[i] += time.perf_counter() - t0
            return [n / t for n, t in zip(done, took, strict=True)]
    finally:
        rclpy.try_shutdown()


def spread(values: list[float], digits: int = 0) -> str:
    return (f'{statistics.median(values):10.{digits}f}  ({min(values):.{digits}f} … '
            f'{max(values):.{digits}f})')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--repeat', type=int, default=3, help='DDS measurements')
    parser.add_argument('--pairs', type=int, default=PAIRS,
                        help='in-process pairs (physics alone, in-process)')
    parser.add_argument('--window', type=float, default=WINDOW,
                        help='s of wall time per DDS measurement')
    parser.add_argument('--no-dds', action='store_true', help='in-process figures only')
    args = parser.parse_args()
    if not os.environ.get('ROS_DOMAIN_ID') and not args.no_dds:
        print('warning: ROS_DOMAIN_ID is not set: other DDS traffic on domain 0 may mix in',
              file=sys.stderr)
    start_load = os.getloadavg()[0]
    physics_alone(200)                  # load the compiled kernels
    in_process(200)
    seen: dict[str, list[float]] = {'physics': [], 'in_process': [], 'ratio': [],
                                    'physics_cpu': [], 'in_process_cpu': [], 'ratio_cpu': [],
                                    'python_cpu': [],
                                    'lockstep': [], 'ping_pong': [], 'ping_pong_single': [],
                                    'ping_pong_handoff': [], 'flat_out': []}
    for k in range(max(args.pairs, args.repeat)):
        if k < args.pairs:
            (a, a_cpu), (b, b_cpu) = physics_alone(IN_PROCESS_TICKS), in_process(IN_PROCESS_TICKS)
            seen['physics'].append(a)
            seen['in_process'].append(b)
            seen['ratio'].append(b / a)
            seen['physics_cpu'].append(a_cpu)
            seen['in_process_cpu'].append(b_cpu)
            seen['ratio_cpu'].append(b_cpu / a_cpu)
            seen['python_cpu'].append(1e6 * (1.0 / b_cpu - 1.0 / a_cpu))
        if k < args.repeat and not args.no_dds:
            measured = rates(args.window, ('lockstep', 'single', 'node', 'handoff'))
            for key, rate in zip(('lockstep', 'ping_pong_single', 'ping_pong',
                                  'ping_pong_handoff'), measured, strict=True):
                seen[key].append(rate)
            seen['flat_out'].append(flat_out(args.window))
    load = os.getloadavg()[0]
    print(f'closed loops, {args.pairs} in-process pairs, {args.repeat} DDS rounds, '
          f'interleaved, load average {start_load:.1f} at the start, {load:.1f} at the end, '
          f'{os.cpu_count()} cores; median (min … max)')
    print(f'physics alone (1 compiled call / chunk)   ticks/s {spread(seen["physics"])}')
    print(f'in-process Simulation.run, Python PD      ticks/s {spread(seen["in_process"])}')
    print(f'  ratio to the physics alone (same pair)          {spread(seen["ratio"], 2)}')
    print(f'physics alone, thread CPU time            ticks/s {spread(seen["physics_cpu"])}')
    print(f'in-process, thread CPU time               ticks/s '
          f'{spread(seen["in_process_cpu"])}')
    print(f'  ratio to the physics alone, CPU time            {spread(seen["ratio_cpu"], 2)}')
    print(f'  Python around the physics, CPU µs a tick        {spread(seen["python_cpu"], 1)}')
    if not args.no_dds:
        lock, floor = statistics.median(seen['lockstep']), statistics.median(seen['ping_pong'])
        inproc = statistics.median(seen['in_process'])
        print(f'DDS lockstep, table_sim + rclpy PD        ticks/s {spread(seen["lockstep"])}')
        print(f'rclpy ping-pong floor (2 processes)   round trips/s {spread(seen["ping_pong"])}')
        print(f'  the same, echo on a SingleThreadedExecutor      '
              f'{spread(seen["ping_pong_single"])}')
        print(f'  the same, echo answering from a second thread   '
              f'{spread(seen["ping_pong_handoff"])}')
        print(f'table_sim alone flat out (no lockstep)    ticks/s {spread(seen["flat_out"])}')
        print(f'  in-process / lockstep                           {inproc / lock:10.1f}')
        print(f'  lockstep / ping-pong floor                      {lock / floor:10.2f}')
        # the goal's anchor: SingleThreadedExecutor on both sides, each round its own pair
        rounds = [a / b for a, b in zip(seen['lockstep'], seen['ping_pong_single'], strict=True)]
        print('  lockstep / ping-pong (single-threaded both sides), per round: '
              + ', '.join(f'{r:.2f}' for r in rounds) + '  (goal >= 0.8 in every round)')
        # the gap of a lockstep tick over the single-threaded round trip, in µs, split
        # into the executor's part, the thread structure's and the node's own
        for k, (lock_k, single, node_echo, handoff) in enumerate(zip(
                seen['lockstep'], seen['ping_pong_single'], seen['ping_pong'],
                seen['ping_pong_handoff'], strict=True)):
            t = [1e6 / v for v in (lock_k, single, node_echo, handoff)]
            print(f'  round {k + 1}: lockstep {t[0]:.0f} µs a tick, single-threaded round trip '
                  f'{t[1]:.0f} µs: gap {t[0] - t[1]:+.0f} µs = executor {t[2] - t[1]:+.0f} '
                  f'+ thread structure {t[3] - t[2]:+.0f} + the node\'s own {t[0] - t[3]:+.0f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
