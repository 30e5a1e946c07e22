"""A linear model of the 3-DOF table at an operating point: ``dx/dt = A·x + B·u``,
``y = C·x + D·u`` (deviations from the point).

The operating point is the preload equilibrium (no torque, no load) or the steady motion
under a constant drive torque, direction and table load: the rigid motion at the speed
where the torque the drive delivers (its torque–speed line, docs/model_notes.md §10)
balances every other term on the rigid motion (the load, the viscous losses, sliding
bearing friction, …: :func:`~screwgear_ros.physics.steady.steady_table_speed`, solved on
the torque terms), at rest when nothing turns the table or friction holds it.
In steady rotation the mesh phase advances, so the model takes the mesh as its time
average: stiffness k_eff = k_m·(1 − α·ΔT) + k_p (the fluctuation k_a averages out, as
do the drive torque fluctuation and the cogging ripple), no static transmission error (a
periodic excitation of the mesh, not a function of the deviations), lever r. Each mesh is on the
branch of the contact law its mean force puts it on, and the drive on the piece of its line
that delivers the torque at that speed.

Standing still (a static point in `angle` phase) the mesh phase does not sweep: ``mesh =
'frozen'`` linearizes the full model at its rest angle instead (the stiffness K(φ0) and the
STE's slope in the pinion's lever there), which is what the table does for small motions
while it stands.

A, B are the model's own equations of motion (:func:`~screwgear_ros.physics.motion.motion`,
the sum of the torque terms of :mod:`screwgear_ros.physics.torques`) on those branches,
evaluated with the averaged mesh, by central differences: there they are affine in the
angles and the inputs, so unit steps give those columns exactly; the speeds' columns take
small extrapolated steps (a slipping bearing's Stribeck slope is not affine).

States: the angle of pinion 1, table, pinion 3, then their speeds (rad, rad/s; pinion
angles counted in the sense that drives the table forward, as in the model). Inputs: the
drive torque magnitude (N·m, cmd_torque: the active pinion's in the commanded direction)
and the table load (N·m, load_torque). Outputs: angle and speed of the table and of each
pinion, and the transmission error δ of the active path (m).

The operating point is :mod:`.operating_point`'s, the model's container and its modes
:mod:`.linear_model`'s, what cannot be done :mod:`.errors`'.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import optimize

from ..params.table import MeshPhase, TableParams, effective_stiffness
from ..physics.drive import drive_targets
from ..physics.equilibrium import NEWTON_ITERATIONS, equilibrium_state
from ..physics.mesh import ContactBranch, mesh_motion
from ..physics.motion import Pieces, motion
from ..physics.packed import Drive, pack
from .errors import MeshModelUnsupported, NoSteadyState
from .linear_model import OUTPUTS, LinearModel, MeshModel
from .operating_point import OperatingPoint, mean_params, operating_point

#: The state each angle/speed output reads (the transmission error is built apart).
_OUTPUT_STATE = {'table_angle': 1, 'table_speed': 4, 'pinion_1_angle': 0,
                 'pinion_1_speed': 3, 'pinion_3_angle': 2, 'pinion_3_speed': 5}

#: A mesh force the ripple of the mesh excitation brings within this fraction of the mean
#: force of a contact is "near a contact change".
NEAR_CONTACT_CHANGE = 0.5


def _derivative(x: np.ndarray, u: np.ndarray, point: OperatingPoint, model) -> np.ndarray:
    # The drives' current loops held at their targets: the linear model takes the drive
    # torque as instant (its lag is a first-order filter in series with it).
    lag1, lag3 = drive_targets(point.drive_piece, x[3], x[5], u[0], float(point.direction),
                               model.p)
    accelerations = motion(0.0, (x[0], x[1], x[2], x[3], x[4], x[5], lag1, lag3), model,
                           Drive(u[0], float(point.direction), u[1]),
                           Pieces(point.contact[0], point.contact[1], point.drive_piece))[:3]
    return np.concatenate([x[3:], accelerations])


def _differences(point: OperatingPoint, model, x0: np.ndarray, dx: np.ndarray,
                 du: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A and B by central differences of the equations of motion on the point's branches,
    steps ``dx`` in the state and ``du`` in the inputs."""
    u0 = np.array([point.torque, point.load])
    a = np.empty((6, 6))
    for j in range(6):
        e = np.zeros(6)
        e[j] = dx[j]
        a[:, j] = (_derivative(x0 + e, u0, point, model)
                   - _derivative(x0 - e, u0, point, model)) / (2.0 * dx[j])
    b = np.empty((6, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = du[j]
        b[:, j] = (_derivative(x0, u0 + e, point, model)
                   - _derivative(x0, u0 - e, point, model)) / (2.0 * du[j])
    return a, b


#: Central-difference steps of the averaged model: angles (rad), speeds (rad/s), inputs
#: (N·m). It is affine in the angles and the inputs on fixed branches (unit steps are
#: exact there), but not in the speeds when a bearing slips with a Stribeck slope, so
#: the speeds' step is small and extrapolated (:func:`_average`).
AVERAGE_STEPS = (1.0, 1e-4, 1.0)


def _average(point: OperatingPoint, model) -> tuple[np.ndarray, np.ndarray]:
    """A and B of the averaged model at the point: central differences at
    :data:`AVERAGE_STEPS` and at half of them, Richardson-extrapolated (O(h⁴); exact
    where the model is affine)."""
    angle, speed, inputs = AVERAGE_STEPS
    dx = np.array([angle] * 3 + [speed] * 3)
    du = np.full(2, inputs)
    x0 = np.array(point.state)
    a_full, b_full = _differences(point, model, x0, dx, du)
    a_half, b_half = _differences(point, model, x0, dx / 2.0, du / 2.0)
    return (4.0 * a_half - a_full) / 3.0, (4.0 * b_half - b_full) / 3.0


#: Central-difference steps of the frozen model: angles, speeds (rad, rad/s), inputs (N·m).
FROZEN_STEPS = (1e-9, 1e-6, 1e-3)

#: A rest state is accepted once its largest scaled residual (:func:`_scaled_residual`) is
#: at most this. Newton's method goes on below it, down to the floor that roundoff puts
#: under the residual (a few hundred float spacings of the terms' magnitudes), and stops
#: there; this bound is six orders of magnitude above that floor, so whether a rest state
#: is found never depends on one CPU's or one BLAS kernel's roundoff, and far below any
#: torque the model resolves.
REST_RESIDUAL = 1e-9

#: A Newton step within this many float spacings of the angles is at their rounding floor.
STEP_SPACINGS = 4.0

#: The rest angle is searched within this many table teeth of the preload equilibrium's,
#: in steps of 1/64 tooth.
SEARCH_TEETH = 4

_PINIONS = [0, 2]


def _scaled_residual(a: np.ndarray, b: np.ndarray, x: np.ndarray, u: np.ndarray,
                     accelerations: np.ndarray, rows: list[int]) -> float:
    """The largest acceleration left among ``rows`` (0, 1, 2: pinion 1, table, pinion 3),
    each body's against the magnitudes of the terms that act on it: Σ|A_ij·x_j| over the
    angles (each elastic term's share: a mesh force is K·r·(r·θ − r2·θ2 − …)) plus
    Σ|B_ik·u_k| (the inputs'). At a rest state every constant term is balanced by these,
    so this is the residual relative to the largest torque involved, in the units in which
    roundoff is bounded."""
    scale = np.abs(a[3:, :3]) @ np.abs(x[:3]) + np.abs(b[3:]) @ np.abs(u)
    scale = np.where(scale > 0.0, scale, 1.0)
    return float(np.max(np.abs(accelerations[rows]) / scale[rows]))


def _pinions_at(theta2: float, start: np.ndarray, u: np.ndarray, point: OperatingPoint,
                model, steps: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, float, float]:
    """The pinions' rest angles with the table held at ``theta2`` (Newton's method on the
    two pinions' balances from ``start``; the meshes make it well conditioned), and the
    table's acceleration there with its scaled residual.

    Newton runs until its step is within :data:`STEP_SPACINGS` float spacings of the
    angles, or the scaled residual stops falling (twice in a row less than halved: the
    rounding floor), keeping the best state it met; :class:`~.errors.NoSteadyState` unless
    that state's scaled residual is at most :data:`REST_RESIDUAL`.
    """
    x = start.copy()
    x[1] = theta2
    best, best_x, stalled = math.inf, x.copy(), 0
    for _ in range(NEWTON_ITERATIONS):
        a, b = _differences(point, model, x, *steps)
        residual = _derivative(x, u, point, model)[3:]
        scaled = _scaled_residual(a, b, x, u, residual, _PINIONS)
        stalled = stalled + 1 if scaled > 0.5 * best else 0
        if scaled < best:
            best, best_x = scaled, x.copy()
        if scaled == 0.0 or stalled >= 2:
            break
        # least squares: a pinion that touches nothing (conventional mode's idle one) has
        # no stiffness, and no residual, so it takes no step
        step = np.linalg.lstsq(a[3:, :3][np.ix_(_PINIONS, _PINIONS)], -residual[_PINIONS],
                               rcond=None)[0]
        x[_PINIONS] += step
        if np.all(np.abs(step) <= STEP_SPACINGS * np.spacing(np.abs(x[_PINIONS]))):
            break
    if not best <= REST_RESIDUAL:
        raise NoSteadyState('no rest state of the full model found under these inputs: the '
                            f'pinions stay {best:.3g} of their torques away from a balance '
                            f'(a rest needs at most {REST_RESIDUAL:g})')
    a, b = _differences(point, model, best_x, *steps)
    residual = _derivative(best_x, u, point, model)[3:]
    return best_x, float(residual[1]), _scaled_residual(a, b, best_x, u, residual, [1])


def _frozen(params: TableParams, point: OperatingPoint) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """The rest state of the full model under the point's inputs, and A, B there by central
    differences, on the point's branches.

    Along the gear's rigid rotation only the cogging (K(φ) and the STE's lever over a
    tooth) holds the table, some 1e-14 of the mesh stiffness, so a Newton step on all
    three angles at once moves the rest angle by whatever roundoff leaves in the residual.
    Instead, the pinions are solved with the table held (:func:`_pinions_at`), and the
    table angle is moved from the preload equilibrium's, in the sense of the table's
    acceleration, in steps of 1/64 tooth until that acceleration changes sign; Brent's
    method then finds the root, where the acceleration falls with the angle: the nearest
    stable rest. Where the table's scaled residual is at most :data:`REST_RESIDUAL` at the
    start (no cogging), that start is the rest.
    """
    model = pack(params)
    start = np.array(equilibrium_state(params), dtype=float)
    u = np.array([point.torque, point.load])
    angle, speed, inputs = FROZEN_STEPS
    steps = (np.array([angle] * 3 + [speed] * 3), np.full(2, inputs))

    def table(theta2: float) -> tuple[np.ndarray, float, float]:
        return _pinions_at(theta2, start, u, point, model, steps)

    lo = float(start[1])
    x, accel, scaled = table(lo)
    if scaled > REST_RESIDUAL:
        tooth = 2.0 * math.pi / (params.teeth_pinion_1 * params.radius_table
                                 / params.radius_pinion_1)
        sense = 1.0 if accel > 0.0 else -1.0
        for _ in range(SEARCH_TEETH * 64):
            hi = lo + sense * tooth / 64.0
            if table(hi)[1] * sense <= 0.0:
                break
            lo = hi
        else:
            raise NoSteadyState('no rest state of the full model found under these inputs: '
                                'the table torque keeps its sign over '
                                f'{SEARCH_TEETH} teeth of the preload equilibrium')
        root = optimize.brentq(lambda theta2: table(theta2)[1], min(lo, hi), max(lo, hi),
                               xtol=STEP_SPACINGS * np.spacing(tooth),
                               rtol=4.0 * np.finfo(float).eps)
        x = table(root)[0]
    a, b = _differences(point, model, x, *steps)
    return a, b, x


def linearize(params: TableParams, torque: float = 0.0, load: float = 0.0,
              direction: int = 1, mesh: MeshModel | str = 'average') -> LinearModel:
    """The linear model at :func:`operating_point` (module docstring). ``mesh``: `average`
    (the mesh over its period, module docstring) or `frozen`: at a static point in `angle`
    phase, the full model at its rest angle (the stiffness K(φ0), the STE's slope in the
    pinion's lever), what the table does for small motions while it stands."""
    mesh = MeshModel(mesh)
    point = operating_point(params, torque, load, direction)
    if mesh is MeshModel.FROZEN:
        if point.rotating:
            raise MeshModelUnsupported('a frozen mesh needs a static operating point: in steady '
                                      'rotation the mesh phase advances (use the average)')
        if params.mesh_phase is not MeshPhase.ANGLE:
            raise MeshModelUnsupported('a frozen mesh needs the angle mesh phase: in time phase '
                                      'the mesh phase advances at rest too (use the average)')
        a, b, state = _frozen(params, point)
        point = replace(point, state=tuple(float(v) for v in state))
    else:
        a, b = _average(point, pack(mean_params(params)))
    c = np.zeros((len(OUTPUTS), 6))
    for i, name in enumerate(OUTPUTS):
        if name == 'transmission_error':
            pinion = 0 if point.path == 1 else 2
            radius = params.radius_pinion_1 if pinion == 0 else params.radius_pinion_3
            if mesh is MeshModel.FROZEN:      # δ = r·θ − ε(z·θ) − r2·θ2: the STE's slope
                teeth = params.teeth_pinion_1 if pinion == 0 else params.teeth_pinion_3
                packed = pack(params)
                slope = mesh_motion(point.state[pinion], 0.0, radius, teeth, point.state[1],
                                    0.0, 0.0, packed)[1]
                radius -= teeth * slope
            c[i, pinion] = radius
            c[i, 1] = -params.radius_table
        else:
            c[i, _OUTPUT_STATE[name]] = 1.0
    d = np.zeros((len(OUTPUTS), 2))
    linear = LinearModel(a, b, c, d, point, params, mesh)
    ripple = _ripple_warnings(linear)
    if ripple:
        point = replace(point, warnings=point.warnings + tuple(ripple))
        linear = LinearModel(a, b, c, d, point, params, mesh)
    return linear


def _ripple_warnings(linear: LinearModel) -> list[str]:
    """Meshes whose mean force the mesh excitation may bring to a contact change.

    The static transmission error drives each mesh as a displacement ε(φ) in δ at the mesh
    frequency and its harmonics (z·|ω| in `angle` phase, ω_e in `time` phase); the force
    it makes there follows from this linear model: F = (k + j·ω·c)·(δ_bodies − ε), the bodies
    driven by the same mesh. The stiffness fluctuation adds k_a·|f| on the mean deflection f.
    Their sum is compared with the mean force of each flank contact.
    """
    params, point = linear.params, linear.point
    if params.backlash <= 0.0:
        return []                   # no flank to lift off: one law at every δ
    omega_mesh = (params.mesh_frequency if params.mesh_phase.value == 'time'
                  else None)
    warnings = []
    k, c = effective_stiffness(params), params.mesh_damping
    inertia = np.array([params.inertia_pinion_1, params.inertia_table, params.inertia_pinion_3])
    for mesh, branch, force in zip((1, 3), point.contact, point.mesh_force, strict=True):
        if branch not in (ContactBranch.FORWARD, ContactBranch.REVERSE):
            continue
        radius = params.radius_pinion_1 if mesh == 1 else params.radius_pinion_3
        teeth = params.teeth_pinion_1 if mesh == 1 else params.teeth_pinion_3
        speed = abs(point.state[3 if mesh == 1 else 5])
        base = omega_mesh if omega_mesh is not None else teeth * speed
        g = np.zeros(3)
        g[0 if mesh == 1 else 2], g[1] = radius, -params.radius_table
        ripple = params.mesh_stiffness_amplitude * abs(force) / k
        if base > 0.0:
            for n, amplitude in enumerate(params.ste_amplitudes, start=1):
                w = n * base
                z = k + 1j * w * c
                # ε in δ: force −z·ε, on the bodies −g·F
                column = np.concatenate([np.zeros(3), g * z / inertia])
                x = np.linalg.solve(1j * w * np.eye(6) - linear.a, column)
                ripple += float(abs(z * (g @ x[:3] - 1.0)) * abs(amplitude))
        if ripple >= NEAR_CONTACT_CHANGE * abs(force):
            warnings.append(
                f'near a contact change: the mesh excitation (STE, stiffness fluctuation) '
                f'moves the force of mesh {mesh} by up to about {ripple:.4g} N around its mean '
                f'{force:.4g} N; where it reaches zero the flank lifts and the linear model '
                'does not hold')
    return warnings



__all__ = [
    'AVERAGE_STEPS',
    'FROZEN_STEPS',
    'NEAR_CONTACT_CHANGE',
    'linearize',
]
