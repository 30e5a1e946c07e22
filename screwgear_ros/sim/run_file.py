"""The complete parameter set of a run as YAML: what a recording needs to be re-integrated.

The node writes it on ``<node>/run_parameters`` (std_msgs/String) at the start of a
run and again, complete, at the step each accepted parameter change takes effect.
Keys: every TableParams and SimSettings field under its ROS parameter name, plus
``package_version``, ``initial_state`` (θ1, θ2, θ3 in rad, ω1, ω2, ω3 in rad/s at
the start of the run) and ``start_step`` (the integration step the run started at).

A recording made before a parameter existed lacks its key; it reads with the value its
declaration says such recordings ran with (``introduced=``, ``before=`` in
:mod:`screwgear_ros.params.table`), decided by the recording's ``package_version``. Any
other missing key refuses the document: it is never filled with a default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import yaml

from .. import __version__
from ..errors import ScrewgearError
from ..params.declarations import declared, excerpt, plain, recorded_without
from ..params.table import ParameterError, SimSettings, TableParams
from .parameter_set import split_parameters

EXTRA_KEYS = ('package_version', 'initial_state', 'start_step')


class RunParametersError(ScrewgearError, ValueError):
    """A run_parameters document that cannot rebuild the model; says what is wrong."""


def package_version() -> str:
    """The version of screwgear_ros that runs (``screwgear_ros.__version__``), as a
    recording carries it."""
    return __version__


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

    Every parameter must be present and valid as the node would judge it. The one
    exception is a parameter the document's ``package_version`` predates: it takes the
    value its declaration says those runs had (:func:`missing_values`). Any failure is a
    :class:`RunParametersError` saying what is wrong.
    """
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RunParametersError(f'run_parameters is not valid YAML: {exc}') from None
    if not isinstance(document, dict):
        raise RunParametersError('run_parameters is not a mapping of parameter names')
    if 'package_version' not in document:
        raise RunParametersError("run_parameters lacks ['package_version']: the model cannot "
                                 'be rebuilt from this bag')
    version = str(document['package_version'])
    older, missing = missing_values(document, version)
    missing += [key for key in EXTRA_KEYS if key not in document]
    if missing:
        raise RunParametersError(f'run_parameters lacks {excerpt(missing)}: the model cannot be '
                                 f'rebuilt from this bag (its package_version '
                                 f'{excerpt(version)} had them)')
    try:
        params, settings = split_parameters(
            {**older, **{k: v for k, v in document.items() if k not in EXTRA_KEYS}})
        run = RunParameters(params, settings,
                            tuple(float(v) for v in document['initial_state']),
                            int(document['start_step']), version)
    except (ParameterError, TypeError, ValueError) as exc:
        raise RunParametersError(f'run_parameters refused: {exc}') from None
    if len(run.initial_state) != 6 or run.start_step < 0:
        raise RunParametersError(f'run_parameters initial_state must hold 6 values and '
                                 f'start_step be >= 0, got {run.initial_state!r}, '
                                 f'{run.start_step!r}')
    return run


def missing_values(document: dict[str, Any], version: str) -> tuple[dict[str, Any], list[str]]:
    """The parameters ``document`` lacks: (name → the value runs of package ``version``
    had, for those the version predates; the names of the others, which nothing fills).

    A version that is not X.Y.Z predates nothing.
    """
    older: dict[str, Any] = {}
    missing: list[str] = []
    for p in (*declared(TableParams), *declared(SimSettings)):
        if p.name in document:
            continue
        if recorded_without(p, version):
            older[p.name] = plain(p.declaration.before)
        else:
            missing.append(p.name)
    return older, missing


__all__ = ['EXTRA_KEYS', 'RunParameters', 'RunParametersError', 'dump', 'load',
           'missing_values', 'package_version']
