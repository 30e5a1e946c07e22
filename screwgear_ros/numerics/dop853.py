"""Dormand–Prince 8(5,3) (DOP853), compiled: the reference solver's integrator.

An explicit Runge–Kutta method of order 8 with embedded error estimators of orders 5
and 3 (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.10), adaptive step size. The
tableau is data: the published coefficients, taken at run time from SciPy's
``scipy.integrate._ivp.dop853_coefficients`` (A, B, C, E3, E5), so this module holds
the algorithm only. The kernel calls the compiled model right-hand side
:func:`screwgear_ros.physics.motion.state_rate` directly and allocates nothing per step (one stage
array per call).

Output: the kernel steps *exactly* onto every requested time (the step is cut to end
there, and the step proposed before the cut is resumed after it), so no interpolant
is involved and every output has the method's full accuracy.

Error control (Hairer's DOP853): per component the scale is atol + rtol·max(|y|, |y_new|);
with the order-5 and order-3 error vectors e5, e3 (RMS norms over the scale),
err = |h|·‖e5‖² / sqrt(‖e5‖² + 0.01·‖e3‖²) · 1/sqrt(n); a step is accepted when err ≤ 1
and the next step is h·min(10, max(0.2, 0.9·err^(−1/8))), never growing right after a
rejection.

Bearing friction (docs/model_notes.md §14): each body's friction is held on its piece
(slipping forward or backward, stuck) through a step. When an accepted step ends with a
body on another piece (its speed through zero, or its holding torque past the static
torque), the event is located by bisection on the step's length, each trial a full
DOP853 step from the step's start (so the event state has the method's accuracy, not an
interpolant's); the step ends there, a body that sticks gets its speed set to exactly 0,
and integration goes on from there on the new pieces, a stuck body's angle and speed
frozen (its slope is exactly 0). A step may also leave a piece and come back to it (a
speed through zero and back, a holding torque beyond τ_S and back) while the pieces at
its end match those of its start; the error control sees neither (the law is smooth on
each piece, a holding torque is no state). So an accepted step is searched inside for
both (:func:`_inside`) and such an event located the same way. With no bearing
friction on any body neither search can find anything, and neither runs.

Failure is a status, never an exception from compiled code: the step size collapsing
below 10 × the spacing of floating-point numbers at t (the solution changes faster
than double precision can follow), non-finite values that no step reduction cures, or
a step budget used up. :mod:`screwgear_ros.numerics.reference` turns it into a typed error.
"""

from __future__ import annotations

import math

import numpy as np

from ..physics.friction import FrictionPiece, speed_dip
from ..physics.jit import allocating_kernel, inline_kernel, kernel
from ..physics.motion import BY_LAW, Pieces
from ..physics.packed import N_MECHANICAL, N_STATE, TAU, Drive, PackedModel
from .dop853_stages import law, slope, slope_and_law, stage_state, stages
from .dop853_tableau import E3, E5, TABLEAU, A, B, C, Tableau

#: Error exponent: 1/(order of the error estimator + 1), Hairer's choice for DOP853.
ERROR_EXPONENT = -1.0 / 8.0
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
#: Step is "too small" below this many float spacings at t.
MIN_STEP_SPACINGS = 10.0

#: Kernel status codes.
OK, STEP_COLLAPSED, NON_FINITE, BUDGET = 0, 1, 2, 3
#: Default step budget per kernel call (a safety net: far above any sane run).
MAX_STEPS = 50_000_000

N = N_STATE
#: Bisection on a step's length for a friction event: the instant to 1e-15 of the step.
EVENT_TOLERANCE = 1e-15
EVENT_BISECTIONS = 60


@kernel
def _spacing(t: float) -> float:
    """Distance from t to the next larger float (t ≥ 0 here)."""
    return np.nextafter(t, np.inf) - t


@kernel
def _normed(model: PackedModel) -> int:
    """How many leading state entries the error norms take: all, or with no current-loop
    lag (τ_d = 0: the lagged torques have slope 0 and stay as they are, unused) the
    mechanical ones alone, so that norms and steps are those of the mechanical model."""
    return N if model.p[TAU] != 0.0 else N_MECHANICAL


