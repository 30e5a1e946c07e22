"""High-accuracy reference solution of the 3-DOF model: DOP853, tight tolerances.

It integrates the very right-hand side the RK4 hot loop uses (:func:`model.rhs`),
restarted at every change of input or parameters, so it checks the integrator and
not a second copy of the physics; everything the parameters select (mode, mesh phase,
``mesh_formulation``, the drive's torque–speed line) comes with each segment's packed
parameters, so a recording is re-integrated with the physics it ran. A run is described as :class:`Segment`s: from
``start_step`` on, this input and these parameters are in force.

The integrator is Dormand–Prince 8(5,3) with adaptive steps, compiled
(:mod:`screwgear_ros.numerics.dop853`, calling the compiled ``model.rhs`` directly) and
independent of the node's fixed-step RK4. ``method='scipy'`` runs SciPy's DOP853
(``solve_ivp``) on the same segments instead, for cross-checks of runs without bearing
friction (the compiled solver locates where a body sticks or breaks away; SciPy's does
not). A run the reference
cannot follow (the step size collapsing below the spacing of floating-point numbers,
non-finite values) raises :class:`ReferenceFailure`, which says why and where.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ScrewgearError
from ..params.table import TableParams
from ..physics.drive import DriveInput
from ..physics.motion import rhs_vector
from ..physics.packed import N_MECHANICAL, N_STATE, pack
from . import dop853

#: Default relative / absolute tolerances (absolute on rad and rad/s).
RTOL = 1e-11
ATOL = 1e-13
#: The solvers :func:`solve` offers.
METHODS = ('dop853', 'scipy')


@dataclass(frozen=True)
class Segment:
    """From integration step ``start_step`` on, ``drive`` and ``params`` are in force."""

    start_step: int
    drive: DriveInput
    params: TableParams


class ReferenceFailure(ScrewgearError, RuntimeError):
    """The reference solver cannot follow the run: why (``reason``), when (``time``,
    s of simulation) and in which segment (``segment``, counted from 0, of ``segments``;
    it spans ``start``..``end`` s with input ``drive``)."""

    def __init__(self, reason: str, time: float, segment: int, segments: int, start: float,
                 end: float, drive: DriveInput):
        self.reason, self.time = reason, time
        self.segment, self.segments, self.start, self.end = segment, segments, start, end
        self.drive = drive
        super().__init__(str(self))

    def __str__(self) -> str:
        d = self.drive
        return (f'the reference solver cannot follow the run at t = {self.time:.6f} s: '
                f'{self.reason}; in segment {self.segment + 1} of {self.segments} '
                f'(t = {self.start:.6f} s to {self.end:.6f} s, torque {d.torque:g} N·m, '
                f'direction {int(d.direction):+d}, load {d.load:g} N·m)')

    def __reduce__(self) -> tuple[type[ReferenceFailure], tuple[str, float, int, int, float, float,
                                                               DriveInput]]:
        return (ReferenceFailure, (self.reason, self.time, self.segment, self.segments,
                                   self.start, self.end, self.drive))

    def located(self, segment: int, segments: int, start: float,
                end: float) -> ReferenceFailure:
        """The same failure, placed in a caller's numbering of segments."""
        return ReferenceFailure(self.reason, self.time, segment, segments, start, end,
                                self.drive)


def solve(initial_state: np.ndarray, segments: Sequence[Segment], dt: float,
          sample_steps: np.ndarray, rtol: float = RTOL, atol: float = ATOL,
          progress: Callable[[int], None] | None = None,
          method: str = 'dop853') -> np.ndarray:
    """States at the integration steps ``sample_steps`` (sorted ints), shape (n, m), as
    long as ``initial_state`` (m = 6: the mechanical state, the drives' lagged torques
    starting at 0; m = N_STATE: the whole state).

    ``segments`` are sorted by start step and the first starts at or before the
    first sample. Time is step·dt, s. ``progress(k)`` is told each segment done.
    ``method``: ``'dop853'`` (compiled, the default) or ``'scipy'`` (SciPy's
    ``solve_ivp`` DOP853). Raises :class:`ReferenceFailure` if the solution cannot
    be followed.
    """
    if method not in METHODS:
        raise ValueError(f'method must be one of {METHODS}, not {method!r}')
    if method == 'scipy' and any(seg.params.table_static_torque > 0.0
                                 or seg.params.pinion_static_torque > 0.0 for seg in segments):
        raise ValueError("method 'scipy' has no events for bearing friction (a body "
                         "sticking); use 'dop853'")
    sample_steps = np.asarray(sample_steps, dtype=np.int64)
    if len(segments) == 0 or segments[0].start_step > (sample_steps[0] if len(sample_steps) else 0):
        raise ValueError('the first segment must start at or before the first sample')
    width = len(initial_state)
    out = np.empty((len(sample_steps), N_STATE))
    y = np.zeros(N_STATE)
    y[:width] = initial_state
    step = segments[0].start_step
    last_step = int(sample_steps[-1]) if len(sample_steps) else step
    integrate = _segment if method == 'dop853' else _segment_scipy
    for k, seg in enumerate(segments):
        end_step = segments[k + 1].start_step if k + 1 < len(segments) else last_step
        end_step = min(end_step, last_step)
        if end_step > step:
            lo = np.searchsorted(sample_steps, step, side='left')
            hi = np.searchsorted(sample_steps, end_step, side='right')
            try:
                y, out[lo:hi] = integrate(y, step, end_step, sample_steps[lo:hi], dt, seg,
                                          rtol, atol)
            except ReferenceFailure as exc:
                raise exc.located(k, len(segments), seg.start_step * dt,
                                  end_step * dt) from None
            step = end_step
        else:
            hit = sample_steps == step
            out[hit] = y
        if progress is not None:
            progress(k)
    return out[:, :width]


