"""``table_markers``: the table and both pinions drawn in one fixed frame, no TF needed.

Each wheel of :mod:`screwgear_ros.view.layout` is a disc (CYLINDER) with a mark (ARROW from
its axis towards its rim) that turns with its joint angle; each pinion's mesh point
is a sphere coloured by the mesh's contact (:class:`screwgear_ros.sim.status.Contact`):
teeth on a flank, inside the backlash gap, or disengaged. The pinion of the active
path is drawn in a brighter colour. Every marker is in :data:`layout.BASE_LINK` and
stamped with the simulation time of the outputs it shows, so RViz (fixed frame
``screwgear_base``) and Foxglove show it live and from a bag with nothing else running.

:func:`table_markers` draws the markers as a MarkerArray, spelt out as a
:class:`~screwgear_ros.bag.cdr.Shape` (no rclpy; :func:`screwgear_ros.ros.messages.to_message`
makes the rclpy message of it). The node sends them as CDR
bytes from :class:`MarkerEncoder`: between two states with the same colours and texts
(the active path, both contacts) only the stamps and the marks' points change, so each
such look is drawn once, as a :class:`~screwgear_ros.bag.cdr.Template`, and then encoded
by one ``struct.pack`` instead of being built and serialized again.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..bag.cdr import Shape, Template, template_of
from ..bag.messages import header
from ..params.table import TableParams
from ..sim.plant import Outputs
from ..sim.status import Contact, contact_states
from .layout import BASE_LINK, FACE_WIDTH, MARK_TO, PALETTE, Wheel, mesh_point, wheels

#: Marker namespaces (ids: 0, 1, 2 = pinion 1, table, pinion 3; meshes 0 = mesh 1, 1 = mesh 3).
DISCS, MARKS, MESHES = 'discs', 'marks', 'meshes'
#: visualization_msgs/Marker's types and its ADD action.
ARROW, SPHERE, CYLINDER, ADD = 0, 2, 3, 0
MARK_LIFT = 0.002            # m above the disc's face
TOP = FACE_WIDTH / 2 + MARK_LIFT     # z of the marks and the contact spots, m
CONTACT_DIAMETER = 0.03      # m


def _xyz(msgtype: str, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Shape:
    return Shape(msgtype, {'x': ('double', x), 'y': ('double', y), 'z': ('double', z)})


def _colour(name: str) -> Shape:
    r, g, b, a = PALETTE[name]
    return Shape('std_msgs/msg/ColorRGBA', {'r': ('float', r), 'g': ('float', g),
                                            'b': ('float', b), 'a': ('float', a)})


def _bytes_of(name: str) -> Shape:
    """An empty visualization_msgs/MeshFile or sensor_msgs/CompressedImage."""
    if name == 'mesh_file':
        return Shape('visualization_msgs/msg/MeshFile',
                     {'filename': ('string', ''), 'data': ('sequence<uint8>', [])})
    return Shape('sensor_msgs/msg/CompressedImage', {
        'header': ('std_msgs/Header', header()), 'format': ('string', ''),
        'data': ('sequence<uint8>', [])})


def marker(ns: str, ident: int, kind: int, time_ns: int, position: Sequence[float],
           scale: Sequence[float], colour: str, points: Sequence[Sequence[float]] = (),
           text: str = '') -> Shape:
    """A visualization_msgs/Marker in :data:`BASE_LINK`, upright, stamped ``time_ns``;
    every field it does not name has the message's default."""
    pose = Shape('geometry_msgs/msg/Pose', {
        'position': ('geometry_msgs/Point', _xyz('geometry_msgs/msg/Point', *position)),
        'orientation': ('geometry_msgs/Quaternion', Shape('geometry_msgs/msg/Quaternion', {
            'x': ('double', 0.0), 'y': ('double', 0.0), 'z': ('double', 0.0),
            'w': ('double', 1.0)}))})
    lifetime = Shape('builtin_interfaces/msg/Duration',
                     {'sec': ('int32', 0), 'nanosec': ('uint32', 0)})
    fields: dict[str, tuple[str, Any]] = {
        'header': ('std_msgs/Header', header(BASE_LINK, time_ns)),
        'ns': ('string', ns), 'id': ('int32', ident), 'type': ('int32', kind),
        'action': ('int32', ADD), 'pose': ('geometry_msgs/Pose', pose),
        'scale': ('geometry_msgs/Vector3', _xyz('geometry_msgs/msg/Vector3', *scale)),
        'color': ('std_msgs/ColorRGBA', _colour(colour)),
        'lifetime': ('builtin_interfaces/Duration', lifetime),
        'frame_locked': ('boolean', False),
        'points': ('sequence<geometry_msgs/Point>',
                   [_xyz('geometry_msgs/msg/Point', *p) for p in points]),
        'colors': ('sequence<std_msgs/ColorRGBA>', []),
        'texture_resource': ('string', ''),
        'texture': ('sensor_msgs/CompressedImage', _bytes_of('texture')),
        'uv_coordinates': ('sequence<visualization_msgs/UVCoordinate>', []),
        'text': ('string', text), 'mesh_resource': ('string', ''),
        'mesh_file': ('visualization_msgs/MeshFile', _bytes_of('mesh_file')),
        'mesh_use_embedded_materials': ('boolean', False)}
    return Shape('visualization_msgs/msg/Marker', fields)


