"""The parameters: one declaration per parameter, the validated sets, the one
parameter-file reader, and the run file a recording carries.

The public names (:class:`TableParams`, :class:`SimSettings`, :class:`ParameterError`,
the enums) live in :mod:`screwgear_ros.params.table`; they are also reachable here, as
they were when ``screwgear_ros.params`` was one module.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any


def __getattr__(name: str) -> Any:
    if name.startswith('__'):
        raise AttributeError(name)
    table = import_module('.table', __name__)
    try:
        return getattr(table, name)
    except AttributeError:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}') from None
