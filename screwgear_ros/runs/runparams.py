"""Reading a bag's ``run_parameters`` documents strictly enough to trust a re-integration.

The document itself (:mod:`screwgear_ros.run_parameters`, written by the node) holds
every TableParams and SimSettings field plus ``package_version``, ``initial_state``
and ``start_step``. Loading it for an offline check must not fill a missing
physical parameter with its default, so :func:`parse_run_parameters` insists that
every one is present before handing the text to :func:`run_parameters.load`, and
turns every failure into a :class:`RunParametersError` that says what is wrong.
"""

from __future__ import annotations

from dataclasses import fields

import yaml

from ..params import ParameterError, TableParams
from ..run_parameters import EXTRA_KEYS, RunParameters, load

_TABLE = {f.name for f in fields(TableParams)}


class RunParametersError(ValueError):
    """A run_parameters document that cannot rebuild the model; says what is wrong."""


def parse_run_parameters(text: str) -> RunParameters:
    """Validated parameters, settings and start of a run from a run_parameters text."""
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RunParametersError(f'run_parameters is not valid YAML: {exc}') from None
    if not isinstance(document, dict):
        raise RunParametersError('run_parameters is not a mapping of parameter names')
    missing = sorted((_TABLE | set(EXTRA_KEYS)) - set(document))
    if missing:
        raise RunParametersError(f'run_parameters lacks {missing}: the model cannot be '
                                 'rebuilt from this bag')
    try:
        run = load(text)
    except (ParameterError, TypeError, ValueError) as exc:
        raise RunParametersError(f'run_parameters refused: {exc}') from None
    if len(run.initial_state) != 6 or run.start_step < 0:
        raise RunParametersError(f'run_parameters initial_state must hold 6 values and '
                                 f'start_step be >= 0, got {run.initial_state!r}, '
                                 f'{run.start_step!r}')
    return run


__all__ = ['RunParameters', 'RunParametersError', 'parse_run_parameters']
