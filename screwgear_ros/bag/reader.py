"""Read a recorded run back: inputs as applied, parameter changes, resets, outputs.

Any storage rosbag2 writes is read (:mod:`screwgear_ros.bag.storage`); the fast path,
one MCAP file, is read record by record in file order (:func:`scan`, with ``mcap``'s
record classes for schemas, channels and chunks), so messages with equal log times keep
the order the node wrote them in (which is the order it applied them), and a bag whose
writer was killed reads up to its last complete chunk. Only the data section is read:
the summary repeats it and is checked, never trusted. A bag that cannot be used raises
:class:`BagError` saying why, whatever failed underneath. Messages are decoded with the
ROS 2 Jazzy CDR codec of ``rosbags``, except the ~4 per tick of fixed layout
(joint_states, transmission_error, mesh_state, clock), decoded in bulk with NumPy
(:mod:`screwgear_ros.bag.bulk_decode`). Topics the check does not read are skipped
undecoded (:mod:`screwgear_ros.bag.mcap_scan`). Topics are matched on their relative
name, so a namespaced table reads the same. Log times are simulation times:
step = round(log_time / dt); a bag whose log times are a recorder's arrival times
(``ros2 bag record``) gets them from its stamps first (:mod:`screwgear_ros.bag.retime`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..interface import CONTRACT
from ..params.table import SimSettings, TableParams
from ..sim.commands import INPUT_TOPICS, command_value
from ..sim.events import Command, Event, ParameterChange, Reset
from ..sim.run_file import RunParameters, RunParametersError, load
from .bulk_decode import _bulk, _Decoder, _Message, _Pieces
from .errors import BagError, InvalidBag, NoParameters, TruncatedBag
from .mcap_scan import (
    BULK_TOPICS,
    OUTPUT_TOPICS,
    RESET,
    RUN_PARAMETERS,
    SETPOINT,
    _relative,
    _wanted,
    scan,
)
from .retime import arrival_times, retime
from .storage import locate, scan_bag


@dataclass
class Signal:
    """Samples of one output topic: steps, file positions (for ordering), values."""

    steps: np.ndarray
    order: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.steps)


@dataclass
class RecordedRun:
    """One run read from a bag. Events and outputs carry their position in the file.

    As on :class:`screwgear_ros.inprocess.samples.Run`, :attr:`joint_states`, :attr:`position`
    and :attr:`velocity` are what the joint_states topic carries (measured by the joint
    sensors) and :attr:`true_joint_states`, :attr:`true_position`, :attr:`true_velocity`
    the exact state; they are the same samples when the sensors are ideal.
    """

    path: Path
    mcap_path: Path                         # its (first) storage file
    parameters: RunParameters               # the first run_parameters: start of the run
    events: list[tuple[float, Event]]       # (file position, event), in file order
    #: The exact joint states: values θ(3) rad, ω(3) rad/s, effort(3) N·m. The bag's
    #: ~/true_joint_states when it has them (its sensors were not all ideal), else its
    #: joint_states (which then are exact).
    true_joint_states: Signal
    transmission_error: Signal              # values: δ of the active path (1), m
    mesh_state: Signal                      # values: δ1, δ3 m, δ̇1, δ̇3 m/s, F1, F3 N
    active_path: Signal                     # values: 1 or 3
    clock: Signal                           # values: none (steps only)
    topics: dict[str, str]                  # resolved topic name → type
    message_count: int
    truncated: str | None = None            # why the file ends early, if it does
    #: what is wrong with the summary section (None: it checks out, or there is none);
    #: it is never used, the data section is read either way
    summary: str | None = None
    names: dict[str, str] = field(default_factory=dict)  # relative → resolved name
    #: (log time, header stamp) of every joint_states whose stamp is not its log time, ns
    stamp_mismatches: list[tuple[int, int]] = field(default_factory=list)
    #: the controller's setpoint for the table joint, rad, where it was recorded (only
    #: recorded, never an event; empty in a bag from before the topic, or without one)
    setpoint: Signal = field(default_factory=lambda: _Collector().signal())
    #: The recorded joint_states when the bag also holds ~/true_joint_states: what the
    #: sensors measured of :attr:`true_joint_states` (None: joint_states are the exact
    #: ones).
    measured: Signal | None = None
    #: How the messages' steps were found when the log times are not simulation times
    #: (:mod:`screwgear_ros.bag.retime`); None: from the log times, as recorded.
    timing: str | None = None
    #: where :attr:`parameters` come from (the bag's run_parameters, or a file)
    parameters_from: str = "the bag's run_parameters"

    @property
    def joint_states(self) -> Signal:
        """The joint_states as recorded: θ and ω measured by the joint sensors (the exact
        :attr:`true_joint_states` when they are ideal), as on
        :class:`screwgear_ros.inprocess.samples.Run`."""
        return self.true_joint_states if self.measured is None else self.measured

    @property
    def position(self) -> np.ndarray:
        """(n, 3): θ of the three joints as joint_states carries it (measured), rad."""
        return self.joint_states.values[:, 0:3]

    @property
    def velocity(self) -> np.ndarray:
        """(n, 3): ω of the three joints as joint_states carries it (measured), rad/s."""
        return self.joint_states.values[:, 3:6]

    @property
    def true_position(self) -> np.ndarray:
        """(n, 3): the exact θ of the three joints (~/true_joint_states), rad."""
        return self.true_joint_states.values[:, 0:3]

    @property
    def true_velocity(self) -> np.ndarray:
        """(n, 3): the exact ω of the three joints (~/true_joint_states), rad/s."""
        return self.true_joint_states.values[:, 3:6]

    @property
    def dt(self) -> float:
        """Integration step, s."""
        return self.parameters.settings.dt

    @property
    def end_step(self) -> int:
        """The last step with a recorded output (or the start)."""
        ends = [int(s.steps[-1]) for s in (self.true_joint_states, self.transmission_error)
                if len(s)]
        return max(ends, default=self.parameters.start_step)


class _Collector:
    """Accumulates the samples of one single-valued output topic (active_path)."""

    def __init__(self) -> None:
        self.steps: list[int] = []
        self.order: list[int] = []
        self.values: list[Any] = []

    def add(self, step: int, order: int, values: Any) -> None:
        self.steps.append(step)
        self.order.append(order)
        self.values.append(values)

    def signal(self) -> Signal:
        return Signal(np.asarray(self.steps, dtype=np.int64),
                      np.asarray(self.order, dtype=np.int64),
                      np.asarray(self.values, dtype=np.float64).reshape(-1, 1))


def read_run(path: str | Path, allow_truncated: bool = False,
             parameters: tuple[TableParams, SimSettings, str] | None = None) -> RecordedRun:
    """Read a table_sim recording. Raises :class:`BagError` when it cannot be used.

    ``parameters`` (params, settings, where they come from): for a bag without
    run_parameters (an older bag, a hardware bag, a recording started after the node
    did), the parameters it ran with; the run is taken to start at its first
    joint_states from the preload equilibrium. A bag with run_parameters refuses them.
    """
    layout = locate(path)
    status: dict[str, Any] = {'truncated': None, 'summary': None}
    found = scan_bag(layout, status)
    timing = None
    if arrival_times(found):
        retime(found, path)
        timing = ('its log times are arrival times (not table_sim\'s recorder): the '
                  'outputs are taken at their stamps, the n-th lockstep answer at the n-th '
                  'tick, anything else at the last output before it')
    topics, names = _topics(path, found)
    one_by_one, bulk = _routes(found)
    reader = _Decoder(path, names)
    first, first_order = _first_parameters(reader, one_by_one, status, parameters is None)
    source = "the bag's run_parameters"
    if parameters is not None:
        if first is not None:
            raise InvalidBag(f'{path} holds its own run_parameters, which rebuild the model: '
                             'parameters from a file are only for a bag without them')
        first, source = _given(parameters, bulk), parameters[2]
    assert first is not None
    reader.dt_ns, reader.joints = first.settings.dt * 1e9, list(first.settings.joint_names)
    events, active_path, setpoint = _events(reader, one_by_one, first_order, first)
    signals, stamp_mismatches = _signals(reader, bulk)
    if status['truncated'] and not allow_truncated:
        raise TruncatedBag(f'{path}: {status["truncated"]}')
    exact, measured = signals['joint_states'], None
    if len(signals['true_joint_states']):
        exact, measured = signals['true_joint_states'], exact
    return RecordedRun(layout.path, layout.files[0], first, events, exact,
                       signals['transmission_error'], signals['mesh_state'],
                       active_path.signal(), signals['clock'], topics, found.count,
                       status['truncated'], status['summary'], names, stamp_mismatches,
                       setpoint.signal(), measured, timing, source)


def _topics(path: str | Path, found: Any) -> tuple[dict[str, str], dict[str, str]]:
    """(topic → type name, relative name → topic), in order of first message; a contract
    topic twice or with another type is an invalid bag."""
    topics: dict[str, str] = {}
    names: dict[str, str] = {}
    for channel in sorted(found.first, key=found.first.__getitem__):
        topic, msgtype = found.channels[channel]
        topics.setdefault(topic, msgtype)
        rel = _relative(topic)
        if names.setdefault(rel, topic) != topic and (rel in OUTPUT_TOPICS or rel in INPUT_TOPICS
                                                      or rel == RUN_PARAMETERS):
            raise InvalidBag(f'{path}: two topics named {rel!r} ({names[rel]}, '
                           f'{topic}); one table per bag')
        if rel in CONTRACT and msgtype != CONTRACT[rel]:
            raise InvalidBag(f'{path}: topic {topic} is declared as '
                           f'{msgtype or "(no schema)"!s}, but table_sim records it as '
                           f'{CONTRACT[rel]}: the bag is inconsistent')
    return topics, names


def _routes(found: Any) -> tuple[list[_Message], dict[str, _Pieces]]:
    """The kept messages split by how they are decoded: one by one (in file order), or
    in bulk (by relative topic name)."""
    one_by_one: list[_Message] = []
    bulk: dict[str, _Pieces] = {}
    for channel, kept in found.kept.items():
        topic, msgtype = found.channels[channel]
        rel = _relative(topic)
        if _wanted(rel, msgtype) == 'bulk':
            bulk.setdefault(rel, []).extend(zip(kept.order, kept.log_time, kept.parts, strict=False))
            continue
        for order, log_time, part in zip(kept.order, kept.log_time, kept.parts, strict=False):
            one_by_one.extend(zip(order.tolist(), [topic] * len(part), [msgtype] * len(part),
                                  log_time.tolist(), part, strict=False))
    one_by_one.sort(key=lambda m: m[0])
    return one_by_one, bulk


def _first_parameters(reader: _Decoder, one_by_one: list[_Message],
                      status: dict[str, Any], needed: bool = True
                      ) -> tuple[RunParameters | None, int]:
    """The first run_parameters message and its file order; a bag without one cannot be
    re-simulated (unless not ``needed``: then (None, -1))."""
    for order, topic, msgtype, _, data in one_by_one:
        if _relative(topic) == RUN_PARAMETERS and msgtype == 'std_msgs/msg/String':
            return _parse(reader.decode(data, msgtype, topic).data, topic), order
    path = reader.path
    if status['truncated']:
        raise TruncatedBag(f'{path}: {status["truncated"]}; no run_parameters '
                       'message is readable before that')
    if not needed:
        return None, -1
    raise NoParameters(f'{path} holds no run_parameters message: the model '
                   'cannot be rebuilt from it (recorded by something other than '
                   "table_sim's record parameter? check_run --params FILE.yaml checks it "
                   'against the parameters it ran with)')


def _given(parameters: tuple[TableParams, SimSettings, str], bulk: dict[str, _Pieces]
           ) -> RunParameters:
    """The run of given parameters: from the preload equilibrium at the step of the
    bag's first joint_states."""
    params, settings, source = parameters
    times = [int(t.min()) for _, t, _ in bulk.get('joint_states', []) if len(t)]
    if not times:
        raise NoParameters(f'{source}: the bag holds no joint_states, so the run\'s start '
                           'is unknown')
    from ..sim.plant import Plant  # the compiled model: only for such a bag
    plant = Plant(params, settings.dt, None, settings.contact_location)
    return RunParameters(params, settings, tuple(float(v) for v in plant.state),
                         round(min(times) / (settings.dt * 1e9)))


