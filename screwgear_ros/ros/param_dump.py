"""A node's parameters as a ROS 2 parameter file that ``--params-file`` reads back exactly.

:func:`render` writes name → value under ``/**:`` / ``ros__parameters`` (any node name,
any namespace); :func:`write` replaces a file with it atomically; :func:`keep_written`
makes a node rewrite its file at start and after every accepted parameter change
(``table_sim --dump-params FILE``). Imports no rclpy.

Both readers of a parameter file decide a scalar's type from its text alone: rcl's
parser (``--params-file``, launch) and PyYAML's YAML 1.1 (``ros2 param load``). So:

* a float is Python's shortest round-trip text with a decimal point in its mantissa
  (``1.0e-06``, ``7.5e-05``): YAML 1.1 reads ``1e-06`` as a string;
* ``.inf``, ``-.inf`` and ``.nan`` for the non-finite ones;
* strings are double-quoted, so ``'12'`` or ``'true'`` stay strings, and so are names
  YAML 1.1 reads as a bool or null (``off``).

What no parameter file can carry is left out and named in the file and in the list
:func:`render` returns: a subnormal float (rcl's parser reads it as a string, its
``strtod`` reports an underflow), an empty array (rcl reads ``[]`` as "not set"), byte
arrays; and the parameters in :data:`RUN_OUTPUTS`, which name the output of one run.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from ..errors import ScrewgearError

#: Parameters that name where one run writes: a restored table must not reuse them.
RUN_OUTPUTS = ('record',)
#: Where ``--params-file`` applies the file: every node, any namespace.
WILDCARD = '/**'
INDENT = '    '
#: Plain words YAML 1.1 reads as a bool or null: a parameter (or key part) so named is
#: written quoted, or ``ros2 param load`` would see the key ``False`` for ``off``.
_YAML11_WORDS = re.compile(r'y|Y|yes|Yes|YES|n|N|no|No|NO|true|True|TRUE|false|False|FALSE|'
                           r'on|On|ON|off|Off|OFF|null|Null|NULL|~')


class Unwritable(ScrewgearError, ValueError):
    """A value no parameter file can carry exactly."""


def _float(x: float) -> str:
    if math.isnan(x):
        return '.nan'
    if math.isinf(x):
        return '.inf' if x > 0 else '-.inf'
    if x != 0.0 and abs(x) < sys.float_info.min:
        raise Unwritable(f'{x!r} is subnormal: rcl reads it back as a string')
    text = repr(x)
    mantissa, e, exponent = text.partition('e')
    if '.' not in mantissa:
        mantissa += '.0'
    return mantissa + e + exponent


def scalar(value: Any) -> str:
    """The YAML text of one parameter value (see the module docstring)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return _float(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)    # a YAML double-quoted scalar
    if isinstance(value, (bytes, bytearray)):
        raise Unwritable('a byte array has no parameter file form')
    if isinstance(value, (list, tuple)) or hasattr(value, 'tolist'):
        items = list(value)
        if not items:
            raise Unwritable('an empty array reads back as "not set"')
        if isinstance(items[0], bytes):
            raise Unwritable('a byte array has no parameter file form')
        return '[' + ', '.join(scalar(v) for v in items) + ']'
    raise Unwritable(f'{type(value).__name__} is not a parameter type')


def render(values: Mapping[str, Any], header: str = '') -> tuple[str, list[tuple[str, str]]]:
    """(file text, (name, why) of each parameter left out), parameters in name order.

    Dotted names (``a.b``) are nested as ``ros2 param dump`` nests them.
    """
    left_out: list[tuple[str, str]] = []
    tree: dict[str, Any] = {}
    for name in sorted(values):
        if name in RUN_OUTPUTS:
            left_out.append((name, f'the output of one run (give it anew: -p {name}:=...)'))
            continue
        try:
            text = scalar(values[name])
        except Unwritable as why:
            left_out.append((name, str(why)))
            continue
        node = tree
        *parents, leaf = name.split('.')
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = text
    lines = [f'# {line}' if line else '#' for line in header.splitlines()]
    lines += [f'# left out: {name}: {why}' for name, why in left_out]
    lines += [f'{WILDCARD}:', f'{INDENT}ros__parameters:']
    lines += _lines(tree, 2)
    return '\n'.join(lines) + '\n', left_out


def _lines(tree: Mapping[str, Any], depth: int) -> list[str]:
    out = []
    for name, value in tree.items():
        key = json.dumps(name) if _YAML11_WORDS.fullmatch(name) else name
        if isinstance(value, dict):
            out.append(f'{INDENT * depth}{key}:')
            out += _lines(value, depth + 1)
        else:
            out.append(f'{INDENT * depth}{key}: {value}')
    return out


def write(path: str | os.PathLike, values: Mapping[str, Any],
          header: str = '') -> list[tuple[str, str]]:
    """Replace ``path`` with :func:`render`'s text in one step (a reader never sees half
    a file); return what was left out. Raises OSError when it cannot be written."""
    path = Path(path)
    text, left_out = render(values, header)
    fd, tmp = tempfile.mkstemp(prefix=f'.{path.name}.', dir=path.parent or Path('.'))
    try:
        with os.fdopen(fd, 'w', encoding='utf-8') as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return left_out


def node_values(node: Any) -> dict[str, Any]:
    """Every parameter of an rclpy node, name → plain Python value."""
    names = node.list_parameters([], 0).names
    return {p.name: (list(p.value) if isinstance(p.value, (list, tuple)) or
                     hasattr(p.value, 'tolist') else p.value)
            for p in node.get_parameters(names)}


def keep_written(node: Any, path: str | os.PathLike,
                 log: Callable[[str], None], error: Callable[[str], None]) -> None:
    """Write ``node``'s parameters to ``path`` now and after every accepted change.

    A first write that fails raises OSError (the caller refuses to start); a later
    one is reported through ``error`` and the node runs on with the file as it was.
    """
    header = (f'parameters of {node.get_fully_qualified_name()}, rewritten after every '
              f'accepted change;\nrestore: table_sim --ros-args --params-file {path}')
    told: set[tuple[str, str]] = set()

    def dump() -> None:
        left_out = write(path, node_values(node), header)
        for name, why in left_out:
            if name not in RUN_OUTPUTS and (name, why) not in told:
                log(f'--dump-params {path}: left out {name}: {why}')
        told.update(left_out)

    def after_set(_changed: Iterable[Any]) -> None:
        try:
            dump()
        except OSError as why:
            error(f'--dump-params {path}: not rewritten ({why.strerror or why}); it '
                  'holds the values before this change')

    try:
        dump()
    except OSError as why:
        raise OSError(f'--dump-params {path}: {why.strerror or why}') from why
    node.add_post_set_parameters_callback(after_set)


__all__ = [
    'RUN_OUTPUTS',
    'WILDCARD',
    'Unwritable',
    'keep_written',
    'node_values',
    'render',
    'scalar',
    'write',
]
