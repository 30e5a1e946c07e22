"""Figures of a recorded run: what ``plot_run`` draws, and ``check_run --plot``.

No ROS here. The outputs are the bag's own samples (:mod:`.bagread`); the input in
force at each step is the node's own fold of the recorded commands, taken from the
ticks of an in-process replay (:func:`.replay.replay_in_process`), so the drawn
torque is the one the node integrated (validated, cut by a lowered limit, kept
through a reset). check_run's errors are the per-sample arrays its report keeps.

:func:`run_figure` and :func:`check_figure` return the matplotlib Figure (the tests
inspect it); :func:`save` writes it and closes it. Each panel carries its
:class:`Panel` (or its signal's name) as the axes label, and every mark drawn on
it a :class:`Mark` as gid.
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backend_bases import FigureCanvasBase
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..bag.errors import NoData
from ..bag.reader import RecordedRun
from ..errors import ScrewgearError
from ..params.table import Mode
from ..sim.session import Tick
from .check import MESH_SIGNALS, CheckReport, signal_names
from .figure_style import COLORS, plt
from .plot_error import ErrorOptions, ErrorView, error_view
from .plot_path import draw_path, draw_switch_lines
from .plot_series import (
    ParameterMark,
    RunMarks,
    drive_series,
    in_contact,
    params_at,
    run_marks,
    setpoint_series,
    tracking_error,
)
from .presets import closest_preset
from .replay_in_process import replay_in_process

if TYPE_CHECKING:    # check_run's reference solver (SciPy): imported by check_figure
    from .check import CheckReport

#: Resolution the figures are written at (and readable at), dots per inch.
DPI = 100
#: Name of plot_run's figure inside the bag directory when no output is given.
DEFAULT_NAME = 'plot.png'

PARAMETER_STYLE: dict[str, Any] = {'color': COLORS[3], 'linestyle': '--', 'linewidth': 1.2}
RESET_STYLE: dict[str, Any] = {'color': COLORS[6], 'linestyle': '-.', 'linewidth': 1.2}
TOLERANCE_STYLE: dict[str, Any] = {'color': COLORS[1], 'linestyle': '--', 'linewidth': 1.4}


class Panel(StrEnum):
    """The panels of :func:`run_figure`, top to bottom (the axes' labels)."""

    TABLE_ANGLE = 'table angle'
    TRACKING = 'tracking error'     # only for a bag with a recorded setpoint
    TABLE_SPEED = 'table speed'
    DRIVE = 'drive input'
    PINIONS = 'pinion speeds'
    TRANSMISSION_ERROR = 'transmission error'
    MESH = 'mesh forces'
    PATH = 'active path'


#: Relative panel heights other than 1.
HEIGHTS = {Panel.MESH: 1.2, Panel.PATH: 0.6}


class Mark(StrEnum):
    """What a drawn artist is (its gid)."""

    PARAMETER_CHANGE = 'parameter change'
    PATH_SWITCH = 'path switch'
    RESET = 'reset'
    REVERSAL = 'reversal'
    DRIVE_TORQUE = 'drive torque'
    LOAD_TORQUE = 'load torque'
    GAP = 'gap'
    MEASURED = 'measured'       # joint_states as the joint sensors measured them
    ERROR = 'error'
    TOLERANCE = 'tolerance'
    SETPOINT = 'setpoint'
    TRACKING_ERROR = 'tracking error'
    BAND = 'tolerance band'


class FigureFileError(ScrewgearError):
    """The figure cannot be written where asked (format unknown, directory not writable)."""


# ----------------------------------------------------------------------------- data

def _mark_events(ax: Axes, marks: RunMarks) -> None:
    for change in marks.parameter_changes:
        ax.axvline(change.time, gid=Mark.PARAMETER_CHANGE, zorder=1, **PARAMETER_STYLE)
    for time in marks.resets:
        ax.axvline(time, gid=Mark.RESET, zorder=1, **RESET_STYLE)


def _label_changes(ax: Axes, marks: RunMarks) -> None:
    """Above the top panel: what each parameter change changed."""
    for change in marks.parameter_changes:
        names = change.changed
        text = (', '.join(names) if 0 < len(names) <= 3 else
                f'{len(names)} values' if names else 'same values')
        ax.annotate(text, (change.time, 1.0), xycoords=('data', 'axes fraction'),
                    xytext=(2, 3), textcoords='offset points', fontsize=8, rotation=15,
                    annotation_clip=True,         # none outside a zoomed time axis
                    color=PARAMETER_STYLE['color'], ha='left', va='bottom')


def _legend(ax: Axes) -> None:
    ax.legend(loc='upper left', bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=9)


def run_figure(run: RecordedRun, zoom: tuple[float, float] | None = None,
               error: ErrorOptions | None = None) -> Figure:
    """The recorded run, panel by panel on one simulation-time axis (see :class:`Panel`;
    the setpoint on the table angle and the tracking-error panel only for a bag that
    recorded a setpoint, or with ``error.target``);
    ``zoom`` (t0, t1 in s): only that stretch, each panel scaled to what it shows there;
    ``error``: the tracking error in encoder counts, a tolerance band, a target
    (:func:`~screwgear_ros.runs.plot_error.error_view`, whose
    :class:`~screwgear_ros.runs.plot_error.ErrorViewError` it raises).

    Raises :class:`BagError` when the bag holds no data to draw (fewer than two output
    samples: empty axes would look like a run that did nothing), when ``zoom`` holds no
    sample, or when its events do not replay as the node applied them (the drawn inputs
    would be guesses).
    """
    if len(run.true_joint_states) < 2:
        raise NoData(f'{run.path}: no data to plot: {len(run.true_joint_states)} '
                       'joint_states sample(s), a run needs two to be drawn over time'
                       + (f' ({run.truncated})' if run.truncated else ''))
    if zoom is not None:
        t = run.true_joint_states.steps * run.dt
        if not np.any((t >= zoom[0]) & (t <= zoom[1])):
            raise NoData(f'{run.path}: no data to plot in --zoom '
                           f'{zoom[0]:g}:{zoom[1]:g} s: the run has samples from '
                           f'{t[0]:g} s to {t[-1]:g} s')
    error = error or ErrorOptions()
    view = error_view(run, error) if len(run.setpoint) or error.any else None
    ticks = replay_in_process(run).ticks
    marks = run_marks(run, ticks)
    params = run.parameters.params
    conventional = params.mode is Mode.CONVENTIONAL
    js = run.true_joint_states
    t = js.steps * run.dt
    t_end = max(run.end_step * run.dt, float(t[-1]))

    panels = [p for p in Panel if p is not Panel.TRACKING or view is not None]
    height = 16 + 2 * (len(panels) - len(Panel) + 1)     # the tracking panel adds room
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(13, height), dpi=DPI,
                             height_ratios=[HEIGHTS.get(p, 1.0) for p in panels],
                             layout='constrained')
    ax = dict(zip(panels, axes, strict=False))
    for panel, a in ax.items():
        a.set_label(panel)

    # With non-ideal sensors the exact state (true_joint_states) and, over it, what
    # joint_states reported: counts as steps, held until the next sample.
    measured = run.measured
    exact = '' if measured is None else ' (exact)'
    a = ax[Panel.TABLE_ANGLE]
    a.plot(t, js.values[:, 1], color=COLORS[0], label='θ2 table' + exact)
    if view is not None:
        if error.target is None:
            a.plot(*setpoint_series(run), drawstyle='steps-post', color=COLORS[1],
                   linestyle='--', linewidth=1.4, gid=Mark.SETPOINT, label='setpoint\n(recorded)')
        else:
            a.axhline(error.target, color=COLORS[1], linestyle='--', linewidth=1.4,
                      gid=Mark.SETPOINT, label=f'target\n{error.target:g} rad')
        _draw_tracking(ax[Panel.TRACKING], view)
    a.set_ylabel('table angle [rad]')

    b = ax[Panel.TABLE_SPEED]
    b.plot(t, js.values[:, 4], color=COLORS[0], label='ω2 table' + exact)
    b.set_ylabel('table speed [rad/s]')
    if measured is not None:
        for panel, column, symbol in ((a, 1, 'θ2'), (b, 4, 'ω2')):
            panel.plot(measured.steps * run.dt, measured.values[:, column],
                       drawstyle='steps-post', color=COLORS[3], linewidth=0.9,
                       gid=Mark.MEASURED, label=f'{symbol} measured (joint_states)')
    _legend(a)
    _legend(b)

    a = ax[Panel.DRIVE]
    times, torque, load = drive_series(run, ticks)
    a.plot(times, torque, drawstyle='steps-post', color=COLORS[1], linewidth=1.8,
           gid=Mark.DRIVE_TORQUE, label='drive torque\n(signed by direction)')
    a.plot(times, load, drawstyle='steps-post', color=COLORS[2], linestyle='--',
           gid=Mark.LOAD_TORQUE, label='table load')
    a.axhline(0.0, color='0.5', linewidth=0.6)
    a.set_ylabel('commanded torque [N·m]')
    _legend(a)

    a = ax[Panel.PINIONS]
    a.plot(t, js.values[:, 3], color=COLORS[0], label='ω1 pinion 1')
    a.plot(t, js.values[:, 5], color=COLORS[1], label='ω3 pinion 3'
           + (' (disengaged)' if conventional else ''))
    a.set_ylabel('pinion speed [rad/s]')
    _legend(a)

    a = ax[Panel.TRANSMISSION_ERROR]
    # δ of each mesh, not of the active path: a path switch at rest would otherwise
    # look like a jump of the transmission error by the whole backlash and preload.
    ms = run.mesh_state
    a.plot(ms.steps * run.dt, ms.values[:, 0] * 1e6, color=COLORS[0], label='δ1 mesh 1')
    if not conventional:
        a.plot(ms.steps * run.dt, ms.values[:, 1] * 1e6, color=COLORS[1], label='δ3 mesh 3')
    draw_switch_lines(a, run, marks, Mark.PATH_SWITCH)
    if params.backlash > 0.0:
        for sign in (1.0, -1.0):
            a.axhline(sign * params.backlash * 1e6, color='0.4', linestyle=':', linewidth=1.0,
                      label='±b backlash (at start)' if sign > 0 else None)
    a.set_ylabel('transm. error [µm]')
    _legend(a)

    _draw_mesh(ax[Panel.MESH], run, ticks, conventional)
    draw_path(ax[Panel.PATH], run, marks, (float(t[0]), t_end), Mark.PATH_SWITCH,
              Mark.REVERSAL)
    _legend(ax[Panel.PATH])

    for a in axes:
        _mark_events(a, marks)
    _label_changes(axes[0], marks)
    axes[-1].set_xlabel('simulation time [s]')
    axes[-1].set_xlim(float(t[0]), t_end)
    if zoom is not None:
        axes[-1].set_xlim(*zoom)
        for a in axes:
            if a.get_label() != Panel.PATH:
                _fit_y(a, *zoom)

    handles = [Line2D([], [], label=f'parameter change ({len(marks.parameter_changes)})',
                      **PARAMETER_STYLE),
               Line2D([], [], label=f'reset ({len(marks.resets)})', **RESET_STYLE)]
    fig.legend(handles=handles, loc='outside upper right', ncols=2, fontsize=9, frameon=False)
    truncated = '; TRUNCATED: the readable part' if run.truncated else ''
    if zoom is not None:
        truncated += f'; zoomed to {zoom[0]:g}–{zoom[1]:g} s'
    preset = closest_preset(params, run.parameters.settings)
    files = '' if preset is None else f'\nparameters: {preset}'
    fig.suptitle(f'{run.path.name}: {params.mode.value} mode, dt = {run.dt * 1e6:g} µs, '
                 f'{run.parameters.settings.publish_rate:g} Hz outputs, '
                 f'{t_end - float(t[0]):.2f} s{truncated}{files}', fontsize=13, x=0.02,
                 ha='left')
    return fig


