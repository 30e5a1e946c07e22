"""The choices a parameter set makes among mechanisms and formulations, as enums (a
parameter file names them by their values)."""

from __future__ import annotations

from enum import StrEnum


class Mode(StrEnum):
    """The mechanism: both pinions under preload, or one pinion with backlash."""

    ANTI_BACKLASH = 'anti_backlash'
    CONVENTIONAL = 'conventional'


class MeshPhase(StrEnum):
    """What drives the mesh phase φ: the pinion angle (φ = z·θ) or time (φ = ω_e·t)."""

    ANGLE = 'angle'
    TIME = 'time'


class MeshFormulation(StrEnum):
    """How the mesh acts on the bodies (docs/model_notes.md §9).

    `paper`: the mesh force F pushes each pinion through its radius r (model.md §3),
    the paper's equations, which do work of their own in `angle` phase.
    `energy_consistent`: the forces derive from the mesh potential ½·K(φ)·f(δ)² with
    φ = z·θ: the pinion's lever is r − z·dε/dφ and the stiffness variation adds
    ½·z·dK/dφ·f(δ)². In `time` phase the two are the same equations.
    """

    PAPER = 'paper'
    ENERGY_CONSISTENT = 'energy_consistent'


__all__ = ['MeshFormulation', 'MeshPhase', 'Mode']