@kernel
def _initial_step(t0: float, y0: np.ndarray, k: np.ndarray, t_span: float, model: PackedModel, drive: Drive,
                  rtol: float, atol: float, y1: np.ndarray, held: Pieces) -> float:
    """Hairer's starting step (Solving ODEs I, §II.4), k[0] = f(t0, y0) given; uses
    k[1] and y1 as scratch."""
    n = _normed(model)
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        sc = atol + rtol * abs(y0[i])
        d0 += (y0[i] / sc) ** 2
        d1 += (k[0, i] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, t_span)
    for i in range(N):
        y1[i] = y0[i] + h0 * k[0, i]
    slope(t0 + h0, y1, k, 1, model, drive, held)
    d2 = 0.0
    for i in range(n):
        sc = atol + rtol * abs(y0[i])
        d2 += ((k[1, i] - k[0, i]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    big = max(d1, d2)
    h1 = max(1e-6, h0 * 1e-3) if big <= 1e-15 else (0.01 / big) ** (1.0 / 8.0)
    h = min(100.0 * h0, h1, t_span)
    if not (h > 0.0) or not math.isfinite(h):
        h = t_span
    return h


@kernel
def _event(t: float, y: np.ndarray, h: float, k: np.ndarray, tableau: Tableau, y_stage: np.ndarray, y_new: np.ndarray,
           model: PackedModel, drive: Drive, held: Pieces, top: float,
           after: Pieces) -> tuple[float, Pieces]:
    """The first instant t + s·h (0 < s ≤ top ≤ 1) at which a bearing leaves its piece in
    ``held`` within the accepted step of h from (t, y), by bisection on s, each trial a
    step of s·h from (t, y) (k[0] = f(t, y) kept; k and y_new are scratch): s, and the
    pieces there (``after``: those at s = top)."""
    lo, hi = 0.0, top
    for _ in range(EVENT_BISECTIONS):
        if hi - lo <= EVENT_TOLERANCE:
            break
        mid = 0.5 * (lo + hi)
        stages(t, y, mid * h, k, tableau, y_stage, y_new, model, drive, held)
        now = law(t + mid * h, y_new, model, drive, held)
        if now == held:
            lo = mid
        else:
            hi, after = mid, now
    return hi, after


@kernel
def _inside(t: float, y: np.ndarray, h: float, k: np.ndarray, tableau: Tableau, y_stage: np.ndarray, y_new: np.ndarray,
            model: PackedModel, drive: Drive, held: Pieces) -> tuple[float, Pieces]:
    """Where a bearing may leave its piece and come back inside the accepted step of h
    from (t, y) to y_new, which the pieces at the step's end cannot show: a slipping
    body's speed through zero and back (the first extremum past zero of its speed's
    cubic Hermite interpolant from the slopes k[0] and k[N_STAGES] at the ends,
    :func:`~screwgear_ros.physics.friction.speed_dip`), or a stuck body's holding torque beyond
    τ_S and back (the holding torque is no state, so the error control does not follow
    it; it is looked at in the step's stage states, kept in k). Each candidate, earliest
    first, is confirmed by a trial step to it. Returns (s, the pieces there) with the
    pieces changed at s, or (1.0, ``held``) with y_new as it was (k[1:N_STAGES] and
    y_new are scratch)."""
    a, b, c = tableau[0], tableau[1], tableau[2]
    e = b.shape[0]                  # k[e]: the slope at the step's end
    dip = min(speed_dip(held.friction_1, y[3], k[0, 3], y_new[3], k[e, 3], h),
              speed_dip(held.friction_2, y[4], k[0, 4], y_new[4], k[e, 4], h),
              speed_dip(held.friction_3, y[5], k[0, 5], y_new[5], k[e, 5], h))
    flagged = 0                     # bit s: stage s's state is on other pieces
    stuck = FrictionPiece.STUCK
    if held.friction_1 == stuck or held.friction_2 == stuck or held.friction_3 == stuck:
        for s in range(1, e):
            stage_state(y, h, k, a, s, y_stage)
            if law(t + c[s] * h, y_stage, model, drive, held) != held:
                flagged |= 1 << s
    if dip >= 1.0 and flagged == 0:
        return 1.0, held
    found, now = 1.0, held
    while True:
        top, pick = dip, -1         # the earliest candidate left
        for s in range(1, e):
            if flagged & (1 << s) and c[s] < top:
                top, pick = c[s], s
        if top >= 1.0:
            break
        if pick < 0:
            dip = 1.0
        else:
            flagged &= ~(1 << pick)
        stages(t, y, top * h, k, tableau, y_stage, y_new, model, drive, held)
        now = law(t + top * h, y_new, model, drive, held)
        if now != held:
            found = top
            break
    stages(t, y, h, k, tableau, y_stage, y_new, model, drive, held)   # the step's end again
    if found >= 1.0:
        return 1.0, held        # no candidate was the step's own
    return found, now


@inline_kernel
def _frictional(held: Pieces) -> bool:
    """Whether any body of ``held`` has bearing friction (a piece other than NONE)."""
    none = FrictionPiece.NONE
    return not (held.friction_1 == none and held.friction_2 == none
                and held.friction_3 == none)


@inline_kernel
def _store(out: np.ndarray, tau_out: np.ndarray, done: int, tau: float, y: np.ndarray) -> int:
    """Every output time not after ``tau`` (elapsed from the start) still to fill gets the
    state ``y``; returns how many are filled."""
    while done < tau_out.shape[0] and tau_out[done] <= tau:
        for i in range(N):
            out[done, i] = y[i]
        done += 1
    return done


@allocating_kernel
def integrate(t0: float, y0: np.ndarray, tau_out: np.ndarray, out: np.ndarray, model: PackedModel, drive: Drive,
              rtol: float, atol: float, tableau: Tableau, max_steps: int
              ) -> tuple[int, float, float, int, int, int]:
    """Integrate y' = rhs(t, y) of the model (a :class:`~screwgear_ros.physics.packed.PackedModel`)
    under the input ``drive`` (a :class:`~screwgear_ros.physics.packed.Drive`) from (t0, y0)
    through the sorted times t0 + ``tau_out`` (``tau_out``: time elapsed since t0, all
    ≥ 0), writing the state at each into ``out[j]``, with the method ``tableau``
    (:data:`TABLEAU`).

    The steps add up to the elapsed time exactly: the kernel counts it from 0 (``tau``)
    and takes each step as the float difference of its end and start there, so the
    state advances by exactly the time the step covers, and a caller that gives the
    elapsed times as whole steps times dt integrates each input for exactly its
    duration. Counted on the absolute time, a step's length would be rounded to the
    spacing of floats at t, which late in a long run is a relative error far above
    any tolerance and unseen by the error control: the momentum the drive's torque
    puts in (a linear invariant, which a Runge–Kutta step otherwise keeps exactly) is
    then off, and the table angle drifts. The model is evaluated at t0 + tau.

    Returns (status, t, h, accepted, rejected, done): status OK or the failure code,
    the time reached (absolute; where it failed), the last step size, step counts, and
    how many rows of ``out`` were written.
    """
    _a, b, _c, e3, e5 = tableau
    normed = _normed(model)
    n_stages = b.shape[0]
    k = np.empty((n_stages + 1, N))
    y = np.empty(N)
    y_new = np.empty(N)
    y_stage = np.empty(N)
    for i in range(N):
        y[i] = y0[i]
    tau = 0.0
    t = t0
    done = 0
    n_out = tau_out.shape[0]
    done = _store(out, tau_out, done, tau, y)     # outputs at the start
    if done == n_out:
        return OK, t, 0.0, 0, 0, done
    tau_end = tau_out[n_out - 1]
    held = law(t, y, model, drive, BY_LAW)
    # With no bearing friction every piece is NONE for the whole call (the static torques
    # are the model's, fixed here): no step can leave its pieces, so the searches at each
    # accepted step's end and inside it would only confirm ``held``.
    frictional = _frictional(held)
    slope(t, y, k, 0, model, drive, held)
    for i in range(N):
        if not (math.isfinite(y[i]) and math.isfinite(k[0, i])):
            return NON_FINITE, t, 0.0, 0, 0, done
    h = _initial_step(t, y, k, tau_end, model, drive, rtol, atol, y_stage, held)
    accepted = 0
    rejected = 0
    last_rejected = False
    last_non_finite = False
    while done < n_out:
        target = tau_out[done]
        min_step = MIN_STEP_SPACINGS * _spacing(t)
        if h < min_step:
            return (NON_FINITE if last_non_finite else STEP_COLLAPSED), t, h, accepted, \
                rejected, done
        if accepted + rejected >= max_steps:
            return BUDGET, t, h, accepted, rejected, done
        # cut the step to land on the next output time exactly
        lands = tau + h >= target - min_step
        h_step = target - tau if lands else (tau + h) - tau
        finite = stages(t, y, h_step, k, tableau, y_stage, y_new, model, drive, held)
        tau_new = target if lands else tau + h_step
        t_new = t0 + tau_new
        at_end = held
        if finite:
            if frictional:          # the slope at the end, and the pieces there
                at_end = slope_and_law(t_new, y_new, k, n_stages, model, drive, held)
            else:
                slope(t_new, y_new, k, n_stages, model, drive, held)
            for i in range(N):
                if not math.isfinite(k[n_stages, i]):
                    finite = False
        if finite:
            err5 = 0.0
            err3 = 0.0
            for i in range(normed):
                sc = atol + rtol * max(abs(y[i]), abs(y_new[i]))
                s5 = 0.0
                s3 = 0.0
                for j in range(n_stages + 1):
                    s5 += e5[j] * k[j, i]
                    s3 += e3[j] * k[j, i]
                err5 += (s5 / sc) ** 2
                err3 += (s3 / sc) ** 2
            if err5 == 0.0 and err3 == 0.0:
                err = 0.0
            else:
                err = abs(h_step) * err5 / math.sqrt((err5 + 0.01 * err3) * normed)
        else:
            err = math.inf
        last_non_finite = not finite
        if err <= 1.0:
            after = held
            top = 1.0
            if frictional:
                after = at_end
                if after == held:       # a piece left and regained inside the step?
                    top, after = _inside(t, y, h_step, k, tableau, y_stage, y_new, model,
                                         drive, held)
            if after != held:
                # a bearing sticks or breaks away inside the step: end the step there
                # (its length the float difference of its ends, as every step's), stop a
                # body that sticks exactly, go on from there on the new pieces
                s_event, after = _event(t, y, h_step, k, tableau, y_stage, y_new, model,
                                        drive, held, top, after)
                tau_new = tau + s_event * h_step
                stages(t, y, tau_new - tau, k, tableau, y_stage, y_new, model, drive, held)
                stuck = FrictionPiece.STUCK
                if after.friction_1 == stuck and held.friction_1 != stuck:
                    y_new[3] = 0.0
                if after.friction_2 == stuck and held.friction_2 != stuck:
                    y_new[4] = 0.0
                if after.friction_3 == stuck and held.friction_3 != stuck:
                    y_new[5] = 0.0
                tau = tau_new
                t = t0 + tau
                for i in range(N):
                    y[i] = y_new[i]
                held = after
                slope(t, y, k, 0, model, drive, held)
                accepted += 1
                last_rejected = False
                done = _store(out, tau_out, done, tau, y)
                continue
            factor = (MAX_FACTOR if err == 0.0
                      else min(MAX_FACTOR, SAFETY * err ** ERROR_EXPONENT))
            if last_rejected:
                factor = min(1.0, factor)
            # a step cut short to land on an output time does not shrink the next one
            h_next = h_step * factor
            h = h if (lands and not last_rejected and h > h_next) else h_next
            tau = tau_new
            t = t_new
            for i in range(N):
                y[i] = y_new[i]
                k[0, i] = k[n_stages, i]
            accepted += 1
            last_rejected = False
            done = _store(out, tau_out, done, tau, y)
        else:
            if math.isfinite(err):
                factor = max(MIN_FACTOR, SAFETY * err ** ERROR_EXPONENT)
            else:
                factor = MIN_FACTOR
            h = h_step * factor
            rejected += 1
            last_rejected = True
    return OK, t, h, accepted, rejected, done


def warm() -> None:
    """Compile (or load) the kernel for the types the reference uses."""
    from ..params.table import TableParams
    from ..physics.packed import pack
    out = np.empty((2, N))
    integrate(0.0, np.zeros(N), np.array([1e-4, 2e-4]), out, pack(TableParams()),
              Drive(10.0, 1.0, 0.0), 1e-11, 1e-13, TABLEAU, MAX_STEPS)


__all__ = [
    'BUDGET',
    'E3',
    'E5',
    'MAX_STEPS',
    'NON_FINITE',
    'OK',
    'STEP_COLLAPSED',
    'TABLEAU',
    'A',
    'B',
    'C',
    'integrate',
    'warm',
]
