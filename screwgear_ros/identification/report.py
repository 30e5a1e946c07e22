"""The identification report: markdown (estimates, intervals, correlations, what the data
cannot determine and what would, fit % before and after) and one PNG (measured against
simulated before and after, and the residuals, for every fit and validation recording).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .problem import Comparison
from .samples import NODE_JOINTS
from .stats import DETERMINED, Statistics

COLUMN_NAMES = [f'θ {j}' for j in NODE_JOINTS] + [f'ω {j}' for j in NODE_JOINTS]


def _fits(c: Comparison, which: str) -> str:
    return ', '.join(f'{v:.2f}' if math.isfinite(v) else 'diverged' for v in c.fit(which))


def _number(value: float, digits: int = 8) -> str:
    return f'{value:.{digits}g}' if math.isfinite(value) else ('—' if math.isnan(value) else
                                                               f'{value:g}')


def markdown(stats: Statistics, comparisons: Sequence[Comparison], *, finished: bool,
             fitted_path: str, png: str, simulations: int, seconds: float,
             sim_seconds: float, workers: str, speeds: bool,
             starts: Sequence[tuple[dict[str, float], float]] = ()) -> str:
    """The report's markdown text."""
    lines = ['# Identification report', '']
    if not finished:
        lines += [('**Unfinished**: the fit was interrupted; the values are the best point '
                  'evaluated so far, without intervals, and nothing is judged determined.'),
                  '']
    if stats.warnings:
        lines += ['## Warnings', '', *(f'- {w}' for w in stats.warnings), '']
    local = ' (local: they hold around this minimum only)' if stats.local else ''
    lines += [(f'Fitted file: `{fitted_path}`. {simulations} simulations on {workers} in '
              f'{seconds:.1f} s ({sim_seconds:.1f} s of simulation). A value is determined '
              f'when its ±2σ interval{local} is within ±{100 * DETERMINED:g} % of it.'), '',
              '| parameter | base | fitted | ±2σ | −2σ | +2σ | unit | determined |',
              '|---|---|---|---|---|---|---|---|']
    for e in stats.estimates:
        reference = abs(e.value) if e.value else math.nan
        half = 100 * (e.high - e.low) / 2 / reference
        lines.append(f'| `{e.name}` | {e.base:.6g} | {e.value:.8g} | {_number(half, 2)} % | '
                     f'{_number(e.low)} | {_number(e.high)} | {e.unit} | {e.verdict} |')
    lines += ['', f'Residual standard deviation (weighted): {stats.sigma:.4g}; singular '
              'values of the column-scaled Jacobian: '
              + ', '.join(f'{s:.3g}' for s in stats.singular_values), '']
    if stats.directions:
        lines += [('Directions of the parameters the recordings cannot see (the intervals '
                   'above are those of the others):'), '',
                  *(f'- {d}' for d in stats.directions), '']
    if stats.undetermined:
        lines += ['## Not determined', '']
        for e in stats.undetermined:
            lines.append(f'- `{e.name}`: {e.undetermined}. To determine it, {e.advice}.')
        lines.append('')
    if len(starts) > 1:
        names = [e.name for e in stats.estimates]
        lines += ['## Starts', '', '| start | cost | ' + ' | '.join(f'`{n}`' for n in names)
                  + ' |', '|---|---|' + '---|' * len(names)]
        for k, (values, cost) in enumerate(starts, 1):
            lines.append(f'| {k} | {cost:.6g} | '
                         + ' | '.join(f'{values[n]:.6g}' for n in names) + ' |')
        lines.append('')
    names = [e.name for e in stats.estimates]
    lines += ['## Correlation', '', '| | ' + ' | '.join(f'`{n}`' for n in names) + ' |',
              '|---|' + '---|' * len(names)]
    for n, row in zip(names, stats.correlation, strict=True):
        lines.append(f'| `{n}` | ' + ' | '.join(f'{v:+.3f}' if math.isfinite(v) else '—'
                                                for v in row) + ' |')
    columns = COLUMN_NAMES[:6 if speeds else 3]
    lines += ['', '## Fit % = 100·(1 − NRMSE), per joint (' + ', '.join(columns) + ')', '',
              '| recording | role | before | after |', '|---|---|---|---|']
    for c in comparisons:
        lines.append(f'| `{c.recording.path}` | {c.role} | {_fits(c, "before")} | '
                     f'{_fits(c, "after")} |')
    lines += ['', f'![measured against simulated]({png})', '']
    return '\n'.join(lines)


def figure(comparisons: Sequence[Comparison], path: str | Path) -> Path:
    """One row per recording: the table's measured angle against the model's before and
    after, and the residuals of every joint before and after the fit, each in % of that
    joint's measured range (the pinions turn eight times the table's angle)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    rows = max(1, len(comparisons))
    fig, axes = plt.subplots(rows, 3, figsize=(16, 3.3 * rows), squeeze=False)
    for ax, c in zip(axes, comparisons, strict=False):
        t = (c.recording.times - c.recording.times[0]) * 1e-9
        name = Path(c.recording.path).name
        ax[0].plot(t, c.measured[:, 1], 'k', lw=1.6, label='measured')
        for label, data, style in (('before', c.before, 'C1--'), ('after', c.after, 'C0-')):
            if data is not None:
                fit = c.fit(label)[1]
                ax[0].plot(t, data[:, 1], style, lw=0.9, label=f'{label} ({fit:.2f} %)')
        ax[0].set_title(f'{name} ({c.role}): table angle')
        ax[0].set_ylabel('θ table, rad (zero fitted)')
        ax[0].legend(loc='best', fontsize=8)
        span = np.ptp(c.measured, axis=0)
        span = np.where(span > 0, span, 1.0)
        for k, (label, data) in enumerate((('before', c.before), ('after', c.after)), 1):
            if data is None:
                ax[k].text(0.5, 0.5, 'the model diverged', ha='center',
                           transform=ax[k].transAxes)
            else:
                for j in range(c.measured.shape[1]):
                    ax[k].plot(t, 100 * (data[:, j] - c.measured[:, j]) / span[j], lw=0.7,
                               label=COLUMN_NAMES[j], zorder=3 if j == 1 else 2)
                ax[k].legend(loc='best', fontsize=8)
            ax[k].set_title(f'{name}: residual {label} the fit (simulated − measured)')
            ax[k].set_ylabel('% of the joint\'s range')
        for a in ax:
            a.set_xlabel('t, s')
            a.grid(alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def write_report(stem: str | os.PathLike[str], stats: Statistics, comparisons: Sequence[Comparison],
                 sections: Sequence[str] = (), **details: Any) -> tuple[Path, Path]:
    """Write ``stem``.md and ``stem``.png; their paths. ``sections``: markdown lines
    appended (the residual analysis, the recordings' timing)."""
    stem = Path(stem)
    png = figure(comparisons, stem.with_suffix('.png'))
    md = stem.with_suffix('.md')
    md.write_text(markdown(stats, comparisons, png=png.name, **details)
                  + '\n'.join(['', *sections]), encoding='utf-8')
    return md, png


__all__ = ['figure', 'markdown', 'write_report']
