"""What ``identify`` refuses: each kind of bad input is its own class.

Every class derives from :class:`screwgear_ros.errors.ScrewgearError` and from
``ValueError`` (bad input), so ``except ScrewgearError`` catches them with the rest of
the package's refusals.
"""

from __future__ import annotations

from ..errors import ScrewgearError


class IdentifyError(ScrewgearError, ValueError):
    """Input that ``identify`` cannot fit; the message names the problem.

    Examples
    --------
    >>> from screwgear_ros import IdentifyError, identify
    >>> try:
    ...     identify(['no/such/bag'], 'no/such/base.yaml', ['inertia_table'])
    ... except IdentifyError as exc:
    ...     print('no/such' in str(exc))
    True
    """


class RecordingError(IdentifyError):
    """A bag that cannot serve: no joint_states, no commands, values that are not
    finite, joints that do not match, a sample rate the model does not run at."""


class FitParameterError(IdentifyError):
    """A parameter to fit that is unknown, fixed for a run (read-only), not a real
    number, or given bounds outside its declared range."""


class TooShortError(IdentifyError):
    """Recordings with too few samples for the number of parameters asked for."""


class FitFailed(IdentifyError):
    """A fit that found no point where the model runs: nothing is written."""


__all__ = ['FitFailed', 'FitParameterError', 'IdentifyError', 'RecordingError',
           'TooShortError']
