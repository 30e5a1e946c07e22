"""plot_run and check_run --plot, as installed, on the checked-in bags; and what the
figures show, through screwgear_ros.runs.plot (each panel is labelled with its Panel
or signal name, each mark carries its Mark as gid).

The expected times come from the recorded events and from the scenarios the bags
were recorded from (test/data/scenarios/), not from the plotting code.
"""

from __future__ import annotations

import shutil
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_runs import copy_bag, installed, nudge_table_angle, truncated_copy
from paths import DATA

from screwgear_ros.bag.reader import read_run
from screwgear_ros.runs.check import check_run
from screwgear_ros.runs.plot import DPI, Mark, Panel, check_figure, params_at, plt, run_figure
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.sim.events import Command, ParameterChange, Reset

PREFIX = Path(sys.prefix)



def png_size(path: Path) -> tuple[int, int]:
    """(width, height) in pixels from the PNG header."""
    data = path.read_bytes()[:24]
    assert data[:8] == b'\x89PNG\r\n\x1a\n' and data[12:16] == b'IHDR', f'{path} is not a PNG'
    return struct.unpack('>II', data[16:24])


def scenario_times(name: str, key: str) -> list[float]:
    """Times of the actions of ``key`` in the scenario the bag was recorded from."""
    actions = yaml.safe_load((DATA / 'scenarios' / f'{name}.yaml').read_text())['actions']
    return [a['time'] for a in actions if key in a]


def axes_by_label(fig) -> dict[str, object]:
    return {ax.get_label(): ax for ax in fig.axes if ax.get_label()}


def with_gid(ax, gid: Mark) -> list:
    return [a for a in ax.get_children() if a.get_gid() == gid]


def vline_times(ax, gid: Mark) -> list[float]:
    return sorted(float(line.get_xdata()[0]) for line in with_gid(ax, gid))


@pytest.fixture(scope='module')
def figures():
    """run_figure of three bags (each replays the run once), closed afterwards; drawing
    them warns of nothing (matplotlib's warnings are errors here)."""
    made = {}
    for name in ('reversals_anti_backlash', 'reversals_conventional',
                 'load_steps_parameter_changes'):
        run = read_run(DATA / name)
        with warnings.catch_warnings():
            warnings.simplefilter('error', UserWarning)
            made[name] = (run, run_figure(run))
    yield made
    for _, fig in made.values():
        plt.close(fig)


# ----------------------------------------------------------------- the executables


@pytest.mark.ros
@pytest.mark.parametrize('name', ['reversals_anti_backlash', 'load_steps_parameter_changes'])
def test_plot_run_writes_a_png(name: str, tmp_path: Path) -> None:
    out = tmp_path / 'sub' / f'{name}.png'
    result = installed('plot_run', DATA / name, '-o', out)
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.strip() == str(out)
    assert out.stat().st_size > 50_000
    width, height = png_size(out)
    assert 1000 <= width <= 2000 and 1200 <= height <= 2400, (width, height)


@pytest.mark.ros
def test_plot_run_default_output_is_in_the_bag_directory(tmp_path: Path) -> None:
    bag = tmp_path / 'run1'
    shutil.copytree(DATA / 'steady_drive', bag)
    result = installed('plot_run', bag)
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.strip() == str(bag / 'plot.png')
    assert png_size(bag / 'plot.png')[0] >= 1000
    assert read_run(bag).message_count > 0         # the bag still reads


@pytest.mark.ros
def test_check_run_plot_writes_a_png(tmp_path: Path) -> None:
    out = tmp_path / 'errors.png'
    result = installed('check_run', '--no-progress', '--plot', out,
                       DATA / 'reversals_anti_backlash')
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'RESULT: PASS' in result.stdout and f'plot: {out}' in result.stdout
    width, height = png_size(out)
    assert out.stat().st_size > 50_000 and width >= 1000 and height >= 800


@pytest.mark.ros
def test_what_cannot_be_plotted_exits_2_with_the_reason(tmp_path: Path) -> None:
    (tmp_path / 'notes.txt').write_text('not a bag')
    for path in (tmp_path / 'missing', tmp_path / 'notes.txt'):
        result = installed('plot_run', path, '-o', tmp_path / 'x.png')
        assert result.returncode == 2, (path, result.stdout, result.stderr)
        assert result.stderr.startswith(f'plot_run: cannot plot {path}: ')
        assert 'Traceback' not in result.stderr and not (tmp_path / 'x.png').exists()
    result = installed('plot_run', DATA / 'steady_drive', '-o', tmp_path / 'figure.xyz')
    assert result.returncode == 2 and 'figure format' in result.stderr, result.stderr
    result = installed('check_run', '--plot', tmp_path / 'figure', DATA / 'steady_drive')
    assert result.returncode == 2 and 'figure format' in result.stderr, result.stderr
    assert 'Traceback' not in result.stderr and result.stdout == ''   # refused before checking