def _look(params: TableParams, out: Outputs) -> tuple[int, Contact, Contact]:
    """What sets the markers' colours and texts: the active pinion's index, the contacts."""
    return (0 if out.active_path == 1 else 2, *contact_states(params, out))


def _mark_points(wheel: Wheel, out: Outputs) -> tuple[float, ...]:
    """x, y, z of the two points of the wheel's mark (axis, then towards the rim)."""
    tip_x, tip_y = wheel.rim_point(out.position[wheel.index], MARK_TO)
    return (*wheel.centre, TOP, tip_x, tip_y, TOP)


def _time_ns(stamp: Any) -> int:
    """Integer nanoseconds of a stamp given as such or as a builtin_interfaces/Time."""
    if isinstance(stamp, int):
        return stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def table_markers(params: TableParams, joint_names: list[str] | tuple[str, ...],
                  out: Outputs, stamp: Any = 0) -> Shape:
    """The visualization_msgs/MarkerArray of the state ``out`` of a table with
    ``params``, every marker stamped ``stamp`` (ns, or a builtin_interfaces/Time).

    Examples
    --------
    >>> from screwgear_ros.params.table import TableParams
    >>> from screwgear_ros.sim.plant import Plant
    >>> out = Plant(TableParams(), 5e-5).compute_outputs()
    >>> [m.ns for m in table_markers(TableParams(), ['a', 'b', 'c'], out).markers][:3]
    ['discs', 'marks', 'discs']
    """
    t_ns = _time_ns(stamp)
    gears = wheels(params, joint_names)
    active, *contacts = _look(params, out)
    markers: list[Shape] = []
    for wheel in gears:
        markers.append(marker(
            DISCS, wheel.index, CYLINDER, t_ns, (*wheel.centre, 0.0),
            (2.0 * wheel.radius, 2.0 * wheel.radius, FACE_WIDTH),
            'table' if wheel.is_table else
            'pinion_active' if wheel.index == active else 'pinion'))
        points = _mark_points(wheel, out)
        markers.append(marker(
            MARKS, wheel.index, ARROW, t_ns, (0.0, 0.0, 0.0),
            (0.06 * wheel.radius, 0.14 * wheel.radius, 0.18 * wheel.radius), 'mark',
            (points[:3], points[3:])))
    for ident, (pinion, contact) in enumerate(zip((gears[0], gears[2]), contacts, strict=True)):
        x, y = mesh_point(pinion, gears[1])
        markers.append(marker(
            MESHES, ident, SPHERE, t_ns, (x, y, TOP), (CONTACT_DIAMETER,) * 3,
            'contact' if contact.touching else 'gap' if contact is Contact.GAP
            else 'disengaged', text=str(contact)))
    return Shape('visualization_msgs/msg/MarkerArray',
                 {'markers': ('sequence<visualization_msgs/Marker>', markers)})


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
        drawn = table_markers(self.params, self.joint_names, out)
        marks = [i for i, m in enumerate(drawn.markers) if m.ns == MARKS]  # wheel order
        return template_of(drawn,
                           [('markers', i, 'header', 'stamp') for i in range(len(drawn.markers))],
                           [[('markers', i, 'points', 0), ('markers', i, 'points', 1)]
                            for i in marks])


__all__ = ['ARROW', 'CYLINDER', 'DISCS', 'MARKS', 'MESHES', 'SPHERE', 'MarkerEncoder', 'marker',
           'table_markers']
