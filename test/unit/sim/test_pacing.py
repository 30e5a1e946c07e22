"""Pacing against a fake clock: absolute deadlines, overruns, resyncs, measured factor;
exact nanosecond simulation time; the warning rate limiter."""

from __future__ import annotations

import math
import random
import threading
import time

import pytest

from screwgear_ros.sim.pacing import AnswerGate, Doorbell, FactorMeter, Pacer, wall_period
from screwgear_ros.sim.ratelimit import RateLimiter
from screwgear_ros.sim.simtime import sim_time_ns


class FakeTime:
    """A monotonic clock that only moves when slept on or told to; sleeps overshoot."""

    def __init__(self, oversleep: float = 0.0, seed: int = 1) -> None:
        self.now = 1000.0
        self.oversleep = oversleep
        self.sleeps: list[float] = []
        self._rng = random.Random(seed)

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds >= 0.0
        self.sleeps.append(seconds)
        self.now += seconds + self._rng.uniform(0.0, self.oversleep)


def test_deadlines_are_absolute_so_sleep_errors_do_not_accumulate() -> None:
    # 60 s at 1 kHz, every sleep overshooting by up to 0.4 ms (a loaded machine):
    # relative sleeps would drift by ~12 s; absolute deadlines keep every wake-up
    # within one oversleep of t0 + k·period, so wall and simulation time agree
    # within one publish period after 60 s.
    period, fake = 1e-3, FakeTime(oversleep=0.4e-3)
    pacer = Pacer(period, 1.0, clock=fake.clock, sleep=fake.sleep)
    t0 = fake.now
    worst = 0.0
    for k in range(1, 60_001):
        fake.now += 0.2e-3                       # the tick's work
        assert pacer.wait()
        worst = max(worst, abs(fake.now - (t0 + k * period)))
    assert worst <= 0.4e-3 + 1e-9
    assert pacer.stats.overruns == 0 and pacer.stats.resyncs == 0
    assert abs((fake.now - t0) - 60.0) < period


def test_real_time_factor_scales_the_wall_period() -> None:
    fake = FakeTime()
    pacer = Pacer(1e-3, 4.0, clock=fake.clock, sleep=fake.sleep)
    t0 = fake.now
    for _ in range(1000):
        pacer.wait()
    assert fake.now - t0 == pytest.approx(0.25, abs=1e-12)   # 1 s simulated in 0.25 s


def test_overrun_is_counted_and_caught_up_without_moving_the_schedule() -> None:
    fake = FakeTime()
    pacer = Pacer(1e-3, 1.0, clock=fake.clock, sleep=fake.sleep)
    t0 = fake.now
    pacer.wait()                                  # tick 1 on time
    fake.now += 3.5e-3                            # tick 2's work takes 3.5 periods
    pacer.wait()
    assert pacer.stats.overruns == 1
    assert pacer.stats.max_lag == pytest.approx(2.5e-3)       # due at t0 + 2 ms, done at 4.5
    n_sleeps = len(fake.sleeps)
    pacer.wait()                                  # ticks 3 and 4 are already late: no sleep
    pacer.wait()
    assert len(fake.sleeps) == n_sleeps and pacer.stats.overruns == 3
    pacer.wait()                                  # tick 5 is due at t0 + 5 ms: sleeps to it
    assert fake.now == pytest.approx(t0 + 5e-3, abs=1e-12)
    assert pacer.stats.resyncs == 0


def test_falling_behind_beyond_max_lag_resyncs_and_reports_the_time_given_up() -> None:
    fake = FakeTime()
    pacer = Pacer(1e-3, 1.0, max_lag=0.1, clock=fake.clock, sleep=fake.sleep)
    pacer.wait()
    fake.now += 0.5                               # a 0.5 s stall
    pacer.wait()
    assert pacer.stats.resyncs == 1
    assert pacer.stats.lost_time == pytest.approx(0.5 - 1e-3)
    resumed = fake.now
    pacer.wait()                                  # new schedule anchored at the stall's end
    assert fake.now == pytest.approx(resumed + 1e-3, abs=1e-12)


def test_factor_zero_never_sleeps() -> None:
    def no_sleep(_: float) -> None:
        raise AssertionError('slept at real_time_factor 0')
    fake = FakeTime()
    pacer = Pacer(1e-3, 0.0, clock=fake.clock, sleep=no_sleep)
    for _ in range(100):
        assert pacer.wait()
    assert pacer.stats.ticks == 100 and pacer.stats.overruns == 0


def test_restart_reanchors_with_the_new_period() -> None:
    fake = FakeTime()
    pacer = Pacer(1e-3, 1.0, clock=fake.clock, sleep=fake.sleep)
    pacer.wait()
    fake.now += 0.2e-3
    pacer.restart(2e-3, 0.5)                      # 2 ms ticks at half speed: 4 ms wall
    t = fake.now
    pacer.wait()
    assert fake.now == pytest.approx(t + 4e-3, abs=1e-12)


def test_a_set_stop_event_ends_the_wait() -> None:
    stop = threading.Event()
    stop.set()
    pacer = Pacer(10.0, 1.0)                      # a 10 s tick: only the event can end it
    assert pacer.wait(stop) is False


def test_invalid_settings_are_refused() -> None:
    with pytest.raises(ValueError):
        Pacer(0.0, 1.0)
    with pytest.raises(ValueError):
        Pacer(1e-3, -1.0)
    with pytest.raises(ValueError):
        Pacer(1e-3, float('nan'))


