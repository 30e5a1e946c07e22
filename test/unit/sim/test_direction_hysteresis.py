"""The realistic preset's direction_hysteresis against path chatter: a PD holding the
table at rest at its target answers encoder noise alone, an effort whose sign flips
from sample to sample. Without hysteresis every flip is a path switch; with the
preset's, none is, and the table holds its target as well."""

from __future__ import annotations

from screwgear_ros import Simulation, config_path
from screwgear_ros.sim.parameter_file import file_values

KP, KD = 2000.0, 300.0          # the README quick start's PD, N·m/rad, N·m·s/rad
HOLD = 2.0                      # s of simulation time


def pd(o) -> float:
    return max(-300.0, min(300.0, -KP * o.position[1] - KD * o.velocity[1]))


def switches_holding(**overrides) -> tuple[int, float]:
    """Path switches and the final exact table angle of the PD holding 0 rad."""
    values = {**file_values(config_path('paper.yaml')),
              **file_values(config_path('realistic.yaml')), **overrides}
    run = Simulation.from_values(values).run(pd, HOLD)
    return int((run.active_path[1:] != run.active_path[:-1]).sum()), float(
        run.true_position[-1, 1])


def test_the_realistic_preset_switches_no_path_on_noise():
    preset = Simulation.from_values(file_values(config_path('realistic.yaml')))
    assert preset.params.direction_hysteresis > 0.0
    chatter, angle_without = switches_holding(direction_hysteresis=0.0)
    quiet, angle_with = switches_holding()
    assert chatter > 100 * HOLD, f'{chatter} switches without hysteresis'
    assert quiet == 0, f'{quiet} switches with the preset\'s hysteresis'
    count = 2.0 * 3.141592653589793 / preset.settings.encoder_counts_table
    assert abs(angle_with) <= 2 * count and abs(angle_without) <= 2 * count
