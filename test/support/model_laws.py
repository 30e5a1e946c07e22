"""Laws of the model spelt out from its kernels, for the tests: one mesh's state and
load, and the drive's torque–speed line, each evaluated from the state."""

from __future__ import annotations

import numpy as np

from screwgear_ros.physics.drive import drive_on, drive_piece
from screwgear_ros.physics.mesh import ContactBranch, mesh_force, mesh_load_on, mesh_motion
from screwgear_ros.physics.packed import B, C, PackedModel


def mesh_state(theta_pinion: float, omega_pinion: float, radius_pinion: float, teeth: float,
               theta2: float, omega2: float, t: float,
               model: PackedModel) -> tuple[float, float, float]:
    """Total transmission error δ (m), its rate δ̇ (m/s) and mesh force F (N) of one mesh.

    δ = r_i·θ_i − r2·θ2 − ε_i, δ̇ = r_i·ω_i − r2·ω2 − ε̇_i (chain rule through φ_i).
    """
    _, _, delta, delta_dot, stiffness = mesh_motion(theta_pinion, omega_pinion, radius_pinion,
                                                    teeth, theta2, omega2, t, model)
    return delta, delta_dot, mesh_force(delta, delta_dot, stiffness, model.p[C], model.p[B])


def mesh_load(theta_pinion: float, omega_pinion: float, radius_pinion: float, teeth: float,
              theta2: float, omega2: float, t: float,
              model: PackedModel) -> tuple[float, float]:
    """Mesh force F (N) and the torque Q (N·m) the mesh exerts against its pinion, on the
    branch of the contact law the state is on."""
    force, load, _ = mesh_load_on(theta_pinion, omega_pinion, radius_pinion, teeth, theta2,
                                  omega2, t, model, ContactBranch.FROM_STATE)
    return force, load


def drive_line(torque: float, speed: float, p: np.ndarray) -> float:
    """Drive torque delivered, N·m, for command ``torque`` at the active pinion's
    ``speed``: the piece of the line the speed is on, evaluated there."""
    return drive_on(drive_piece(torque, speed, p), torque, speed, p)
