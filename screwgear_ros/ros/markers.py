"""``table_markers``: the table and both pinions drawn in one fixed frame, no TF needed.

Each wheel of :mod:`screwgear_ros.layout` is a disc (CYLINDER) with a mark (ARROW from
its axis towards its rim) that turns with its joint angle; each pinion's mesh point
is a sphere coloured by the mesh's contact (:class:`screwgear_ros.status.Contact`):
teeth on a flank, inside the backlash gap, or disengaged. The pinion of the active
path is drawn in a brighter colour. Every marker is in :data:`layout.BASE_LINK` and
stamped with the simulation time of the outputs it shows, so RViz (fixed frame
``screwgear_base``) and Foxglove show it live and from a bag with nothing else running.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..layout import BASE_LINK, FACE_WIDTH, MARK_TO, PALETTE, mesh_point, wheels
from ..params import TableParams
from ..plant import Outputs
from ..status import Contact, contact_states

#: Marker namespaces (ids: 0, 1, 2 = pinion 1, table, pinion 3; meshes 0 = mesh 1, 1 = mesh 3).
DISCS, MARKS, MESHES = 'discs', 'marks', 'meshes'
MARK_LIFT = 0.002            # m above the disc's face
CONTACT_DIAMETER = 0.03      # m


def _colour(name: str) -> ColorRGBA:
    r, g, b, a = PALETTE[name]
    return ColorRGBA(r=r, g=g, b=b, a=a)


def _marker(ns: str, ident: int, kind: int, stamp: Time) -> Marker:
    marker = Marker(ns=ns, id=ident, type=kind, action=Marker.ADD)
    marker.header.frame_id = BASE_LINK
    marker.header.stamp = stamp
    marker.pose.orientation.w = 1.0
    return marker


def table_markers(params: TableParams, joint_names: list[str] | tuple[str, ...],
                  out: Outputs, stamp: Time) -> MarkerArray:
    """The markers of the state ``out`` of a table with ``params``."""
    gears = wheels(params, joint_names)
    active = 0 if out.active_path == 1 else 2
    markers: list[Marker] = []
    top = FACE_WIDTH / 2 + MARK_LIFT
    for wheel in gears:
        disc = _marker(DISCS, wheel.index, Marker.CYLINDER, stamp)
        disc.pose.position.x, disc.pose.position.y = wheel.centre
        disc.scale.x = disc.scale.y = 2.0 * wheel.radius
        disc.scale.z = FACE_WIDTH
        disc.color = _colour('table' if wheel.is_table else
                             'pinion_active' if wheel.index == active else 'pinion')
        markers.append(disc)
        theta = out.position[wheel.index]
        mark = _marker(MARKS, wheel.index, Marker.ARROW, stamp)
        tip_x, tip_y = wheel.rim_point(theta, MARK_TO)
        mark.points = [Point(x=wheel.centre[0], y=wheel.centre[1], z=top),
                       Point(x=tip_x, y=tip_y, z=top)]
        mark.scale.x, mark.scale.y, mark.scale.z = (0.06 * wheel.radius, 0.14 * wheel.radius,
                                                    0.18 * wheel.radius)
        mark.color = _colour('mark')
        markers.append(mark)
    for ident, (pinion, contact) in enumerate(zip((gears[0], gears[2]),
                                                  contact_states(params, out))):
        spot = _marker(MESHES, ident, Marker.SPHERE, stamp)
        x, y = mesh_point(pinion, gears[1])
        spot.pose.position.x, spot.pose.position.y, spot.pose.position.z = x, y, top
        spot.scale.x = spot.scale.y = spot.scale.z = CONTACT_DIAMETER
        spot.color = _colour('contact' if contact.touching else
                             'gap' if contact is Contact.GAP else 'disengaged')
        spot.text = str(contact)
        markers.append(spot)
    return MarkerArray(markers=markers)


__all__ = ['DISCS', 'MARKS', 'MESHES', 'table_markers']
