"""Energy audit of a run: kinetic energy + mesh potential against the work done on the gear.

Along a run driven through a :class:`~screwgear_ros.sim.session.Session`, the balance

    E_kin(t) + V(t) − E_kin(0) − V(0) = Σ W_term + W_phase − D_mesh + residual

is evaluated at every integration step (docs/model_notes.md §9–10 give the derivation):

- E_kin = ½·(I1·ω1² + I2·ω2² + I3·ω3²); V = Σ ½·K(φ_i)·f(δ_i)² over the meshes in use
  (mesh 3 only in `anti_backlash`), f the spring deflection (:func:`branch_penetration`);
- W_term = ∫ Σ_j τ_j·ω_j dt for every term of the equations of motion but the mesh
  (:class:`~screwgear_ros.physics.torques.Terms`: the drives with the preload, cogging,
  the load, the viscous losses, …, and bearing friction,
  :func:`~screwgear_ros.physics.motion.bearings`), each from the very torques the
  right-hand side sums, so a new term is audited without an edit here
  (:attr:`EnergyAudit.work` by name; a loss's work is negative);
- the mesh's own work is the change of V, less D_mesh = ∫ (F − K·f)·δ̇ dt per mesh, the
  contact damping's dissipation (F the contact force of ``mesh_state``, spring K·f plus
  damping, clipped so it never pulls; ≥ 0), plus W_phase:
- W_phase = ∫ (½·K'(φ)·f² − F·ε'(φ))·φ̇ dt per mesh: in `time` phase the work of the
  prescribed mesh excitation, part of the balance (``excitation``). In `angle` phase it
  is only reported (``phase_work``): it is the work the `paper` formulation's mesh does
  on its own, i.e. that formulation's residual; `energy_consistent` cancels it with
  its lever and stiffness-slope terms;
- a parameter change that alters the stored energy (stiffness, inertia, backlash, STE)
  does so at the step it takes effect: that step is counted as work (``retuning``).

The residual is what is left: zero for exact solutions of the `energy_consistent`
equations (and of both formulations in `time` phase), RK4's own error here; in `angle`
phase with the `paper` formulation it is the energy the paper's mesh creates.

**Quadrature.** The integrals are taken over the states at every integration step
(:func:`record` ticks the session one step per tick), per stretch of constant input and
parameters (the integrand jumps where they change, which happens only at step
boundaries), with the 6-point Lagrange rule on each interval between two steps: the
polynomial through the nearest six samples, centered ([11, −93, 802, 802, −93, 11]/1440
interior) and one-sided at the ends of a stretch. It is exact for quintics: its error is
O(h⁶) over a run, h = dt, against RK4's O(h⁴). On the paper's case at dt = 20 µs the
fastest integrand (the mesh mode, ≈ 1.4e3 rad/s; the power oscillates at twice that)
gives (h·ω)⁶ ≈ 3e-8 before the rule's small constant, far below the 1e-6 audited; the
doubling test in ``test/test_energy.py`` confirms the rule against a closed form. A
kink of the integrand inside a step (a contact opening or closing, the drive line's
corner) costs the rule its order on that one interval, as it costs RK4 its order.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..params.table import SimSettings, TableParams
from ..physics.jit import kernel
from ..physics.mesh import (
    branch_force,
    branch_penetration,
    contact_branch,
    mesh_motion,
    mesh_phase,
    mesh_stiffness_slope,
)
from ..physics.motion import BY_LAW, bearings
from ..physics.packed import (
    I1,
    I2,
    I3,
    MODE,
    MODE_CONVENTIONAL,
    PHASE,
    PHASE_TIME,
    R1,
    R3,
    Z1,
    Z3,
    B,
    C,
    Drive,
    PackedModel,
    pack,
)
from ..physics.torques import MESH_TERM, TERM_NAMES, net_torques, torque_terms
from .events import Command, Event
from .plant import DriveInput
from .session import Session, Tick

#: Points of the quadrature stencil (degree 5).
STENCIL = 6

#: The works :attr:`EnergyAudit.work` holds: every torque term's but the mesh's (whose
#: work is the change of its potential, its damping and its phase work), then bearing
#: friction's.
WORKS: tuple[str, ...] = tuple(
    name for k, name in enumerate(TERM_NAMES) if k != MESH_TERM) + ('bearing_friction',)
_FRICTION = len(TERM_NAMES)                      # power columns after the terms'
_MESH_DAMPING, _PHASE, _COLUMNS = _FRICTION + 1, _FRICTION + 2, _FRICTION + 3


@dataclass(frozen=True)
class Stretch:
    """Samples ``start``..``end`` (indices into :attr:`Trace.states`, inclusive) lie in one
    stretch of constant input and parameters."""

    start: int
    end: int
    drive: DriveInput
    params: TableParams


@dataclass(frozen=True)
class Trace:
    """The states of a run at its integration steps and what was in force between them."""

    dt: float
    step0: int                   # integration step of the first sample
    stride: int                  # integration steps between samples
    states: np.ndarray           # (n + 1, 8): θ1, θ2, θ3 (rad), ω1, ω2, ω3 (rad/s), L1, L3 (N·m)
    stretches: tuple[Stretch, ...]

    @property
    def time(self) -> np.ndarray:
        """Simulation time of each sample, s."""
        return (self.step0 + self.stride * np.arange(len(self.states))) * self.dt


@dataclass(frozen=True)
class EnergyAudit:
    """Energies (J) along a run, each at every sample; works cumulative from the start."""

    time: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    mesh_damping: np.ndarray     # dissipated by the contact damping (≥ 0)
    excitation: np.ndarray       # work of the time-driven mesh (`time` phase), else 0
    retuning: np.ndarray         # stored-energy steps where a parameter change took effect
    phase_work: np.ndarray       # ∫(½·K'·f² − F·ε')·φ̇ dt over the meshes, any phase
    #: The work done on the gear by each torque term but the mesh's, by the names of
    #: :data:`WORKS` (a loss's is negative).
    work: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def stored(self) -> np.ndarray:
        """Kinetic energy + mesh potential, J."""
        return self.kinetic + self.potential

    @property
    def supplied(self) -> np.ndarray:
        """Net energy put in since the start: works minus dissipation, J."""
        return (sum(self.work.values(), np.zeros_like(self.time)) + self.excitation
                + self.retuning - self.mesh_damping)

    @property
    def residual(self) -> np.ndarray:
        """Change of stored energy minus the energy supplied, J (0 for an exact balance)."""
        return self.stored - self.stored[0] - self.supplied

    @property
    def scale(self) -> float:
        """The largest energy in the balance, J: stored energy or any one work term."""
        terms = (self.stored, self.mesh_damping, self.excitation, self.retuning,
                 *self.work.values())
        return float(max(np.max(np.abs(term)) for term in terms))

    @property
    def relative_residual(self) -> float:
        """max |residual| over the run / :attr:`scale`."""
        return float(np.max(np.abs(self.residual))) / self.scale


# ---------------------------------------------------------------- running a session

def settings_for(dt: float) -> SimSettings:
    """Settings that tick a session one integration step per tick (every state seen) and
    never time a command out (an audited run holds its commands as long as it likes)."""
    return SimSettings(dt=dt, publish_rate=1.0 / dt, command_timeout=0.0)


def record(session: Session, ticks: int,
           events: Mapping[int, Sequence[Event]] | None = None) -> Trace:
    """Tick ``session`` ``ticks`` times, submitting ``events[k]`` before tick k, and keep
    the state after every tick with the input and parameters in force during it.

    The quadrature needs the state at every step: give the session one step per tick
    (:func:`settings_for`); a coarser stride is accepted and audited on its samples.
    Stops early if the plant faults.
    """
    plant = session.plant
    stride = session.settings.steps_per_publish
    step0 = plant.step
    states = [plant.full_state.copy()]
    spans: list[Stretch] = []
    # Tick k starts at step0 + k·stride (the stride is checked after every tick).
    timeline = [event for k in sorted(events or {}) for event in
                (e.at(step0 + k * stride) for e in (events or {})[k])]

    def keep(tick: Tick | None) -> bool:
        assert tick is not None               # no controller: every tick is a full one
        if tick.fault is not None:
            return True
        if session.settings.steps_per_publish != stride:
            raise ValueError('the session changed its steps per tick during an audited run')
        states.append(plant.full_state.copy())
        k = len(states) - 2
        last = spans[-1] if spans else None
        if last is not None and last.drive == tick.drive and last.params == tick.params:
            spans[-1] = Stretch(last.start, k + 1, last.drive, last.params)
        else:
            spans.append(Stretch(k, k + 1, tick.drive, tick.params))
        return False

    session.advance(ticks, events=timeline, monitor=keep)
    return Trace(session.settings.dt, step0, stride, np.array(states), tuple(spans))


def run(params: TableParams, dt: float, duration: float,
        commands: Iterable[tuple[float, Command]] = (),
        initial_state: np.ndarray | None = None) -> EnergyAudit:
    """Audit a run of ``duration`` s at step ``dt`` s: a fresh :class:`Session` (one step
    per tick, no command timeout) from ``initial_state`` (default: the equilibrium),
    with each ``(time, command)`` submitted before the tick that starts at that time."""
    session = Session(params, settings_for(dt), initial_state)
    events: dict[int, list[Event]] = {}
    for time, command in commands:
        events.setdefault(round(time / dt), []).append(command)
    return audit(record(session, round(duration / dt), events))


# ---------------------------------------------------------------- the audit

def audit(trace: Trace) -> EnergyAudit:
    """The energy balance of a recorded run (module docstring)."""
    y = trace.states
    t = trace.time
    n = len(y)
    h = trace.stride * trace.dt
    kinetic = np.empty(n)
    potential = np.empty(n)
    names = ('mesh_damping', 'excitation', 'retuning', 'phase_work', *WORKS)
    works = {name: np.zeros(n) for name in names}
    if not trace.stretches:
        raise ValueError('an audit needs at least one integration step')
    columns = [k for k in range(len(TERM_NAMES)) if k != MESH_TERM] + [_FRICTION]
    for k, stretch in enumerate(trace.stretches):
        a, b = stretch.start, stretch.end
        model = pack(stretch.params)
        power = np.empty((b - a + 1, _COLUMNS))
        stored = np.empty((b - a + 1, 2))
        _powers(t[a:b + 1], y[a:b + 1], model, stretch.drive.kernel, power, stored)
        if k == 0:
            kinetic[a], potential[a] = stored[0]
        # new parameters (stiffness, inertia, …) change the stored energy at their step
        step = float(np.sum(stored[0])) - (kinetic[a] + potential[a])
        kinetic[a + 1:b + 1], potential[a + 1:b + 1] = stored[1:, 0], stored[1:, 1]
        gained = {name: cumulative(power[:, column], h)
                  for name, column in zip(WORKS, columns, strict=True)}
        gained['mesh_damping'] = cumulative(power[:, _MESH_DAMPING], h)
        gained['phase_work'] = cumulative(power[:, _PHASE], h)
        gained['excitation'] = (gained['phase_work'] if model.p[PHASE] == PHASE_TIME
                                else np.zeros(b - a + 1))
        gained['retuning'] = np.full(b - a + 1, step)
        for name, values in gained.items():
            works[name][a + 1:b + 1] = works[name][a] + values[1:]
    return EnergyAudit(t, kinetic, potential, works.pop('mesh_damping'),
                       works.pop('excitation'), works.pop('retuning'),
                       works.pop('phase_work'), works)


@kernel
def _powers(t: np.ndarray, y: np.ndarray, model: PackedModel, drive: Drive,
            power: np.ndarray, stored: np.ndarray) -> None:
    """Per sample: power[:, k] = the power of torque term k (W, in the order of
    :class:`~screwgear_ros.physics.torques.Terms`), then of bearing friction, of the mesh
    damping and the phase power; stored[:, 0..1] = kinetic energy, mesh potential (J)."""
    p = model.p
    held = BY_LAW
    for k in range(t.shape[0]):
        th1, th2, th3, w1, w2, w3 = y[k, 0], y[k, 1], y[k, 2], y[k, 3], y[k, 4], y[k, 5]
        state = (th1, th2, th3, w1, w2, w3, y[k, 6], y[k, 7])
        terms = torque_terms(t[k], state, model, drive, held.branch_1, held.branch_3,
                             held.drive)[0]
        for i in range(len(terms)):
            power[k, i] = terms[i][0] * w1 + terms[i][1] * w2 + terms[i][2] * w3
        tau1, tau2, tau3 = net_torques(terms)
        friction = bearings(state, tau1, tau2, tau3, p, held)
        power[k, _FRICTION] = friction[3] * w1 + friction[4] * w2 + friction[5] * w3
        stored[k, 0] = 0.5 * (p[I1] * w1 * w1 + p[I2] * w2 * w2 + p[I3] * w3 * w3)
        damping = 0.0
        phase_power = 0.0
        potential = 0.0
        meshes = 1 if p[MODE] == MODE_CONVENTIONAL else 2
        for i in range(meshes):
            theta, omega = (th1, w1) if i == 0 else (th3, w3)
            radius, teeth = (p[R1], p[Z1]) if i == 0 else (p[R3], p[Z3])
            phi, deps, delta, delta_dot, stiffness = mesh_motion(
                theta, omega, radius, teeth, th2, w2, t[k], model)
            phi_dot = mesh_phase(theta, omega, teeth, t[k], p)[1]
            branch = contact_branch(delta, delta_dot, stiffness, p[C], p[B])
            force = branch_force(branch, delta, delta_dot, stiffness, p[C], p[B])
            f = branch_penetration(branch, delta, p[B])
            spring = stiffness * f
            potential += 0.5 * spring * f
            damping += (force - spring) * delta_dot
            phase_power += (0.5 * mesh_stiffness_slope(phi, p) * f * f - force * deps) * phi_dot
        power[k, _MESH_DAMPING] = damping
        power[k, _PHASE] = phase_power
        stored[k, 1] = potential


# ---------------------------------------------------------------- quadrature

def _weights(points: int) -> np.ndarray:
    """W[j, i] = ∫ over [x_j, x_j+1] of the Lagrange basis polynomial of node x_i, nodes
    x = 0, 1, …, points − 1 (unit spacing): exact for polynomials of degree points − 1."""
    x = np.arange(points, dtype=np.float64)
    vander = np.vander(x, points, increasing=True).T            # [power, node]
    powers = np.arange(1, points + 1)
    out = np.empty((points - 1, points))
    for j in range(points - 1):
        moments = ((j + 1.0) ** powers - float(j) ** powers) / powers
        out[j] = np.linalg.solve(vander, moments)
    return out


_WEIGHTS = {m: _weights(m) for m in range(2, STENCIL + 1)}


def cumulative(values: np.ndarray, h: float) -> np.ndarray:
    """∫ from the first sample to each sample of a smooth function sampled every ``h``:
    the 6-point Lagrange rule per interval (centered inside, one-sided near the ends;
    fewer points when there are fewer samples). out[0] = 0."""
    values = np.asarray(values, dtype=np.float64)
    intervals = len(values) - 1
    out = np.zeros(len(values))
    if intervals < 1:
        return out
    points = min(STENCIL, intervals + 1)
    weights = _WEIGHTS[points]
    j = np.arange(intervals)
    start = np.clip(j - (points // 2 - 1), 0, intervals + 1 - points)
    stencil = values[start[:, None] + np.arange(points)]
    pieces = h * np.sum(weights[j - start] * stencil, axis=1)
    out[1:] = np.cumsum(pieces)
    return out


__all__ = [
    'STENCIL',
    'WORKS',
    'EnergyAudit',
    'Stretch',
    'Trace',
    'audit',
    'cumulative',
    'record',
    'run',
    'settings_for',
]
