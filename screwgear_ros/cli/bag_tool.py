"""The error ladder of the tools that read a recorded run and re-simulate it (check_run,
plot_run): a bag they cannot read, recorded parameters the model refuses, anything else."""

from __future__ import annotations

from typing import cast

from ..bag.errors import BagError
from ..physics.equilibrium import EquilibriumNotFound
from . import Errors, Failures, Message


def bag_failures(tool: str, verb: str, bag: str,
                 ladder: dict[Errors, Message | tuple[Message, int]] | None = None) -> Failures:
    """:class:`Failures` for ``tool`` that cannot ``verb`` the run at ``bag``, with the
    tool's own ``ladder`` tried after an unreadable bag (errors of neither kind)."""
    return Failures(tool, {
        BagError: lambda exc: cast(BagError, exc).report(verb, bag),
        **(ladder or {}),
        (EquilibriumNotFound, ValueError):      # ParameterError is a ValueError
            'cannot {verb} {bag}: the recorded parameters cannot be simulated: {exc}',
    }, unexpected='cannot {verb} {bag}: unexpected {kind}: {exc}', verb=verb, bag=bag)


__all__ = ['bag_failures']