def _fit_y(a: Axes, t0: float, t1: float) -> None:
    """Scale the y axis of ``a`` to its data lines between t0 and t1 (a step line's
    value at t0 included)."""
    low, high = np.inf, -np.inf
    for line in a.get_lines():
        if line.get_transform() != a.transData:        # axhline/axvline: not data
            continue
        x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        if len(x) < 1:
            continue
        inside = (x >= t0) & (x <= t1)
        before = np.flatnonzero(x < t0)
        if len(before):
            inside[before[-1]] = True
        values = y[inside & np.isfinite(y)]
        if len(values):
            low, high = min(low, values.min()), max(high, values.max())
    if np.isfinite(low):
        pad = 0.05 * (high - low) or 0.05 * abs(high) or 1.0
        a.set_ylim(low - pad, high + pad)


def _draw_tracking(a: Axes, view: ErrorView) -> None:
    exact = '' if view.measured_error is None else ' (exact)'
    a.plot(view.times, view.error, color=COLORS[0], gid=Mark.TRACKING_ERROR,
           label=f'{view.reference} − θ2{exact}\n(RMS {view.rms:.3g} {view.unit} over the run)')
    if view.measured_times is not None and view.measured_error is not None:
        a.plot(view.measured_times, view.measured_error, drawstyle='steps-post',
               color=COLORS[3], linewidth=0.9, gid=Mark.MEASURED,
               label=f'{view.reference} − θ2 measured')
    if view.band is not None:
        inside = ('outside at the end' if view.inside_from is None else
                  f'inside from t = {view.inside_from:.4g} s on')
        a.axhspan(-view.band, view.band, color=COLORS[2], alpha=0.15, gid=Mark.BAND,
                  label=f'±{view.band:g} {view.unit}: {inside}')
        if view.inside_from is not None:
            a.axvline(view.inside_from, color=COLORS[2], linewidth=1.0, linestyle=':')
    a.axhline(0.0, color='0.5', linewidth=0.6)
    a.set_ylabel(f'tracking error [{view.unit}]')
    _legend(a)


