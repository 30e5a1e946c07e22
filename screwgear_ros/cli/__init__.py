"""The imperative shell: the node and command-line tools (these import rclpy where needed).

Every tool ends with its documented exit code and a reason, never a traceback: the
long-running offline tools stop on Ctrl-C through :func:`interruptible`, with one line
that says what they had not finished, and exit :data:`EXIT_INTERRUPTED`.
"""

from __future__ import annotations

import functools
import sys
from typing import Callable

#: 128 + SIGINT: what a shell reports for a command that Ctrl-C stopped.
EXIT_INTERRUPTED = 130


def interruptible(tool: str, unfinished: str) -> Callable[[Callable[..., int]], Callable[..., int]]:
    """Decorate a tool's ``main`` so that SIGINT ends it with one line naming what it had
    ``unfinished`` (and what it keeps), exit :data:`EXIT_INTERRUPTED`. Python raises
    KeyboardInterrupt between bytecodes, so a tool stops as soon as its compiled call of
    the moment returns."""
    def wrap(main: Callable[..., int]) -> Callable[..., int]:
        @functools.wraps(main)
        def run(*args: object, **kwargs: object) -> int:
            try:
                return main(*args, **kwargs)
            except KeyboardInterrupt:
                print(f'{tool}: interrupted (SIGINT): {unfinished}', file=sys.stderr)
                return EXIT_INTERRUPTED
        return run
    return wrap


__all__ = ['EXIT_INTERRUPTED', 'interruptible']