def _events(reader: _Decoder, one_by_one: list[_Message], first_order: int,
            first: RunParameters
            ) -> tuple[list[tuple[float, Event]], _Collector, _Collector]:
    """The inputs, parameter changes and resets with their file order, and the
    active_path and setpoint samples, from the messages decoded one by one."""
    path = reader.path
    events: list[tuple[float, Event]] = []
    active_path = _Collector()
    setpoint = _Collector()
    for order, topic, msgtype, log_time, data in one_by_one:
        rel = _relative(topic)
        if order == first_order:
            continue
        step = int(reader.steps(np.array([log_time]), topic)[0])
        if rel == 'active_path':
            value = reader.decode(data, msgtype, topic).data
            if value not in (1, 3):
                raise InvalidBag(f'{path}: {topic} says path {value}; the paths are '
                               '1 and 3')
            active_path.add(step, order, value)
        elif rel in INPUT_TOPICS:
            msg = reader.decode(data, msgtype, topic)
            try:
                value = command_value(rel, msg)
            except (TypeError, ValueError) as exc:
                raise InvalidBag(f'{path}: a message on {topic} carries no command '
                               f'value ({exc})') from None
            events.append((order, Command(rel, value, step)))
        elif rel == RUN_PARAMETERS:
            params = _parse(reader.decode(data, msgtype, topic).data, topic)
            if params.settings.dt != first.settings.dt:
                raise InvalidBag(f'{topic}: dt changed during the run')
            events.append((order, ParameterChange(params.params, params.settings, step)))
        elif rel == RESET:
            events.append((order, Reset(step)))
        elif rel == SETPOINT:
            setpoint.add(step, order, reader.decode(data, msgtype, topic).data)
    return events, active_path, setpoint