def _draw_mesh(a: Axes, run: RecordedRun, ticks: list[Tick], conventional: bool) -> None:
    ms = run.mesh_state
    t = ms.steps * run.dt
    meshes = [(0, 'mesh 1', COLORS[0])] + ([] if conventional else [(1, 'mesh 3', COLORS[1])])
    contact = in_contact(run, ticks) if len(ms) else np.ones((0, 2), dtype=bool)
    notes = []
    for k, name, color in meshes:
        a.plot(t, ms.values[:, 4 + k] / 1e3, color=color, label=f'F{2 * k + 1} {name}')
        gap = ~contact[:, k]
        if gap.any():
            # a gap sample shades up to the next sample: the interval it stands for
            a.fill_between(t, 0.0, 1.0, where=gap, step='post', alpha=0.18, color=color,
                           transform=a.get_xaxis_transform(), gid=Mark.GAP,
                           label=f'{name} gap, |δ| ≤ b ({gap.mean():.1%} of the\n'
                           f'{run.parameters.settings.publish_rate:g} Hz samples)')
        else:
            notes.append(name)
    if notes:       # legend lines without a handle
        a.plot([], [], ' ', label=' and '.join(notes) + ':\nin contact at every sample (|δ| > b)')
    if conventional:
        a.plot([], [], ' ', label='conventional mode:\npinion 3 disengaged (F3 = 0)')
    a.axhline(0.0, color='0.5', linewidth=0.6)
    a.set_ylabel('mesh force [kN]')
    _legend(a)


