"""The ``identify`` command line: its arguments, and what it prints of a result."""

from __future__ import annotations

import argparse
import math
from typing import Any

from .checks import MAX_STARTS
from .known import parse_fix
from .parameters import parse_bounds
from .recording import parse_joints
from .resid import verdict_lines


def arguments(argv: list[str] | None) -> argparse.Namespace:
    """Parse identify's arguments (argparse exits 2 on a malformed command line)."""
    parser = argparse.ArgumentParser(
        prog='identify', description='Fit the table model\'s parameters to recordings '
        '(joint_states and the commands sent): output error through the node\'s own '
        'simulation; writes FITTED.yaml and a report (markdown + PNG).')
    parser.add_argument('bags', nargs='+', metavar='BAG', help='recordings to fit (rosbag2 '
                        'directories, MCAP or sqlite3)')
    parser.add_argument('--params', required=True, metavar='BASE.yaml',
                        help='base parameter file (table_sim --params-file format)')
    parser.add_argument('--fit', required=True, metavar='NAME[,NAME ...]',
                        help='parameters to fit, comma-separated')
    parser.add_argument('--bounds', nargs='+', default=[], metavar='NAME=LO:HI',
                        help='bounds of a fitted parameter (default: base/10 … base·10)')
    parser.add_argument('--validate', nargs='+', default=[], metavar='BAG',
                        help='recordings compared before and after, not fitted')
    parser.add_argument('--namespace', metavar='NS', help='the table\'s namespace, for bags '
                        'that hold several tables\' topics (/axis_a)')
    parser.add_argument('--workers', type=int, default=1, metavar='N',
                        help='processes simulating the Jacobian\'s trial points (default 1)')
    parser.add_argument('--scheduler', metavar='ADDRESS',
                        help='simulate them on the Dask cluster of this scheduler instead')
    parser.add_argument('--joints', metavar='NODE=BAG[,...]', help='joint names of the bags '
                        'where they differ from pinion_1, table, pinion_3')
    parser.add_argument('--input-delay', type=float, default=0.0, metavar='TICKS',
                        help='ticks of the model (a fraction too) by which the drive '
                        'applies a command after its log time (0)')
    parser.add_argument('--time', choices=('stamp', 'log'), default='stamp',
                        help='place each joint_states sample at its header stamp (default) '
                        'or its log time')
    parser.add_argument('--settle', type=float, default=0.0, metavar='SECONDS',
                        help='leave each recording\'s first SECONDS out of the comparison, '
                        'for a recording that does not start at rest (0)')
    parser.add_argument('--fix', nargs='+', default=[], metavar='NAME=VALUE',
                        help='hold a parameter at VALUE instead of the base file\'s')
    parser.add_argument('--speeds', action='store_true', help='compare the speeds too')
    parser.add_argument('--starts', type=int, default=3, metavar='N',
                        help='starting points: the base values and N-1 seeded draws (3; '
                        f'at most {MAX_STARTS})')
    parser.add_argument('--seed', type=int, default=0, help='seed of the starting points '
                        '(a whole number >= 0)')
    parser.add_argument('--max-evaluations', type=int, default=40, metavar='N',
                        help='residual evaluations per starting point (40)')
    parser.add_argument('--report', metavar='STEM', help='report files STEM.md, STEM.png '
                        '(default: beside FITTED.yaml, <FITTED>_report)')
    parser.add_argument('-o', '--output', required=True, metavar='FITTED.yaml')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    return parser.parse_args(argv)


def options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments of :func:`~screwgear_ros.identification.api.identify`
    (raises IdentifyError for bounds or joints it cannot parse)."""
    return {'bags': args.bags, 'params': args.params,
            'fit': [n.strip() for n in args.fit.split(',') if n.strip()],
            'bounds': parse_bounds(args.bounds), 'validate': args.validate,
            'output': args.output, 'report': args.report, 'workers': args.workers,
            'scheduler': args.scheduler, 'joints': parse_joints(args.joints),
            'input_delay': args.input_delay, 'speeds': args.speeds, 'clock': args.time,
            'settle': args.settle, 'fix': parse_fix(args.fix),
            'starts_count': args.starts, 'seed': args.seed, 'namespace': args.namespace,
            'max_evaluations': args.max_evaluations, 'progress': not args.no_progress}


def summary(result: Any) -> list[str]:
    """The lines identify prints of a result."""
    lines = [f'WARNING: {w}' for w in result.statistics.warnings]
    starts = list(zip(result.start_values, result.start_costs, strict=True))
    for k, (values, cost) in enumerate(starts if len(starts) > 1 else (), 1):
        lines.append(f'start {k}: cost {cost:.6g}: '
                     + ', '.join(f'{n} = {v:.6g}' for n, v in values.items()))
    local = ', local' if result.statistics.local else ''
    for e in result.estimates:
        interval = (f'  [{e.low:.6g} … {e.high:.6g}] (±2σ{local})'
                    if math.isfinite(e.low) and math.isfinite(e.high) else '')
        flag = f'  UNDETERMINED: {e.undetermined}; {e.advice}' if e.undetermined else ''
        if not e.judged:
            flag = '  (not judged: the fit was interrupted)'
        lines.append(f'{e.name} = {e.value:.6g} {e.unit}{interval} (base {e.base:.6g}){flag}')
    for direction in result.statistics.directions:
        lines.append(f'the recordings cannot see the direction {direction}')
    for c in result.comparisons:
        fits = ', '.join(f'{v:.1f}' for v in c.fit('after'))
        lines.append(f'fit % ({c.role}) {c.recording.path}: {fits}')
    lines += verdict_lines(result)
    lines.append(f'{result.simulations} simulations, {result.seconds:.1f} s '
                 f'({result.sim_seconds:.1f} s simulating)')
    for label, path in (('fitted', result.output), ('report', result.report),
                        ('figure', result.figure)):
        if path is not None:
            lines.append(f'{label}: {path}')
    return lines


__all__ = ['arguments', 'options', 'summary']
