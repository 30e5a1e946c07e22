"""The warm-up's progress lines: one per period in which more kernels were compiled,
counting kernels this process compiled (not those loaded from the cache)."""

from __future__ import annotations

import time

import numba

from screwgear_ros.numerics.kernels import FIRST_COMPILE, progress, progress_line


def _lines_of_two_compiles(**options: int) -> list[str]:
    """The progress lines while two fresh kernels compile half a second apart."""
    @numba.njit
    def double(x):
        return 2.0 * x

    @numba.njit
    def triple(x):
        return 3.0 * x

    lines: list[str] = []
    with progress(period=0.05, say=lines.append, every=[double, triple], **options):
        double(1.0)
        time.sleep(0.5)
        triple(1.0)
        time.sleep(0.5)
    return lines


def test_progress_counts_the_kernels_compiled_within():
    lines = _lines_of_two_compiles()
    counts = [line.split('compiling kernels: ')[1].split(' done')[0] for line in lines]
    assert counts == ['1', '2'], lines
    assert all(f'of about {FIRST_COMPILE}' in line for line in lines)


def test_nothing_compiled_nothing_said():
    """A kernel the block does not call is not compiled and not reported."""
    @numba.njit
    def half(x):
        return 0.5 * x

    lines: list[str] = []
    with progress(period=0.01, say=lines.append, every=[half]):
        time.sleep(0.1)
    assert lines == []


def test_a_count_past_the_estimate_never_reads_as_past_its_total():
    """The issue's "52 done of about 51": more kernels than the estimate compile (one
    added since, a CPU that needs another signature); the lines then say so."""
    lines = _lines_of_two_compiles(expected=1)
    assert len(lines) == 2, lines
    assert 'of about 1 (nearly there)' in lines[0], lines
    assert '2 done (more than the 1 expected' in lines[1], lines
    for done in range(1, 200):
        line = progress_line(done, FIRST_COMPILE, 1.0)
        total = line.split(' of about ')[1].split(',')[0].split(' ')[0] if 'of about' in line else None
        assert total is None or done <= int(total), line
