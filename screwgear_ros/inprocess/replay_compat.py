"""What ``screwgear_ros.runs.replay`` held, for its old import path (one release): the
in-process replay and, under its old name ``load_scenario``, the schedule of a scenario
file (now :func:`screwgear_ros.inprocess.scenario.schedule_from_scenario`)."""

from __future__ import annotations

import warnings
from typing import Any

from ..runs.replay_in_process import *
from ..runs.replay_in_process import __all__ as _replay_names
from .scenario import schedule_from_scenario


def __getattr__(name: str) -> Any:
    if name == 'load_scenario':
        warnings.warn('screwgear_ros.runs.replay.load_scenario is '
                      'screwgear_ros.inprocess.scenario.schedule_from_scenario; the old name '
                      'goes in the next release', DeprecationWarning, stacklevel=2)
        return schedule_from_scenario
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


__all__ = list(_replay_names)
