"""One declaration per parameter: name, type, default, symbol, unit, range, read-only flag,
description and history, written once as a dataclass field.

``x: float = parameter(1.0, 'I1', 'kg·m²', 'inertia of pinion 1', low=0.0, strict=True)``
declares everything about ``x``. A parameter added after recordings exist says since when
and what those recordings ran with: ``introduced='0.2.0', before=0.0`` (``before`` is the
default when not given); a recording by an older version reads with ``before``
(:func:`recorded_without`), so no second table says it. The rest is derived here: the
per-field validation (:func:`validate`), the ROS parameter descriptors
(``ros/parameters.py``, with ``FloatingPointRange``/``IntegerRange``), the packed layout
of the compiled kernel (``kernel=True`` fields, :func:`kernel_fields`), the parameter file
and the table of docs/parameters.md (:func:`yaml_lines`, :func:`markdown_rows`, written
by ``python -m screwgear_ros.params.docs --write`` and tested against both files).
Rules that relate several parameters stay in the classes' ``__post_init__``.
"""

from __future__ import annotations

import functools
import math
import numbers
import re
from collections.abc import Iterator
from dataclasses import MISSING, Field, dataclass, field, fields
from enum import Enum
from typing import Any

import numpy as np

from ..errors import ScrewgearError


class ParameterError(ScrewgearError, ValueError):
    """A parameter value that breaks a rule; says which, what and why.

    Parameters
    ----------
    name : str
        The parameter's name, as the node declares it.
    value : object
        The value refused (shown cut to a line in the message).
    rule : str
        The rule it breaks, with the bound or reason.

    Examples
    --------
    >>> from screwgear_ros import ParameterError, TableParams
    >>> try:
    ...     TableParams(inertia_table=0.0)
    ... except ParameterError as exc:
    ...     print(exc.name)
    inertia_table
    """

    def __init__(self, name: str, value: Any, rule: str) -> None:
        self.name = name
        self.value = value
        self.rule = rule
        super().__init__(f'parameter {name!r} = {excerpt(value)} refused: {rule}')


#: Longest text of a refused value in a message: a value of 10⁵ elements must not make a
#: log line of megabytes.
EXCERPT_CHARS = 120


def excerpt(value: Any) -> str:
    """``repr(value)``, cut to EXCERPT_CHARS with the element count of a long list."""
    if isinstance(value, (list, tuple)) and len(value) > 8:
        head = ', '.join(repr(v) for v in value[:4])
        text = f'[{head}, … ({len(value)} elements)]'
    else:
        text = repr(value)
    return text if len(text) <= EXCERPT_CHARS else text[:EXCERPT_CHARS - 1] + '…'



class Kind(Enum):
    """What a parameter holds; derived from its default."""

    FLOAT = 'double'
    INTEGER = 'integer'
    FLOATS = 'double list'
    STRINGS = 'string list'
    BOOL = 'bool'
    TEXT = 'string'
    CHOICE = 'one of'


@dataclass(frozen=True)
class Declaration:
    """Everything about one parameter besides its name and default."""

    symbol: str
    unit: str
    description: str
    low: float | None = None         # smallest value (each element for lists)
    high: float | None = None        # largest value
    strict: bool = False             # low itself is refused (> low)
    zero: bool = False               # 0 is also valid (it switches the feature off)
    max_items: int | None = None     # longest list
    why: str = ''                    # why the bounds are what they are
    read_only: bool = False          # fixed for a run
    kernel: bool = False             # a scalar of the compiled model's packed array
    note: str = ''                   # why the default is what it is (parameter file)
    introduced: str = ''             # package version that added it ('' = every recording has it)
    before: Any = None               # what recordings made before `introduced` ran with

    def range_text(self) -> str:
        """'> 0', '>= 0', '1 … 3', '0 or 0.01 … 1000', '≤ 32 items', or '' when unbounded."""
        text = ''
        if self.low is not None and self.high is not None:
            text = f'{"> " if self.strict else ""}{self.low:g} … {self.high:g}'
        elif self.low is not None:
            text = f'{">" if self.strict else ">="} {self.low:g}'
        elif self.high is not None:
            text = f'<= {self.high:g}'
        if self.zero and text:
            text = f'0 or {text}'
        if self.max_items is not None:
            text = ', '.join(x for x in (text, f'at most {self.max_items} items') if x)
        return text


