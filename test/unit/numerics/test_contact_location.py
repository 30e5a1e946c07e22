"""Contact changes located inside RK4 steps (integrator, ``contact_location``).

Independent reference: SciPy's DOP853 (rtol 1e-12) on the equations of motion with each
mesh held on its branch of the contact law and the drive on its piece of the torque–speed
line, stopped by SciPy's own event detection where one leaves (switching functions
written here from δ, δ̇, K and the pinion speed, not the integrator's), and restarted on
the new piece; its steps are at most 20 µs, so no contact
episode hides inside one. No piece of it integrates across a jump or kink of the mesh
force, so it is accurate to its tolerance through every impact.

Runs go through the Session, as the node runs them: 400 N·m forward from rest, reversed
at 0.3 s, sampled every millisecond to 0.6 s, at the paper's speed (c_t = 8867 N·m·s/rad).
"""

from __future__ import annotations

import functools

import numba
import numpy as np
import pytest
from bag_runs import reversal_run
from scipy.integrate import solve_ivp

from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.physics.drive import DrivePiece, active_speed, drive_piece
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.friction import FrictionPiece
from screwgear_ros.physics.mesh import ContactBranch, mesh_motion
from screwgear_ros.physics.motion import Pieces, contact_branches, motion, rhs_vector
from screwgear_ros.physics.packed import R1, R3, TS, WNL, Z1, Z3, B, C, Drive, PackedModel, pack
from screwgear_ros.sim import run_file as run_parameters
from screwgear_ros.sim.session import Session

TORQUE = 400.0
REVERSAL, END, SAMPLE = 0.3, 0.6, 1e-3      # s
TABLE_DAMPING = 8867.0                      # N·m·s/rad: the paper's speed at 400 N·m
#: The reference's longest step, s: events are seen as sign changes between steps, and a
#: free flight through the gap would otherwise be crossed in steps long enough to hide a
#: whole bounce on a flank (the shortest contact episode here lasts 76 µs).
MAX_STEP = 20e-6

SCENARIOS = {
    # the flank of mesh 1 lifts off, crosses the gap, bounces on the reverse flank
    'conventional': {'mode': 'conventional'},
    # the same with the forces from the mesh potential (f(δ) kinks at the gap edge too)
    'conventional energy-consistent': {'mode': 'conventional',
                                           'mesh_formulation': 'energy_consistent'},
    # too little preload: the reversal opens the meshes of the anti-backlash gear
    'anti-backlash, 200 N·m preload': {'preload_torque': 200.0},
    # a weaker drive: the bounces after the reversal cross the drive line's corner
    # (400 N·m meets T_s·(1 − ω/ω_nl) at 8.4 rad/s), a kink of the drive torque
    'conventional, drive line corner': {'mode': 'conventional', 'drive_stall_torque': 600.0},
}


def _params(name: str) -> TableParams:
    return TableParams(table_damping=TABLE_DAMPING, **SCENARIOS[name])