#: Why the compiled solver stopped, by its status code.
_REASONS = {
    dop853.STEP_COLLAPSED: 'the step size fell to {h:.3g} s, below the spacing of '
                           'floating-point numbers there (the solution changes faster than '
                           'double precision can resolve, e.g. a run driven through the '
                           'mesh resonance)',
    dop853.NON_FINITE: 'the state or its derivative became non-finite (the model diverged)',
    dop853.BUDGET: 'more than {steps} steps in one stretch of integration (step size '
                   '{h:.3g} s)',
}


def _segment(y0: np.ndarray, step_a: int, step_b: int, samples: np.ndarray, dt: float,
             seg: Segment, rtol: float, atol: float) -> tuple[np.ndarray, np.ndarray]:
    """Integrate one segment with the compiled DOP853; returns (state at step_b,
    states at ``samples``)."""
    model = pack(seg.params)
    drive = seg.drive
    ends_on_sample = len(samples) > 0 and samples[-1] == step_b
    steps = samples if ends_on_sample else np.append(samples, step_b)  # always see the end
    states = np.empty((len(steps), N_STATE))
    # the output times as steps elapsed × dt: each input lasts exactly its ticks
    status, t, h, accepted, rejected, _ = dop853.integrate(
        step_a * dt, y0, (steps - step_a) * dt, states, model, drive.kernel, rtol, atol,
        dop853.TABLEAU, dop853.MAX_STEPS)
    if status != dop853.OK:
        reason = _REASONS[status].format(h=h, steps=accepted + rejected)
        raise ReferenceFailure(reason, float(t), 0, 1, step_a * dt, step_b * dt, drive)
    return states[-1].copy(), (states if ends_on_sample else states[:-1])


def _segment_scipy(y0: np.ndarray, step_a: int, step_b: int, samples: np.ndarray, dt: float,
                   seg: Segment, rtol: float, atol: float) -> tuple[np.ndarray, np.ndarray]:
    """The same with SciPy's solve_ivp DOP853 (for cross-checks)."""
    from scipy.integrate import solve_ivp  # only this cross-check uses it
    model = pack(seg.params)
    drive = seg.drive
    ends_on_sample = len(samples) > 0 and samples[-1] == step_b
    steps = samples if ends_on_sample else np.append(samples, step_b)
    kernel_drive = drive.kernel
    t0 = step_a * dt         # time counted from the segment's start, as the kernel counts it
    # With no current-loop lag the lagged torques stay as they are: SciPy integrates (and
    # norms) the mechanical state alone, as the compiled solver does.
    width = N_STATE if seg.params.drive_time_constant > 0.0 else N_MECHANICAL
    rest = y0[width:]
    sol = solve_ivp(lambda tau, y: rhs_vector(t0 + tau, np.concatenate([y, rest]), model,
                                              kernel_drive)[:width],
                    (0.0, (step_b - step_a) * dt), y0[:width], method='DOP853', rtol=rtol,
                    atol=atol, t_eval=(steps - step_a) * dt)
    if sol.success:
        sol.y = np.vstack([sol.y, np.repeat(rest[:, None], sol.y.shape[1], axis=1)])
    if not sol.success:
        t = t0 + float(sol.t[-1]) if len(sol.t) else t0
        raise ReferenceFailure(f'SciPy: {sol.message}', t, 0, 1, step_a * dt, step_b * dt,
                               drive)
    states = sol.y.T if ends_on_sample else sol.y[:, :-1].T
    return sol.y[:, -1].copy(), states


__all__ = ['ATOL', 'METHODS', 'RTOL', 'ReferenceFailure', 'Segment', 'solve']
