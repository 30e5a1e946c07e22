"""plot_run's views: a near-empty bag says "no data", the transmission-error panel shows
δ1 and δ3 with the path switches marked (so a switch at rest is no jump), and
``--zoom T0:T1`` draws one stretch scaled to it. The drawn data are held against the
bag as ``rosbags`` decodes it.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from bag_runs import copy_bag, installed
from paths import DATA
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag.reader import read_run
from screwgear_ros.paper.common import plt
from screwgear_ros.runs.plot import Panel, run_figure

STORE = get_typestore(Stores.ROS2_JAZZY)


def _decoded(bag: Path, rel: str) -> list[tuple[int, object]]:
    with Reader(bag) as reader:
        return [(t, STORE.deserialize_cdr(raw, c.msgtype)) for c, t, raw in reader.messages()
                if c.topic.rsplit('/', 1)[1] == rel]


@pytest.mark.ros
def test_a_near_empty_bag_says_no_data(tmp_path: Path) -> None:
    """A bag that ends at the start of the run (what a demo killed while compiling
    leaves): no empty axes, exit 2 with "no data"."""
    copy_bag(DATA / 'steady_drive', tmp_path / 'bag',
             lambda topic, msgtype, t, raw: (t, raw) if t == 0 else None)
    assert len(_decoded(tmp_path / 'bag', 'joint_states')) == 1
    result = installed('plot_run', tmp_path / 'bag', '-o', tmp_path / 'plot.png')
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'no data' in result.stderr and 'Traceback' not in result.stderr
    assert not (tmp_path / 'plot.png').exists()


def _axes(fig) -> dict[str, object]:
    return {a.get_label(): a for a in fig.axes}


def test_the_transmission_error_panel_shows_both_meshes_and_the_switches() -> None:
    bag = DATA / 'reversals_anti_backlash'
    mesh = _decoded(bag, 'mesh_state')
    paths = _decoded(bag, 'active_path')
    assert len(paths) > 1
    run = read_run(bag)
    with warnings.catch_warnings():
        warnings.simplefilter('error', UserWarning)
        fig = run_figure(run)
    try:
        a = _axes(fig)[Panel.TRANSMISSION_ERROR]
        lines = {line.get_label(): line for line in a.get_lines()}
        for k, label in enumerate(('δ1 mesh 1', 'δ3 mesh 3')):
            x, y = lines[label].get_data()
            assert np.allclose(x, [t * 1e-9 for t, _ in mesh], rtol=1e-12, atol=0.0)
            assert np.array_equal(y, [m.position[k] * 1e6 for _, m in mesh])
        switches = [line.get_xdata()[0] for line in a.get_lines()
                    if line.get_gid() == 'path switch']
        assert np.allclose(switches, [t * 1e-9 for t, _ in paths[1:]], rtol=1e-12, atol=0.0)
    finally:
        plt.close(fig)


@pytest.mark.ros
def test_zoom_draws_one_stretch_scaled_to_it(tmp_path: Path) -> None:
    bag = DATA / 'load_steps_parameter_changes'
    run = read_run(bag)
    t0, t1 = 0.8, 1.4
    fig = run_figure(run, (t0, t1))
    full = run_figure(run)
    try:
        zoomed, whole = _axes(fig)[Panel.TABLE_SPEED], _axes(full)[Panel.TABLE_SPEED]
        assert zoomed.get_xlim() == (t0, t1)
        speeds = [(t * 1e-9, m.velocity[1]) for t, m in _decoded(bag, 'joint_states')]
        inside = [w for t, w in speeds if t0 <= t <= t1]
        low, high = zoomed.get_ylim()
        assert low <= min(inside) and max(inside) <= high
        assert high - low < 0.5 * (whole.get_ylim()[1] - whole.get_ylim()[0])
    finally:
        plt.close(fig)
        plt.close(full)
    result = installed('plot_run', bag, '--zoom', f'{t0}:{t1}', '-o', tmp_path / 'z.png')
    assert result.returncode == 0, result.stderr
    assert (tmp_path / 'z.png').stat().st_size > 0
    for bad in ('1.4:0.8', 'a:b', '50:60'):
        result = installed('plot_run', bag, '--zoom', bad, '-o', tmp_path / 'bad.png')
        assert result.returncode == 2 and 'Traceback' not in result.stderr, result.stderr
