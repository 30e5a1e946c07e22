"""The bearing friction of a linear model: the state it is linearized in, named, or a
refusal that says why (:func:`linearize_with_friction`).

Bearing friction (docs/model_notes.md §14) is stuck at rest and sliding in motion, and
neither is smooth where the two meet:

* **at rest** (any static operating point, either mesh model) every body whose bearing
  has a breakaway torque is *stuck*: its friction takes whatever torque holds it, up to
  breakaway, so for small inputs nothing moves, and beyond breakaway it slides: a
  switch, not a slope. A linear model about rest has no meaning there, and the
  differences that build A (``design.linearize``) would read the switch as a huge
  damping (the frozen model's real poles at kHz to hundreds of kHz) or mix stuck and
  sliding (the averaged one). It is refused, with the breakaway torques named.
* **in steady rotation** every body is *sliding* in one direction: its friction is the
  Coulomb torque plus the Stribeck peak, which has died out a few ω_S above rest, so its
  slope in speed is zero and it adds nothing to A or B. It is a constant torque against
  the motion, which the operating point counts (``physics.steady``: the steady speed
  balances every torque term, bearing friction included). A point so slow that the
  central differences in speed (±1 rad/s) reach a body's Stribeck region is refused.

A table with no bearing friction (every ``*_static_torque`` 0) is linearized as before,
its friction state ``none``.
"""

from __future__ import annotations

from enum import StrEnum

from ..params.table import TableParams
from .errors import DesignError
from .linear_model import LinearModel, MeshModel

#: How far (in Stribeck speeds ω_S) above a body's speed minus the difference step the
#: Stribeck term exp(−ω/ω_S) must lie to count as gone (e^−20 ≈ 2e−9 of the peak).
STRIBECK_CLEAR = 20.0
#: The speed step of the averaged model's central differences, rad/s (design.linearize).
SPEED_STEP = 1.0


class FrictionState(StrEnum):
    """The friction state a linear model is taken in."""

    NONE = 'none'              # no bearing friction declared
    SLIDING = 'sliding'        # every body sliding at the steady speed
    IGNORED = 'ignored'        # declared, left out on request (the table without it)


class FrictionUndefined(DesignError):
    """A linear model whose friction state is not defined (at rest: stuck), or that the
    differences cannot take (too slow); the message says why and what to do."""


def has_friction(params: TableParams) -> bool:
    """Whether any bearing has a breakaway torque (static torque > 0)."""
    return params.table_static_torque > 0.0 or params.pinion_static_torque > 0.0


def sliding_load(params: TableParams) -> float:
    """The Coulomb torques of the three bearings as one load at the table, N·m (each
    pinion's times r2/r_i, rigid kinematics), resisting the motion.

    Examples
    --------
    >>> p = TableParams().replace(table_coulomb_torque=3.0, table_static_torque=4.0)
    >>> sliding_load(p)
    3.0
    """
    return (params.table_coulomb_torque
            + params.pinion_coulomb_torque * params.radius_table / params.radius_pinion_1
            + params.pinion_coulomb_torque * params.radius_table / params.radius_pinion_3)


def without_friction(params: TableParams) -> TableParams:
    """``params`` with every bearing's friction 0."""
    return params.replace(table_coulomb_torque=0.0, table_static_torque=0.0,
                          pinion_coulomb_torque=0.0, pinion_static_torque=0.0)


def linearize_with_friction(params: TableParams, torque: float = 0.0, load: float = 0.0,
                            direction: int = 1, mesh: MeshModel | str = 'average',
                            ignore: bool = False) -> tuple[LinearModel, FrictionState, str]:
    """:func:`~.linearize.linearize` in a named friction state (module docstring): the
    model, its :class:`FrictionState` and a line saying what was done with the friction.
    ``ignore``: the table without its bearing friction (``linearize --friction ignore``),
    said so.

    Raises
    ------
    FrictionUndefined
        At rest on a table with bearing friction, or in rotation so slow that the
        differences reach a body's Stribeck region.
    """
    from .linearize import linearize
    from .operating_point import operating_point
    if not has_friction(params):
        return (linearize(params, torque, load, direction, mesh), FrictionState.NONE,
                'bearing friction: none declared')
    if ignore:
        note = ('bearing friction: left out on request: the model of this table with every '
                'bearing frictionless; the real one sticks at rest and breaks away at its '
                'breakaway torque')
        return (linearize(without_friction(params), torque, load, direction, mesh),
                FrictionState.IGNORED, note)
    breakaway = (f'table_static_torque {params.table_static_torque:g} N·m, '
                 f'pinion_static_torque {params.pinion_static_torque:g} N·m')
    resisting = sliding_load(params)
    if not operating_point(params, torque, load, direction).rotating:
        raise FrictionUndefined(
            f'no linear model at rest with bearing friction ({breakaway}): at rest each '
            'bearing is stuck, its friction takes whatever torque holds it up to breakaway, '
            'so small inputs move nothing and larger ones break it away (a switch, not a '
            'slope; differences across it give kHz poles). Linearize in steady rotation '
            '(--torque T: the bearings slide), or leave the friction out, said so '
            '(--friction ignore)')
    model = linearize(params, torque, load, direction, mesh)   # its point counts the friction
    state = model.point.state
    for name, speed, stribeck in (
            ('pinion 1', state[3], params.pinion_stribeck_speed),
            ('the table', state[4], params.table_stribeck_speed),
            ('pinion 3', state[5], params.pinion_stribeck_speed)):
        static = params.table_static_torque if name == 'the table' else \
            params.pinion_static_torque
        if static > 0.0 and abs(speed) - SPEED_STEP < STRIBECK_CLEAR * stribeck:
            raise FrictionUndefined(
                f'{name} turns at {abs(speed):.4g} rad/s: the linear model\'s differences '
                f'(±{SPEED_STEP:g} rad/s) reach its bearing\'s Stribeck region (ω_S '
                f'{stribeck:g} rad/s) or rest, where the friction is not smooth; a larger '
                '--torque (a faster steady speed) linearizes it sliding')
    note = (f'bearing friction: sliding (every bearing in one direction, the Stribeck peak '
            f'gone at this speed: no slope, nothing in A or B); its Coulomb torques, '
            f'{resisting:.4g} N·m at the table in all, resist the motion and the steady '
            'speed above counts them')
    return model, FrictionState.SLIDING, note


__all__ = [
    'SPEED_STEP',
    'STRIBECK_CLEAR',
    'FrictionState',
    'FrictionUndefined',
    'has_friction',
    'linearize_with_friction',
    'sliding_load',
    'without_friction',
]
