"""check_run's forked computations (:class:`screwgear_ros.runs.check.forked.Forked`): the
result and the error are the ones the same work gives in this process, whether it ran
in a child, in a child that died, or here.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from screwgear_ros.bag.errors import InvalidBag
from screwgear_ros.runs.check.forked import Forked, cores

pytestmark = pytest.mark.ros        # forks processes

needs_two = pytest.mark.skipif(cores() < 2, reason='forks only with two cores')


def rows(forked: bool) -> tuple[np.ndarray, int]:
    """Work whose result tells where it ran (its pid)."""
    return np.arange(12.0).reshape(3, 4) / 7.0, os.getpid()


@needs_two
def test_the_work_runs_in_a_child_and_its_result_comes_back() -> None:
    job = Forked(rows, parallel=True, name='test')
    assert job.forked
    result, pid = job.result()
    assert pid != os.getpid()
    assert np.array_equal(result, rows(False)[0])


def test_without_parallel_the_work_runs_here_when_asked() -> None:
    job = Forked(rows, parallel=False, name='test')
    assert not job.forked
    result, pid = job.result()
    assert pid == os.getpid() and np.array_equal(result, rows(False)[0])


def refuse(forked: bool) -> None:
    raise InvalidBag(f'damaged (forked={forked})')


@needs_two
def test_the_packages_error_in_the_child_is_raised_here() -> None:
    with pytest.raises(InvalidBag, match=r'damaged \(forked=True\)'):
        Forked(refuse, parallel=True, name='test').result()


def die_there(forked: bool) -> int:
    if forked:
        os._exit(3)         # the child dies without an answer
    return os.getpid()


def crash_there(forked: bool) -> int:
    if forked:
        raise MemoryError('the child ran out')      # not the package's: redone here
    return os.getpid()


@needs_two
@pytest.mark.parametrize('work', [die_there, crash_there], ids=['dies', 'crashes'])
def test_a_child_that_dies_or_crashes_is_redone_here(work) -> None:
    job = Forked(work, parallel=True, name='test')
    assert job.forked
    assert job.result() == os.getpid()
