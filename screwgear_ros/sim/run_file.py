"""The complete parameter set of a run as YAML: what a recording needs to be re-integrated.

The node writes it on ``<node>/run_parameters`` (std_msgs/String) at the start of a
run and again, complete, at the step each accepted parameter change takes effect.
Keys: every TableParams and SimSettings field under its ROS parameter name, plus
``package_version``, ``initial_state`` (θ1, θ2, θ3 in rad, ω1, ω2, ω3 in rad/s at
the start of the run) and ``start_step`` (the integration step the run started at).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from importlib import metadata
from typing import Any

import yaml

from ..errors import ScrewgearError
from ..params.table import ParameterError, SimSettings, TableParams
from .parameter_set import split_parameters

EXTRA_KEYS = ('package_version', 'initial_state', 'start_step')
#: Parameters and settings added after the first release, with the value that recordings
#: made before them ran with (so that such a recording replays as it ran): no command
#: timeout, the ideal torque source (the stall torque then plays no part), the paper's
#: mesh equations, plain fixed-step RK4 (no contact location), no effort deadband and
#: no direction hysteresis, no bearing friction, an instant drive torque without cogging.
INTRODUCED = {'command_timeout': 0.0, 'drive_no_load_speed': 0.0, 'effort_deadband': 0.0,
              'direction_hysteresis': 0.0,
              'drive_stall_torque': TableParams.drive_stall_torque, 'mesh_formulation': 'paper',
              'contact_location': False, **{
                  f'{body}_{what}': 0.0 for body in ('table', 'pinion')
                  for what in ('coulomb_torque', 'static_torque', 'stribeck_speed')},
              'pinion_damping': 0.0, 'drive_time_constant': 0.0,
              'cogging_amplitude': 0.0, 'cogging_order': 1}
_REQUIRED = ({f.name for f in fields(TableParams)} | set(EXTRA_KEYS)) - set(INTRODUCED)


class RunParametersError(ScrewgearError, ValueError):
    """A run_parameters document that cannot rebuild the model; says what is wrong."""


def package_version() -> str:
    """Installed version of screwgear_ros ('unknown' when run from a source tree)."""
    try:
        return metadata.version('screwgear_ros')
    except metadata.PackageNotFoundError:
        return 'unknown'


@dataclass(frozen=True)
class RunParameters:
    """Parameters, settings and start of a run."""

    params: TableParams
    settings: SimSettings
    initial_state: tuple[float, ...]
    start_step: int = 0
    package_version: str = ''


def dump(run: RunParameters) -> str:
    """YAML text of a run's complete parameter set (floats round-trip exactly)."""
    document: dict[str, Any] = {**run.params.as_dict(), **run.settings.as_dict()}
    document['package_version'] = run.package_version or package_version()
    document['initial_state'] = [float(v) for v in run.initial_state]
    document['start_step'] = int(run.start_step)
    return yaml.safe_dump(document, sort_keys=False)


def load(text: str) -> RunParameters:
    """Parse :func:`dump`'s YAML back, strictly enough to trust a re-integration.

    Every physical parameter must be present (a missing one is never filled with its
    default) and valid as the node would judge it; any failure is a
    :class:`RunParametersError` saying what is wrong.
    """
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RunParametersError(f'run_parameters is not valid YAML: {exc}') from None
    if not isinstance(document, dict):
        raise RunParametersError('run_parameters is not a mapping of parameter names')
    missing = sorted(_REQUIRED - set(document))
    if missing:
        raise RunParametersError(f'run_parameters lacks {missing}: the model cannot be '
                                 'rebuilt from this bag')
    try:
        params, settings = split_parameters(
            {**INTRODUCED, **{k: v for k, v in document.items() if k not in EXTRA_KEYS}})
        run = RunParameters(params, settings,
                            tuple(float(v) for v in document['initial_state']),
                            int(document['start_step']), str(document['package_version']))
    except (ParameterError, TypeError, ValueError) as exc:
        raise RunParametersError(f'run_parameters refused: {exc}') from None
    if len(run.initial_state) != 6 or run.start_step < 0:
        raise RunParametersError(f'run_parameters initial_state must hold 6 values and '
                                 f'start_step be >= 0, got {run.initial_state!r}, '
                                 f'{run.start_step!r}')
    return run


__all__ = ['EXTRA_KEYS', 'RunParameters', 'RunParametersError', 'dump', 'load',
           'package_version']