def check_figure(run: RecordedRun, report: CheckReport) -> Figure:
    """|node − reference| of every checked signal against its tolerance, log scale:
    rows pinion 1, table, pinion 3 (position, velocity, effort), then the
    transmission error, then mesh 1 and mesh 3 (δ, δ̇, F); one time axis. Each axes is
    labelled with its signal's name."""
    names = signal_names(run) + MESH_SIGNALS
    joints = len(run.parameters.settings.joint_names)
    by_name = {s.name: s for s in report.signals}
    fig = plt.figure(figsize=(14, 16), dpi=DPI, layout='constrained')
    grid = fig.add_gridspec(joints + 3, 3)
    marks = run_marks(run)
    first: Axes | None = None
    for k, (name, unit) in enumerate(names):
        mesh = k - 3 * joints - 1          # δ1, δ3, δ̇1, δ̇3, F1, F3: a column per quantity
        cell = (grid[joints, :] if k == 3 * joints else grid[k % joints, k // joints]
                if k < 3 * joints else grid[joints + 1 + mesh % 2, mesh // 2])
        a = fig.add_subplot(cell, sharex=first)
        first = first or a
        a.set_label(name)
        a.set_yscale('log')
        signal = by_name.get(name)
        if signal is None or signal.errors is None or not len(signal.errors):
            a.text(0.5, 0.5, 'no samples', transform=a.transAxes, ha='center')
            a.set_title(name, fontsize=10)
            continue
        if signal.max_error == 0.0:     # nothing to scale the log axis by but the tolerance
            a.set_ylim(signal.tolerance * 1e-3, signal.tolerance * 10.0)
            a.text(0.5, 0.3, 'exactly 0 at every sample', transform=a.transAxes,
                   ha='center', color='0.3')
        assert signal.times is not None and signal.errors is not None   # check_run's
        shown = np.where(signal.errors > 0.0, signal.errors, np.nan)   # log scale: 0 is -inf
        a.plot(signal.times, shown, color=COLORS[0], linewidth=0.9, gid=Mark.ERROR,
               label='|node − reference|')
        a.axhline(signal.tolerance, gid=Mark.TOLERANCE, label='tolerance', **TOLERANCE_STYLE)
        if signal.max_error > 0.0:
            a.plot([signal.at_time], [signal.max_error], marker='o', markersize=5,
                   color=COLORS[0] if signal.ok else COLORS[1])
        _mark_events(a, marks)
        verdict = 'ok' if signal.ok else 'FAIL'
        a.set_title(f'{name}: max {signal.max_error:.2g} / tol {signal.tolerance:.2g} '
                    f'{unit}: {verdict}', fontsize=10,
                    color='k' if signal.ok else COLORS[1], fontweight='normal'
                    if signal.ok else 'bold')
        a.set_ylabel(f'|error| [{unit}]')
        if mesh >= 0 and mesh % 2 == 1:     # the bottom row
            a.set_xlabel('simulation time [s]')
    handles = [Line2D([], [], color=COLORS[0], label='|node − reference| at each sample'),
               Line2D([], [], label=f'tolerance ({report.safety:g} × Richardson estimate of '
                      'RK4\'s error, or its floor)', **TOLERANCE_STYLE),
               Line2D([], [], label='parameter change', **PARAMETER_STYLE),
               Line2D([], [], label='reset', **RESET_STYLE)]
    fig.legend(handles=handles, loc='outside lower center', ncols=4, fontsize=10, frameon=False)
    result = 'PASS' if report.ok else 'FAIL'
    fig.suptitle(f'check_run {run.path.name}: recorded minus DOP853 reference, '
                 f'{run.parameters.params.mode.value} mode, dt = {run.dt * 1e6:g} µs: {result}',
                 fontsize=13)
    return fig


# ------------------------------------------------------------------------- files


def output_path(path: str | Path) -> Path:
    """``path`` if matplotlib can write its format; else :class:`FigureFileError`."""
    path = Path(path)
    formats = FigureCanvasBase.get_supported_filetypes()
    if path.suffix.lstrip('.').lower() not in formats:
        raise FigureFileError(f'{path}: the file name must end in a figure format '
                              f'(.png, .pdf, .svg, …), not {path.suffix or "nothing"!r}')
    return path


def default_output(run: RecordedRun) -> Path:
    """plot_run's figure when no output is given: ``plot.png`` in the bag directory."""
    return run.path / DEFAULT_NAME


def save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` at :data:`DPI` (creating the directory), close it, return the path."""
    path = output_path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=DPI)
    except OSError as exc:
        raise FigureFileError(f'cannot write {path}: {exc.strerror or exc}') from None
    finally:
        plt.close(fig)
    return path


__all__ = [
    'DEFAULT_NAME',
    'DPI',
    'FigureFileError',
    'Mark',
    'Panel',
    'ParameterMark',
    'RunMarks',
    'check_figure',
    'default_output',
    'drive_series',
    'in_contact',
    'output_path',
    'params_at',
    'run_figure',
    'run_marks',
    'save',
    'setpoint_series',
    'tracking_error',
]
