"""cli.Failures, the tools' error ladder: the first rung whose types match the error says
the tool's line and sets the exit code; anything else is 'unexpected', exit 2, never a
traceback; Ctrl-C passes on to cli.interruptible."""

from __future__ import annotations

import errno

import pytest

from screwgear_ros.cli import EXIT_ERROR, EXIT_INTERRUPTED, Failures, interruptible


class Refused(ValueError):
    pass


def _ladder(**context: object) -> Failures:
    return Failures('tool', {
        Refused: 'cannot use {path}: {exc}',
        (KeyError, ValueError): ('{kind} in {path}: {exc}', 7),
        OSError: lambda exc: f'cannot write: {exc.strerror}',
    }, **context)


@pytest.mark.parametrize('error, line, code', [
    (Refused('bad'), 'tool: cannot use in.yaml: bad', EXIT_ERROR),     # before its base
    (ValueError('odd'), 'tool: ValueError in in.yaml: odd', 7),
    (KeyError('k'), "tool: KeyError in in.yaml: 'k'", 7),
    (OSError(errno.ENOSPC, 'No space left on device'), ('tool: cannot write: No space left '
     'on device'), EXIT_ERROR),
    (ZeroDivisionError('x'), 'tool: ZeroDivisionError: x', EXIT_ERROR),  # unexpected
])
def test_the_first_matching_rung_says_the_line_and_keeps_the_code(capsys, error, line, code):
    failures = _ladder(path='in.yaml')
    with failures:
        raise error
    assert failures.code == code
    assert capsys.readouterr().err == line + '\n'


def test_no_error_leaves_no_code_and_says_nothing(capsys):
    failures = _ladder(path='in.yaml')
    with failures:
        pass
    assert failures.code is None and capsys.readouterr().err == ''


def test_a_rung_added_once_the_work_began_is_tried_before_unexpected(capsys):
    failures = Failures('tool', {}, unexpected='unexpected {kind}')
    with failures:
        failures.add(ArithmeticError, 'arithmetic: {exc}', 3)
        raise ZeroDivisionError('x')
    assert (failures.code, capsys.readouterr().err) == (3, 'tool: arithmetic: x\n')


def test_ctrl_c_passes_through_to_interruptible(capsys):
    @interruptible('tool', 'nothing written')
    def main() -> int:
        with Failures('tool', {}):
            raise KeyboardInterrupt
        return 0

    assert main() == EXIT_INTERRUPTED
    assert capsys.readouterr().err == 'tool: interrupted (SIGINT): nothing written\n'
