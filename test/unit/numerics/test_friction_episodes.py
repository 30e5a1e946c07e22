"""Sticking episodes that start and end inside one integration step (docs/model_notes.md
§14): a slipping body whose speed reaches zero sticks there, and may break away again
before the step ends, its speed back on its old side. The pieces at the step's end are
then those of its start, so only the speed's path inside the step shows the episode.

Judged against an event-by-event solution written here from the law alone: pinion 1
free in a wide backlash gap under Coulomb friction and a drive torque T + T_v·sin(ω_v·t)
(T constant over each tick), whose speed and angle on each piece are closed forms and
whose events are roots of them, bracketed between the closed-form extrema.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from screwgear_ros.numerics.integrator import OBSERVED
from screwgear_ros.numerics.reference import Segment, solve
from screwgear_ros.numerics.rk import hermite
from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.friction import FrictionPiece, speed_dip
from screwgear_ros.sim.plant import DriveInput, Plant

DT = 50e-6                      # s
TICK = 20                       # steps a tick: the command changes only between ticks
TICKS = 400
COULOMB, STATIC = 0.5, 0.6      # N·m on pinion 1's bearing
RIPPLE, RIPPLE_HZ = 1.0, 500.0  # N·m, Hz: the drive's fluctuation T_v·sin(ω_v·t)
F1 = 6 + 5                      # mesh 1's force in the observed vector


def _commands() -> np.ndarray:
    """The command of each tick (N·m, direction +1: the ripple keeps its sign): a slow
    sweep below τ_C, so the pinion sticks and slips each ripple period at shifting
    phases, and creeps forward on the whole."""
    k = np.arange(TICKS)
    return 0.25 + 0.15 * np.sin(2.0 * math.pi * k / 53.0) + 0.05 * np.cos(2.0 * math.pi * k / 17.0)


def _params(static: float = STATIC, ripple: float = RIPPLE,
            ripple_hz: float = RIPPLE_HZ) -> TableParams:
    # pinion 1 in the middle of a 1 cm gap (it never reaches a flank); the ideal torque
    # source (no drive line); Coulomb friction (no Stribeck curve): closed forms
    return TableParams(mode='conventional', backlash=1e-2, ste_amplitudes=(), ste_phases=(),
                       pinion_coulomb_torque=COULOMB, pinion_static_torque=static,
                       pinion_stribeck_speed=0.0, drive_no_load_speed=0.0,
                       torque_fluctuation_amplitude=ripple,
                       torque_fluctuation_frequency=2.0 * math.pi * ripple_hz)


class _Exact:
    """Pinion 1's motion from the law, event by event, with closed forms on each piece."""

    def __init__(self, params: TableParams) -> None:
        self.inertia = params.inertia_pinion_1
        self.wv = params.torque_fluctuation_frequency
        self.ripple = params.torque_fluctuation_amplitude
        self.static = params.pinion_static_torque
        self.episodes: list[tuple[float, float]] = []      # (stick, breakaway) times

    def torque(self, t: float, command: float) -> float:
        return command + self.ripple * math.sin(self.wv * t)

    def _solutions(self, x: float, a: float, b: float) -> list[float]:
        """Every t in (a, b) with sin(ω_v·t) = x."""
        if abs(x) > 1.0:
            return []
        out = []
        for base in (math.asin(x), math.pi - math.asin(x)):
            n = math.floor((self.wv * a - base) / (2.0 * math.pi))
            while True:
                t = (base + 2.0 * math.pi * n) / self.wv
                if t >= b:
                    break
                if t > a:
                    out.append(t)
                n += 1
        return sorted(out)

    def _first(self, f, a: float, b: float, breaks: list[float]) -> float | None:
        """The first t in (a, b] where f turns > 0 (f monotone between ``breaks``)."""
        points = [a] + [x for x in breaks if a < x < b] + [b]
        for lo, hi in itertools.pairwise(points):
            if f(hi) > 0.0:
                return brentq(f, lo, hi, xtol=1e-16, rtol=1e-15) if f(lo) < 0.0 else lo
        return None

    def slip(self, t0: float, th0: float, w0: float, sense: float, command: float, t: float):
        """(θ, ω) at t on the slip piece of ``sense`` from (t0, θ0, ω0)."""
        i, wv, c = self.inertia, self.wv, command - sense * COULOMB
        dt = t - t0
        w = w0 + (c * dt - self.ripple / wv * (math.cos(wv * t) - math.cos(wv * t0))) / i
        th = th0 + w0 * dt + (0.5 * c * dt * dt - self.ripple / wv * (
            (math.sin(wv * t) - math.sin(wv * t0)) / wv - math.cos(wv * t0) * dt)) / i
        return th, w

    def advance(self, end: float, command: float) -> None:
        """Follow the law from (t, θ, ω, piece) to ``end`` under ``command``."""
        while True:
            t = self.t
            if self.piece == 0.0:        # stuck: until |τ| passes τ_S
                turns = self._solutions(1.0, t, end) + self._solutions(-1.0, t, end)
                up = self._first(lambda s: self.torque(s, command) - self.static, t, end, turns)
                down = self._first(lambda s: -self.torque(s, command) - self.static, t, end,
                                   turns)
                hits = [x for x in (up, down) if x is not None]
                if not hits:
                    self.t = end
                    return
                self.t = min(hits)
                self.piece = 1.0 if self.t == up else -1.0
                self.episodes.append((self.stuck_at, self.t))
                continue
            sense, th0, w0 = self.piece, self.th, self.w
            extrema = self._solutions((sense * COULOMB - command) / self.ripple, t, end)
            cross = self._first(lambda s, t=t, th0=th0, w0=w0, sense=sense:
                                -sense * self.slip(t, th0, w0, sense, command, s)[1],
                                t, end, extrema)
            if cross is None:
                self.th, self.w = self.slip(t, th0, w0, sense, command, end)
                self.t = end
                return
            self.th = self.slip(t, th0, w0, sense, command, cross)[0]
            self.t, self.w = cross, 0.0
            tau = self.torque(cross, command)
            self.piece = 0.0 if abs(tau) <= self.static else math.copysign(1.0, tau)
            self.stuck_at = cross

    def run(self, commands: np.ndarray, speed: float = 0.0) -> np.ndarray:
        """(θ1, ω1) at the end of every step, from θ1 = 0 at t = 0 at ``speed`` (at rest,
        or slipping in its sense)."""
        self.t, self.th, self.w, self.stuck_at = 0.0, 0.0, speed, None
        self.piece = math.copysign(1.0, speed) if speed != 0.0 else 0.0
        out = []
        for k, command in enumerate(commands):
            for j in range(1, TICK + 1):
                self.advance((k * TICK + j) * DT, float(command))
                out.append((self.th, self.w))
        return np.array(out)


