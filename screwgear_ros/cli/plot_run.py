"""plot_run BAG [-o OUT.png]: draw a recorded table_sim run (see screwgear_ros.runs.plot).

``--counts [N]``, ``--band TOL`` and ``--target RAD`` draw the tracking error in encoder
counts, with a tolerance band, against a target (:mod:`screwgear_ros.runs.plot_error`).

Prints the path of the figure it wrote. Exit status: 0 written, 2 the bag cannot be
read (not a bag, no run_parameters, truncated, damaged, inconsistent), its recorded
parameters cannot be simulated, or the figure cannot be written there. Never a
traceback: anything else unexpected also exits 2, with its type and message.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable

from ..bag.reader import read_run
from ..runs.plot import (
    DEFAULT_NAME,
    FigureFileError,
    default_output,
    output_path,
    run_figure,
    save,
)
from ..runs.plot_error import MAX_COUNTS, ErrorOptions, ErrorViewError
from . import EXIT_OK, interruptible
from .bag_tool import bag_failures


def _span(text: str) -> tuple[float, float]:
    """'T0:T1' (s) as (t0, t1), t0 < t1, both finite."""
    try:
        t0, t1 = (float(v) for v in text.split(':'))
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not T0:T1 (two times in s)') from None
    if not (math.isfinite(t0) and math.isfinite(t1) and t0 < t1):
        raise argparse.ArgumentTypeError(f'{text!r}: T0 must be before T1, both finite')
    return t0, t1


def _counts(text: str) -> int:
    """--counts N: counts per revolution, a whole number from 1 to MAX_COUNTS."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 1 <= value <= MAX_COUNTS:
        raise argparse.ArgumentTypeError(
            f'{text!r}: counts per revolution must be a whole number from 1 to {MAX_COUNTS} '
            '(or leave it out: the run\'s table encoder)')
    return value


def _number(text: str, valid: Callable[[float], bool], rule: str) -> float:
    """``text`` as a float that ``valid`` accepts; otherwise argparse's error naming ``rule``."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and valid(value)):
        raise argparse.ArgumentTypeError(f'{text!r}: {rule}')
    return value


def _band(text: str) -> float:
    """--band TOL: a finite tolerance > 0."""
    return _number(text, lambda v: v > 0.0, 'the tolerance must be a finite number > 0 '
                                            '(± counts with --counts, else ± mrad)')


def _target(text: str) -> float:
    """--target RAD: a finite angle."""
    return _number(text, lambda v: True, 'the target must be a finite angle in rad')


@interruptible('plot_run', 'no figure was written; the bag is untouched')
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='plot_run', description='Draw a run recorded by table_sim: table angle (with '
        'the controller\'s setpoint and the tracking error, when the bag recorded one) and '
        'speed, commanded torque and load, pinion speeds, transmission error, mesh forces '
        'with contact, active path with reversals; parameter changes and resets as '
        'vertical lines.')
    parser.add_argument('bag', help='rosbag2 directory (or its .mcap file) written with '
                        'table_sim record:=PATH')
    parser.add_argument('-o', '--output', metavar='OUT.png',
                        help=f'figure file, any matplotlib format by its extension '
                        f'(default: BAG/{DEFAULT_NAME})')
    parser.add_argument('--allow-truncated', action='store_true',
                        help='plot the readable part of a bag whose recording was killed')
    parser.add_argument('--zoom', metavar='T0:T1', type=_span,
                        help='draw only simulation times T0 to T1 s (e.g. one step response), '
                        'each panel scaled to what it shows there')
    parser.add_argument('--counts', metavar='N', nargs='?', const=0, type=_counts,
                        help='the tracking error in encoder counts: of the run\'s table '
                        'encoder (encoder_counts_table), or of one of N counts per revolution')
    parser.add_argument('--band', metavar='TOL', type=_band,
                        help='shade ±TOL around zero on the tracking error (counts with '
                        '--counts, else mrad) and say from when on the error stays inside')
    parser.add_argument('--target', metavar='RAD', type=_target,
                        help='the reference of the tracking error, a constant angle in rad, '
                        'instead of the recorded setpoint (for a controller that sends none)')
    args = parser.parse_args(argv)
    error = ErrorOptions(args.counts, args.band, args.target)
    failures = bag_failures('plot_run', 'plot', args.bag,
                            {(FigureFileError, ErrorViewError): '{exc}'})
    with failures:
        out = output_path(args.output) if args.output else None
        run = read_run(args.bag, allow_truncated=args.allow_truncated)
        written = save(run_figure(run, args.zoom, error), out or default_output(run))
    if failures.code is not None:
        return failures.code
    print(written)
    return EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
