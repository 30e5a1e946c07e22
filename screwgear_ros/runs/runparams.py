"""The ``run_parameters`` document: everything needed to re-integrate a run, as YAML.

The node publishes it (std_msgs/String on ``<node>/run_parameters``) into the bag at
the start and again, complete, at the step each parameter change takes effect. It
holds every :class:`TableParams` and :class:`SimSettings` field under its ROS
parameter name, plus ``package_version``, ``initial_state`` (θ1, θ2, θ3 in rad,
ω1, ω2, ω3 in rad/s at ``start_step``) and ``start_step``. Floats are written with
``repr`` precision, so they read back bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Sequence

import numpy as np
import yaml

from .. import __version__
from ..params import ParameterError, SimSettings, TableParams

EXTRA_KEYS = ('package_version', 'initial_state', 'start_step')
_TABLE = [f.name for f in fields(TableParams)]
_SIM = [f.name for f in fields(SimSettings)]


class RunParametersError(ValueError):
    """A run_parameters document that cannot rebuild the model; says what is wrong."""


@dataclass(frozen=True)
class RunParameters:
    """A parsed run_parameters document."""

    params: TableParams
    settings: SimSettings
    initial_state: np.ndarray      # θ1, θ2, θ3 (rad), ω1, ω2, ω3 (rad/s)
    start_step: int
    package_version: str


def run_parameters_yaml(params: TableParams, settings: SimSettings,
                        initial_state: Sequence[float], start_step: int) -> str:
    """The YAML text of a run_parameters message (complete parameter set)."""
    state = [float(v) for v in initial_state]
    if len(state) != 6:
        raise ValueError(f'initial_state needs 6 values, got {len(state)}')
    document = {**params.as_dict(), **settings.as_dict(), 'package_version': __version__,
                'initial_state': state, 'start_step': int(start_step)}
    return yaml.safe_dump(document, default_flow_style=None, sort_keys=False)


def parse_run_parameters(text: str) -> RunParameters:
    """Rebuild validated parameters from a run_parameters document."""
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RunParametersError(f'run_parameters is not valid YAML: {exc}') from None
    if not isinstance(document, dict):
        raise RunParametersError('run_parameters is not a mapping of parameter names')
    unknown = sorted(set(document) - set(_TABLE) - set(_SIM) - set(EXTRA_KEYS))
    missing = sorted(set(_TABLE) - set(document))
    if unknown:
        raise RunParametersError(f'run_parameters has unknown keys {unknown} '
                                 '(written by a newer screwgear_ros?)')
    if missing:
        raise RunParametersError(f'run_parameters lacks the physical parameters {missing}: '
                                 'the model cannot be rebuilt from this bag')
    try:
        params = TableParams(**{k: document[k] for k in _TABLE})
        settings = SimSettings(**{k: document[k] for k in _SIM if k in document})
    except (ParameterError, TypeError) as exc:
        raise RunParametersError(f'run_parameters refused: {exc}') from None
    state = np.asarray(document.get('initial_state', []), dtype=np.float64)
    if state.shape != (6,) or not np.all(np.isfinite(state)):
        raise RunParametersError(f'run_parameters initial_state must be 6 finite floats, '
                                 f'got {document.get("initial_state")!r}')
    start_step = document.get('start_step', 0)
    if isinstance(start_step, bool) or not isinstance(start_step, int) or start_step < 0:
        raise RunParametersError(f'run_parameters start_step must be an integer >= 0, '
                                 f'got {start_step!r}')
    return RunParameters(params, settings, state, start_step,
                         str(document.get('package_version', 'unknown')))


__all__ = ['RunParameters', 'RunParametersError', 'run_parameters_yaml',
           'parse_run_parameters', 'EXTRA_KEYS']
