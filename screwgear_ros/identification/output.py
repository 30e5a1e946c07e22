"""FITTED.yaml: the base parameter file with the fitted values written in.

The base file's text is kept (its comments and order): a fitted parameter's line gets
the new value, with its ±2σ interval as the line's comment; a parameter the file did
not set is added at the end of its ``ros__parameters`` block. A header says where the
values come from, and, for an interrupted fit, that they are unfinished. The result is
read back and compared, so a file that would not load as written is never left behind.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path

from .adapter import base_values
from .errors import IdentifyError
from .stats import Estimate


def _number(value: float) -> str:
    """The shortest text that reads back as ``value`` in YAML 1.1 (PyYAML, the ROS 2
    parameter file parser): its exponent form needs a point in the mantissa."""
    text = repr(float(value))
    mantissa, e, exponent = text.partition('e')
    return f'{mantissa}.0e{exponent}' if e and '.' not in mantissa else text


def _comment(e: Estimate) -> str:
    if math.isfinite(e.low) and math.isfinite(e.high):
        text = f'fitted, ±2σ: {e.low:.8g} … {e.high:.8g}'
    else:
        text = 'fitted'
    return text + (f'; undetermined: {e.undetermined}' if e.undetermined else '')


def fitted_text(base: str, estimates: Sequence[Estimate], header: Sequence[str]) -> str:
    """``base`` (a parameter file's text) with ``estimates`` written in."""
    lines = base.splitlines()
    missing = []
    for e in estimates:
        pattern = re.compile(rf'^(\s*){re.escape(e.name)}\s*:\s*([^#]*?)\s*(#.*)?$')
        for k, line in enumerate(lines):
            match = pattern.match(line)
            if match:
                lines[k] = f'{match.group(1)}{e.name}: {_number(e.value)}   # {_comment(e)}'
                break
        else:
            missing.append(e)
    if missing:
        block = [k for k, line in enumerate(lines) if re.match(r'^\s*ros__parameters\s*:', line)]
        if block:
            indent = len(lines[block[-1]]) - len(lines[block[-1]].lstrip()) + 2
            end = len(lines)
            for k in range(block[-1] + 1, len(lines)):
                text = lines[k]
                if text.strip() and not text.lstrip().startswith('#') and \
                        len(text) - len(text.lstrip()) < indent:
                    end = k
                    break
            while end > block[-1] + 1 and not lines[end - 1].strip():
                end -= 1
        else:
            if not lines:
                lines = ['/**:', '  ros__parameters:']
                indent, end = 4, 2
            else:
                indent, end = 0, len(lines)
        added = [f'{" " * indent}{e.name}: {_number(e.value)}   # {_comment(e)}'
                 for e in missing]
        lines[end:end] = added
    return '\n'.join([*(f'# {h}' for h in header), *lines]) + '\n'


def write_fitted(base_path: str | os.PathLike[str], out: str | os.PathLike[str],
                 estimates: Sequence[Estimate], header: Sequence[str]) -> Path:
    """Write FITTED.yaml (see the module docstring) and check it loads with the values.

    Raises
    ------
    IdentifyError
        The written file does not read back with the fitted values.
    """
    base = Path(base_path).read_text(encoding='utf-8')
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(fitted_text(base, estimates, header), encoding='utf-8')
    values = base_values(out)
    wrong = [e.name for e in estimates if values.get(e.name) != e.value]
    if wrong:
        raise IdentifyError(f'{out}: the fitted values of {", ".join(wrong)} do not read '
                            'back from the file written (a parameter file laid out in a way '
                            'this writer does not follow)')
    return out


__all__ = ['fitted_text', 'write_fitted']
