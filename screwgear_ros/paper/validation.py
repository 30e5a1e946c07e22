"""Section 10: the paper's experimental validation, which cannot be checked."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .common import UNCHECKABLE, Section, Verdict, table


@dataclass(frozen=True)
class Validation:
    """Nothing to compute: the paper publishes no measurement."""


def compute(quick: bool = False) -> Validation:
    return Validation()


def render(v: Validation, outdir: Path) -> Section:
    missing = table(('what a check would need', 'in the paper'), (
        ('the prototype\'s parameters (inertias, stiffness, damping, STE, preload)',
         '"similar to those in the simulation"'),
        ('the measured displacement–time curves or transmission error', 'not published'),
        ('sensor type, location, bandwidth, load and speed of each test', 'not given'),
        ('how the correlation coefficient was computed (which signals, time window)',
         'not given'),
    ))
    body = f"""
The paper reports that measured displacement–time curves of a prototype agree with the
simulation, with correlation coefficients above 0.9 for ζ = 0.05 to 0.1. No measured data,
prototype parameters or test conditions are published, and none exist in this project, so the
claim cannot be checked here:

{missing}

Two remarks on what such a number could mean. First, a correlation coefficient ignores
offset and scale: any curve dominated by the quasi-static deflection f0/(1 + k_a'·cos Ωτ)
(sections 2–4) correlates highly with any other such curve, whatever ζ, so r > 0.9 would
say little about damping. Second, the model's damping is an input: ζ = 0.05–0.1 would have
to be identified from the measurement (e.g. from the decay rate of the transient, which is
exactly ζ in τ, section 3) before a comparison tests anything. A replay of recorded runs
against the project's own reference solver (`check_run`) is what this package offers
instead: it checks the simulator, not the paper's prototype.
"""
    verdicts = [Verdict('experiments agree with the model, correlation > 0.9',
                        'r > 0.9 for ζ = 0.05–0.1', 'no data', UNCHECKABLE,
                        'no measurement, prototype parameters or method are published')]
    return Section(10, 'Experimental validation', body, [], verdicts)


__all__ = ['Validation', 'compute', 'render']