def _signals(reader: _Decoder, bulk: dict[str, _Pieces]
             ) -> tuple[dict[str, Signal], list[tuple[int, int]]]:
    """Every bulk topic's samples in file order, and the joint_states whose stamp is not
    their log time (log time, stamp)."""
    signals: dict[str, Signal] = {}
    stamp_mismatches: list[tuple[int, int]] = []
    for rel in BULK_TOPICS:
        pieces = bulk.get(rel, [])
        order = np.concatenate([p[0] for p in pieces] or [np.empty(0, np.int64)])
        log_time = np.concatenate([p[1] for p in pieces] or [np.empty(0, np.int64)])
        sort = np.argsort(order, kind='stable')
        steps = reader.steps(log_time[sort], reader.names.get(rel, rel))
        if rel == 'clock':
            signals[rel] = Signal(steps, order[sort], np.empty((len(steps), 0)))
            continue
        make, width, one = reader.layout(rel)
        parts = [p[2] for p in pieces]
        values, stamps = _bulk(parts, make(parts), width, one)
        signals[rel] = Signal(steps, order[sort], values[sort])
        if rel in ('joint_states', 'true_joint_states'):
            off = np.flatnonzero(stamps[sort] != log_time[sort])
            stamp_mismatches += zip(log_time[sort][off].tolist(), stamps[sort][off].tolist(), strict=False)
    return signals, sorted(stamp_mismatches)


def _parse(text: str, topic: str) -> RunParameters:
    try:
        return load(text)
    except RunParametersError as exc:
        raise NoParameters(f'{topic}: {exc}') from None
    except Exception as exc:  # noqa: BLE001 - a value load() does not foresee (inf, NaN…)
        raise NoParameters(f'{topic}: run_parameters refused: '
                       f'{type(exc).__name__}: {exc}') from None


__all__ = [
    'BULK_TOPICS',
    'OUTPUT_TOPICS',
    'BagError',
    'Command',
    'Event',
    'ParameterChange',
    'RecordedRun',
    'Reset',
    'Signal',
    'read_run',
    'scan',
]
