"""The node's interface, declared once and free of ROS: every topic (and the service) with
its name, message type, direction, delivery and meaning.

The node's publishers and subscriptions (:mod:`screwgear_ros.ros.messages`), the input
commands (:data:`screwgear_ros.sim.commands.INPUT_TOPICS`), the bag contract the readers
enforce (:mod:`screwgear_ros.bag.reader`), lockstep's answers and docs/topics.md's topic
table (``python -m screwgear_ros.interface``) are all derived from :data:`TOPICS`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class Direction(StrEnum):
    IN = 'in'                   # the node subscribes
    INFO = 'in, recorded only'  # the node subscribes and records it; nothing else uses it
    OUT = 'out'                 # the node publishes (and records)
    SERVICE = 'service'         # the node serves


class Delivery(StrEnum):
    PER_TICK = 'per tick'       # once per publish period of simulation time
    LATCHED = 'latched (transient local)'   # a late subscriber gets the last one
    #: when what it states changes (recorded at that step), transient local: a recorder
    #: started late still gets the last one
    ON_CHANGE = 'on change (transient local)'
    AS_SENT = 'as sent'         # an input: whenever the sender sends one
    WALL_TIME = 'wall time'     # paced by the wall clock, not by simulation time


@dataclass(frozen=True)
class Topic:
    """One topic (or service) of the node."""

    key: str                    # how the code names it (unique)
    name: str                   # relative, absolute ('/clock') or private ('~/tick')
    type: str                   # 'std_msgs/msg/Float64'
    direction: Direction
    delivery: Delivery
    meaning: str                # one line for docs/topics.md
    answer: bool = False        # in lockstep, a message on it answers the last tick
    contract: bool = False      # part of the bag contract (docs/recording.md): the
    #                             offline tools read it and refuse a bag where it has
    #                             another type

    @property
    def private(self) -> bool:
        return self.name.startswith('~/')

    @property
    def absolute(self) -> bool:
        return self.name.startswith('/')



class Input(StrEnum):
    """The node's inputs by name: what a controller (or a recording) sends to the table.

    A member is its topic's key and equals that string, so it serves wherever a topic
    name did; code compares inputs with these members, never with string literals.
    """

    CMD_TORQUE = 'cmd_torque'
    CMD_DIRECTION = 'cmd_direction'
    CMD_EFFORT = 'cmd_effort'
    LOAD_TORQUE = 'load_torque'
    JOINT_COMMANDS = 'joint_commands'
    SETPOINT = 'setpoint'

IN, INFO, OUT, SERVICE = Direction
TOPICS = (
    Topic(Input.CMD_TORQUE, 'cmd_torque', 'std_msgs/msg/Float64', IN, Delivery.AS_SENT,
          'drive torque magnitude on the active pinion, N·m, 0 ≤ T ≤ `max_torque`',
          contract=True),
    Topic(Input.CMD_DIRECTION, 'cmd_direction', 'std_msgs/msg/Int8', IN, Delivery.AS_SENT,
          '+1 forward (path 1, screw gear A → pinion 1), −1 reverse (path 3)',
          contract=True),
    Topic(Input.CMD_EFFORT, 'cmd_effort', 'std_msgs/msg/Float64MultiArray', IN, Delivery.AS_SENT,
          'one signed torque (ros2_control effort controllers): sign = direction, 0 keeps '
          'the direction', answer=True, contract=True),
    Topic(Input.LOAD_TORQUE, 'load_torque', 'std_msgs/msg/Float64', IN, Delivery.AS_SENT,
          'external table load, N·m, signed, \\|load\\| ≤ 10·`max_torque`·r2/r1 (ten times '
          'what the drive can hold: 29.8 kN·m by default)', contract=True),
    Topic(Input.JOINT_COMMANDS, 'joint_commands', 'sensor_msgs/msg/JointState', IN,
          Delivery.AS_SENT,
          "ros2_control's `JointStateTopicSystem`: every URDF joint named, `pinion_1`'s one "
          'effort value = signed drive torque as `cmd_effort`; all-NaN = no command yet '
          '(silent)', answer=True, contract=True),
    Topic(Input.SETPOINT, 'setpoint', 'std_msgs/msg/Float64', INFO, Delivery.AS_SENT,
          "the controller's target for the `table` joint, rad, finite: recorded at the "
          'next tick\'s first step for plots of the tracking error; never applied, '
          'answers nothing, not replayed', contract=True),
    Topic('joint_states', 'joint_states', 'sensor_msgs/msg/JointState', OUT,
          Delivery.PER_TICK, '`pinion_1`, `table`, `pinion_3`: rad, rad/s (as the joint '
          'sensors measure them: encoder_counts_*, …), applied torque N·m',
          contract=True),
    Topic('true_joint_states', '~/true_joint_states', 'sensor_msgs/msg/JointState', OUT,
          Delivery.PER_TICK, 'the exact state joint_states measures (as joint_states); only '
          'when a joint sensor is not ideal (else joint_states is exact)', contract=True),
    Topic('mesh_state', 'mesh_state', 'sensor_msgs/msg/JointState', OUT, Delivery.PER_TICK,
          '`mesh_1`, `mesh_3`: δ (m), δ̇ (m/s), mesh force F (N)', contract=True),
    Topic('transmission_error', 'transmission_error', 'std_msgs/msg/Float64', OUT,
          Delivery.PER_TICK, 'total transmission error δ of the active path, m',
          contract=True),
    Topic('active_path', 'active_path', 'std_msgs/msg/Int8', OUT, Delivery.LATCHED,
          '1 or 3', contract=True),
    Topic('clock', '/clock', 'rosgraph_msgs/msg/Clock', OUT, Delivery.PER_TICK,
          'simulation time (`publish_clock`)', contract=True),
    Topic('diagnostics', '/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', OUT,
          Delivery.WALL_TIME, 'achieved real-time factor, overruns, rejected inputs, contact '
          'per mesh, free-running the controller\'s answers in time and missed; once per '
          'second of wall time'),
    Topic('robot_description', 'robot_description', 'std_msgs/msg/String', OUT,
          Delivery.LATCHED, "the table's URDF (geometry from the parameters, ros2_control "
          "block naming this node's topics)"),
    Topic('table_markers', 'table_markers', 'visualization_msgs/msg/MarkerArray', OUT,
          Delivery.LATCHED, 'discs, turning marks and mesh contact in frame '
          '`screwgear_base`, ~30 Hz wall time'),
    Topic('tick', '~/tick', 'std_msgs/msg/Empty', IN, Delivery.AS_SENT,
          '`lockstep` only: advance one tick without a command (for tools such as '
          '`replay_run`)', answer=True),
    Topic('run_parameters', '~/run_parameters', 'std_msgs/msg/String', OUT,
          Delivery.ON_CHANGE, 'YAML of the complete parameter set at the start and at the '
          'step each parameter change took effect (what `check_run` rebuilds the model '
          'from)', contract=True),
    Topic('reset', '~/reset', 'std_msgs/msg/Empty', OUT, Delivery.ON_CHANGE,
          'the step a reset took effect', contract=True),
    Topic('reset_service', '~/reset', 'std_srvs/srv/Trigger', SERVICE, Delivery.AS_SENT,
          'back to the preload equilibrium at the first step of the next tick; answers at '
          'once ("reset queued"), the log says the step'),
)
BY_KEY = {t.key: t for t in TOPICS}


def _select(direction: Direction, private: bool = False) -> dict[str, str]:
    return {t.key: t.type for t in TOPICS if t.direction is direction and t.private == private}


#: The command inputs: key (= relative topic name) → message type name.
COMMAND_TOPICS = _select(IN)
#: Inputs the node only records (the controller's setpoint): key → message type name.
INFO_TOPICS = _select(INFO)
#: What the node publishes (under its namespace, or its private one): key → type name.
OUTPUT_TOPICS = {**_select(OUT), **_select(OUT, private=True)}
#: Outputs published (and recorded) transient local: a late subscriber gets the last one
#: (a viewer opened while the table stands, in lockstep or halted, still sees it; a
#: ``ros2 bag record`` started after the node still gets the parameters in force).
LATCHED_OUTPUTS = frozenset(t.key for t in TOPICS if t.direction is OUT and t.delivery in
                            (Delivery.LATCHED, Delivery.ON_CHANGE))
#: The bag contract: key (the topic's name relative to its namespace) → the only type it
#: may have in a recording.
CONTRACT = {t.key: t.type for t in TOPICS if t.contract}

#: Lockstep: the inputs whose message also answers a tick (the controller's per-tick output:
#: an effort controller's, or ros2_control's topic hardware interface's), and the node's
#: private topic (``~/tick``, std_msgs/Empty) a tool answers with when it commands nothing.
ANSWER_TOPICS = tuple(t.key for t in TOPICS if t.answer and not t.private)
TICK_TOPIC = next(t.name[2:] for t in TOPICS if t.answer and t.private)
#: How the node's texts name the answers.
ANSWERS = f"{', '.join(ANSWER_TOPICS)} or ~/{TICK_TOPIC}"


def _resolved(t: Topic, ns: str, node_name: str) -> str:
    if t.private:
        return f'{ns}/{node_name}/{t.name[2:]}'
    return t.name if t.absolute else f'{ns}/{t.name}'


def topic_names(namespace: str = '', node_name: str = 'table_sim',
                clock: bool = True, true_states: bool = False) -> dict[str, str]:
    """Key → resolved topic name of every topic a table in ``namespace`` publishes or
    records (outputs, the private run_parameters and reset among them, inputs, the
    setpoint);
    without /clock unless ``clock``, without ~/true_joint_states unless ``true_states``
    (a table publishes it only when its sensors are not ideal: not by default)."""
    ns = namespace.rstrip('/')
    names = {key: _resolved(BY_KEY[key], ns, node_name) for key in OUTPUT_TOPICS}
    if not clock:
        del names['clock']
    if not true_states:
        del names['true_joint_states']
    names.update({topic: f'{ns}/{topic}' for topic in COMMAND_TOPICS})
    names.update({topic: f'{ns}/{topic}' for topic in INFO_TOPICS})
    return names


def topic_table() -> str:
    """The topic table of docs/topics.md (Markdown)."""
    def row(t: Topic) -> str:
        kind = t.type.replace('/msg/', '/').replace('/srv/', '/')
        meaning = t.meaning + ('; a lockstep answer' if t.answer and not t.private else '')
        return f'| `{t.name}` | {kind} | {t.direction} | {t.delivery} | {meaning} |'
    return '\n'.join(['| topic | type | direction | delivery | meaning |',
                      '|---|---|---|---|---|', *map(row, TOPICS)]) + '\n'


__all__ = [
    'ANSWERS',
    'ANSWER_TOPICS',
    'BY_KEY',
    'COMMAND_TOPICS',
    'CONTRACT',
    'INFO_TOPICS',
    'LATCHED_OUTPUTS',
    'OUTPUT_TOPICS',
    'TICK_TOPIC',
    'TOPICS',
    'Delivery',
    'Direction',
    'Topic',
    'topic_names',
    'topic_table',
]


if __name__ == '__main__':
    print(topic_table(), end='')