def parameter(default: Any, symbol: str, unit: str, description: str, **options: Any) -> Any:
    """A dataclass field carrying its :class:`Declaration` (see the module docstring).

    ``introduced`` must be a version of this package (X.Y.Z); ``before`` needs it and
    defaults to ``default`` (the parameter then changed nothing the older runs did).
    """
    if options.get('introduced'):
        version_key(options['introduced'])          # a malformed version fails at import
        options.setdefault('before', default)
    elif 'before' in options:
        raise TypeError(f'{description!r}: before= says what recordings made before the '
                        'parameter ran with, so it needs introduced=')
    return field(default=default, metadata={'declaration': Declaration(symbol, unit,
                                                                       description, **options)})


@dataclass(frozen=True)
class Parameter:
    """A declared parameter as the rest of the code sees it."""

    name: str
    default: Any
    kind: Kind
    declaration: Declaration
    choices: tuple[str, ...] = ()

    @property
    def ros_default(self) -> Any:
        """The default as a ROS parameter value (lists, enum strings)."""
        return plain(self.default)


def kind_of(default: Any) -> Kind:
    if isinstance(default, bool):
        return Kind.BOOL
    if isinstance(default, Enum):
        return Kind.CHOICE
    if isinstance(default, int):
        return Kind.INTEGER
    if isinstance(default, float):
        return Kind.FLOAT
    if isinstance(default, str):
        return Kind.TEXT
    if isinstance(default, tuple) and all(isinstance(v, str) for v in default):
        return Kind.STRINGS
    if isinstance(default, tuple):
        return Kind.FLOATS
    raise TypeError(f'no parameter kind for a default of {default!r}')


def declared(cls: type) -> Iterator[Parameter]:
    """The declared parameters of a dataclass, in declaration order."""
    return iter(_declared(cls))


@functools.cache
def _declared(cls: type) -> tuple[Parameter, ...]:
    # every construction of a parameter set validates through this list: built once
    # per class (a class's fields and their frozen declarations never change)
    found = []
    for f in fields(cls):
        declaration = f.metadata.get('declaration')
        if declaration is None:
            raise TypeError(f'{cls.__name__}.{f.name} has no declaration (use parameter())')
        default = _default(f)
        choices = tuple(m.value for m in type(default)) if isinstance(default, Enum) else ()
        found.append(Parameter(f.name, default, kind_of(default), declaration, choices))
    return tuple(found)


def _default(f: Field) -> Any:
    if f.default is MISSING:
        raise TypeError(f'{f.name} has no default')
    return f.default


def version_key(version: str) -> tuple[int, int, int]:
    """(0, 2, 0) for '0.2.0': this package's versions are plain X.Y.Z (setup.py and
    package.xml's ``<version>`` require it), so they compare as tuples of whole numbers.

    Raises ValueError for any other text.
    """
    found = re.fullmatch(r'(\d+)\.(\d+)\.(\d+)', version, re.ASCII)
    if found is None:
        raise ValueError(f'{version!r} is not a version of screwgear_ros (X.Y.Z)')
    major, minor, patch = (int(n) for n in found.groups())
    return major, minor, patch


def recorded_without(p: Parameter, version: str) -> bool:
    """Whether a recording made by package ``version`` predates parameter ``p``: it then
    carries no value of ``p`` and ran with ``p.declaration.before``.

    False when ``p`` has been there from the first version, and for a version that is not
    X.Y.Z (nothing then says the recording is older).
    """
    if not p.declaration.introduced:
        return False
    try:
        return version_key(version) < version_key(p.declaration.introduced)
    except ValueError:
        return False


def kernel_fields(cls: type) -> tuple[str, ...]:
    """Names of the scalars packed for the compiled kernel, in layout order."""
    return tuple(p.name for p in declared(cls) if p.declaration.kernel)


def plain(value: Any) -> Any:
    """A value as a ROS parameter / YAML value: lists for tuples, strings for enums."""
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, tuple):
        return [plain(v) for v in value]
    return value


# ---------------------------------------------------------------- validation

def _is_number(value: Any) -> bool:
    """A real number (Python or NumPy scalar) a double can hold, but not a bool."""
    if not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_)):
        return False
    try:
        float(value)
    except OverflowError:           # an integer beyond any double
        return False
    return True