def test_factor_meter_measures_simulated_over_wall_time() -> None:
    fake = FakeTime()
    meter = FactorMeter(clock=fake.clock)
    fake.now += 2.0
    assert meter.update(1.0) == pytest.approx(0.5)
    fake.now += 0.5
    assert meter.update(3.0) == pytest.approx(4.0)     # 2 s simulated in 0.5 s


def test_sim_time_ns_is_exact_integer_arithmetic() -> None:
    # 1e12 steps of 50 µs = 5e16 ns, beyond float's exact integers (2^53 ≈ 9.0e15):
    # consecutive steps still differ by exactly 50 000 ns.
    big = 10 ** 12
    assert sim_time_ns(big, 50e-6) == 50_000 * big
    assert sim_time_ns(big + 1, 50e-6) - sim_time_ns(big, 50e-6) == 50_000
    assert sim_time_ns(7, 20e-6) == 140_000
    # a step that is no whole number of ns is rounded to the nearest ns
    assert sim_time_ns(3, 1e-9 / 3.0) == 1
    assert sim_time_ns(1, 1e-9 / 3.0) == 0


def test_rate_limiter_lets_one_warning_per_key_and_interval_through() -> None:
    fake = FakeTime()
    limiter = RateLimiter(1.0, clock=fake.clock)
    assert limiter.allow('cmd_torque') == (True, 0)
    assert limiter.allow('cmd_torque') == (False, 0)
    assert limiter.allow('cmd_torque') == (False, 0)
    assert limiter.allow('cmd_direction') == (True, 0)   # keys have their own budget
    fake.now += 1.0
    assert limiter.allow('cmd_torque') == (True, 2)      # and report what was held back
    assert limiter.allow('cmd_direction') == (True, 0)
    for _ in range(41):
        limiter.allow('cmd_direction')
    assert limiter.drain('cmd_direction') == 41          # a summary takes the count ...
    assert limiter.drain('cmd_direction') == 0
    fake.now += 1.0
    assert limiter.allow('cmd_direction') == (True, 0)   # ... and it is not reported twice


def test_answer_gate_counts_only_an_answer_to_outputs_that_were_published() -> None:
    gate = AnswerGate()
    assert not gate.answer()                 # before any outputs: not an answer
    gate.expect()                            # outputs of tick k about to go out
    assert gate.answer()                     # the controller's answer to tick k
    assert not gate.answer()                 # a duplicate answer to tick k
    assert gate.wait(0.0)                    # releases tick k + 1 at once
    assert not gate.answer()                 # tick k + 1 running: nothing is expected
    gate.expect()
    assert not gate.wait(0.01)               # no answer yet: times out
    assert gate.ignored == 3


def test_answer_gate_wakes_a_waiting_thread_on_answer_and_on_release() -> None:
    gate = AnswerGate()
    gate.expect()
    results: list[bool] = []
    waiter = threading.Thread(target=lambda: results.append(gate.wait(30.0)))
    waiter.start()
    gate.answer()
    waiter.join(10.0)
    assert results == [True]
    gate.expect()
    waiter = threading.Thread(target=lambda: results.append(gate.wait(30.0)))
    waiter.start()
    gate.release()                           # shutdown: no answer will come
    waiter.join(10.0)
    assert results == [True, False] and not waiter.is_alive()


def test_doorbell_rings_coalesce_and_wake_a_thread_waiting_in_another() -> None:
    bell = Doorbell()
    assert not bell.wait(0.0)                # nothing rung: no wake-up
    bell.ring()
    bell.ring()
    assert bell.wait(0.0)                    # both rings: one wake-up ...
    assert not bell.wait(0.0)                # ... and none left over
    results: list[bool] = []
    waiter = threading.Thread(target=lambda: results.append(bell.wait(30.0)))
    waiter.start()
    bell.ring()
    waiter.join(10.0)
    assert results == [True] and not waiter.is_alive()


def test_answer_gate_ignores_a_ring_it_already_took_while_waiting() -> None:
    # the answer to tick k rings; the waiter takes the answer before it polls, so the
    # ring is still pending when tick k + 1 waits: that wait must not return True
    gate = AnswerGate()
    gate.expect()
    assert gate.answer()
    assert gate.wait(0.0)
    gate.expect()
    assert not gate.wait(0.05)
    assert gate.answer()
    assert gate.wait(0.0)


def test_a_change_wakes_the_pacer_however_far_its_deadline_is() -> None:
    # a tick of 1 s at real-time factor 0.01 lasts 100 s of wall time: a change set
    # meanwhile must not wait for that deadline; a stop neither
    for event_name in ('wake', 'stop'):
        pacer = Pacer(1.0, 0.01)
        stop, wake = threading.Event(), threading.Event()
        result: list[bool] = []
        waiter = threading.Thread(target=lambda result=result, pacer=pacer, stop=stop, wake=wake:
                                  result.append(pacer.wait(stop, wake)))
        waiter.start()
        time.sleep(0.05)
        assert waiter.is_alive()                      # asleep until its deadline
        (wake if event_name == 'wake' else stop).set()
        waiter.join(timeout=20.0)
        assert not waiter.is_alive(), f'{event_name} did not end the sleep'
        assert result == [event_name == 'wake']
        assert not wake.is_set()                      # taken: the next wait sleeps again


def test_the_wall_period_of_any_accepted_pace_is_finite_and_else_refused() -> None:
    assert wall_period(1e-3, 0.0) == 0.0
    assert wall_period(1.0, 0.01) == pytest.approx(100.0)
    for period, factor in ((1e300, 1e-300), (1.0, math.nan), (1.0, -1.0), (0.0, 1.0)):
        with pytest.raises(ValueError):
            wall_period(period, factor)
        with pytest.raises(ValueError):
            Pacer(period, factor)
