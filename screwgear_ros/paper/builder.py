"""Run every section of the paper report and write ``report.md`` with its figures."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from types import ModuleType
from typing import Any

from tqdm import tqdm

from .. import __name__ as package_name
from . import (
    antibacklash,
    damping,
    derived,
    design,
    energy,
    fluctuation,
    index,
    response,
    stability,
    stiffness,
    summary,
    thermal,
    validation,
)
from .common import Section, verdict_table

SECTIONS: tuple[ModuleType, ...] = (derived, response, damping, stiffness, index, stability,
                                    fluctuation, thermal, antibacklash, validation, energy,
                                    design)
#: The paper, as its text (the project's seed) gives it: no title line, authors or venue,
#: so the citation quotes its own statement of subject and mechanism.
PAPER_SUBJECT = ('a novel double screw gear anti-backlash transmission mechanism',
                 'its nonlinear dynamic characteristics')
PAPER_MECHANISM = ('preloaded nuts that axially fix two screw gears in opposite directions, '
                   'creating a constant unilateral contact in the gear pairs')
PAPER_SOURCE = 'seed/000_7c306ecbcaa524e9.txt'
PAPER = (f'that proposes "{PAPER_SUBJECT[0]}" and investigates "{PAPER_SUBJECT[1]}" (its text is '
         f'the project\'s seed, `{PAPER_SOURCE}`, the source of model.md; the text carries no '
         'title line, authors or venue, so it is cited by these words of its own). The '
         f'mechanism it proposes uses "{PAPER_MECHANISM}": two pinions, each driven by a screw '
         'gear through a worm wheel, engage the large gear of a rotary table on opposite '
         'sides, one path active per direction of rotation, so that the table has no '
         'backlash. The paper models one gear pair with a lumped-parameter equation, '
         'normalizes it and integrates it with fourth-order Runge–Kutta')


@dataclass(frozen=True)
class Report:
    path: Path                   # report.md
    sections: list[Section]
    seconds: dict                # section number → run time, s


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(package_name)
    except PackageNotFoundError:  # not installed (running from the source tree)
        return 'source tree'


def build(outdir: str | Path, quick: bool = False) -> Report:
    """Compute and render every section into ``outdir``; returns the report."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    sections: list[Section] = []
    results: dict[ModuleType, Any] = {}
    seconds: dict[int, float] = {}
    for number, module in enumerate(tqdm(SECTIONS, desc='paper report', unit='section'),
                                    start=1):
        start = time.perf_counter()
        results[module] = module.compute(quick)
        section = module.render(results[module], out)
        seconds[number] = time.perf_counter() - start
        sections.append(section)
    first_page = summary.render(summary.compute(results[derived], results[antibacklash]),
                                sections)
    text = _markdown(sections, quick, seconds, first_page)
    path = out / 'report.md'
    path.write_text(text, encoding='utf-8')
    return Report(path, sections, seconds)


def _markdown(sections: list[Section], quick: bool, seconds: dict, first_page: str) -> str:
    summary = [replace(v, claim=f'§{s.number} {v.claim}') for s in sections for v in s.verdicts]
    toc = '\n'.join(f'{s.number}. [{s.title}](#{_anchor(s)})' for s in sections)
    head = f"""# The paper, claim by claim

Recomputed with `screwgear_ros` {_version()} for the paper {PAPER}.

Every number below comes from the package's own model: `params.py` (derived quantities),
`normalized.py` + `batch.py` (the normalized equation, RK4), `floquet.py` (stability,
periodic steady states) and `plant.py` (the 3-DOF table). Dimensionless quantities (x, τ)
are as in the paper: τ = ω0·t, u = l·x with l = 1 µm.
{'**Quick run** (`--quick`): coarse grids, for tests; numbers of the full run may differ slightly.' if quick else ''}

Verdicts: **holds** (the number or statement is reproduced), **does not hold** (the model
gives something else, shown beside it), **vague** (true only under an unstated reading, or
too loose to test), **cannot be checked** (no data).

{first_page}
## Contents

{toc}

## Summary of verdicts

{verdict_table(summary)}
"""
    timing = ', '.join(f'§{n}: {t:.1f} s' for n, t in seconds.items())
    tail = f'\n---\nRun time per section: {timing}; total {sum(seconds.values()):.0f} s.\n'
    return head + '\n' + '\n'.join(s.markdown() for s in sections) + tail


def _anchor(section: Section) -> str:
    """GitHub-style anchor of a section heading."""
    text = f'{section.number}. {section.title}'.lower()
    kept = ''.join(ch for ch in text if ch.isalnum() or ch in ' -_')
    return kept.replace(' ', '-')


__all__ = ['PAPER', 'PAPER_MECHANISM', 'PAPER_SUBJECT', 'SECTIONS', 'Report', 'build']