def _short_episodes(exact: _Exact) -> int:
    """Sticking episodes that start and end inside one step."""
    return sum(1 for a, b in exact.episodes
               if a is not None and math.floor(a / DT) == math.floor(b / DT))


def _rk4(params: TableParams, commands: np.ndarray, speed: float = 0.0) -> np.ndarray:
    plant = Plant(params, DT, initial_state=np.array([0.0, 0.0, 0.0, speed, 0.0, 0.0]))
    rows = np.empty((TICK, OBSERVED))
    out = []
    for command in commands:
        plant.set_input(DriveInput(float(command), 1))
        assert plant.advance_ticks(TICK, 1, rows) == TICK and plant.fault is None
        assert np.all(rows[:, F1] == 0.0), 'pinion 1 touched a flank'
        out.append(rows[:, [0, 3]].copy())
    return np.concatenate(out)


def test_the_event_solution_has_short_episodes():
    """The constructed run does what it is for: the law's own solution sticks many times,
    some episodes wholly inside one step."""
    exact = _Exact(_params())
    exact.run(_commands())
    assert len(exact.episodes) > 50
    assert _short_episodes(exact) >= 3, exact.episodes


def test_rk4_locates_sticking_episodes_inside_a_step():
    """RK4 follows the law's own solution to its truncation error, short episodes
    included: a missed one (the slip law run through it) is an error of order
    (τ_S − τ_C)·(episode)/I in the speed, orders of magnitude above that."""
    params = _params()
    commands = _commands()
    exact = _Exact(params).run(commands)
    rk4 = _rk4(params, commands)
    scale = np.max(np.abs(exact[:, 1]))
    error = np.max(np.abs(rk4[:, 1] - exact[:, 1])) / scale
    angle = np.max(np.abs(rk4[:, 0] - exact[:, 0])) / np.max(np.abs(exact[:, 0]))
    print(f'RK4 against the event solution: speed {error:.2e}, angle {angle:.2e} (relative)')
    assert error < 1e-6 and angle < 1e-6


