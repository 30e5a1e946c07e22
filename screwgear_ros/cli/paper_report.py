"""``paper_report OUTDIR [--quick]``: recompute the paper's claims into a Markdown report."""

from __future__ import annotations

import argparse
import sys
import time

from ..errors import ScrewgearError
from . import EXIT_OK, Failures, interruptible


@interruptible('paper_report', 'the report is incomplete; OUTDIR keeps the sections '
               'written so far')
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='paper_report',
        description='Recompute every quantitative claim of the paper with the package\'s own '
                    'model and write OUTDIR/report.md with PNG figures.')
    parser.add_argument('outdir', help='directory for report.md and the figures')
    parser.add_argument('--quick', action='store_true',
                        help='coarse grids (well under a minute; used by the tests)')
    args = parser.parse_args(argv)
    from ..paper.builder import build  # after argument parsing: --help stays fast

    start = time.perf_counter()
    failures = Failures('paper_report', {
        ScrewgearError: '{exc} (OUTDIR keeps the sections written so far)',
        OSError: 'cannot write {outdir}: {why}',
    }, outdir=args.outdir)
    with failures:
        report = build(args.outdir, quick=args.quick)
    if failures.code is not None:
        return failures.code
    print(f'wrote {report.path} ({len(report.sections)} sections, '
          f'{sum(len(s.figures) for s in report.sections)} figures) in '
          f'{time.perf_counter() - start:.0f} s')
    return EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
