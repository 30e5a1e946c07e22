"""FITTED.yaml: the base parameter file with the fitted values written in.

The base file's text is kept (its comments and order): a fitted parameter's line gets
the new value, with its ±2σ interval as the line's comment; a parameter the file did
not set is added at the end of its ``ros__parameters`` block. A comment elsewhere that
quotes a fitted parameter's base value with its unit ("4 N·m") gets the fitted value
beside it, so no comment states a value the file no longer holds. A header says where
the values come from, and, for an interrupted fit, that they are unfinished. The file is
written beside its place, read back and compared, and only then moved there: a file
that would not load as written is never left behind. :func:`rehearse` does the same
before the fit, with trial values, and keeps nothing.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..inprocess.simulation import ParameterFileError, file_values
from .adapter import base_values
from .errors import FitParameterError, IdentifyError
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


def _annotate(line: str, estimates: Sequence[Estimate]) -> str:
    """A comment line with each quoted base value of a fitted parameter (with its unit)
    followed by the fitted value."""
    for e in estimates:
        if not e.unit or e.value == e.base or not math.isfinite(e.base):
            continue
        quoted = re.compile(rf'(?<![\d.]){re.escape(f"{e.base:g}")}(?:\.0*)?\s*'
                            rf'{re.escape(e.unit)}(?![\w])')
        note = f' (base; fitted {e.value:.6g} {e.unit})'
        line = quoted.sub(lambda m: m.group(0) + note, line)  # noqa: B023 (used at once)
    return line


def fitted_text(base: str, estimates: Sequence[Estimate], header: Sequence[str],
                settings: Mapping[str, Sequence[str]] | None = None) -> str:
    """``base`` (a parameter file's text) with ``estimates`` written in, and ``settings``
    (name → list of names: the --joints mapping as ``joint_names``)."""
    lines = [_annotate(line, estimates) if line.lstrip().startswith('#') else line
             for line in base.splitlines()]
    entries = [(e.name, _number(e.value), _comment(e)) for e in estimates]
    entries += [(name, json.dumps(list(value)), 'the recordings\' names (--joints)')
                for name, value in (settings or {}).items()]
    missing = []
    for name, text, comment in entries:
        pattern = re.compile(rf'^(\s*){re.escape(name)}\s*:\s*([^#]*?)\s*(#.*)?$')
        for k, line in enumerate(lines):
            match = pattern.match(line)
            if match:
                lines[k] = f'{match.group(1)}{name}: {text}   # {comment}'
                break
        else:
            missing.append((name, text, comment))
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
        added = [f'{" " * indent}{name}: {text}   # {comment}' for name, text, comment in missing]
        lines[end:end] = added
    return '\n'.join([*(f'# {h}' for h in header), *lines]) + '\n'


def _write(base_path: str | os.PathLike[str], out: str | os.PathLike[str],
           estimates: Sequence[Estimate], header: Sequence[str], keep: bool,
           settings: Mapping[str, Sequence[str]] | None = None) -> Path:
    base = Path(base_path).read_text(encoding='utf-8')
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f'.{out.name}.', suffix='.partial', dir=out.parent)
    partial = Path(name)
    try:
        with os.fdopen(handle, 'w', encoding='utf-8') as stream:
            stream.write(fitted_text(base, estimates, header, settings))
        try:
            values: Mapping[str, Any] = base_values(partial) if keep else \
                file_values(partial)
        except (ParameterFileError, FitParameterError) as exc:
            raise IdentifyError(f'-o {out}: the file written would not load: '
                                f'{str(exc).replace(str(partial), str(out))}') from None
        wrong = [e.name for e in estimates if values.get(e.name) != e.value]
        wrong += [name for name, value in (settings or {}).items()
                  if list(values.get(name) or ()) != list(value)]
        if wrong:
            raise IdentifyError(
                f'--params {base_path}: the fitted values of {", ".join(wrong)} would not '
                'read back from the file written: its layout is not one this writer '
                'follows; write the base file with one block-style ros__parameters '
                '(/**: then ros__parameters: then one NAME: VALUE a line)')
        if keep:
            os.replace(partial, out)
        return out
    finally:
        partial.unlink(missing_ok=True)


def write_fitted(base_path: str | os.PathLike[str], out: str | os.PathLike[str],
                 estimates: Sequence[Estimate], header: Sequence[str],
                 settings: Mapping[str, Sequence[str]] | None = None) -> Path:
    """Write FITTED.yaml (see the module docstring) and check it loads with the values.

    Raises
    ------
    IdentifyError
        The written file does not read back with the fitted values (nothing is left).
    """
    return _write(base_path, out, estimates, header, True, settings)


def rehearse(base_path: str | os.PathLike[str], out: str | os.PathLike[str],
             trials: Mapping[str, float],
             settings: Mapping[str, Sequence[str]] | None = None) -> None:
    """Before a fit: write the base file with ``trials`` (name → a value other than the
    base's) beside ``out``, read it back and remove it.

    Raises
    ------
    IdentifyError
        ``out``'s folder is not writable, or the values would not read back.
    """
    estimates = [Estimate(name, value, math.nan, math.nan, math.nan, '')
                 for name, value in trials.items()]
    try:
        _write(base_path, out, estimates, [], False, settings)
    except OSError as exc:
        raise IdentifyError(f'-o {out}: cannot write there: {exc.strerror or exc}') from None


__all__ = ['fitted_text', 'rehearse', 'write_fitted']
