"""What the user knows before a fit: parameters held at a given value (``--fix
NAME=VALUE``), checked as the node checks a parameter file's values."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from .adapter import Diverged, declarations, model
from .errors import FitParameterError


def parse_fix(items: Sequence[str]) -> dict[str, float]:
    """``NAME=VALUE`` strings → {name: value}.

    Examples
    --------
    >>> parse_fix(['preload_torque=290'])
    {'preload_torque': 290.0}
    """
    out = {}
    for item in items:
        name, sep, text = item.partition('=')
        try:
            if not sep:
                raise ValueError
            value = float(text)
        except ValueError:
            raise FitParameterError(f'--fix {item!r}: not NAME=VALUE') from None
        if not math.isfinite(value):
            raise FitParameterError(f'--fix {item!r}: the value is not finite')
        out[name.strip()] = value
    return out


def fixed(base: Mapping[str, Any], fix: Mapping[str, float], fit: Sequence[str]
          ) -> dict[str, Any]:
    """``base`` with the ``fix`` values (a parameter of the model, not also fitted)."""
    known = declarations()
    for name in fix:
        if name not in known:
            raise FitParameterError(f'--fix {name}: not a parameter of table_sim')
        if name in fit:
            raise FitParameterError(f'--fix {name}: also in --fit; a parameter is held or '
                                    'fitted, not both')
    values = {**base, **fix}
    try:
        model(values)
    except Diverged as exc:
        raise FitParameterError(f'--fix: {exc}') from None
    return values


__all__ = ['fixed', 'parse_fix']
