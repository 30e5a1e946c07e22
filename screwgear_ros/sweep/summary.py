"""DIR/summary.png and the worst runs of a sweep.

A grid: each metric against each swept parameter. A Monte Carlo draw: a histogram of each
metric, and the first metric against each drawn parameter with the worst runs marked and
named in a column beside the panel (named at the points, they overlap: the worst runs
crowd at the top). Axes carry the parameters' units; tick labels are few and short, so
that neighbouring panels' labels stay apart.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

#: How many worst runs the summary marks and the command lists.
WORST = 5


def worst(table: dict[str, list[Any]], metric: str, count: int = WORST) -> list[int]:
    """Positions in ``table`` of the ``count`` largest values of ``metric``, +inf first
    (a step that never settles is the worst settling there is), ties by run index; NaN
    (no value: no step, a failed run) and -inf are never the worst.

    Examples
    --------
    >>> inf = float('inf')
    >>> worst({'index': [0, 1, 2], 'm': [1.0, inf, float('nan')]}, 'm')
    [1, 0]
    """
    values = table[metric]
    ranked = [k for k, v in enumerate(values) if not math.isnan(v) and v != -math.inf]
    return sorted(ranked, key=lambda k: (-values[k], table['index'][k]))[:count]


def label(column: str) -> str:
    """An axis label for a swept column: the parameter with its unit, or the factor of a
    scaled one."""
    from ..params.declarations import declared
    from ..params.table import SimSettings, TableParams

    if column.endswith('_scale'):
        return f'{column} (× base value)'
    units = {p.name: p.declaration.unit for cls in (TableParams, SimSettings)
             for p in declared(cls)}
    unit = units.get(column)
    return f'{column} [{unit}]' if unit else column


def _tidy(ax: Any) -> None:
    """At most four ticks on x, in short numbers (an exponent at the axis' end)."""
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(nbins=4))
    ax.ticklabel_format(axis='both', style='sci', scilimits=(-2, 3), useOffset=False)
    ax.tick_params(labelsize=8)


def _mark_worst(ax: Any, x: Any, y: Any, marked: list[int], table: dict[str, list[Any]],
                metric: str) -> None:
    """The worst runs in red, named in a column right of the panel, worst first, each
    joined to its point; a run whose value is +inf (never settled) at the panel's top,
    named so."""
    import numpy as np

    shown = [m for m in marked if np.isfinite(y[m])]
    ax.scatter(x[shown], y[shown], s=30, color='tab:red', label='worst', zorder=3)
    for rank, m in enumerate(marked):
        finite = bool(np.isfinite(y[m]))
        ax.annotate(f'run {table["index"][m]}' + ('' if finite else ' (inf: off the top)'),
                    xy=(x[m], y[m] if finite else 1.0),
                    xycoords='data' if finite else ('data', 'axes fraction'),
                    xytext=(1.03, 0.95 - 0.16 * rank), textcoords='axes fraction',
                    fontsize=7, va='center', color='tab:red', annotation_clip=False,
                    arrowprops={'arrowstyle': '-', 'color': 'tab:red', 'lw': 0.5,
                                'alpha': 0.6})


def figure(table: dict[str, list[Any]], columns: tuple[str, ...], metrics: tuple[str, ...],
           monte_carlo: bool, path: Path) -> Path:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    numeric = [c for c in columns if table[c] and isinstance(table[c][0], float)]
    ok = np.array([s in ('ok', 'fault') for s in table['status']], dtype=bool)
    if monte_carlo:
        cols = max(len(metrics), len(numeric), 1)
        fig, axes = plt.subplots(2, cols, figsize=(4.2 * cols, 6.8), squeeze=False)
        for k, name in enumerate(metrics):
            values = np.array(table[name])[ok]
            values = values[np.isfinite(values)]
            ax = axes[0][k]
            ax.hist(values, bins=max(5, min(40, int(math.sqrt(len(values))) + 1)),
                    color='tab:blue')
            ax.set_xlabel(name, fontsize=9)
            ax.set_ylabel('runs', fontsize=9)
            _tidy(ax)
        for k in range(len(metrics), cols):
            axes[0][k].axis('off')
        first = np.array(table[metrics[0]])
        marked = worst(table, metrics[0])
        for k, column in enumerate(numeric):
            ax = axes[1][k]
            x = np.array(table[column])
            ax.scatter(x[ok], first[ok], s=8, color='tab:blue', label='runs')
            _mark_worst(ax, x, first, marked, table, metrics[0])
            ax.set_xlabel(label(column), fontsize=9)
            ax.set_ylabel(metrics[0], fontsize=9)
            _tidy(ax)
        for k in range(len(numeric), cols):
            axes[1][k].axis('off')
        if numeric:
            axes[1][0].legend(fontsize=7, loc='lower left')
    else:
        rows, cols = len(metrics), max(len(numeric), 1)
        fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.9 * rows), squeeze=False)
        for r, name in enumerate(metrics):
            y = np.array(table[name])
            for c, column in enumerate(numeric):
                ax = axes[r][c]
                ax.plot(np.array(table[column])[ok], y[ok], 'o', ms=4)
                ax.set_xlabel(label(column), fontsize=9)
                ax.set_ylabel(name, fontsize=9)
                _tidy(ax)
    failed = int((~ok).sum())
    fig.suptitle(f'{len(table["index"])} runs' + (f', {failed} without metrics (error or '
                                                    'timeout)' if failed else ''))
    fig.tight_layout(w_pad=4.0)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


__all__ = ['WORST', 'figure', 'label', 'worst']
