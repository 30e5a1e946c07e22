"""A whole, validated parameter set of the node: (TableParams, SimSettings) from a flat
mapping or a ROS 2 parameter file, with the step checked against RK4's stability limit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..numerics.stability import check_step
from .table import ParameterError, SimSettings, TableParams

_TABLE_FIELDS = {f.name for f in fields(TableParams)}
_SIM_FIELDS = {f.name for f in fields(SimSettings)}


def split_parameters(values: Mapping[str, Any]) -> tuple[TableParams, SimSettings]:
    """Build validated (TableParams, SimSettings) from a flat name → value mapping.

    Unknown names are refused (a typo in a parameter file must not pass silently).
    """
    unknown = set(values) - _TABLE_FIELDS - _SIM_FIELDS
    if unknown:
        name = min(unknown)
        raise ParameterError(name, values[name], 'is not a parameter of table_sim')
    params = TableParams(**{k: v for k, v in values.items() if k in _TABLE_FIELDS})
    settings = SimSettings(**{k: v for k, v in values.items() if k in _SIM_FIELDS})
    try:
        check_step(params, settings.dt)
    except (ArithmeticError, np.linalg.LinAlgError) as error:
        raise ParameterError('dt', settings.dt, 'the stability limit of RK4 cannot be '
                             f'computed for these parameters ({type(error).__name__}: '
                             f'{error})') from None
    return params, settings


def ros_parameters(document: Mapping[str, Any]) -> dict[str, Any]:
    """The flat ``ros__parameters`` mapping of a ROS 2 parameter file.

    Accepts ``node_name: {ros__parameters: ...}``, ``/**: {ros__parameters: ...}``
    or a bare mapping of parameter names.
    """
    merged: dict[str, Any] = {}
    found = False
    for value in document.values():
        if isinstance(value, Mapping) and 'ros__parameters' in value:
            merged.update(value['ros__parameters'] or {})
            found = True
    return merged if found else dict(document)


def load_yaml(path: str | Path) -> tuple[TableParams, SimSettings]:
    """Load a ``config/*.yaml`` parameter file (ROS 2 params-file format)."""
    with open(path, encoding='utf-8') as stream:
        document = yaml.safe_load(stream) or {}
    return split_parameters(ros_parameters(document))


def default_values() -> dict[str, Any]:
    """Every node parameter with its default (physics and settings), ROS-friendly."""
    return {**TableParams().as_dict(), **SimSettings().as_dict()}


__all__ = ['default_values', 'load_yaml', 'ros_parameters', 'split_parameters']
