"""The complete parameter set of a run as YAML: what a recording needs to be re-integrated.

The node writes it on ``<node>/run_parameters`` (std_msgs/String) at the start of a
run and again, complete, at the step each accepted parameter change takes effect.
Keys: every TableParams and SimSettings field under its ROS parameter name, plus
``package_version``, ``initial_state`` (θ1, θ2, θ3 in rad, ω1, ω2, ω3 in rad/s at
the start of the run) and ``start_step`` (the integration step the run started at).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import metadata
from typing import Any

import yaml

from .params import SimSettings, TableParams, split_parameters

EXTRA_KEYS = ('package_version', 'initial_state', 'start_step')


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
    """Parse :func:`dump`'s YAML back; validates like the node (ParameterError)."""
    document = yaml.safe_load(text)
    values = {k: v for k, v in document.items() if k not in EXTRA_KEYS}
    params, settings = split_parameters(values)
    state = document['initial_state']
    return RunParameters(params, settings, tuple(float(v) for v in state),
                         int(document['start_step']), str(document['package_version']))


__all__ = ['EXTRA_KEYS', 'RunParameters', 'dump', 'load', 'package_version']
