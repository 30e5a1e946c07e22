"""The figure of a run whose drive path chatters: thousands of switches drawn as a rate
per time bin (summing to the recorded switches), not one mark each; and the figure's
title names the shipped parameter files the run's parameters come from."""

from __future__ import annotations

import numpy as np
import pytest

from screwgear_ros import Simulation, config_path
from screwgear_ros.bag.reader import read_run
from screwgear_ros.runs.plot import Mark, Panel, plt, run_figure
from screwgear_ros.runs.plot_path import DENSE
from screwgear_ros.runs.presets import closest_preset


def axes_by_label(fig) -> dict[str, object]:
    return {ax.get_label(): ax for ax in fig.axes if ax.get_label()}


def with_gid(ax, gid: Mark) -> list:
    return [a for a in ax.get_children() if a.get_gid() == gid]


@pytest.fixture(scope='module')
def chattering(tmp_path_factory):
    """0.6 s of an effort that flips sign at every tick: a path switch each tick."""
    bag = tmp_path_factory.mktemp('chatter') / 'bag'
    sign = [1.0]

    def flip(observation) -> float:
        sign[0] = -sign[0]
        return 20.0 * sign[0]

    Simulation.from_yaml(config_path('paper.yaml')).run(flip, 0.6, record=bag)
    run = read_run(bag)
    fig = run_figure(run)
    yield run, fig
    plt.close(fig)


def test_thousands_of_switches_are_drawn_as_a_rate_summing_to_them(chattering):
    run, fig = chattering
    switches = len(run.active_path) - 1
    assert switches > 10 * DENSE
    panels = axes_by_label(fig)
    assert with_gid(panels[Panel.TRANSMISSION_ERROR], Mark.PATH_SWITCH) == []
    rates = with_gid(panels[Panel.PATH], Mark.PATH_SWITCH)
    assert len(rates) == 2                          # to path 1, to path 3
    drawn = 0.0
    for stairs in rates:
        values, edges, _ = stairs.get_data()
        drawn += float(np.sum(values * np.diff(edges)))
    assert drawn == pytest.approx(switches)
    assert len(panels[Panel.PATH].get_lines()) <= 2     # no marker per switch


def test_the_title_names_the_parameter_files(chattering):
    _, fig = chattering
    assert 'parameters: paper.yaml' in fig.get_suptitle()


def test_the_realistic_preset_is_named_with_the_file_it_is_loaded_after():
    sim = Simulation.from_yaml(config_path('realistic.yaml'))
    preset = closest_preset(sim.params, sim.settings)
    assert str(preset) == 'paper.yaml + realistic.yaml'
    changed = sim.with_values(backlash=5e-5)
    assert str(closest_preset(changed.params, changed.settings)) == \
        'paper.yaml + realistic.yaml with backlash changed'
