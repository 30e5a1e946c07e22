"""check_run BAG: check a recorded table_sim run against the reference solution.

Exit status: 0 every signal within tolerance, 1 some signal outside it (the report
says which, by how much, when), 2 the path cannot be checked (not a bag, no
run_parameters in it, truncated, damaged, inconsistent: a contract topic declared with
another type, a message that does not decode), nothing to compare (no output recorded
after the start of the run), the reference solver cannot follow the
run (its step size collapses below the spacing of floating-point numbers, e.g. a run
driven through the mesh resonance, or the state becomes non-finite: stderr says why, at
what simulation time and in which segment), the reference cannot judge the run (its
own error, taken as the difference of its solutions at two tolerances, straddles a
signal's tolerance), the recorded parameters cannot be
simulated (refused by the model: an equilibrium not found, an unstable step), or the
--plot figure cannot be written. Never a traceback: anything else unexpected also
exits 2, with its type and message.

--params FILE.yaml: for a bag without run_parameters, the parameters it ran with; the
report's ``parameters:`` line says where the model came from.

--serial: the RK4 replay at dt/2 and the reference at the looser tolerance run in this
process after the rest, instead of in forked processes meanwhile (the report is the
same).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from ..bag.reader import RecordedRun, read_run
from ..numerics.kernels import loads_without_registries, without_blas_probe
from ..numerics.reference import ReferenceFailure
from ..params.table import ParameterError
from ..runs.check import CheckReport, check_run, format_report
from ..sim.parameter_file import ParameterFileError, load_yaml
from . import EXIT_ERROR, EXIT_OK, Failures, interruptible
from .bag_tool import bag_failures

#: Some signal outside its tolerance.
EXIT_FAIL = 1


@interruptible('check_run', 'nothing was judged; the bag is untouched')
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='check_run', description='Re-integrate the inputs recorded in a table_sim bag '
        'with the compiled DOP853 reference solver and compare the recorded joint states and '
        'transmission error with it.')
    parser.add_argument('bag', help='rosbag2 directory (or its .mcap file) written with '
                        'table_sim record:=PATH')
    parser.add_argument('--allow-truncated', action='store_true',
                        help='check the readable part of a bag whose recording was killed')
    parser.add_argument('--params', metavar='FILE.yaml',
                        help='for a bag without run_parameters: the parameter file (as '
                        'table_sim takes it) the run ran with; the run is taken to start '
                        'from the preload equilibrium at its first joint_states')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    parser.add_argument('--serial', action='store_true',
                        help='replay at dt/2 and solve the looser reference in this process '
                        'after the rest, instead of in forked processes meanwhile (same '
                        'result, slower on two cores)')
    parser.add_argument('--plot', metavar='OUT.png',
                        help='also draw |node − reference| of every signal against its '
                        'tolerance (log scale) into this figure file')
    args = parser.parse_args(argv)
    given = None
    if args.params:
        refused = Failures('check_run', {(ParameterFileError, ParameterError, OSError):
                                         'cannot check {bag} with --params {file}: {exc}'},
                           bag=args.bag, file=args.params)
        with refused:
            given = (*load_yaml(args.params), f'{args.params} (--params)')
        if refused.code is not None:
            return refused.code
    failures = bag_failures('check_run', 'check', args.bag,
                            {ReferenceFailure: 'cannot check {bag}: {exc}'})
    with failures:
        plot = None
        if args.plot:     # matplotlib only when a figure is asked for (a quarter second)
            from ..runs import plot as plotting
            failures.add(plotting.FigureFileError, '{exc}')
            plot = plotting.output_path(args.plot)
        run = read_run(args.bag, allow_truncated=args.allow_truncated, parameters=given)
        if args.no_progress:
            report = _check(run, None, args.serial)
        else:
            from tqdm import tqdm  # only for the bar (off where stderr is no terminal)
            total = (run.end_step - run.parameters.start_step) * run.dt
            with tqdm(total=round(total, 6), unit='s sim', desc='reference solution',
                      disable=None, leave=False, bar_format='{l_bar}{bar}| {n:.2f}/{total:.2f} s sim '
                      '[{elapsed}<{remaining}]') as bar:
                report = _check(run, bar.update, args.serial)
    if failures.code is not None:
        return failures.code
    print(format_report(report))
    if plot is not None:
        with failures:
            print(f'  plot: {plotting.save(plotting.check_figure(run, report), plot)}')
        if failures.code is not None:
            return failures.code
    if report.undecided:
        print(f'check_run: cannot judge {args.bag}: the reference solution\'s own error '
              '(its difference between two tolerances) reaches the tolerance of '
              f'{", ".join(s.name for s in report.undecided)}, so neither PASS nor FAIL '
              'holds', file=sys.stderr)
        return EXIT_ERROR
    return EXIT_OK if report.ok else EXIT_FAIL


def _check(run: RecordedRun, progress: Callable[[float], None] | None,
           serial: bool) -> CheckReport:
    """check_run of ``run``, without numba's probe of SciPy's BLAS (no kernel of the
    check calls BLAS, and importing ``scipy.linalg`` for the probe is a good part of
    loading the first kernel) and, as the node's start, without the CPU target's
    registries, which only a compile uses (a compile still loads them)."""
    with without_blas_probe(), loads_without_registries():
        return check_run(run, progress=progress, parallel=not serial)


if __name__ == '__main__':
    sys.exit(main())