@pytest.mark.ros
def test_a_truncated_bag_is_plotted_only_when_asked(tmp_path: Path) -> None:
    bag = truncated_copy(DATA / 'reversals_anti_backlash', tmp_path / 'cut')
    result = installed('plot_run', bag)
    assert result.returncode == 2 and '--allow-truncated' in result.stderr, result.stderr
    result = installed('plot_run', '--allow-truncated', bag)
    assert result.returncode == 0 and (bag / 'plot.png').is_file(), result.stderr


@pytest.mark.ros
def test_ros2_run_launcher_execs_plot_run() -> None:
    launcher = PREFIX / 'lib' / 'screwgear_ros' / 'plot_run'
    result = subprocess.run([str(launcher), '--help'], capture_output=True, text=True,
                            timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith('usage: plot_run')


# ------------------------------------------------------------- what the figure shows


def test_panels_share_one_time_axis_with_units(figures) -> None:
    run, fig = figures['load_steps_parameter_changes']
    panels = axes_by_label(fig)
    assert list(panels) == [p for p in Panel if p is not Panel.TRACKING]   # no setpoint
    bottom = panels[Panel.PATH]
    assert bottom.get_xlabel() == 'simulation time [s]'
    for panel, ax in panels.items():
        assert ax.get_shared_x_axes().joined(ax, bottom), panel
        assert ax.get_ylabel().endswith(']'), (panel, ax.get_ylabel())
    assert bottom.get_xlim() == pytest.approx((0.0, run.end_step * run.dt))
    title = fig.get_suptitle()
    assert 'load_steps_parameter_changes' in title and 'anti_backlash' in title
    assert 'dt = 50 µs' in title
    width, height = fig.get_size_inches() * DPI
    assert width >= 1000 and height >= 1200


def test_parameter_changes_and_resets_are_lines_on_every_panel(figures) -> None:
    run, fig = figures['load_steps_parameter_changes']
    changes = [e.step * run.dt for _, e in run.events if isinstance(e, ParameterChange)]
    resets = [e.step * run.dt for _, e in run.events if isinstance(e, Reset)]
    # the scenario's (landing within a few ticks; the first change is replay_run's
    # real-time factor going from its slow start to 1)
    assert changes[1:] == pytest.approx(scenario_times('load_steps_parameter_changes',
                                                       'parameters'), abs=0.05)
    assert resets == pytest.approx(scenario_times('load_steps_parameter_changes', 'reset'),
                                   abs=0.05)
    for panel, ax in axes_by_label(fig).items():
        assert vline_times(ax, Mark.PARAMETER_CHANGE) == pytest.approx(changes), panel
        assert vline_times(ax, Mark.RESET) == pytest.approx(resets), panel
    labels = [t.get_text() for t in axes_by_label(fig)[Panel.TABLE_ANGLE].texts]
    assert labels == ['real_time_factor', 'mesh_damping, preload_torque', 'table_damping']


def _sign_changes(x: np.ndarray, y: np.ndarray) -> list[float]:
    """Times where the nonzero values of a step line change sign."""
    nonzero = y != 0.0
    x, s = x[nonzero], np.sign(y[nonzero])
    return [float(t) for t in x[1:][s[1:] != s[:-1]]]


@pytest.mark.parametrize('name', ['reversals_anti_backlash', 'reversals_conventional'])
def test_commanded_torque_changes_sign_at_the_reversals(figures, name: str) -> None:
    run, fig = figures[name]
    ax = axes_by_label(fig)[Panel.DRIVE]
    line, = with_gid(ax, Mark.DRIVE_TORQUE)
    x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    reversals = [e.step * run.dt for _, e in run.events
                 if isinstance(e, Command) and e.topic == 'cmd_direction']
    assert reversals == pytest.approx(scenario_times(name, 'cmd_direction'), abs=0.05)
    assert _sign_changes(x, y) == pytest.approx(reversals)
    assert set(np.abs(y[y != 0.0])) == {400.0}
    assert y[0] == 0.0 and x[-1] == pytest.approx(run.end_step * run.dt)
    # the same instants are marked on the active path, on the path driven after them
    marks = with_gid(axes_by_label(fig)[Panel.PATH], Mark.REVERSAL)
    points = sorted((float(t), float(p)) for m in marks for t, p in zip(*m.get_data(), strict=True))
    assert [t for t, _ in points] == pytest.approx(reversals)
    paths = [3.0, 1.0, 3.0] if name == 'reversals_anti_backlash' else [1.0, 1.0, 1.0]
    assert [p for _, p in points] == paths


def test_commanded_torque_and_load_are_the_folded_commands(figures) -> None:
    """cmd_effort reverses by its sign; the reset keeps the input; load steps ±."""
    _run, fig = figures['load_steps_parameter_changes']
    ax = axes_by_label(fig)[Panel.DRIVE]
    drive, = with_gid(ax, Mark.DRIVE_TORQUE)
    load, = with_gid(ax, Mark.LOAD_TORQUE)

    def at(line, t: float) -> float:     # value of a steps-post line at time t
        x, y = line.get_xdata(), line.get_ydata()
        return float(y[np.searchsorted(x, t, side='right') - 1])
    assert [at(drive, t) for t in (0.1, 1.0, 2.5, 3.5, 4.0)] == [0.0, 300.0, -350.0, -350.0,
                                                                 250.0]
    assert [at(load, t) for t in (0.5, 1.0, 2.0, 4.0)] == [0.0, 500.0, -300.0, -300.0]


def test_contact_state_shows_the_gaps_of_a_conventional_drive(figures) -> None:
    _, anti = figures['reversals_anti_backlash']
    run, conventional = figures['reversals_conventional']
    mesh = axes_by_label(anti)[Panel.MESH]
    assert with_gid(mesh, Mark.GAP) == []            # the preload keeps both flanks
    assert len(mesh.get_lines()) >= 2
    mesh = axes_by_label(conventional)[Panel.MESH]
    gaps = with_gid(mesh, Mark.GAP)
    assert len(gaps) == 1 and 'mesh 1' in gaps[0].get_label()
    # at rest before the first command the unpreloaded mesh sits at the edge (|δ1| = b)
    extent = gaps[0].get_paths()[0].get_extents()
    assert extent.x0 == pytest.approx(0.0) and extent.x1 >= 0.19
    delta1 = run.mesh_state.values[:, 0]
    assert np.any(np.abs(delta1) <= run.parameters.params.backlash)



def test_contact_is_judged_with_the_parameters_in_force(figures) -> None:
    """A sample at the step a change takes effect was computed before it."""
    run, _ = figures['load_steps_parameter_changes']
    steps = run.mesh_state.steps
    in_force = params_at(run, replay_in_process(run).ticks, steps)
    change = [e.step for _, e in run.events if isinstance(e, ParameterChange)][1]
    preload = np.array([p.preload_torque for p in in_force])
    assert change in steps
    assert set(preload[steps <= change]) == {350.0} and set(preload[steps > change]) == {300.0}


def test_check_figure_draws_each_error_against_its_tolerance(tmp_path: Path) -> None:
    """A copy with 0.1 µrad added to the table angle at t = 2 s: that panel, and only
    that one, shows the error above its tolerance line, at 2 s."""
    target = 2 * 10**9
    copy_bag(DATA / 'steady_drive', tmp_path / 'nudged', nudge_table_angle(target, 1e-7))
    run = read_run(tmp_path / 'nudged')
    report = check_run(run)
    with warnings.catch_warnings():      # e.g. a log axis of errors that are all 0
        warnings.simplefilter('error', UserWarning)
        fig = check_figure(run, report)
    try:
        panels = axes_by_label(fig)
        assert list(panels) == [s.name for s in report.signals]
        for signal in report.signals:
            ax = panels[signal.name]
            assert ax.get_yscale() == 'log' and signal.unit in ax.get_ylabel()
            tolerance, = with_gid(ax, Mark.TOLERANCE)
            assert tolerance.get_ydata()[0] == signal.tolerance
            error, = with_gid(ax, Mark.ERROR)
            x, y = np.asarray(error.get_xdata()), np.asarray(error.get_ydata())
            above = x[y > signal.tolerance]
            if signal.name == 'table position':
                assert list(above) == [2.0] and not signal.ok
                assert 'FAIL' in ax.get_title()
            else:
                assert len(above) == 0 and signal.ok, signal.name
        assert 'FAIL' in fig.get_suptitle()
    finally:
        plt.close(fig)


def test_check_figure_of_errors_that_are_all_zero(figures) -> None:
    """Conventional mode: pinion 3 is disengaged and matches the reference exactly; its
    panels say so and still show the tolerance line, and nothing warns."""
    run, _ = figures['reversals_conventional']
    report = check_run(run)
    with warnings.catch_warnings():
        warnings.simplefilter('error', UserWarning)
        fig = check_figure(run, report)
    try:
        panels = axes_by_label(fig)
        for signal in report.signals:
            ax = panels[signal.name]
            low, high = ax.get_ylim()
            assert low < signal.tolerance < high, signal.name
            zero = [t.get_text() for t in ax.texts] == ['exactly 0 at every sample']
            assert zero == (signal.max_error == 0.0), signal.name
        assert panels['pinion_3 position'].texts and 'PASS' in fig.get_suptitle()
    finally:
        plt.close(fig)
