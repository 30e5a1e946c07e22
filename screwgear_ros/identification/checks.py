"""What ``identify`` checks before it fits: its arguments, where it will write, the
joint mapping, the recordings against the options, and the bounds against what the
node accepts. Each refusal names the argument and the rule, so that no fit runs for
minutes only to end in an error or an unusable file.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..sim.machine import cores
from .adapter import Diverged, model
from .errors import FitParameterError, IdentifyError, RecordingError
from .parameters import FitParameter, start_point
from .samples import NODE_JOINTS, Recording

#: Most starting points: each is a whole fit.
MAX_STARTS = 100
#: Most residual evaluations per start.
MAX_EVALUATIONS = 10_000
#: Worker processes per core this process may use (more only queue for the cores).
WORKERS_PER_CORE = 4
#: A Dask scheduler address: [PROTOCOL://]HOST:PORT.
SCHEDULER = re.compile(r'^(?:(tcp|tls|ucx|ws|wss)://)?(\[[0-9a-fA-F:]+\]|[\w.-]+):(\d{1,5})$')


def whole(name: str, value: Any, low: int, high: int | None = None) -> int:
    """``value`` as an int in [low, high], or an IdentifyError naming ``name``."""
    try:
        if isinstance(value, bool):
            raise TypeError
        number = operator.index(value)
    except TypeError:
        raise IdentifyError(f'{name} {value!r}: not a whole number') from None
    if number < low or (high is not None and number > high):
        rule = f'{low} … {high}' if high is not None else f'>= {low}'
        raise IdentifyError(f'{name} {number}: takes a whole number {rule}')
    return number


def finite(name: str, value: Any, unit: str) -> float:
    """``value`` as a finite float >= 0, or an IdentifyError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise IdentifyError(f'{name} {value!r}: not a number of {unit}')
    if not 0 <= value < math.inf:
        raise IdentifyError(f'{name} {value}: takes a number of {unit} >= 0')
    return float(value)


def check_options(workers: Any, scheduler: Any, starts: Any, seed: Any,
                  max_evaluations: Any, input_delay: Any, settle: Any
                  ) -> tuple[int, int, int, int, float, float]:
    """(workers, starts, seed, max_evaluations, input_delay, settle), checked."""
    most = WORKERS_PER_CORE * cores()
    workers = whole('--workers', workers, 1, most)
    if scheduler is not None:
        if not isinstance(scheduler, str) or not SCHEDULER.match(scheduler):
            raise IdentifyError(f'--scheduler {scheduler!r}: not a Dask scheduler address '
                                '[PROTOCOL://]HOST:PORT (tcp://10.0.0.5:8786)')
        if not 0 < int(SCHEDULER.match(scheduler).group(3)) < 65536:  # type: ignore[union-attr]
            raise IdentifyError(f'--scheduler {scheduler}: the port is 1 … 65535')
        if workers != 1:
            raise IdentifyError('--workers is for local processes; a --scheduler has its own')
    return (workers, whole('--starts', starts, 1, MAX_STARTS), whole('--seed', seed, 0),
            whole('--max-evaluations', max_evaluations, 1, MAX_EVALUATIONS),
            finite('--input-delay', input_delay, 'ticks'), finite('--settle', settle, 'seconds'))


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def check_paths(bags: Sequence[Any], validate: Sequence[Any], params: Any,
                outputs: Sequence[tuple[str, Path]]) -> None:
    """Refuse a path the fit would write (``outputs``: (label, path)) that is the base
    file, a folder, or lies in (or is) a recording."""
    if not bags:
        raise IdentifyError('no recording to fit: name at least one BAG')
    base = Path(params).resolve()
    recordings = [Path(b).resolve() for b in (*bags, *validate)]
    for label, path in outputs:
        target = Path(path).resolve()
        if target.is_dir():
            raise IdentifyError(f'{label} {path}: is a folder; name a file')
        if target == base:
            raise IdentifyError(f'{label} {path}: is the base file --params; the fit never '
                                'overwrites its input: name another file')
        for bag, given in zip(recordings, (*bags, *validate), strict=True):
            if _inside(target, bag):
                raise IdentifyError(f'{label} {path}: lies in the recording {given}; the fit '
                                    'never writes into its input: name a file outside it')