def _session_run(p: TableParams, dt: float, locate: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """(initial state, states at every SAMPLE, contact changes located)."""
    stride = round(SAMPLE / dt)
    settings = SimSettings(dt=dt, publish_rate=1.0 / (stride * dt), contact_location=locate,
                           command_timeout=0.0)
    return reversal_run(p, settings, TORQUE, round(REVERSAL / dt), round(END / dt))


# ------------------------------------------------------------------ the reference
#
# SciPy calls the right-hand side at every stage of every step and the switching function
# at every step, so both are compiled here and take plain numbers and arrays: called from
# Python with the model's named tuples, numba would type every field of them at each call,
# which costs far more than the equations. Not cached: a cached copy would keep the model
# kernels it was linked with after the model changed.

_BRANCHES, _DRIVE_PIECES = tuple(ContactBranch), tuple(DrivePiece)


@numba.njit(cache=False)
def _member(members: tuple, value: int):
    """The member of an enum (given as the tuple of its members) with this value, the last
    (FROM_STATE) for none: compiled code cannot call the enum class."""
    for member in members:
        if member == value:
            return member
    return members[-1]


@numba.njit(cache=False)
def _held(branch_1: int, branch_3: int, drive: int) -> Pieces:
    """The pieces the reference holds, from their values: the contact branches of mesh 1
    and mesh 3 and the drive piece; each bearing's friction picked from the state."""
    return Pieces(_member(_BRANCHES, branch_1), _member(_BRANCHES, branch_3),
                  _member(_DRIVE_PIECES, drive), FrictionPiece.FROM_STATE,
                  FrictionPiece.FROM_STATE, FrictionPiece.FROM_STATE)


@numba.njit(cache=False)
def _held_rate(t: float, y: np.ndarray, p: np.ndarray, ste_amp: np.ndarray,
               ste_phase: np.ndarray, direction: float, branch_1: int, branch_3: int,
               drive: int) -> tuple:
    """dy/dt of the mechanical state y, the law held on the pieces given by value
    (:func:`_held`): the model's :func:`motion`, TORQUE in ``direction`` and no load."""
    a = motion(t, (y[0], y[1], y[2], y[3], y[4], y[5]), PackedModel(p, ste_amp, ste_phase),
               Drive(TORQUE, direction, 0.0), _held(branch_1, branch_3, drive))
    return y[3], y[4], y[5], a[0], a[1], a[2]


@numba.njit(cache=False)
def _inside(branch: int, delta: float, rate: float, k: float, c: float, b: float) -> float:
    """A switching function, N: > 0 while a mesh stays on ``branch`` of the contact law
    of model.md §2, crossing 0 where it leaves (gap edges |δ| = b as K·(|δ| − b); a flank
    loses contact where K·(δ ∓ b) + c·δ̇ reaches 0)."""
    spring_fwd, spring_rev = k * (delta - b), k * (delta + b)
    if branch == ContactBranch.GAP:
        return min(-spring_fwd, spring_rev)
    if branch == ContactBranch.FORWARD:
        return min(spring_fwd, spring_fwd + c * rate)
    if branch == ContactBranch.FORWARD_LIFTING:
        return min(spring_fwd, -(spring_fwd + c * rate))
    if branch == ContactBranch.REVERSE:
        return min(-spring_rev, -(spring_rev + c * rate))
    if branch == ContactBranch.REVERSE_LIFTING:
        return min(-spring_rev, spring_rev + c * rate)
    return np.inf


@numba.njit(cache=False)
def _drive_inside(piece: int, speed: float, p: np.ndarray) -> float:
    """The same for the drive (N·m): on the command while it is below the line
    T_s·(1 − ω/ω_nl), on the line while the command is above it."""
    if p[WNL] <= 0.0:
        return np.inf
    margin = p[TS] * (1.0 - speed / p[WNL]) - TORQUE
    return margin if piece == DrivePiece.COMMAND else -margin


@numba.njit(cache=False)
def _switching(t: float, y: np.ndarray, p: np.ndarray, ste_amp: np.ndarray,
               ste_phase: np.ndarray, direction: float, branch_1: int, branch_3: int,
               drive: int) -> float:
    """The least of the switching functions of the held pieces (arguments as
    :func:`_held_rate`): > 0 while the state stays on all of them."""
    m = PackedModel(p, ste_amp, ste_phase)
    value = _drive_inside(drive, active_speed(y[3], y[5], direction, p), p)
    for branch, th, w, r, z in ((branch_1, y[0], y[3], p[R1], p[Z1]),
                                (branch_3, y[2], y[5], p[R3], p[Z3])):
        _, _, delta, rate, k = mesh_motion(th, w, r, z, y[1], y[4], t, m)
        value = min(value, _inside(branch, delta, rate, k, p[C], p[B]))
    return value


def reference(p: TableParams, y0: np.ndarray, rtol: float = 1e-12,
              atol: float = 1e-14) -> tuple[np.ndarray, int]:
    """States at every SAMPLE, and how many contact changes the run has (module docstring)."""
    m = pack(p)
    times = np.arange(1, round(END / SAMPLE) + 1) * SAMPLE
    out = np.empty((len(times), 6))
    y, t, changes = np.array(y0, dtype=np.float64), 0.0, 0

    def held(direction, pieces):
        """What :func:`_held_rate` and :func:`_switching` take after (t, y)."""
        return (m.p, m.ste_amp, m.ste_phase, direction, *(int(piece) for piece in pieces))

    def pieces_at(tt, yy, direction):
        """Branches of the contact law and piece of the drive line at (tt, yy)."""
        return (*contact_branches(tt, tuple(yy), m),
                drive_piece(TORQUE, active_speed(yy[3], yy[5], direction, m.p), m.p))

    for _start, stop, direction in ((0.0, REVERSAL, 1.0), (REVERSAL, END, -1.0)):
        branches = pieces_at(t, y, direction)
        while t < stop:
            args = held(direction, branches)
            # a restart sits on the boundary it just crossed, to rounding: start inside
            lift = 2.0 * max(0.0, -_switching(t, y, *args)) + 1e-300

            def rate(tt, yy, args=args):
                return _held_rate(tt, yy, *args)

            def event(tt, yy, args=args, lift=lift):
                return _switching(tt, yy, *args) + lift
            event.terminal, event.direction = True, -1
            sol = solve_ivp(rate, (t, stop), y, method='DOP853',
                            rtol=rtol, atol=atol, events=event, dense_output=True,
                            max_step=MAX_STEP)
            assert sol.success, sol.message
            here = (times > t + 1e-12) & (times <= sol.t[-1] + 1e-12)
            if here.any():
                out[here] = sol.sol(times[here]).T
            y, t = sol.y[:, -1].copy(), sol.t[-1]
            if sol.status == 1:                   # left the branch: on which is it now?
                changes += 1
                probe, after = 1e-8, branches
                while after == branches:
                    ahead = solve_ivp(rate, (t, t + probe), y,
                                      method='DOP853', rtol=rtol, atol=atol).y[:, -1]
                    after = pieces_at(t + probe, ahead, direction)
                    probe *= 4.0
                    assert probe < 1e-4, 'a contact change the reference cannot follow'
                branches = after
    return out, changes


@functools.cache
def _reference_run(name: str) -> tuple[TableParams, np.ndarray, np.ndarray, int]:
    """(params, initial state, reference states, reference contact changes) of a scenario."""
    p = _params(name)
    y0 = equilibrium_state(p)                 # where a session starts
    return (p, y0, *reference(p, y0))


@pytest.fixture(params=list(SCENARIOS))
def scenario(request):
    """(name, params, initial state, reference states, reference contact changes)."""
    return (request.param, *_reference_run(request.param))


def test_reference_resolves_itself():
    """The reference at rtol 1e-12 against 1e-13: far below what is tested."""
    p, y0, ref, changes = _reference_run('conventional')
    tighter, changes_tighter = reference(p, y0, rtol=1e-13, atol=1e-15)
    spread = np.max(np.abs(tighter - ref), axis=0)
    print(f'reference rtol 1e-12 vs 1e-13: θ1 θ2 θ3 {spread[:3]} rad, ω {spread[3:]} rad/s')
    assert changes_tighter == changes
    assert spread[1] < 1e-13 and spread[0] < 1e-12


def test_located_rk4_agrees_with_the_reference_at_the_default_step(scenario):
    """Goal: |θ2 − reference| ≤ 1e-9 rad at dt = 50 µs through backlash reversals."""
    name, p, _, ref, changes = scenario
    _, located, found = _session_run(p, 50e-6, True)
    _, fixed, _ = _session_run(p, 50e-6, False)
    err = np.max(np.abs(located - ref), axis=0)
    err_fixed = np.max(np.abs(fixed - ref), axis=0)
    print(f'{name}: {found} contact changes located ({changes} in the reference); '
          f'max |error| located θ1 θ2 θ3 {err[:3]} rad, ω1 ω2 ω3 {err[3:]} rad/s; '
          f'fixed-step θ2 {err_fixed[1]:.2e} rad, ω1 {err_fixed[3]:.2e} rad/s')
    assert found == changes > 0
    assert err[1] <= 1e-9
    assert max(err[0], err[2]) <= 1e-7 and max(err[3], err[5]) <= 1e-4 and err[4] <= 1e-6
    assert err_fixed[1] > 10 * err[1]            # what the location buys


def test_order_through_impacts_is_four(scenario):
    """Measured order, halving dt 200 → 100 → 50 µs, per component, against the reference
    and by Richardson differences (no reference): ≥ 3.5 located; the fixed step is not."""
    name, p, _, ref, _ = scenario
    runs = {locate: [_session_run(p, dt, locate)[1] for dt in (200e-6, 100e-6, 50e-6)]
            for locate in (True, False)}
    moving = [0, 1, 3, 4] + ([2, 5] if p.mode == 'anti_backlash' else [])
    for locate, states in runs.items():
        err = [np.max(np.abs(s - ref), axis=0)[moving] for s in states]
        diff = [np.max(np.abs(states[i] - states[i + 1]), axis=0)[moving] for i in range(2)]
        orders = [np.log2(err[i] / err[i + 1]) for i in range(2)]
        richardson = np.log2(diff[0] / diff[1])
        print(f'{name}, contact location {locate}: order vs reference {np.round(orders, 2)}, '
              f'by Richardson {np.round(richardson, 2)}')
        if locate:
            assert all(np.all(o >= 3.5) for o in (*orders, richardson))
        else:
            assert min(np.min(o) for o in orders) < 3.0


def test_without_contact_changes_both_paths_are_the_same_bits():
    """The default anti-backlash gear keeps its flanks through the reversal: nothing to
    locate, and the located path takes exactly the fixed step."""
    p = TableParams(table_damping=TABLE_DAMPING)
    _, located, found = _session_run(p, 50e-6, True)
    _, fixed, _ = _session_run(p, 50e-6, False)
    assert found == 0
    assert np.array_equal(located, fixed)


def test_fixed_step_path_is_the_textbook_rk4():
    """contact_location off: classical RK4 on the contact law, written out here in the
    association the integrator has always used, y + dt/6·(k1 + 2·(k2 + k3) + k4), through
    the conventional reversal's impacts: the same bits (what recordings made before the
    setting hold)."""
    p = _params('conventional')
    dt, m = 50e-6, pack(p)
    y0, fixed, _ = _session_run(p, dt, False)
    y = y0.copy()
    out = []
    reversal = round(REVERSAL / dt)
    for k in range(round(0.32 / dt)):
        direction = 1.0 if k < reversal else -1.0

        def f(t, state, direction=direction):
            return rhs_vector(t, state, m, Drive(TORQUE, direction, 0.0))
        t, h = k * dt, 0.5 * dt
        k1 = f(t, y)
        k2 = f(t + h, y + h * k1)
        k3 = f(t + h, y + h * k2)
        k4 = f(t + dt, y + dt * k3)
        y = y + dt / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
        if (k + 1) % round(SAMPLE / dt) == 0:
            out.append(y.copy())
    assert np.array_equal(np.array(out), fixed[:len(out)])


def test_recordings_made_before_the_setting_replay_with_the_fixed_step():
    run = run_parameters.RunParameters(TableParams(), SimSettings(), (0.0,) * 6,
                                       package_version='0.1.0')    # before the setting
    text = run_parameters.dump(run)
    assert run_parameters.load(text).settings.contact_location is True
    old = '\n'.join(line for line in text.splitlines()
                    if not line.startswith('contact_location:'))
    assert run_parameters.load(old).settings.contact_location is False
    session = Session(TableParams(), SimSettings(contact_location=False))
    assert session.plant.contact_location is False
