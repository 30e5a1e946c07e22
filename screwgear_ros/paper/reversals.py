"""The reversal runs of section 9 and what they measure (3-DOF plant).

The table driven forward at a torque until steady, then reversed abruptly
(:func:`reversal`), by a :class:`~screwgear_ros.sim.session.Session`; the table speed
before the reversal is set with a viscous table load c_t = T·(r2/r1)/ω2, so that torque
T holds speed ω2. From these runs: the metrics of a reversal, the smallest preload that
keeps both meshes on their flanks (δ1 > b, δ3 < −b) through reversals at several mesh
phases (:func:`scan_preload`), and the mesh harmonics of steady forward motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..interface import Input
from ..params.table import PAPER_PINION_SPEED, Mode, SimSettings, TableParams, effective_stiffness
from ..sim.events import Command, ParameterChange
from ..sim.session import ROW, AdvanceMode, Session, Tick

DT = 50e-6                 # s, the node's default step
REALISTIC_STE = 20e-6      # m, an STE amplitude typical of a module-6 gear, for comparison
ARCSEC = math.pi / (180 * 3600)
PREVIEW = 0.01             # s of forward motion shown before the reversal


def paper_table_speed(p: TableParams) -> float:
    """Table speed, rad/s, of the paper's pinion speed (24 r/min) through the radii."""
    return PAPER_PINION_SPEED * p.radius_pinion_1 / p.radius_table


def table_damping_for(p: TableParams, torque: float, table_speed: float) -> float:
    """c_t, N·m·s/rad, at which drive torque T (N·m) holds the table at ω2 (rad/s)."""
    return torque * p.radius_table / p.radius_pinion_1 / table_speed


def _mechanical_time(p: TableParams) -> float:
    """I_eff/c_t, s: time constant of the table speed under the viscous load."""
    ratio = p.radius_table / p.radius_pinion_1
    inertia = (p.inertia_table + (p.inertia_pinion_1 + p.inertia_pinion_3) * ratio ** 2)
    return inertia / p.table_damping


@dataclass(frozen=True)
class ReversalTrace:
    """Signals around a reversal; t = 0 at the reversal command, SI units."""

    params: TableParams
    torque: float
    t: np.ndarray
    theta2: np.ndarray     # rad
    omega2: np.ndarray     # rad/s
    delta: np.ndarray      # (n, 2): δ1, δ3, m
    force: np.ndarray      # (n, 2): F1, F3, N


def _settled(p: TableParams, torque: float, steps: int) -> Session:
    """A session that has driven the table at ``torque`` for ``steps`` steps: ticks of
    one step, so that it stops at exactly that step, run many to a compiled call."""
    session = Session(p, SimSettings(dt=DT, publish_rate=1.0 / DT))
    session.advance(until=steps, events=[Command(Input.CMD_TORQUE, torque, step=0)],
                    mode=AdvanceMode.ROWS, rows=np.empty((steps, ROW)))
    return session


def reversal(params: TableParams, torque: float, table_speed: float,
             delay: float = 0.0, stride: int = 2) -> ReversalTrace:
    """Drive forward at ``torque`` until steady at ``table_speed``, then reverse abruptly.

    ``delay`` (s) shifts the reversal instant (to sample the mesh phase at reversal).
    Recorded every ``stride`` steps from PREVIEW s before the reversal until the table
    runs steadily backwards.
    """
    p = params.replace(table_damping=table_damping_for(params, torque, table_speed),
                       max_torque=max(params.max_torque, torque))
    tm = _mechanical_time(p)
    n_forward = round((0.1 + 6 * tm + delay) / DT)
    n_before = round(PREVIEW / DT / stride)
    n_after = round((0.05 + 3 * tm) / DT / stride)
    lead = n_forward - n_before * stride
    sampled = SimSettings(dt=DT, publish_rate=1.0 / (stride * DT))
    session = _settled(p, torque, lead)
    rows: list[tuple[float, ...]] = []

    def sample(tick: Tick | None) -> None:
        o = session.last_outputs if tick is None else tick.outputs
        rows.append((o.time, o.position[1], o.velocity[1], *o.delta, *o.mesh_force))

    session.advance(n_before + n_after, monitor=sample,
                    events=[ParameterChange(p, sampled, step=lead),
                            Command(Input.CMD_DIRECTION, -1, step=lead + n_before * stride)])
    a = np.array(rows)
    t = a[:, 0] - n_forward * DT
    return ReversalTrace(p, torque, t, a[:, 1], a[:, 2], a[:, 3:5], a[:, 5:7])


