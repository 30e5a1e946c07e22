"""What every tick records, as CDR bytes, with no ROS message package.

A session's tick sends the same topics every time (/clock when it is published,
joint_states, mesh_state, transmission_error, and ~/true_joint_states when the sensors
are not ideal), each of a fixed layout: :class:`TickEncoder` encodes them with one pack
of a :class:`~screwgear_ros.bag.cdr.MessageBundle` of their templates. The node's
:class:`~screwgear_ros.runs.run_io.RunIO` publishes and records these bytes; the topics'
types come from :mod:`screwgear_ros.interface` (:func:`topic_specs`), so opening a
recording needs no rclpy either.

Examples
--------
>>> from screwgear_ros.bag.tick_encoder import TickEncoder
>>> TickEncoder({'joint_states': '/joint_states', 'mesh_state': '/mesh_state',
...              'transmission_error': '/transmission_error'}, ['a', 'b', 'c']).keys
('joint_states', 'mesh_state', 'transmission_error')
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from ..interface import BY_KEY, LATCHED_OUTPUTS
from ..sim.plant import Outputs
from . import cdr

if TYPE_CHECKING:
    from .bag_files import TopicSpec
# The bag's writer (mcap, zstandard) is imported where a recording opens, not with the
# encoder: a node that does not record never loads it.

#: The two "joints" of mesh_state: the meshes of pinions 1 and 3.
MESH_NAMES = ['mesh_1', 'mesh_3']


def topic_specs(topics: Mapping[str, str]) -> list[TopicSpec]:
    """The recorded topics (key → resolved name, as :func:`~screwgear_ros.interface.
    topic_names` gives them) with their types and whether they are latched."""
    from .bag_files import TopicSpec
    return [TopicSpec(name, BY_KEY[key].type, key in LATCHED_OUTPUTS)
            for key, name in topics.items()]


class TickEncoder:
    """The CDR bytes of a tick's outputs on the per-tick topics among ``topics``.

    Parameters
    ----------
    topics : Mapping[str, str]
        Key → resolved name of the session's topics.
    joint_names : Sequence[str]
        The joints of joint_states (:meth:`rename` when a parameter change renames them).

    Raises
    ------
    ValueError
        If a per-tick topic is a latched one.
    """

    def __init__(self, topics: Mapping[str, str], joint_names: Sequence[str]) -> None:
        # The clock first: it has no values, so the blocks encode() packs are the same
        # with or without it. The exact state last (when the sensors are not ideal, the
        # caller names its topic): joint_states then carries what the sensors measure.
        self.keys = (('clock',) if 'clock' in topics else ()) + (
            'joint_states', 'mesh_state', 'transmission_error') + (
            ('true_joint_states',) if 'true_joint_states' in topics else ())
        if LATCHED_OUTPUTS.intersection(self.keys):
            raise ValueError('a latched topic must be published whether or not anybody '
                             'listens: not one of the per-tick topics')
        self.joint_states_at = self.keys.index('joint_states')
        self.rename(joint_names)

    def rename(self, joint_names: Sequence[str]) -> None:
        """Encode joint_states with these joint names from now on."""
        self.joint_names = list(joint_names)
        templates = {'clock': cdr.clock_template,
                     'joint_states': lambda: cdr.joint_state_template(self.joint_names),
                     'mesh_state': lambda: cdr.joint_state_template(MESH_NAMES),
                     'transmission_error': cdr.float64_template,
                     'true_joint_states': lambda: cdr.joint_state_template(self.joint_names)}
        self.bundle = cdr.MessageBundle([templates[key]() for key in self.keys])

    def encode(self, out: Outputs, measured: Outputs | None = None) -> list[bytes]:
        """Each per-tick topic's message of ``out``, in :attr:`keys`' order: joint_states
        of ``measured`` (what the sensors measure of ``out``; None: ``out`` itself), the
        exact state on true_joint_states."""
        js = out if measured is None else measured
        return self.bundle.encode(out.time_ns, js.position, js.velocity, js.effort,
                                  out.delta, out.delta_rate, out.mesh_force,
                                  (out.transmission_error,), out.position, out.velocity,
                                  out.effort)


__all__ = ['MESH_NAMES', 'TickEncoder', 'topic_specs']
