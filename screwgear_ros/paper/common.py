"""What every report section shares: the section record, verdicts, tables, figures.

A section module computes its numbers in a ``compute(quick)`` function (returning a
plain dataclass the tests check) and turns them into a :class:`Section` with
``render(result, outdir)``: Markdown text, PNG figures written into ``outdir``
(matplotlib, Agg backend) and a list of :class:`Verdict`s.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..params.config_files import config_path
from ..runs.figure_style import COLORS, plt

HOLDS = 'holds'
FAILS = 'does not hold'
VAGUE = 'vague'
UNCHECKABLE = 'cannot be checked'


@dataclass(frozen=True)
class Verdict:
    """One claim of the paper, its number or words, what the model gives, the verdict."""

    claim: str
    paper: str
    recomputed: str
    verdict: str          # HOLDS | FAILS | VAGUE | UNCHECKABLE, optionally qualified
    note: str = ''


@dataclass
class Section:
    """One section of the report: Markdown body, figure files, verdicts."""

    number: int
    title: str
    body: str
    figures: list[str] = field(default_factory=list)
    verdicts: list[Verdict] = field(default_factory=list)

    def markdown(self) -> str:
        lines = [f'## {self.number}. {self.title}', '', self.body.strip(), '']
        if self.verdicts:
            lines += ['**Verdicts**', '', verdict_table(self.verdicts), '']
        return '\n'.join(lines)


def table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A Markdown table; cells are str()-ed as given (format numbers before)."""
    def cell(value: object) -> str:
        return str(value).replace('|', '\\|')

    out = ['| ' + ' | '.join(cell(h) for h in header) + ' |', '|' + '---|' * len(header)]
    out += ['| ' + ' | '.join(cell(c) for c in row) + ' |' for row in rows]
    return '\n'.join(out)


def verdict_table(verdicts: Sequence[Verdict]) -> str:
    return table(('claim', 'paper', 'recomputed', 'verdict'),
                 ((v.claim, v.paper, v.recomputed,
                   f'**{v.verdict}**' + (f': {v.note}' if v.note else '')) for v in verdicts))


def save_figure(fig: plt.Figure, outdir: Path, name: str, alt: str) -> tuple[str, str]:
    """Write ``fig`` as ``outdir/name`` (PNG), close it; returns (file name, Markdown link)."""
    fig.savefig(outdir / name, bbox_inches='tight')
    plt.close(fig)
    return name, f'![{alt}]({name})'


def fmt(value: float, digits: int = 4) -> str:
    """A number to ``digits`` significant digits, plain notation where readable."""
    if value == 0.0:
        return '0'
    text = f'{value:.{digits}g}'
    if 'e' in text:
        mantissa, exponent = text.split('e')
        return f'{mantissa}·10^{int(exponent)}'
    return text


def agreement(difference: float, scale: float = 1.0) -> str:
    """How closely two computations agree, for prose: 'exactly (bit for bit)' at 0,
    else 'to 3·10^-12' relative to ``scale`` (never 'by at most 0')."""
    if difference == 0.0:
        return 'exactly (bit for bit)'
    return f'to {fmt(difference / scale, 1)}' + (' of the scale' if scale != 1.0 else '')


__all__ = [
    'COLORS',
    'FAILS',
    'HOLDS',
    'UNCHECKABLE',
    'VAGUE',
    'Section',
    'Verdict',
    'agreement',
    'config_path',
    'fmt',
    'plt',
    'save_figure',
    'table',
    'verdict_table',
]
