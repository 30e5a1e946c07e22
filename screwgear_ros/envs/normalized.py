"""What the Gymnasium environment's agent sees and is scored by, normalised: every
observation entry in a finite box of order one, and a tracking cost that sees a
precision table's last encoder counts as well as a large step.

The tracking error spans six decades on a precision table: a 0.05 rad step, and the
last counts of a 26-bit encoder (2π/2²⁶ = 9.4e-8 rad). A Gaussian cost of one width sees
one of them only. :func:`compressed_error` weighs every decade alike, as a dB scale
does: ``sign(e) · min(1, ln(1 + |e|/s) / ln(1 + L/s))`` with ``s`` the error scale
(default one such count) and ``L`` the error limit (default 0.05 rad, the default
target's amplitude): 0 on target, ±1 at and beyond ``L``. The reward's tracking cost is
its magnitude, and the observation carries it signed, so the agent sees the error at
the resolution it is scored by. No matplotlib, no ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..inprocess.samples import Observation
from ..params.table import TableParams

#: Default error scale of the tracking cost, rad: one count of a 26-bit table encoder
#: (config/realistic.yaml's), so that a table held a few counts off scores near 0 and one
#: hundreds of counts off clearly worse.
ERROR_SCALE = 2.0 * math.pi / 2 ** 26
#: Default error limit, rad: an error of the default target's amplitude or more costs
#: the whole step (−1).
ERROR_LIMIT = 0.05
#: Bound of the linearly scaled observation entries (beyond it an entry is clipped; the
#: exact values are in ``info['observation']``).
LIMIT = 10.0
#: Scale of the table angle and the target, rad.
ANGLE_SCALE = math.pi
#: Scale of the transmission error, m (the preload's wind-up of the meshes is 0.3–0.9 mm).
TE_SCALE = 1e-3
#: Pinion speed scale when the drive is an ideal torque source (drive_no_load_speed 0):
#: the default no-load speed, 240 r/min, rad/s.
PINION_SPEED = 8.0 * math.pi


def compressed_error(error: float, scale: float, limit: float) -> float:
    """``sign(e) · min(1, ln(1 + |e|/scale) / ln(1 + limit/scale))``, in [−1, 1].

    Examples
    --------
    >>> compressed_error(0.0, 1e-7, 0.05)
    0.0
    >>> round(compressed_error(-1e-3, 1e-7, 0.05), 3)
    -0.702
    >>> compressed_error(7.0, 1e-7, 0.05)
    1.0
    """
    magnitude = min(1.0, math.log1p(abs(error) / scale) / math.log1p(limit / scale))
    return math.copysign(magnitude, error) if error else 0.0


@dataclass(frozen=True)
class Scales:
    """How each observation entry is scaled, for one table (its speeds set the speed
    scales) and one reward (its error scale and limit)."""

    pinion_speed: float          # rad/s
    table_speed: float           # rad/s
    error_scale: float           # rad
    error_limit: float           # rad

    @classmethod
    def of(cls, params: TableParams, error_scale: float, error_limit: float) -> Scales:
        """The drive's no-load speed at the pinions (the fastest a drive turns them) and
        over the gear ratio at the table."""
        pinion = params.drive_no_load_speed or PINION_SPEED
        return cls(pinion, pinion * params.radius_pinion_1 / params.radius_table,
                   error_scale, error_limit)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation box: ±1 for the wrapped pinion angles and the
        compressed error, ±:data:`LIMIT` for the rest."""
        high = np.array([1.0, LIMIT, 1.0, LIMIT, LIMIT, LIMIT, LIMIT, LIMIT, 1.0])
        return -high, high

    def observe(self, o: Observation, target: float) -> np.ndarray:
        """The observation of ``o`` with the target angle ``target`` (rad)."""
        (th1, th2, th3), (w1, w2, w3) = o.position, o.velocity
        linear = np.array([th2 / ANGLE_SCALE, w1 / self.pinion_speed, w2 / self.table_speed,
                           w3 / self.pinion_speed, o.transmission_error / TE_SCALE,
                           target / ANGLE_SCALE])
        linear = np.clip(linear, -LIMIT, LIMIT)
        return np.array([_wrapped(th1), linear[0], _wrapped(th3), *linear[1:],
                         compressed_error(target - th2, self.error_scale, self.error_limit)],
                        dtype=np.float64)


def _wrapped(angle: float) -> float:
    """A pinion angle as a fraction of half a turn, in [−1, 1): the mesh repeats with the
    pinion's turn (whole teeth), so its phase is all an agent needs of it."""
    return ((angle + math.pi) % (2.0 * math.pi) - math.pi) / math.pi


__all__ = ['ANGLE_SCALE', 'ERROR_LIMIT', 'ERROR_SCALE', 'LIMIT', 'PINION_SPEED', 'TE_SCALE',
           'Scales', 'compressed_error']
