"""DIR/summary.png and the worst runs of a sweep.

A grid: each metric against each swept parameter. A Monte Carlo draw: a histogram of each
metric, and the first metric against each drawn parameter with the worst runs marked.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

#: How many worst runs the summary marks and the command lists.
WORST = 5


def worst(table: dict[str, list[Any]], metric: str, count: int = WORST) -> list[int]:
    """Positions in ``table`` of the ``count`` largest finite values of ``metric``."""
    values = table[metric]
    finite = [k for k, v in enumerate(values) if not math.isnan(v) and not math.isinf(v)]
    return sorted(finite, key=lambda k: (-values[k], table['index'][k]))[:count]


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
        fig, axes = plt.subplots(2, cols, figsize=(3.6 * cols, 6.4), squeeze=False)
        for k, name in enumerate(metrics):
            values = np.array(table[name])[ok]
            values = values[np.isfinite(values)]
            ax = axes[0][k]
            ax.hist(values, bins=max(5, min(40, int(math.sqrt(len(values))) + 1)),
                    color='tab:blue')
            ax.set_xlabel(name)
            ax.set_ylabel('runs')
        for k in range(len(metrics), cols):
            axes[0][k].axis('off')
        first = np.array(table[metrics[0]])
        marked = worst(table, metrics[0])
        for k, column in enumerate(numeric):
            ax = axes[1][k]
            x = np.array(table[column])
            ax.scatter(x[ok], first[ok], s=8, color='tab:blue', label='runs')
            ax.scatter(x[marked], first[marked], s=30, color='tab:red', label='worst')
            for m in marked:
                ax.annotate(str(table['index'][m]), (x[m], first[m]), fontsize=7)
            ax.set_xlabel(column)
            ax.set_ylabel(metrics[0])
        for k in range(len(numeric), cols):
            axes[1][k].axis('off')
        if numeric:
            axes[1][0].legend(fontsize=7)
    else:
        rows, cols = len(metrics), max(len(numeric), 1)
        fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.8 * rows), squeeze=False)
        for r, name in enumerate(metrics):
            y = np.array(table[name])
            for c, column in enumerate(numeric):
                ax = axes[r][c]
                ax.plot(np.array(table[column])[ok], y[ok], 'o', ms=4)
                ax.set_xlabel(column)
                ax.set_ylabel(name)
    failed = int((~ok).sum())
    fig.suptitle(f'{len(table["index"])} runs' + (f', {failed} without metrics (error or '
                                                    'timeout)' if failed else ''))
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


__all__ = ['WORST', 'figure', 'worst']
