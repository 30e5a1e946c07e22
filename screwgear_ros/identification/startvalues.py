"""Starting values read off the data where physics allows, before the local search.

- ``preload_torque`` from the recorded effort: the drive that does not drive holds its
  pinion at the preload (the preload law: one path drives, the other keeps the preload
  torque), so the smaller of the two pinions' |effort| is the preload at every sample
  the drive is in a steady path, at rest too. The median over the recording ignores the
  moments of a reversal. A recording whose ``joint_states`` carry no effort gives
  nothing.

Each value found moves every starting point's coordinate of that parameter (the draws
stay spread around it), and the report names where it came from.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .parameters import FitParameter
from .samples import Recording


def preload_from_effort(recordings: Sequence[Recording]) -> float:
    """The median over all samples of min(|effort pinion 1|, |effort pinion 3|), N·m
    (NaN: no recording carries the pinions' efforts).

    Examples
    --------
    >>> import numpy as np
    >>> from screwgear_ros.identification.samples import Recording
    >>> effort = np.array([[330.0, 0, -330], [336.5, 17, -330], [330, -4, -338]])
    >>> r = Recording('r', np.arange(3), np.zeros((3, 3)), np.zeros((3, 3)), (), effort)
    >>> preload_from_effort([r])
    330.0
    """
    parts = []
    for recording in recordings:
        effort = recording.effort
        if effort is None:
            continue
        held = np.minimum(np.abs(effort[:, 0]), np.abs(effort[:, 2]))
        parts.append(held[np.isfinite(held)])
    values = np.concatenate(parts) if parts else np.empty(0)
    return float(np.median(values)) if len(values) else math.nan


def data_starts(fitted: Sequence[FitParameter], recordings: Sequence[Recording]
                ) -> dict[str, tuple[float, str]]:
    """name → (starting value, where it comes from), for the fitted parameters the data
    give one for (within their bounds)."""
    found: dict[str, tuple[float, str]] = {}
    names = {p.name: p for p in fitted}
    if 'preload_torque' in names:
        value = preload_from_effort(recordings)
        p = names['preload_torque']
        if math.isfinite(value) and p.low < value < p.high:
            found[p.name] = (value, ('the recorded effort of the pinion that holds the '
                             'preload (median)'))
    return found


def moved(fitted: Sequence[FitParameter], points: Sequence[np.ndarray],
          found: dict[str, tuple[float, str]]) -> list[np.ndarray]:
    """``points`` with each found parameter's coordinate moved from the base value to
    the found one (clipped to the bounds)."""
    out = [np.array(x, dtype=np.float64) for x in points]
    for j, p in enumerate(fitted):
        if p.name not in found or p.base <= 0.0 and p.scale.value == 'log':
            continue
        shift = p.to_x(found[p.name][0]) - p.to_x(min(max(p.base, p.low), p.high))
        lo, hi = p.x_bounds
        for x in out:
            x[j] = min(max(x[j] + shift, lo + 1e-9 * (hi - lo)), hi - 1e-9 * (hi - lo))
    return out


__all__ = ['data_starts', 'moved', 'preload_from_effort']
