"""Which shipped parameter files a recorded run ran with, for a figure's title.

A bag records the parameters in force, not the files they came from; the files are
found again by comparing those parameters with what each shipped file (alone, or
loaded after ``paper.yaml``, as ``run_demo.sh --realistic`` loads ``realistic.yaml``)
gives. Settings of the run rather than of the table (recording, pacing, lockstep) are
not compared.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import ScrewgearError
from ..params.config_files import config_dirs
from ..params.table import SimSettings, TableParams
from ..sim.parameter_file import file_values, resolve

#: Settings that say how a run was made, not what was simulated.
RUN_SETTINGS = frozenset({'record', 'real_time_factor', 'lockstep', 'publish_clock'})
#: The base file the other presets are loaded after.
BASE = 'paper.yaml'
#: At most this many differing names are listed in a title.
SHOWN_CHANGES = 3


@dataclass(frozen=True)
class Preset:
    """The shipped files whose parameters are closest to a run's, and what differs."""

    files: tuple[str, ...]          # file names, in load order
    changed: tuple[str, ...]        # parameter names whose value the run changed

    def __str__(self) -> str:
        text = ' + '.join(self.files)
        if self.changed:
            shown = ', '.join(self.changed[:SHOWN_CHANGES])
            more = len(self.changed) - SHOWN_CHANGES
            text += f' with {shown}' + (f' and {more} more' if more > 0 else '') + ' changed'
        return text


def _values(params: TableParams, settings: SimSettings) -> dict[str, Any]:
    values = {**params.as_dict(), **settings.as_dict()}
    return {k: v for k, v in values.items() if k not in RUN_SETTINGS}


def _candidates() -> list[tuple[tuple[str, ...], dict[str, Any]]]:
    """(files, values) of each shipped file the node reads, alone and after the base."""
    files: dict[str, Path] = {}
    for directory in reversed(config_dirs()):          # the first place wins
        files.update({f.name: f for f in sorted(directory.glob('*.yaml'))})
    read: dict[str, Mapping[str, Any]] = {}
    for name, path in files.items():
        try:
            values = file_values(path)
        except (ScrewgearError, OSError, ValueError):   # not a table_sim file
            continue
        if values:                                       # no table_sim parameters: skip
            read[name] = values
    found: list[tuple[tuple[str, ...], dict[str, Any]]] = []
    combos: list[tuple[str, ...]] = [(name,) for name in read]
    combos += [(BASE, name) for name in read if BASE in read and name != BASE]
    for combo in combos:
        merged: dict[str, Any] = {}
        for name in combo:
            merged.update(read[name])
        try:
            found.append((combo, _values(*resolve(merged))))
        except (ScrewgearError, ValueError):
            continue
    return found


def closest_preset(params: TableParams, settings: SimSettings) -> Preset | None:
    """The shipped files that give the most of these values, with the names whose value
    differs; on a tie the base and the file loaded after it (every file holds the
    base's values where it sets nothing, so a preset alone ties with it loaded after
    the base, as the demo loads it); None when no shipped file is found."""
    run = _values(params, settings)
    best = None
    for files, values in _candidates():
        changed = tuple(sorted(k for k in run if values.get(k) != run[k]))
        key = (len(changed), -len(files))
        if best is None or key < best[0]:
            best = (key, Preset(files, changed))
    return None if best is None else best[1]


__all__ = ['BASE', 'RUN_SETTINGS', 'Preset', 'closest_preset']
