"""identify BAG [BAG ...] --params BASE.yaml --fit NAME[,NAME ...] -o FITTED.yaml: fit the
table model's parameters to recordings (docs/identification.md).

Exit status: 0 fitted and written; 2 bad input (a bag without commands or joint_states,
an unknown or read-only parameter, bounds outside the declared range, joints that do not
match, values that are not finite, a recording too short, an argument out of its range,
an output inside a recording), or a model that diverged at every point tried, with the
reason on stderr; 130 interrupted (Ctrl-C): the best point so far is written, marked
unfinished.
"""

from __future__ import annotations

import sys

from . import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_OK, Failures, interruptible

#: What identify says of an error no check of its input foresaw: never the error's own
#: text, which names no input.
UNEXPECTED = ('internal error ({kind}), not a refusal of your input: please report it with '
              'the command line')


@interruptible('identify', 'stopped before the fitted file was written; nothing written')
def main(argv: list[str] | None = None) -> int:
    from ..identification.api import identify
    from ..identification.command import arguments, options, summary
    from ..identification.errors import IdentifyError

    args = arguments(argv)
    failures = Failures('identify', {IdentifyError: '{exc}', OSError: '{exc}'},
                        unexpected=UNEXPECTED)
    with failures:
        result = identify(**options(args))
    if failures.code is not None:
        return failures.code
    print('\n'.join(summary(result)))
    if result.stopped:
        print(f'identify: {result.stopped}', file=sys.stderr)
        return EXIT_INTERRUPTED
    if not result.finished:
        print(f'identify: {result.message}; written to {result.output} marked unfinished',
              file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_OK if result.output is not None else EXIT_ERROR
