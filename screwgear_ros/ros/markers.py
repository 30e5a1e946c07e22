"""``table_markers``: the table and both pinions drawn in one fixed frame, no TF needed.

Each wheel of :mod:`screwgear_ros.ros.layout` is a disc (CYLINDER) with a mark (ARROW from
its axis towards its rim) that turns with its joint angle; each pinion's mesh point
is a sphere coloured by the mesh's contact (:class:`screwgear_ros.sim.status.Contact`):
teeth on a flank, inside the backlash gap, or disengaged. The pinion of the active
path is drawn in a brighter colour. Every marker is in :data:`layout.BASE_LINK` and
stamped with the simulation time of the outputs it shows, so RViz (fixed frame
``screwgear_base``) and Foxglove show it live and from a bag with nothing else running.

:func:`table_markers` draws the markers as a MarkerArray. The node sends them as CDR
bytes from :class:`MarkerEncoder`: between two states with the same colours and texts
(the active path, both contacts) only the stamps and the marks' points change, so each
such look is drawn once, as a :class:`~screwgear_ros.bag.cdr.Template`, and then encoded
by one ``struct.pack`` instead of being built and serialized again.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..bag.cdr import Template, template_of
from ..params.table import TableParams
from ..sim.plant import Outputs
from ..sim.status import Contact, contact_states
from .layout import BASE_LINK, FACE_WIDTH, MARK_TO, PALETTE, Wheel, mesh_point, wheels

#: Marker namespaces (ids: 0, 1, 2 = pinion 1, table, pinion 3; meshes 0 = mesh 1, 1 = mesh 3).
DISCS, MARKS, MESHES = 'discs', 'marks', 'meshes'
MARK_LIFT = 0.002            # m above the disc's face
TOP = FACE_WIDTH / 2 + MARK_LIFT     # z of the marks and the contact spots, m
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


def _look(params: TableParams, out: Outputs) -> tuple[int, Contact, Contact]:
    """What sets the markers' colours and texts: the active pinion's index, the contacts."""
    return (0 if out.active_path == 1 else 2, *contact_states(params, out))


def _mark_points(wheel: Wheel, out: Outputs) -> tuple[float, ...]:
    """x, y, z of the two points of the wheel's mark (axis, then towards the rim)."""
    tip_x, tip_y = wheel.rim_point(out.position[wheel.index], MARK_TO)
    return (*wheel.centre, TOP, tip_x, tip_y, TOP)


def table_markers(params: TableParams, joint_names: list[str] | tuple[str, ...],
                  out: Outputs, stamp: Time) -> MarkerArray:
    """The markers of the state ``out`` of a table with ``params``."""
    gears = wheels(params, joint_names)
    active, *contacts = _look(params, out)
    markers: list[Marker] = []
    for wheel in gears:
        disc = _marker(DISCS, wheel.index, Marker.CYLINDER, stamp)
        disc.pose.position.x, disc.pose.position.y = wheel.centre
        disc.scale.x = disc.scale.y = 2.0 * wheel.radius
        disc.scale.z = FACE_WIDTH
        disc.color = _colour('table' if wheel.is_table else
                             'pinion_active' if wheel.index == active else 'pinion')
        markers.append(disc)
        mark = _marker(MARKS, wheel.index, Marker.ARROW, stamp)
        x0, y0, z0, x1, y1, z1 = _mark_points(wheel, out)
        mark.points = [Point(x=x0, y=y0, z=z0), Point(x=x1, y=y1, z=z1)]
        mark.scale.x, mark.scale.y, mark.scale.z = (0.06 * wheel.radius, 0.14 * wheel.radius,
                                                    0.18 * wheel.radius)
        mark.color = _colour('mark')
        markers.append(mark)
    for ident, (pinion, contact) in enumerate(zip((gears[0], gears[2]), contacts, strict=False)):
        spot = _marker(MESHES, ident, Marker.SPHERE, stamp)
        x, y = mesh_point(pinion, gears[1])
        spot.pose.position.x, spot.pose.position.y, spot.pose.position.z = x, y, TOP
        spot.scale.x = spot.scale.y = spot.scale.z = CONTACT_DIAMETER
        spot.color = _colour('contact' if contact.touching else
                             'gap' if contact is Contact.GAP else 'disengaged')
        spot.text = str(contact)
        markers.append(spot)
    return MarkerArray(markers=markers)


class MarkerEncoder:
    """:func:`table_markers` of one table (``params``, ``joint_names``) as CDR bytes.

    One template per look (:func:`_look`: the active pinion and each mesh's contact
    branch; a run meets a few of them), drawn by :func:`table_markers` the first time
    the look appears; encoding fills in every marker's stamp and the marks' points. A
    parameter change needs a new encoder (:meth:`draws` says whether this one fits).
    Not thread-safe: it belongs to its caller's thread (the node's pacing thread).
    """

    def __init__(self, params: TableParams, joint_names: list[str] | tuple[str, ...]) -> None:
        self.params = params
        self.joint_names = tuple(joint_names)
        self._gears = wheels(params, joint_names)
        self._templates: dict[tuple[int, Contact, Contact], Template] = {}

    def draws(self, params: TableParams, joint_names: list[str] | tuple[str, ...]) -> bool:
        return params == self.params and tuple(joint_names) == self.joint_names

    def encode(self, out: Outputs, time_ns: int) -> bytes:
        """The CDR bytes of ``table_markers(params, joint_names, out, <time_ns>)``."""
        look = _look(self.params, out)
        template = self._templates.get(look)
        if template is None:
            template = self._templates[look] = self._template(out)
        return template.encode(time_ns, *(_mark_points(wheel, out) for wheel in self._gears))

    def _template(self, out: Outputs) -> Template:
        drawn = table_markers(self.params, self.joint_names, out, Time()).markers
        marks = [i for i, marker in enumerate(drawn) if marker.ns == MARKS]  # wheel order
        return template_of(MarkerArray(markers=drawn),
                           [('markers', i, 'header', 'stamp') for i in range(len(drawn))],
                           [[('markers', i, 'points', 0), ('markers', i, 'points', 1)]
                            for i in marks])


__all__ = ['DISCS', 'MARKS', 'MESHES', 'MarkerEncoder', 'table_markers']
