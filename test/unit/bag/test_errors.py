"""Why a bag cannot be used is the class of the error read_run raises, and the tools'
one-line report follows from it (the --allow-truncated hint only for a truncated bag)."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest
from bag_runs import truncated_copy
from paths import DATA

from screwgear_ros.bag import errors
from screwgear_ros.bag.errors import BagError, NotABag, TruncatedBag
from screwgear_ros.bag.reader import read_run
from screwgear_ros.errors import ScrewgearError
from screwgear_ros.runs.check import NothingToCompare


def test_every_bag_error_is_a_screwgear_error_and_no_value_or_os_error() -> None:
    classes = [c for _, c in inspect.getmembers(errors, inspect.isclass)
               if c.__module__ == errors.__name__] + [NothingToCompare]
    assert len(classes) >= 6
    for cls in classes:
        assert issubclass(cls, BagError) and issubclass(cls, ScrewgearError)
        # replay_run reads a scenario under `except (ValueError, OSError, KeyError)`:
        # an unusable bag must reach its own rung of the ladder instead
        assert not issubclass(cls, (ValueError, OSError, KeyError))


def test_a_missing_path_is_not_a_bag(tmp_path: Path) -> None:
    with pytest.raises(NotABag) as refused:
        read_run(tmp_path / 'nothing here')
    assert refused.value.report('check', 'X') == \
        f'cannot check X: {tmp_path / "nothing here"}: no such file or directory'


def test_a_truncated_bag_says_how_to_read_its_readable_part(tmp_path: Path) -> None:
    bag = truncated_copy(DATA / 'steady_drive', tmp_path / 'cut')
    with pytest.raises(TruncatedBag) as refused:
        read_run(bag)
    assert refused.value.report('plot', 'B').endswith(
        ' (use --allow-truncated to plot the readable part)')
    assert read_run(bag, allow_truncated=True).truncated
