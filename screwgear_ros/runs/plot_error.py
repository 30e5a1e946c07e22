"""The tracking-error panel of a recorded run, as data: the error in mrad or in encoder
counts, and a tolerance band with the time the error last entered it.

Computed first, drawn after (as python-control's ``*_response`` objects are): no
matplotlib here. :func:`error_view` is what ``plot_run --counts/--band/--target`` draws
(:func:`screwgear_ros.runs.plot.run_figure`); the tests hold it against errors computed
from the bag by another library.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..bag.reader import RecordedRun
from ..errors import ScrewgearError
from .plot_series import tracking_error

#: Most encoder counts per revolution a --counts value may give (the parameter's bound).
MAX_COUNTS = 2 ** 30


class ErrorViewError(ScrewgearError, ValueError):
    """An error-panel option that cannot be drawn; names the option and the rule."""


@dataclass(frozen=True)
class ErrorOptions:
    """How to show the tracking error.

    counts
        None: in mrad. 0: in counts of the table encoder the run recorded
        (``encoder_counts_table``). N > 0: in counts of an encoder of N counts per
        revolution.
    band
        ± tolerance in the unit shown (counts or mrad), > 0; None: no band.
    target
        rad: the reference, a constant, instead of the recorded setpoint (for a
        controller that sends none); None: the recorded setpoint.
    """

    counts: int | None = None
    band: float | None = None
    target: float | None = None

    @property
    def any(self) -> bool:
        """Whether any option asks for the error panel."""
        return self.counts is not None or self.band is not None or self.target is not None


@dataclass(frozen=True)
class ErrorView:
    """What the tracking-error panel draws.

    ``times`` (s) and ``error`` (reference − θ2 of the exact table angle, in ``unit``);
    ``measured_times``/``measured_error`` the same of the angle joint_states reported
    (None with ideal sensors); ``band`` (± in ``unit``) and ``inside_from`` (s: the sample
    from which on |error| stays within the band to the end of the run; None when the last
    sample is outside, or no band); ``rms`` over the run, in ``unit``.
    """

    times: np.ndarray
    error: np.ndarray
    unit: str
    per_rad: float
    reference: str
    rms: float
    band: float | None = None
    inside_from: float | None = None
    measured_times: np.ndarray | None = None
    measured_error: np.ndarray | None = None


def _reference_error(run: RecordedRun, target: float | None,
                     exact: bool) -> tuple[np.ndarray, np.ndarray]:
    """(times, reference − θ2 rad) of the exact or the measured angle."""
    js = run.true_joint_states if exact else run.joint_states
    if target is not None:
        return js.steps * run.dt, target - js.values[:, 1]
    if exact:
        return tracking_error(run)
    sp = run.setpoint                         # the measured angle against the setpoint
    index = np.searchsorted(sp.steps, js.steps, side='right') - 1
    known = index >= 0
    return js.steps[known] * run.dt, sp.values[index[known], 0] - js.values[known, 1]


def inside_from(times: np.ndarray, error: np.ndarray, band: float) -> float | None:
    """The time of the sample from which on |error| ≤ band to the last sample; None
    when the last sample is outside (or there is none).

    Examples
    --------
    >>> import numpy as np
    >>> inside_from(np.array([0.0, 1.0, 2.0, 3.0]), np.array([5.0, 0.5, 3.0, -1.0]), 2.0)
    3.0
    >>> inside_from(np.array([0.0, 1.0]), np.array([0.0, 9.0]), 2.0) is None
    True
    """
    outside = np.flatnonzero(~(np.abs(error) <= band))
    if not len(error) or (len(outside) and outside[-1] == len(error) - 1):
        return None
    return float(times[outside[-1] + 1] if len(outside) else times[0])


def error_view(run: RecordedRun, options: ErrorOptions) -> ErrorView:
    """The error panel's data for ``run`` under ``options``; :class:`ErrorViewError`
    naming the option when one cannot be drawn.
    """
    counts, band, target = options.counts, options.band, options.target
    if target is not None and not (isinstance(target, (int, float)) and math.isfinite(target)):
        raise ErrorViewError(f'--target {target!r}: the reference angle must be a finite '
                             'number of rad')
    if target is None and not len(run.setpoint):
        raise ErrorViewError('the tracking error needs a reference: the bag recorded no '
                             'setpoint, so give the target angle with --target RAD')
    if counts is None:
        unit, per_rad = 'mrad', 1e3
    else:
        if isinstance(counts, bool) or not isinstance(counts, int) or \
                not 0 <= counts <= MAX_COUNTS:
            raise ErrorViewError(f'--counts {counts!r}: counts per revolution must be a whole '
                                 f'number from 1 to {MAX_COUNTS} (or none: the run\'s table '
                                 'encoder)')
        if counts == 0:
            counts = run.parameters.settings.encoder_counts_table
            if counts == 0:
                raise ErrorViewError('--counts: the run\'s table encoder is ideal '
                                     '(encoder_counts_table 0), so it has no counts; give '
                                     'the resolution: --counts N (counts per revolution)')
        unit, per_rad = 'counts', counts / (2.0 * math.pi)
    if band is not None and not (isinstance(band, (int, float)) and not isinstance(band, bool)
                                 and math.isfinite(band) and band > 0.0):
        raise ErrorViewError(f'--band {band!r}: the tolerance must be a finite number > 0 '
                             f'(± {unit})')
    times, error = _reference_error(run, target, exact=True)
    error = error * per_rad
    rms = float(np.sqrt(np.mean(error ** 2))) if len(error) else 0.0
    measured_times = measured_error = None
    if run.measured is not None:
        measured_times, measured = _reference_error(run, target, exact=False)
        measured_error = measured * per_rad
    return ErrorView(times, error, unit, per_rad,
                     'setpoint' if target is None else f'target {target:g} rad', rms, band,
                     None if band is None else inside_from(times, error, band),
                     measured_times, measured_error)


__all__ = ['MAX_COUNTS', 'ErrorOptions', 'ErrorView', 'ErrorViewError', 'error_view',
           'inside_from']
