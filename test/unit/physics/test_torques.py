"""The torque terms (screwgear_ros.physics.torques) are the one source of the physics:
every quantity derived from the equations of motion follows every declared kernel
parameter, each in turn at a nonzero value.

For each ``kernel=True`` parameter of TableParams, on a gear with every term at work
(drive on its torque–speed line with lag and fluctuation, cogging, preload, load, both
viscous losses, both bearings' friction slipping, the energy-consistent mesh):

- the energy audit of a driven run closes within its bound (1e-6 of the largest energy,
  where RK4 at 20 µs leaves ~1e-10): a term the right-hand side has and the audit lacks
  leaves its whole work in the residual;
- the operating point is a steady state of the right-hand side (no acceleration beyond
  the roundoff of the torques it sums), and the terminal speed is its pinion speed;
- the linearization's A is the finite difference of the right-hand side at that point,
  within the difference's own error (its truncation, from halving the step, and its
  roundoff, from the size of the torques summed).

A parameter whose declared default is 0 and that the base below leaves at 0 is tried at
1e-6 of its declared upper bound; if that is not a mild value for it, give it a base
value in ``BASE``.
"""

from __future__ import annotations

import numpy as np
import pytest

from screwgear_ros.design.linearize import linearize
from screwgear_ros.design.operating_point import mean_params
from screwgear_ros.params.declarations import declared, kernel_fields
from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.drive import drive_targets
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.mesh import ContactBranch
from screwgear_ros.physics.motion import rhs
from screwgear_ros.physics.packed import N_MECHANICAL, Drive, pack
from screwgear_ros.physics.quantities import terminal_speed
from screwgear_ros.physics.torques import torque_terms
from screwgear_ros.sim import energy
from screwgear_ros.sim.events import Command

#: Every term at work (module docstring).
BASE = {
    'mesh_formulation': 'energy_consistent', 'table_damping': 500.0, 'pinion_damping': 0.01,
    'table_coulomb_torque': 10.0, 'table_static_torque': 20.0, 'table_stribeck_speed': 0.5,
    'pinion_coulomb_torque': 0.2, 'pinion_static_torque': 0.4, 'pinion_stribeck_speed': 0.5,
    'torque_fluctuation_amplitude': 20.0, 'torque_fluctuation_frequency': 30.0,
    'drive_time_constant': 2e-3, 'cogging_amplitude': 2.0, 'mesh_stiffness_phase': 0.3,
    'ste_amplitudes': (20e-6,),
}
TORQUE, LOAD, DT, DURATION = 400.0, 100.0, 20e-6, 0.02


def _declarations() -> dict:
    return {p.name: p.declaration for p in declared(TableParams)}


#: Parameters the validation ties together: each moves with its partner.
PARTNERS = {'radius_pinion_1': 'radius_pinion_3', 'radius_pinion_3': 'radius_pinion_1'}


def _varied(name: str) -> TableParams:
    """The base with ``name`` moved to another nonzero value (module docstring)."""
    base = TableParams(**BASE)
    value = getattr(base, name)
    if value == 0:
        value = 1e-6 * _declarations()[name].high
    elif isinstance(value, int):
        value += 1
    else:
        value *= 1.25
    changes = {name: value}
    if name in PARTNERS:
        changes[PARTNERS[name]] = value
    return base.replace(**changes)


KERNEL = kernel_fields(TableParams)


@pytest.mark.parametrize('name', KERNEL)
def test_the_energy_audit_closes_with_every_parameter(name):
    params = _varied(name)
    start = equilibrium_state(params)
    table_speed = 0.8 * params.drive_no_load_speed * params.radius_pinion_1 \
        / params.radius_table
    start[3:] = (table_speed * params.radius_table / params.radius_pinion_1, table_speed,
                 table_speed * params.radius_table / params.radius_pinion_3)
    audit = energy.run(params, DT, DURATION, [(0.0, Command('cmd_torque', TORQUE)),
                                             (0.0, Command('load_torque', LOAD))], start)
    works = {k: f'{v[-1]:.3g}' for k, v in audit.work.items()}
    assert audit.relative_residual <= 1e-6, (
        f'{name} = {getattr(params, name)!r}: the energy balance misses by '
        f'{audit.relative_residual:.2e} of {audit.scale:.4g} J (works {works} J): a term '
        'of the right-hand side that the audit does not see?')


def _accelerations(x: np.ndarray, model, point) -> np.ndarray:
    """The right-hand side's accelerations at mechanical state x, the drives' current
    loops at their targets (as the linear model takes them)."""
    lag1, lag3 = drive_targets(point.drive_piece, x[3], x[5], point.torque,
                               float(point.direction), model.p)
    y = (*(float(v) for v in x), lag1, lag3)
    return np.array(rhs(0.0, y, model, Drive(point.torque, float(point.direction),
                                               point.load))[3:N_MECHANICAL])


def _summed(x: np.ndarray, model, point, inertia: np.ndarray) -> np.ndarray:
    """Σ |torque| of the terms on each body at x over its inertia, 1/s²: the size the
    roundoff of an acceleration is relative to."""
    lag1, lag3 = drive_targets(point.drive_piece, x[3], x[5], point.torque,
                               float(point.direction), model.p)
    terms = torque_terms(0.0, (*(float(v) for v in x), lag1, lag3), model,
                         Drive(point.torque, float(point.direction), point.load),
                         ContactBranch.FROM_STATE, ContactBranch.FROM_STATE,
                         point.drive_piece)[0]
    return np.sum(np.abs(np.array(terms)), axis=0) / inertia


@pytest.mark.parametrize('name', KERNEL)
def test_the_operating_point_and_the_linearization_follow_every_parameter(name):
    params = _varied(name)
    linear = linearize(params, TORQUE, LOAD)
    point = linear.point
    model = pack(mean_params(params))
    inertia = np.array([params.inertia_pinion_1, params.inertia_table,
                        params.inertia_pinion_3])
    x0 = np.array(point.state)
    size = _summed(x0, model, point, inertia)
    eps = np.finfo(float).eps
    # the point is a steady state of the right-hand side, up to its torques' roundoff
    rest = _accelerations(x0, model, point)
    assert np.all(np.abs(rest) <= 1e-9 * size), (
        f'{name}: the operating point leaves accelerations {rest} rad/s² (torques of '
        f'{size * inertia} N·m summed): a term the point does not balance?')
    assert terminal_speed(params, TORQUE, LOAD) == pytest.approx(
        x0[3], rel=1e-12), name           # the driving pinion's speed (direction +1)
    # A against central differences of the right-hand side
    steps = np.array([1e-8] * 3 + [1e-4] * 3)
    def difference(j: int, h: float) -> np.ndarray:
        e = np.zeros(N_MECHANICAL)
        e[j] = h
        return (_accelerations(x0 + e, model, point)
                - _accelerations(x0 - e, model, point)) / (2.0 * h)

    for j in range(N_MECHANICAL):
        fine, coarse = difference(j, steps[j]), difference(j, 2.0 * steps[j])
        bound = 4.0 * (np.abs(fine - coarse) + 4.0 * eps * size / steps[j])
        miss = np.abs(linear.a[3:, j] - fine)
        assert np.all(miss <= bound), (
            f'{name}: column {j} of A is {linear.a[3:, j]}, the right-hand side\'s '
            f'difference {fine} (bound {bound}): a term the linearization does not see?')
