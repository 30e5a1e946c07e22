"""The machine seen from above: where the table and the pinions are, how they turn, and
how big a picture of them is. No ROS.

One declaration of the plan view, used by the URDF (:mod:`screwgear_ros.view.urdf`) and
by the node's markers (:mod:`screwgear_ros.view.markers`), so the model and the markers
always agree.

Frame :data:`BASE_LINK`: z up, origin on the table's axis, the discs' mid-plane at
z = 0. Pinion 1 sits on +x, pinion 3 on −x (they mesh the table from opposite sides),
each at the sum of the tip radii from the table axis, so the discs touch at the mesh.
Signs are those of ``shared/spec/model.md`` §1: θ2 > 0 is the table's forward sense,
clockwise seen from above (a turn about −z); a pinion angle counts in the sense that
drives the table forward, which for an external mesh is counterclockwise (about +z).
Every wheel carries a mark that points along the wheel's +x at angle 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..params.table import TableParams
from ..sim.status import MAX_PHASE_PER_STEP

#: The fixed frame of the URDF's root link and of the markers.
BASE_LINK = 'screwgear_base'
#: Thickness of every disc (face width), m: a picture, not a model parameter.
FACE_WIDTH = 0.06
#: The mark on each disc: a bar from 55 % to 95 % of the radius, on top of the disc.
MARK_FROM, MARK_TO = 0.55, 0.95
#: Colours (r, g, b, a) shared by the URDF's materials and the markers.
PALETTE = {
    'table': (0.55, 0.60, 0.68, 1.0),
    'pinion': (0.40, 0.45, 0.52, 1.0),
    'pinion_active': (0.25, 0.45, 0.85, 1.0),   # the pinion of the active path
    'mark': (1.0, 0.55, 0.0, 1.0),
    'contact': (0.1, 0.8, 0.2, 1.0),            # teeth on a flank
    'gap': (0.9, 0.1, 0.1, 1.0),                # inside the backlash gap
    'disengaged': (0.6, 0.6, 0.6, 1.0),         # conventional mode: pinion 3 out of mesh
}


@dataclass(frozen=True)
class Wheel:
    """One gear of the plan view, in joint_states order (pinion 1, table, pinion 3)."""

    index: int                      # its angle is Outputs.position[index]
    joint: str                      # joint name (joint_states, URDF)
    radius: float                   # tip radius, m
    teeth: int
    inertia: float                  # about its axis, kg·m²
    centre: tuple[float, float]     # axis position in BASE_LINK, m
    turn: int                       # +1: a positive angle turns it about +z; −1: about −z

    @property
    def is_table(self) -> bool:
        return self.index == 1

    @property
    def link(self) -> str:
        """URDF link name."""
        return f'{self.joint}_gear'

    @property
    def mass(self) -> float:
        """Mass of a uniform disc of this radius with the model's inertia, kg."""
        return 2.0 * self.inertia / self.radius ** 2

    def mark_angle(self, theta: float) -> float:
        """Direction of the wheel's mark in BASE_LINK (from +x, counterclockwise) at
        joint angle ``theta``, rad."""
        return self.turn * theta

    def rim_point(self, theta: float, fraction: float = 1.0) -> tuple[float, float]:
        """The point of the mark at ``fraction`` of the radius, at joint angle ``theta``."""
        a = self.mark_angle(theta)
        r = fraction * self.radius
        return self.centre[0] + r * math.cos(a), self.centre[1] + r * math.sin(a)

    def speed_limit(self, dt: float) -> float:
        """The speed, rad/s, above which ``dt`` no longer resolves the tooth mesh
        (the node warns past it: status.MAX_PHASE_PER_STEP per step)."""
        return MAX_PHASE_PER_STEP / (self.teeth * dt)


def wheels(params: TableParams, joint_names: Sequence[str]) -> tuple[Wheel, Wheel, Wheel]:
    """Pinion 1, table, pinion 3 with the geometry of ``params``."""
    r1, r2, r3 = params.radius_pinion_1, params.radius_table, params.radius_pinion_3
    j1, j2, j3 = joint_names
    return (Wheel(0, j1, r1, params.teeth_pinion_1, params.inertia_pinion_1, (r1 + r2, 0.0), 1),
            Wheel(1, j2, r2, params.teeth_table, params.inertia_table, (0.0, 0.0), -1),
            Wheel(2, j3, r3, params.teeth_pinion_3, params.inertia_pinion_3,
                  (-(r3 + r2), 0.0), 1))


def mesh_point(pinion: Wheel, table: Wheel) -> tuple[float, float]:
    """Where ``pinion`` meshes the table: on the line of centres, at the table's rim."""
    dx, dy = pinion.centre[0] - table.centre[0], pinion.centre[1] - table.centre[1]
    d = math.hypot(dx, dy)
    return (table.centre[0] + table.radius * dx / d, table.centre[1] + table.radius * dy / d)


__all__ = [
    'BASE_LINK',
    'FACE_WIDTH',
    'MARK_FROM',
    'MARK_TO',
    'PALETTE',
    'Wheel',
    'mesh_point',
    'wheels',
]