@dataclass(frozen=True)
class ReversalMetrics:
    contact_loss_time: float    # s, total time mesh 1 (or either mesh) is off its flank
    contact_losses: int         # number of separate losses of contact
    dead_travel: float          # rad at the table: mesh travel without contact / r2
    peak_force_ratio: float     # peak |F| of the driving mesh after reversal / (T/r1)
    overshoot_ratio: float      # (peak − new steady |F|) / (T/r1): the impact part
    overtravel: float           # rad: table travel after the command before it turns
    min_margin: float           # m: min(δ1 − b, −b − δ3) (anti), min |δ1| − b (conventional)


def metrics(r: ReversalTrace) -> ReversalMetrics:
    p = r.params
    b = p.backlash
    after = r.t >= 0.0
    d1, d3 = r.delta[after, 0], r.delta[after, 1]
    if p.mode is Mode.CONVENTIONAL:
        on_flank = np.abs(d1) > b
        driving_force = np.abs(r.force[after, 0])
        margin = float(np.min(np.abs(d1) - b))
    else:
        on_flank = (d1 > b) & (d3 < -b)
        driving_force = np.abs(r.force[after, 1])
        margin = float(min(np.min(d1 - b), np.min(-b - d3)))
    off = ~on_flank
    dt = float(r.t[1] - r.t[0])
    starts = int(np.sum(off[1:] & ~off[:-1]) + (1 if off[0] else 0))
    # Travel of mesh 1 inside the gap |δ1| ≤ b: 2b per crossing, plus any rattling.
    dead = float(np.sum(np.abs(np.diff(np.clip(d1, -b, b))))) / p.radius_table
    theta = r.theta2[after]
    unit = r.torque / p.radius_pinion_1
    steady = float(np.mean(driving_force[-len(driving_force) // 5:]))
    peak = float(np.max(driving_force))
    return ReversalMetrics(
        contact_loss_time=float(np.sum(off) * dt), contact_losses=starts, dead_travel=dead,
        peak_force_ratio=peak / unit, overshoot_ratio=(peak - steady) / unit,
        overtravel=float(np.max(theta) - theta[0]), min_margin=margin)


def flank_margin(params: TableParams, torque: float, table_speed: float, preload: float,
                 delay: float = 0.0) -> float:
    """min(δ1 − b, −b − δ3), m, from steady forward motion through a reversal."""
    r = reversal(params.replace(preload_torque=preload), torque, table_speed, delay,
                 stride=4)
    b = params.backlash
    return float(min(np.min(r.delta[:, 0] - b), np.min(-b - r.delta[:, 1])))


def mesh_modes(p: TableParams) -> tuple[float, ...]:
    """Undamped mesh modes, rad/s, of the 3-DOF table with its meshes in contact at the
    mean stiffness k_eff (rigid-body mode left out), lowest first: both meshes in
    `anti_backlash`, mesh 1 alone in `conventional` (then the one mode is √(k/m_e))."""
    k = effective_stiffness(p)
    g = np.array([[p.radius_pinion_1, -p.radius_table, 0.0],
                  [0.0, -p.radius_table, p.radius_pinion_3]])
    inertia = np.array([p.inertia_pinion_1, p.inertia_table, p.inertia_pinion_3])
    if p.mode is Mode.CONVENTIONAL:
        g, inertia = g[:1, :2], inertia[:2]
    # M^(-1/2)·K·M^(-1/2) is symmetric; its eigenvalues are the squared mode frequencies.
    scale = 1.0 / np.sqrt(inertia)
    squared = np.linalg.eigvalsh(scale[:, None] * (k * g.T @ g) * scale[None, :])
    return tuple(float(w) for w in np.sqrt(np.sort(squared[squared > 1e-9 * squared.max()])))


def mesh_period(params: TableParams, table_speed: float) -> float:
    """s, one tooth of pinion 1 at table speed ω2 (rad/s)."""
    pinion_speed = table_speed * params.radius_table / params.radius_pinion_1
    return 2 * math.pi / (params.teeth_pinion_1 * pinion_speed)


def reversal_instants(params: TableParams, table_speed: float, least: int = 8,
                      most: int = 48) -> int:
    """How many reversal instants to try over one mesh period.

    With a large STE the steady forward motion carries harmonics of the mesh frequency
    up to the mesh modes (its kinematics are far from linear), and a reversal adds its own
    ringing at those modes: the worst instant is set to within a fraction of a mode's
    period. Six instants per period of the highest mesh mode, between ``least`` and
    ``most`` (slow speeds, where those harmonics are negligible, get ``most``).
    """
    needed = 6.0 * max(mesh_modes(params)) * mesh_period(params, table_speed) / (2 * math.pi)
    return int(min(most, max(least, math.ceil(needed))))


@dataclass(frozen=True)
class PhaseScan:
    """The flank margin over the reversal instant, and the preload at the worst ones."""

    delays: np.ndarray        # s after the start of a mesh period
    scan_preload: float       # N·m at which the margins were taken
    margins: np.ndarray       # m, flank margin at each delay with scan_preload
    worst: np.ndarray         # indices of the delays bisected, worst first
    preloads: np.ndarray      # N·m, minimum preload at each of them (inf above the cap)

    @property
    def minimum_preload(self) -> float:
        return float(np.max(self.preloads))


def scan_preload(params: TableParams, torque: float, table_speed: float,
                 phases: int | None = None, tolerance: float = 2.0, cap: float = 3000.0,
                 bisected: int = 3) -> PhaseScan:
    """Smallest preload torque T_p (N·m) keeping both flanks loaded through a reversal,
    worst case over the reversal instant.

    The instant is shifted over ``phases`` points of one mesh period (default
    :func:`reversal_instants`) and the flank margin taken at T_p = ``torque``: it is
    nearly affine in T_p (the preload's torques cancel on the table, so the motion
    hardly depends on it), so the instants with the smallest margins are the ones that
    need the most preload. T_p is bisected to ``tolerance`` N·m at the ``bisected`` worst
    of them (inf if even ``cap`` N·m does not hold).
    """
    if phases is None:
        phases = reversal_instants(params, table_speed)
    delays = np.arange(phases) * mesh_period(params, table_speed) / phases
    margins = np.array([flank_margin(params, torque, table_speed, torque, d) for d in delays])
    worst = np.argsort(margins)[:bisected]
    preloads = np.empty(len(worst))
    for n, k in enumerate(worst):

        def holds(tp: float, delay: float = delays[k]) -> bool:
            return flank_margin(params, torque, table_speed, tp, delay) > 0.0

        lo, hi = 0.0, torque
        if margins[k] <= 0.0:
            lo, hi = hi, 2 * hi
            while not holds(hi) and hi <= cap:
                lo, hi = hi, 2 * hi
        if hi > cap:
            preloads[n] = math.inf
            continue
        while hi - lo > tolerance:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if holds(mid) else (mid, hi)
        preloads[n] = hi
    return PhaseScan(delays, torque, margins, worst, preloads)


def minimum_preload(params: TableParams, torque: float, table_speed: float,
                    phases: int | None = None, tolerance: float = 2.0,
                    cap: float = 3000.0) -> float:
    """The worst case over the reversal instant of :func:`scan_preload`, N·m."""
    return scan_preload(params, torque, table_speed, phases, tolerance, cap).minimum_preload


def forward_harmonics(params: TableParams, torque: float, table_speed: float,
                      harmonics: int | None = None, periods: int = 4) -> np.ndarray:
    """Amplitudes, m, of the mesh-frequency harmonics 1…``harmonics`` of δ1 in steady
    forward motion at ``table_speed`` under ``torque`` (c_t as in :func:`reversal`),
    from a DFT over ``periods`` whole mesh periods. By default up to 1.5 times the
    highest mesh mode."""
    if harmonics is None:
        harmonics = math.ceil(1.5 * max(mesh_modes(params)) * mesh_period(params, table_speed)
                              / (2 * math.pi))
    p = params.replace(table_damping=table_damping_for(params, torque, table_speed),
                       max_torque=max(params.max_torque, torque))
    period = mesh_period(p, table_speed)
    settle = 0.1 + 6 * _mechanical_time(p)
    n_settle = round(settle / DT)
    n = round(periods * period / DT)
    session = _settled(p, torque, n_settle)
    delta: list[float] = []
    session.advance(n, monitor=lambda _: delta.append(session.last_outputs.delta[0]),
                    events=[ParameterChange(p, SimSettings(dt=DT, publish_rate=1.0 / DT),
                                            step=n_settle)])
    spectrum = np.fft.rfft(np.asarray(delta) - np.mean(delta)) * 2 / n
    # Whole periods: harmonic h of the mesh frequency is DFT bin h·periods (up to the
    # rounding of the period to whole steps).
    return np.abs(spectrum[periods * np.arange(1, harmonics + 1)])


__all__ = [
    'ARCSEC',
    'DT',
    'PREVIEW',
    'REALISTIC_STE',
    'PhaseScan',
    'ReversalMetrics',
    'ReversalTrace',
    'flank_margin',
    'forward_harmonics',
    'mesh_modes',
    'mesh_period',
    'metrics',
    'minimum_preload',
    'paper_table_speed',
    'reversal',
    'reversal_instants',
    'scan_preload',
    'table_damping_for',
]
