"""The drive path in the figure of a recorded run: the path switches over the
transmission error, and the active path panel.

A run with a few switches gets one mark each; a run whose path chatters (a controller
whose near-zero effort flips sign under sensor noise switches thousands of times) gets
the switches as a rate per time bin instead, since one mark each would cover the panels.
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes

from ..bag.reader import RecordedRun
from ..physics.drive import active_path
from .figure_style import COLORS
from .plot_series import RunMarks

#: Beyond this many switches (or reversals) they are drawn as a rate per bin.
DENSE = 40
#: Time bins of the rate over the drawn span.
BINS = 120


def switch_times(run: RecordedRun) -> tuple[np.ndarray, np.ndarray]:
    """(times in s, the path after each) of the recorded path switches."""
    path = run.active_path
    return path.steps[1:] * run.dt, path.values[1:, 0]


def dense(run: RecordedRun, marks: RunMarks) -> bool:
    """Whether the run's switches are drawn as a rate."""
    return max(len(run.active_path) - 1, len(marks.reversals)) > DENSE


def draw_switch_lines(a: Axes, run: RecordedRun, marks: RunMarks, gid: str) -> None:
    """The path switches on a panel: a dotted line each, or (dense) a legend line
    pointing to the rate in the path panel."""
    switches, _ = switch_times(run)
    if dense(run, marks):
        a.plot([], [], ' ', label=f'{len(switches)} path switches:\ntheir rate is in '
               'the path panel')
        return
    for k, time in enumerate(switches):
        a.axvline(time, color=COLORS[4], linestyle=':', linewidth=1.0, gid=gid,
                  label=f'path switch ({len(switches)})' if k == 0 else None)


def draw_path(a: Axes, run: RecordedRun, marks: RunMarks, span: tuple[float, float],
              switch_gid: str, reversal_gid: str) -> None:
    """The active path panel over ``span`` (s): the path as a step line with a marker
    per reversal, or (dense) the rate of switches to each path per time bin."""
    if dense(run, marks):
        _draw_rate(a, run, span, switch_gid)
        return
    t_end = span[1]
    path = run.active_path
    if len(path):
        values = path.values[:, 0]
        a.plot(np.append(path.steps * run.dt, t_end), np.append(values, values[-1]),
               drawstyle='steps-post', color=COLORS[0], linewidth=1.8, label='active path')
    mode = run.parameters.params.mode
    for direction, marker, name in ((1, '^', 'forward'), (-1, 'v', 'reverse')):
        at = [time for time, d in marks.reversals if d == direction]
        if at:      # on the path that carries the drive after the reversal
            a.plot(at, [active_path(mode, direction)] * len(at), linestyle='none',
                   marker=marker, markersize=9, color=COLORS[4], markeredgecolor='k',
                   gid=reversal_gid, zorder=3, label=f'reversal to {name} ({len(at)})')
    if not marks.reversals:
        a.plot([], [], ' ', label='no commanded reversal')
    a.set_yticks([1, 3], ['1  (A → pinion 1)', '3  (B → pinion 3)'])
    a.set_ylim(0.2, 3.8)
    a.set_ylabel('path [–]')


def _draw_rate(a: Axes, run: RecordedRun, span: tuple[float, float], gid: str) -> None:
    times, after = switch_times(run)
    edges = np.linspace(span[0], span[1], BINS + 1)
    width = edges[1] - edges[0]
    for path, color in ((1, COLORS[0]), (3, COLORS[1])):
        counts, _ = np.histogram(times[after == path], bins=edges)
        a.stairs(counts / width, edges, color=color, linewidth=1.4, gid=gid,
                 label=f'switches to path {path} ({int(counts.sum())})')
    a.plot([], [], ' ', label=f'per {width * 1e3:.3g} ms bin')
    a.set_ylim(bottom=0.0)
    a.set_ylabel('path switches [1/s]')


__all__ = ['BINS', 'DENSE', 'dense', 'draw_path', 'draw_switch_lines', 'switch_times']
