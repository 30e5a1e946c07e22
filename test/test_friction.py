"""Bearing friction with exact sticking (screwgear_ros.friction, docs/model_notes.md §13).

The law's pieces are checked against the law written out here from its definition
(Modelica's BearingFriction with an exponential Stribeck curve), the parameters against
their rules.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.friction import (FrictionPiece, at_rest, friction_on, friction_piece,
                                    sliding_torque)
from screwgear_ros.params import ParameterError, TableParams

COULOMB, STATIC, STRIBECK = 3.0, 5.0, 0.02      # N·m, N·m, rad/s


def _friction(speed: float, coulomb: float, static: float, stribeck: float) -> float:
    """T_f(ω) in slip from the definition: −sign(ω)·(τ_C + (τ_S − τ_C)·exp(−|ω|/ω_S))."""
    decay = math.exp(-abs(speed) / stribeck) if stribeck > 0.0 else 0.0
    return -math.copysign(coulomb + (static - coulomb) * decay, speed)


@pytest.mark.parametrize('stribeck', [STRIBECK, 0.0])
def test_sliding_torque_is_the_stribeck_curve(stribeck):
    rng = np.random.default_rng(23)
    for speed in rng.uniform(-1.0, 1.0, 200):
        piece = FrictionPiece.SLIP_FORWARD if speed > 0 else FrictionPiece.SLIP_BACKWARD
        assert sliding_torque(piece, speed, COULOMB, STATIC, stribeck) == pytest.approx(
            _friction(speed, COULOMB, STATIC, stribeck), rel=1e-14)
    # leaving rest, the sliding torque starts at the breakaway torque (with a Stribeck
    # curve) and falls to the Coulomb torque far from rest
    if stribeck > 0.0:
        assert sliding_torque(FrictionPiece.SLIP_FORWARD, 0.0, COULOMB, STATIC,
                              stribeck) == -STATIC
        assert sliding_torque(FrictionPiece.SLIP_BACKWARD, 0.0, COULOMB, STATIC,
                              stribeck) == STATIC
    assert sliding_torque(FrictionPiece.SLIP_FORWARD, 100.0, COULOMB, STATIC,
                          stribeck) == pytest.approx(-COULOMB, rel=1e-15)
    # a slip piece is continued smoothly past zero (the stage the integrator locates)
    assert sliding_torque(FrictionPiece.SLIP_FORWARD, -1e-6, COULOMB, STATIC, stribeck) < 0.0
    assert sliding_torque(FrictionPiece.STUCK, 0.0, COULOMB, STATIC, stribeck) == 0.0


def test_pieces():
    F, S, B = FrictionPiece.SLIP_FORWARD, FrictionPiece.STUCK, FrictionPiece.SLIP_BACKWARD
    # at rest: stuck while the holding torque is within ±τ_S (the bounds included)
    for torque, piece in ((0.0, S), (STATIC, S), (-STATIC, S), (STATIC * (1 + 1e-15), F),
                          (-STATIC * (1 + 1e-15), B)):
        assert at_rest(torque, STATIC) == piece
        assert friction_piece(FrictionPiece.FROM_STATE, 0.0, torque, STATIC) == piece
        assert friction_piece(S, 0.0, torque, STATIC) == piece
    # slipping: stays on its piece while the speed keeps its sign, whatever the torque
    assert friction_piece(F, 1e-9, -100.0, STATIC) == F
    assert friction_piece(B, -1e-9, 100.0, STATIC) == B
    assert friction_piece(FrictionPiece.FROM_STATE, 1e-9, -100.0, STATIC) == F
    assert friction_piece(FrictionPiece.FROM_STATE, -1e-9, 100.0, STATIC) == B
    # the speed reaching or crossing zero: sticks, or slips on in the sense of the torque
    for held, speed in ((F, 0.0), (F, -1e-12), (B, 0.0), (B, 1e-12)):
        assert friction_piece(held, speed, 0.5 * STATIC, STATIC) == S
        assert friction_piece(held, speed, -2.0 * STATIC, STATIC) == B
        assert friction_piece(held, speed, 2.0 * STATIC, STATIC) == F
    # no static torque: no friction, whatever else
    for held in FrictionPiece:
        assert friction_piece(held, 0.0, 0.0, 0.0) == FrictionPiece.NONE


def test_accelerations_on_each_piece():
    inertia = 0.7
    rng = np.random.default_rng(5)
    for torque, speed in zip(rng.normal(0.0, 10.0, 100), rng.normal(0.0, 0.1, 100)):
        # no friction: exactly τ/I, the expression of the model without friction
        assert friction_on(FrictionPiece.NONE, speed, torque, inertia, COULOMB, STATIC,
                           STRIBECK) == (torque / inertia, 0.0)
        # stuck: no acceleration at all, the bearing holds −τ
        assert friction_on(FrictionPiece.STUCK, 0.0, torque, inertia, COULOMB, STATIC,
                           STRIBECK) == (0.0, -torque)
        piece = FrictionPiece.SLIP_FORWARD if speed > 0 else FrictionPiece.SLIP_BACKWARD
        acceleration, friction = friction_on(piece, speed, torque, inertia, COULOMB, STATIC,
                                             STRIBECK)
        expected = _friction(speed, COULOMB, STATIC, STRIBECK)
        assert friction == pytest.approx(expected, rel=1e-14)
        assert acceleration == pytest.approx((torque + expected) / inertia, rel=1e-12,
                                             abs=1e-12)


def test_parameters():
    p = TableParams()
    # off by default: today's model
    for body in ('table', 'pinion'):
        assert getattr(p, f'{body}_coulomb_torque') == 0.0
        assert getattr(p, f'{body}_static_torque') == 0.0
        assert getattr(p, f'{body}_stribeck_speed') == 0.0
    assert p.pinion_damping == 0.0
    TableParams(table_coulomb_torque=3.0, table_static_torque=3.0)
    TableParams(pinion_static_torque=2.0)            # pure stiction
    for body in ('table', 'pinion'):
        with pytest.raises(ParameterError, match=f'{body}_static_torque.*>= {body}_coulomb'):
            TableParams(**{f'{body}_coulomb_torque': 3.0, f'{body}_static_torque': 2.0})
        with pytest.raises(ParameterError, match=f'{body}_stribeck_speed'):
            TableParams(**{f'{body}_stribeck_speed': -1.0})
    with pytest.raises(ParameterError, match='pinion_damping'):
        TableParams(pinion_damping=-1.0)