def test_the_reference_locates_sticking_episodes_inside_its_steps():
    """The DOP853 reference, asked for the state only every tick (so its steps are long,
    many spanning a short episode), follows the law's own solution to its tolerance."""
    params = _params()
    commands = _commands()
    exact = _Exact(params).run(commands)[TICK - 1::TICK]
    segments = [Segment(k * TICK, DriveInput(float(c), 1), params)
                for k, c in enumerate(commands)]
    steps = np.arange(1, TICKS + 1) * TICK
    ref = solve(np.zeros(6), segments, DT, steps, rtol=1e-12, atol=1e-14)
    scale = np.max(np.abs(exact[:, 1]))
    error = np.max(np.abs(ref[:, 3] - exact[:, 1])) / scale
    print(f'reference against the event solution: speed {error:.2e} (relative)')
    assert error < 1e-9


def test_rk4_locates_a_dip_through_zero_that_returns_inside_its_step():
    """Pinion 1 slips forward slowly, the drive torque below τ_C and rising fast (a 500 Hz
    ripple from its zero): the speed reaches zero after a few µs, the body sticks, breaks
    away at about 18 µs when the torque passes τ_S, all inside the first 50 µs step. The
    slip law run on through the episode would dip below zero and be back above it by the
    step's end, so the pieces at the step's end show nothing; the episode is located
    from the interpolant's dip, and RK4 follows the law's own solution."""
    params = _params(static=COULOMB + 0.1, ripple=4.0, ripple_hz=500.0)
    commands = np.full(1, COULOMB - 0.126)         # N·m, a tick of 20 steps
    speed = 1e-5                                   # rad/s
    exact_solution = _Exact(params)
    exact = exact_solution.run(commands, speed)
    (stuck, breakaway), = exact_solution.episodes[:1]
    assert 0.0 < stuck < breakaway < DT                  # the case: inside step 1
    assert exact[0, 1] > 0.0
    rk4 = _rk4(params, commands, speed)
    error = np.max(np.abs(rk4[:, 1] - exact[:, 1])) / np.max(np.abs(exact[:, 1]))
    print(f'episode {stuck * 1e6:.2f}-{breakaway * 1e6:.2f} µs; RK4 against the event '
          f'solution: speed {error:.2e} (relative)')
    assert error < 1e-6


@pytest.mark.parametrize('sense', [1.0, -1.0])
def test_speed_dip_is_the_interpolants_first_extremum_past_zero(sense):
    """speed_dip against the cubic Hermite interpolant sampled densely (written here from
    its basis functions; rk.hermite, the one the integrator locates on, agrees): a dip
    is reported exactly when the sampled cubic goes past zero inside the step with both
    ends on the slip side, at its lowest point in the first stretch past zero."""
    piece = FrictionPiece.SLIP_FORWARD if sense > 0 else FrictionPiece.SLIP_BACKWARD
    rng = np.random.default_rng(14)
    theta = np.linspace(0.0, 1.0, 20001)
    basis = (2 * theta**3 - 3 * theta**2 + 1, theta**3 - 2 * theta**2 + theta,
             -2 * theta**3 + 3 * theta**2, theta**3 - theta**2)
    h = 1e-3
    found = 0
    for i in range(1000):
        w0, w1 = sense * rng.uniform(0.0, 1.0, 2) * rng.choice([1e-3, 1.0], 2)
        a0, a1 = rng.uniform(-3e3, 3e3, 2)
        path = sense * (basis[0] * w0 + basis[1] * h * a0 + basis[2] * w1 + basis[3] * h * a1)
        if i < 10:
            assert hermite(w0, a0, w1, a1, h, theta[777]) == pytest.approx(
                sense * path[777], rel=1e-12, abs=1e-15)
        dip = speed_dip(piece, w0, a0, w1, a1, h)
        past = path < 0.0
        if not past.any():
            assert dip == 1.0
            continue
        found += 1
        assert 0.0 < dip < 1.0
        # the first stretch past zero holds the dip, at its lowest point
        first = np.flatnonzero(past)[0]
        back = np.flatnonzero(~past[first:])
        stretch = slice(first, first + (back[0] if len(back) else len(theta) - first))
        lowest = theta[stretch][np.argmin(path[stretch])]
        assert theta[stretch][0] - 1e-4 <= dip <= theta[stretch][-1] + 1e-4
        assert abs(dip - lowest) < 2e-3
    assert found > 100
    assert speed_dip(FrictionPiece.STUCK, 1.0, -1e4, 1.0, 1e4, h) == 1.0
    assert speed_dip(FrictionPiece.NONE, 1.0, -1e4, 1.0, 1e4, h) == 1.0
