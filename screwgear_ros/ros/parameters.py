"""The node's ROS parameters, derived from their one declaration (the fields of
:class:`~screwgear_ros.params.table.TableParams` and :class:`~screwgear_ros.params.table.SimSettings`,
see :mod:`screwgear_ros.params.declarations`).

Each is declared with its default's type, a description with symbol and unit,
``read_only`` where a run cannot change it, and a ``FloatingPointRange`` or
``IntegerRange`` wherever its valid values are an interval (``ros2 param describe``
shows it; rqt_reconfigure makes a slider of it). Values are then checked by the core's
own validation (:func:`screwgear_ros.sim.parameter_set.split_parameters`), so a refusal carries
the core's :class:`~screwgear_ros.params.table.ParameterError` text; rclpy itself refuses a
value outside a declared range before that.

Harmonics in one set: ``ste_amplitudes`` and ``ste_phases`` must have one entry per
STE harmonic. When a set makes their lengths differ, the shorter one is completed
with zeros (a missing phase is 0 rad, a missing amplitude 0 m: that harmonic off) and
set together with it, so ``ros2 param set /table_sim ste_amplitudes "[1.0e-6, 2.0e-7]"``
alone changes the number of harmonics; the node logs what it completed once the set
was applied. The longer one is cut only where it holds zeros: a set of one array that
would drop a nonzero entry of the other is refused (the arrays' lengths differ), and the
node logs a warning saying which value it would have lost; set both arrays in one set
to remove a harmonic. The same rules hold at start, for ``-p`` and ``--params-file`` values, as
for a set at run time: an integer where a double is declared is that double (YAML and
``ros2 param set`` read ``46`` as an integer), and one STE array given without the
other completes the other.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..params.declarations import Kind, declared, excerpt
from ..params.table import MAX_HARMONICS, SimSettings, TableParams

#: Every node parameter, in declaration order.
PARAMETERS = (*declared(TableParams), *declared(SimSettings))
#: The pair of STE arrays that must be as long as each other.
HARMONICS = ('ste_amplitudes', 'ste_phases')
#: Prefix of a pre-set note that says why the STE arrays were not completed.
REFUSED = 'refused: '

_INT_MAX = 2 ** 31 - 1


def descriptor(p: Any) -> ParameterDescriptor:
    """The ROS descriptor of a declared parameter (see the module docstring)."""
    d = p.declaration
    head = ', '.join(x for x in (d.symbol, d.description) if x)
    text = f'{head}, {d.unit}' if d.unit else head
    constraints = d.range_text() + (f' ({d.why})' if d.why else '')
    if p.choices:
        constraints = 'one of ' + ', '.join(p.choices)
    desc = ParameterDescriptor(description=text, read_only=d.read_only,
                               additional_constraints=constraints)
    if d.low is not None or d.high is not None:
        low = -math.inf if d.low is None else 0.0 if d.zero else float(d.low)
        high = math.inf if d.high is None else float(d.high)
        if p.kind is Kind.FLOAT:
            desc.floating_point_range = [FloatingPointRange(from_value=low, to_value=high,
                                                            step=0.0)]
        elif p.kind is Kind.INTEGER:
            desc.integer_range = [IntegerRange(
                from_value=int(max(low, -_INT_MAX)), to_value=int(min(high, _INT_MAX)),
                step=1)]
    return desc


def declare(node: Node, log: Callable[[str], None]) -> tuple[dict[str, Any], str | None]:
    """Declare every table_sim parameter on ``node``; return name → value in force and
    what the start completed of the STE harmonics (None: nothing), for the caller to
    log once the start's values are accepted.

    ``log`` is told, once a set applied it, when it completed the STE harmonics.
    Raises rclpy's ParameterException when a parameter file gives a value of the wrong
    type (e.g. a string for a number) or outside a declared range.
    """
    notes: list[str] = []           # of the set in progress; logged once it was applied

    def pre_set(params: list[Parameter]) -> list[Parameter]:
        notes.clear()
        params, note = _complete_harmonics(node, _integers_as_doubles(node, params))
        if note is not None and note.startswith(REFUSED):
            # the validation refuses the lengths; this says why they were not made equal
            node.get_logger().warning(note[len(REFUSED):])
        elif note:
            notes.append(note)
        return params

    def post_set(params: list[Parameter]) -> None:
        for note in notes:
            log(note)
        notes.clear()

    note = _start_overrides(node)
    declared_now = node.declare_parameters('', [(p.name, p.ros_default, descriptor(p))
                                                for p in PARAMETERS])
    node.add_pre_set_parameters_callback(pre_set)
    node.add_post_set_parameters_callback(post_set)
    return {p.name: plain_value(p.value) for p in declared_now}, note


def _start_overrides(node: Node) -> str | None:
    """The start's values (``-p``, ``--params-file``) under the run-time rules:
    integers for doubles become doubles, and one STE array given alone completes the
    other (rclpy declares from these overrides). What was completed, or None."""
    overrides = getattr(node, '_parameter_overrides', {})   # rclpy keeps them here
    wanted = {p.name: p for p in PARAMETERS}
    for name, given in list(overrides.items()):
        p = wanted.get(name)
        if p is not None and p.kind in (Kind.FLOAT, Kind.FLOATS):
            overrides[name] = _as_double(given, p.kind is Kind.FLOAT)
    given = [name for name in HARMONICS if name in overrides]
    if len(given) != 1 or not _is_double_array(overrides[given[0]]):
        return None
    current = {name: list(overrides[name].value) if name in overrides
               else list(wanted[name].ros_default) for name in HARMONICS}
    amplitudes, phases, note = complete_harmonics(current['ste_amplitudes'],
                                                  current['ste_phases'], given[0])
    if note is not None:
        other = HARMONICS[1] if given[0] == HARMONICS[0] else HARMONICS[0]
        value = phases if other == 'ste_phases' else amplitudes
        overrides[other] = Parameter(other, Parameter.Type.DOUBLE_ARRAY,
                                     [float(v) for v in value])
    return note


def plain_value(value: Any) -> Any:
    """A parameter value as plain Python (arrays become lists)."""
    if isinstance(value, (str, bytes, bool, int, float)) or value is None:
        return value
    return list(value)


def unknown_overrides(node: Node) -> list[str]:
    """Names given on the command line or in a parameter file that the node does not
    have (a typo, or a parameter meant for another node under ``/**``)."""
    given = getattr(node, '_parameter_overrides', {})   # rclpy keeps them here
    return sorted(name for name in given
                  if not node.has_parameter(name) and not name.startswith('qos_overrides.'))


def complete_harmonics(amplitudes: list[float], phases: list[float],
                       changed: str) -> tuple[list[float], list[float], str | None]:
    """The STE arrays with the one not being set completed with zeros (or cut, where it
    holds only zeros beyond) to the length of the one being set (``changed``), and what
    was done (None: nothing). A cut that would drop a nonzero entry is not made
    (:func:`dropped_harmonics` says why): the arrays come back as given, and the
    validation refuses their lengths."""
    if len(amplitudes) == len(phases) or max(len(amplitudes), len(phases)) > MAX_HARMONICS:
        return amplitudes, phases, None    # nothing to do, or the validation refuses it
    if dropped_harmonics(amplitudes, phases, changed) is not None:
        return amplitudes, phases, None
    if changed == 'ste_amplitudes':
        n, other, name = len(amplitudes), phases, 'ste_phases'
    else:
        n, other, name = len(phases), amplitudes, 'ste_amplitudes'
    fitted = (list(other) + [0.0] * n)[:n]
    note = (f'{name} set to {excerpt(fitted)} to match {n} STE harmonic{"s" * (n != 1)} of '
            f'{changed} (a missing entry is 0)')
    return ((amplitudes, fitted, note) if name == 'ste_phases' else (fitted, phases, note))


def dropped_harmonics(amplitudes: list[float], phases: list[float], changed: str) -> str | None:
    """Why setting ``changed`` to a shorter array than the other STE array is refused:
    completing it would cut nonzero entries of the other (data lost without a word);
    None when the other holds only zeros beyond (or is not longer).

    Examples
    --------
    >>> print(dropped_harmonics([1e-6, 2e-7], [0.5], 'ste_phases'))
    ste_phases: refused [0.5]: 1 entry would cut ste_amplitudes [1e-06, 2e-07] to 1 STE harmonic and drop its nonzero 2e-07; set both arrays in one set (ros2 param load) to change the number of harmonics
    >>> dropped_harmonics([1e-6, 0.0], [0.5], 'ste_phases') is None
    True
    """
    given, other, name = ((amplitudes, phases, 'ste_phases') if changed == 'ste_amplitudes'
                          else (phases, amplitudes, 'ste_amplitudes'))
    lost = [v for v in other[len(given):] if v != 0.0]
    if not lost:
        return None
    n = len(given)
    return (f'{changed}: refused {excerpt(given)}: {n} entr{"ies" if n != 1 else "y"} would '
            f'cut {name} {excerpt(other)} to {n} STE harmonic{"s" * (n != 1)} and drop its '
            f'nonzero {excerpt(lost[0] if len(lost) == 1 else lost)}; set both arrays in one '
            'set (ros2 param load) to change the number of harmonics')


_DOUBLE_TYPES = {
    ParameterType.PARAMETER_DOUBLE: ParameterType.PARAMETER_INTEGER,
    ParameterType.PARAMETER_DOUBLE_ARRAY: ParameterType.PARAMETER_INTEGER_ARRAY,
}


def _as_double(p: Parameter, scalar: bool) -> Parameter:
    """``p`` as a double (``scalar``) or a double array when it holds integers of that
    shape; otherwise unchanged, for rclpy to refuse its type."""
    if scalar and p.type_ == Parameter.Type.INTEGER:
        return Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
    if not scalar and p.type_ == Parameter.Type.INTEGER_ARRAY:
        return Parameter(p.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in p.value])
    return p


def _is_double_array(p: Parameter) -> bool:
    return p.type_ == Parameter.Type.DOUBLE_ARRAY


def _integers_as_doubles(node: Node, params: Iterable[Parameter]) -> list[Parameter]:
    """Let `ros2 param set table_sim inertia_table 46` mean 46.0 (whole numbers parse
    as integers); other type mismatches are left for rclpy to refuse."""
    out = []
    for p in params:
        if node.has_parameter(p.name):
            wanted = node.describe_parameter(p.name).type
            if wanted in _DOUBLE_TYPES:
                p = _as_double(p, wanted == ParameterType.PARAMETER_DOUBLE)
        out.append(p)
    return out


def _complete_harmonics(node: Node,
                        params: list[Parameter]) -> tuple[list[Parameter], str | None]:
    """Pre-set: a set of one STE array that changes the harmonic count also sets the
    other; what was completed (None: nothing), or REFUSED and why it was not (the set then
    fails its validation: the lengths differ). A value that is no double array is left for
    rclpy to refuse by its type."""
    names = [p.name for p in params]
    if sum(name in HARMONICS for name in names) != 1 or not node.has_parameter(HARMONICS[0]):
        return params, None
    changed = next(p for p in params if p.name in HARMONICS)
    if not _is_double_array(changed):
        return params, None
    current = {name: list(node.get_parameter(name).value) for name in HARMONICS}
    current[changed.name] = plain_value(changed.value)
    why = dropped_harmonics(current['ste_amplitudes'], current['ste_phases'], changed.name)
    if why is not None:
        return params, REFUSED + why
    amplitudes, phases, note = complete_harmonics(current['ste_amplitudes'],
                                                  current['ste_phases'], changed.name)
    if note is None:
        return params, None
    other = 'ste_phases' if changed.name == 'ste_amplitudes' else 'ste_amplitudes'
    value = phases if other == 'ste_phases' else amplitudes
    return ([*params, Parameter(other, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in value])],
            note)


def changed_values(current: dict[str, Any], params: Iterable[Parameter]) -> dict[str, Any]:
    """``current`` with the table_sim parameters among ``params`` replaced."""
    candidate = dict(current)
    for p in params:
        if p.name in candidate:
            candidate[p.name] = plain_value(p.value)
    return candidate


__all__ = [
    'HARMONICS',
    'PARAMETERS',
    'changed_values',
    'complete_harmonics',
    'declare',
    'descriptor',
    'dropped_harmonics',
    'plain_value',
    'unknown_overrides',
]
