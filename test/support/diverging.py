"""A model that diverges, for the tests of what a faulted plant does (the unit replay
tests and the integration replay of a run whose time stood still)."""

from __future__ import annotations

from dataclasses import replace

from screwgear_ros.params.table import MeshPhase, Mode, SimSettings, TableParams
from screwgear_ros.physics.quantities import natural_frequency


def diverging() -> tuple[TableParams, SimSettings]:
    """A parametric pump of the mesh stiffness at twice the natural frequency, no mesh
    damping (test_node_fault's)."""
    unstable = TableParams(mode=Mode.CONVENTIONAL, backlash=0.0, mesh_phase=MeshPhase.TIME,
                           mesh_stiffness_amplitude=5.0e6, mesh_damping=0.0)
    return (replace(unstable, mesh_frequency=2.0 * natural_frequency(unstable)),
            SimSettings(dt=50e-6, publish_rate=200.0, command_timeout=0.0))