def _number(p: Parameter, value: Any, shown: Any) -> float:
    d = p.declaration
    if not _is_number(value):
        raise ParameterError(p.name, shown, 'must be a number' if p.kind is not Kind.FLOATS
                             else 'must be a list of numbers')
    if not math.isfinite(value):
        raise ParameterError(p.name, shown, 'must be finite')
    if d.zero and value == 0:
        return float(value)
    if ((d.low is not None and (value <= d.low if d.strict else value < d.low))
            or (d.high is not None and value > d.high)):
        why = f' ({d.why})' if d.why else ''
        raise ParameterError(p.name, shown, f'must be {d.range_text()}{why}')
    return float(value)


def check(p: Parameter, value: Any) -> Any:
    """``value`` converted to the parameter's type, or a :class:`ParameterError`."""
    if p.kind is Kind.FLOAT:
        return _number(p, value, value)
    if p.kind is Kind.INTEGER:
        if not _is_number(value) or not math.isfinite(value) or value != int(value):
            raise ParameterError(p.name, value, 'must be a whole number')
        return int(_number(p, value, value))
    if p.kind is Kind.FLOATS:
        if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
            raise ParameterError(p.name, value, 'must be a list of numbers')
        values = list(value)
        limit = p.declaration.max_items
        if limit is not None and len(values) > limit:
            why = f' ({p.declaration.why})' if p.declaration.why else ''
            raise ParameterError(p.name, values, f'has {len(values)} items, at most {limit} '
                                 f'allowed{why}')
        return tuple(_number(p, v, values) for v in values)
    if p.kind is Kind.CHOICE:
        try:
            return type(p.default)(value)
        except ValueError:
            raise ParameterError(p.name, value, 'must be one of '
                                 + ', '.join(p.choices)) from None
    if p.kind is Kind.BOOL:
        if not isinstance(value, (bool, np.bool_)):
            raise ParameterError(p.name, value, 'must be true or false')
        return bool(value)
    if p.kind is Kind.TEXT:
        if not isinstance(value, str):
            raise ParameterError(p.name, value, 'must be a string')
        return value
    if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__') or not all(
            isinstance(v, str) for v in value):
        raise ParameterError(p.name, value, 'must be a list of strings')
    return tuple(value)


def validate(instance: Any) -> None:
    """Check and convert every declared field of a frozen dataclass in place."""
    for p in declared(type(instance)):
        object.__setattr__(instance, p.name, check(p, getattr(instance, p.name)))


# ---------------------------------------------------------------- documents

def yaml_lines(*classes: type, indent: str = '    ') -> list[str]:
    """``name: default  # symbol, unit (note)`` for every parameter, as in a ROS
    parameter file (floats written so that YAML 1.1 reads them back as floats)."""
    lines = []
    for cls in classes:
        for p in declared(cls):
            d = p.declaration
            comment = (', '.join(x for x in (d.symbol, d.unit) if x) if d.symbol
                       else ', '.join(x for x in (d.description, d.unit) if x))
            comment += f' ({d.note})' if d.note else ''
            lines.append(f'{indent}{p.name}: {yaml_value(p.ros_default)}  # {comment}')
    return lines


def yaml_value(value: Any) -> str:
    """One YAML 1.1 scalar or flow list; floats always with a '.' (1.0e-06, not 1e-06)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        text = repr(value)
        if 'e' in text and '.' not in text.split('e')[0]:
            mantissa, exponent = text.split('e')
            text = f'{mantissa}.0e{exponent}'
        return text
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return f"'{value}'"
    return '[' + ', '.join(yaml_value(v) for v in value) + ']'


def markdown_rows(cls: type) -> list[str]:
    """``| `name` | symbol | default | unit | range | description |`` per parameter."""
    rows = []
    for p in declared(cls):
        d = p.declaration
        default = p.ros_default
        shown = ', '.join(f'{v:g}' if isinstance(v, float) else str(v) for v in default) \
            if isinstance(default, list) else (f'{default:g}' if isinstance(default, float)
                                               else str(default).lower()
                                               if isinstance(default, bool) else str(default))
        allowed = ' \\| '.join(p.choices) if p.choices else d.range_text()
        ro = ' (read-only)' if d.read_only else ''
        shown = shown or "''"
        rows.append(f'| `{p.name}` | {d.symbol or "–"} | {shown} | {d.unit or "–"} | '
                    f'{allowed or "–"} | {d.description}{ro} |')
    return rows


__all__ = [
    'EXCERPT_CHARS',
    'Declaration',
    'Kind',
    'Parameter',
    'ParameterError',
    'check',
    'declared',
    'excerpt',
    'kernel_fields',
    'markdown_rows',
    'parameter',
    'plain',
    'recorded_without',
    'validate',
    'version_key',
    'yaml_lines',
    'yaml_value',
]
