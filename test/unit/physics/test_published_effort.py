"""The table effort joint_states publishes (docs/model_notes.md §1): the net torque on
the table, its bearing friction included, so 0 while the table sticks; without
friction the paper's r2·(F1 + F3) − T_load − c_t·θ̇2, recomputed here from the
published mesh forces and speed."""

from __future__ import annotations

import pytest

from screwgear_ros import Simulation

DRIVE = 5.0        # N·m at the pinion: 37 N·m at the table, below the breakaway below


def last_observation(sim: Simulation, ticks: int = 30):
    sim.reset()
    for _ in range(ticks):
        observation = sim.step(DRIVE)
    return observation


def test_a_sticking_table_publishes_zero_effort():
    sim = Simulation.from_values(table_static_torque=60.0, table_coulomb_torque=50.0)
    o = last_observation(sim)
    r2 = sim.params.radius_table
    assert abs(r2 * sum(o.mesh_force)) > 10.0       # the meshes push the table ...
    assert o.true_velocity[1] == 0.0                # ... which sticks
    assert o.effort[1] == 0.0                       # and the published effort says 0


def test_without_friction_the_table_effort_is_the_papers_net_torque():
    sim = Simulation.from_values()
    o = last_observation(sim)
    p = sim.params
    paper = p.radius_table * sum(o.mesh_force) - p.table_damping * o.velocity[1]
    assert o.effort[1] != 0.0
    assert o.effort[1] == pytest.approx(paper, rel=1e-9, abs=1e-9)
