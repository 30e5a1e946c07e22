"""Quantities the paper derives from the parameters: equivalent mass, natural frequency,
damping ratio, stiffness fluctuation, mean mesh force, mesh frequency, performance index;
and the terminal speed of the drive line (:mod:`.steady`'s rigid steady motion).

The two the validation of :class:`~screwgear_ros.params.table.TableParams` itself needs
(:func:`~screwgear_ros.params.table.effective_stiffness`, :func:`~screwgear_ros.params.table.ste_slope`)
stay beside it.
"""

from __future__ import annotations

import math

from ..params.table import PAPER_DRIVE_TORQUE, PAPER_PINION_SPEED, TableParams
from .packed import pack
from .steady import steady_table_speed


def equivalent_mass(p: TableParams) -> float:
    """m_e = I1·I2 / (I1·r2² + I2·r1²), kg (pinion 1 – table pair)."""
    i1, i2 = p.inertia_pinion_1, p.inertia_table
    r1, r2 = p.radius_pinion_1, p.radius_table
    return i1 * i2 / (i1 * r2 ** 2 + i2 * r1 ** 2)


def natural_frequency(p: TableParams) -> float:
    """ω0 = √(k_m / m_e), rad/s (the paper's normalizing frequency, mean stiffness k_m)."""
    return math.sqrt(p.mesh_stiffness_mean / equivalent_mass(p))


def damping_ratio(p: TableParams) -> float:
    """ζ = c / (2·m_e·ω0)."""
    return p.mesh_damping / (2.0 * equivalent_mass(p) * natural_frequency(p))


def stiffness_fluctuation(p: TableParams) -> float:
    """k_a' = k_a / k_m (the paper's definition, mean stiffness k_m)."""
    return p.mesh_stiffness_amplitude / p.mesh_stiffness_mean


def mean_mesh_force(p: TableParams, drive_torque: float = PAPER_DRIVE_TORQUE) -> float:
    """F_m = T1 / r1, N."""
    return drive_torque / p.radius_pinion_1


def mesh_frequency_at(p: TableParams, pinion_speed: float = PAPER_PINION_SPEED) -> float:
    """ω_e = z1·ω1, rad/s, for pinion speed ω1 in rad/s."""
    return p.teeth_pinion_1 * pinion_speed


def performance_index(zeta: float, ka_rel: float, k_m: float) -> float:
    """The paper's P = (ζ / k_a')·√k_m (k_m in N/m); infinite for k_a' = 0."""
    return math.inf if ka_rel == 0.0 else zeta / ka_rel * math.sqrt(k_m)


def terminal_speed(p: TableParams, torque: float, load: float = 0.0) -> float:
    """Steady speed, rad/s, of the driving pinion (pinion 1, direction +1) under a constant
    command ``torque`` > 0 (N·m) against a constant table load (N·m): the rigid steady
    motion of :func:`~screwgear_ros.physics.steady.steady_table_speed`, where the torque
    the drive delivers (min(T, T_s·(1 − ω/ω_nl))) balances every other term (the table
    damping c_t, the load, the pinions' c_p, sliding bearing friction, …) on the rigid
    motion. ``inf`` when nothing holds the drive back (e.g. an ideal source and no loss).

    It is the exact mean speed of a periodic steady state in the `paper` formulation
    while the speed ripple stays on one piece of the line (docs/model_notes.md §10).

    Examples
    --------
    >>> from screwgear_ros.params.table import TableParams
    >>> p = TableParams(table_damping=1000.0, drive_no_load_speed=0.0)
    >>> speed = terminal_speed(p, 100.0)       # c_t·(r1/r2)²·ω = T at the pinion
    >>> abs(speed * 1000.0 * (p.radius_pinion_1 / p.radius_table) ** 2 / 100.0 - 1.0) < 1e-12
    True
    """
    return steady_table_speed(pack(p), torque, load, 1) * p.radius_table / p.radius_pinion_1


__all__ = [
    'damping_ratio',
    'equivalent_mass',
    'mean_mesh_force',
    'mesh_frequency_at',
    'natural_frequency',
    'performance_index',
    'stiffness_fluctuation',
    'terminal_speed',
]
