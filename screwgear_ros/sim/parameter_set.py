"""A whole, validated parameter set of the node: (TableParams, SimSettings) from a flat
mapping, with the step checked against RK4's stability limit (so it sits above the
numerics). Files are read by :mod:`screwgear_ros.sim.parameter_file`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any

import numpy as np

from ..numerics.stability import check_step
from ..params.table import ParameterError, SimSettings, TableParams

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


def default_values() -> dict[str, Any]:
    """Every node parameter with its default (physics and settings), ROS-friendly."""
    return {**TableParams().as_dict(), **SimSettings().as_dict()}




__all__ = ['default_values', 'split_parameters']
