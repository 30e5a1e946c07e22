"""The executables' ``main()`` functions: each parses its command line and calls the
node (:mod:`screwgear_ros.ros`) or the work it runs; these import rclpy where needed.

Every tool ends with its documented exit code and a reason, never a traceback: the
long-running offline tools stop on Ctrl-C through :func:`interruptible`, with one line
that says what they had not finished, and exit :data:`EXIT_INTERRUPTED`; the errors a
tool's work can end in are declared as one :class:`Failures` ladder each, which prints
the tool's own line for each and keeps its exit code.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable, Mapping
from typing import Self

#: The tools' exit code for work done (and, where a tool gives a verdict, a good one).
EXIT_OK = 0
#: 128 + SIGINT: what a shell reports for a command that Ctrl-C stopped.
EXIT_INTERRUPTED = 130
#: The tools' documented exit code for work they could not do.
EXIT_ERROR = 2
#: 128 + SIGPIPE: what a shell reports for a command whose output's reader left
#: (``| head``).
EXIT_BROKEN_PIPE = 141

#: An exception type, or a tuple of them, as ``except`` takes it.
Errors = type[BaseException] | tuple[type[BaseException], ...]
#: A message: a ``str.format`` template over ``exc`` (the error), ``kind`` (its type's
#: name), ``why`` (an OSError's strerror, else the error) and the ladder's context, or a
#: function of the error for text that depends on more than these.
Message = str | Callable[[BaseException], str]


def interruptible(tool: str, unfinished: str) -> Callable[[Callable[..., int]], Callable[..., int]]:
    """Decorate a tool's ``main`` so that SIGINT ends it with one line naming what it had
    ``unfinished`` (and what it keeps), exit :data:`EXIT_INTERRUPTED`; a reader of its
    output that leaves (``| head``) ends it quietly, exit :data:`EXIT_BROKEN_PIPE`. Python raises
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
            except BrokenPipeError:
                # the reader of stdout left: end quietly, as a shell's tools do, and
                # keep the interpreter's last flush from failing again at exit
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
                return EXIT_BROKEN_PIPE
        return run
    return wrap


class Failures:
    """A tool's error ladder as data, used as a context manager around its work.

    ``ladder`` maps error types (a type or a tuple, tried in order, as ``except`` clauses
    are) to a :data:`Message`, or to ``(message, exit code)`` where the code is not
    :data:`EXIT_ERROR`. Any other Exception gets ``unexpected``, so the tool never ends in
    a traceback; KeyboardInterrupt passes on to :func:`interruptible`. The error's line,
    ``'<tool>: <message>'``, goes to stderr, and :attr:`code` holds its exit code (None
    while nothing failed): ``with failures: ...`` then ``if failures.code is not None:
    return failures.code``. ``context`` names the values the templates use (the input's
    path, say).
    """

    def __init__(self, tool: str, ladder: Mapping[Errors, Message | tuple[Message, int]],
                 *, unexpected: Message = '{kind}: {exc}', **context: object) -> None:
        self.tool = tool
        self.context = context
        self.rungs: list[tuple[Errors, Message, int]] = []
        for errors, answer in ladder.items():
            message, code = answer if isinstance(answer, tuple) else (answer, EXIT_ERROR)
            self.add(errors, message, code)
        self.unexpected = unexpected
        self.code: int | None = None

    def add(self, errors: Errors, message: Message, code: int = EXIT_ERROR) -> None:
        """One more rung below the others: for error types known only once the work has
        begun (those of a module imported only when an option asks for it)."""
        self.rungs.append((errors, message, code))

    def message(self, exc: BaseException, message: Message) -> str:
        if callable(message):
            return message(exc)
        why = (exc.strerror or exc) if isinstance(exc, OSError) else exc
        return message.format(exc=exc, kind=type(exc).__name__, why=why, **self.context)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 traceback: object) -> bool:
        if not isinstance(exc, Exception):      # none, or KeyboardInterrupt / SystemExit
            return False
        message, code = next(((m, c) for errors, m, c in self.rungs if isinstance(exc, errors)),
                             (self.unexpected, EXIT_ERROR))
        print(f'{self.tool}: {self.message(exc, message)}', file=sys.stderr)
        self.code = code
        return True


__all__ = ['EXIT_BROKEN_PIPE', 'EXIT_ERROR', 'EXIT_INTERRUPTED', 'EXIT_OK', 'Errors', 'Failures',
           'Message', 'interruptible']