def check_joints(joints: Mapping[str, str] | None) -> None:
    """Refuse a --joints mapping that puts two node joints on one bag joint."""
    names = {j: (joints or {}).get(j, j) for j in NODE_JOINTS}
    for j in NODE_JOINTS:
        others = [k for k in NODE_JOINTS if k != j and names[k] == names[j]]
        if others:
            raise RecordingError(f'--joints: {j} and {", ".join(others)} would both read the '
                                 f'bag\'s joint {names[j]!r}: each node joint needs a joint '
                                 'of its own')


def check_recordings(recordings: Sequence[Recording], input_delay: float, tick: float,
                     speeds: bool) -> None:
    """Refuse recordings the options cannot use: a delay (``input_delay`` ticks of
    ``tick`` s) as long as a recording or one that moves every command past its end, and
    --speeds where a joint has no recorded speed."""
    for r in recordings:
        if input_delay * tick >= r.duration:
            raise RecordingError(f'--input-delay {input_delay:g}: {input_delay * tick:.4g} s, '
                                 f'as long as {r.path}, which holds {r.samples} samples '
                                 f'({r.duration:.4g} s): a delay is a few ticks of the drive')
        if not r.inputs:
            raise RecordingError(f'{r.path}: --input-delay {input_delay:g} moves every command '
                                 'past the recording\'s end')
        if speeds:
            absent = [j for j, column in zip(NODE_JOINTS, r.velocity.T, strict=True)
                      if np.isnan(column).all()]
            if absent:
                raise RecordingError(f'--speeds: {r.path} records no velocity of '
                                     f'{", ".join(absent)}: fit the angles alone (no --speeds)')


def _refusal(base: Mapping[str, Any], name: str, value: float) -> str:
    try:
        model({**base, name: value})
    except Diverged as exc:
        return str(exc)
    return ''


def probe_bounds(base: Mapping[str, Any], fitted: Sequence[FitParameter]) -> dict[str, float]:
    """Check that the node accepts each parameter somewhere in its bounds, and near its
    start (where the first Jacobian is taken): the other parameters at their base values.
    Returns a trial value of each, other than its base, for :func:`~.output.rehearse`.

    Raises
    ------
    FitParameterError
        The node refuses every value tried, or every value but the base one.
    """
    trials = {}
    for q, x0 in zip(fitted, start_point(fitted), strict=True):
        lo, hi = q.x_bounds
        points = [float(v) for v in (lo, (lo + hi) / 2, hi, x0 + 1e-4 * (hi - lo),
                                     x0 - 1e-4 * (hi - lo)) if lo <= v <= hi]
        values = [q.to_value(v) for v in points]
        reasons = [_refusal(base, q.name, v) for v in values]
        accepted = [v for v, why in zip(values, reasons, strict=True) if not why and v != q.base]
        if not accepted:
            why = next(w for w in reasons if w)
            raise FitParameterError(
                f'--fit {q.name}: the node refuses every value tried within its bounds '
                f'{q.low:.6g} … {q.high:.6g} (with the other parameters at the base file\'s '
                f'values): {why}')
        trials[q.name] = accepted[0]
    return trials


def report_stem(output: Any, report: Any) -> Path | None:
    """The report's stem: ``report``, else beside ``output`` (<output>_report)."""
    if report is not None:
        return Path(report)
    return None if output is None else Path(output).with_name(Path(output).stem + '_report')


def written_paths(output: Any, report: Any) -> list[tuple[str, Path]]:
    """The files a fit writes, each with the argument that names it."""
    paths = [] if output is None else [('-o', Path(output))]
    stem = report_stem(output, report)
    if stem is not None:
        paths += [('--report', stem.with_suffix('.md')), ('--report', stem.with_suffix('.png'))]
    return paths


__all__ = ['MAX_EVALUATIONS', 'MAX_STARTS', 'SCHEDULER', 'WORKERS_PER_CORE', 'check_joints',
           'check_options', 'check_paths', 'check_recordings', 'finite', 'probe_bounds',
           'report_stem', 'whole', 'written_paths']
