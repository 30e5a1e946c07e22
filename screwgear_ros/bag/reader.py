"""Read a recorded run back: inputs as applied, parameter changes, resets, outputs.

The MCAP file is read record by record in file order (:func:`scan`, with ``mcap``'s
record classes for schemas, channels and chunks), so messages with equal log times keep
the order the node wrote them in (which is the order it applied them), and a bag whose
writer was killed reads up to its last complete chunk. Only the data section is read:
the summary repeats it and is checked, never trusted. A bag that cannot be used raises
:class:`BagError` saying why, whatever failed underneath. Messages are decoded with the
ROS 2 Jazzy CDR codec of ``rosbags``, except the ~4 per tick of fixed layout
(joint_states, transmission_error, mesh_state, clock): a chunk's message records are
located in one pass and those messages are
decoded in bulk with NumPy, on the layout the node writes them in
(:class:`screwgear_ros.bag.cdr.Template`: a message is decoded that way only if every
byte outside its stamps and values equals the template's, which fixes where they are;
any other message of these topics goes through ``rosbags``). Topics the
check does not read are skipped undecoded. Topics are matched on their relative name,
so a namespaced table reads the same. Log times are simulation times:
step = round(log_time / dt).

Why one module of this length: scanning the file, decoding in bulk and assembling a
:class:`RecordedRun` share the file's schema and channel tables and one error type, and
the bag contract is read in one pass from top to bottom.
"""

from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Schema

from ..interface import BY_KEY, CONTRACT, Direction
from ..params.run_file import RunParameters, RunParametersError, load
from ..sim.commands import INPUT_TOPICS, command_value
from ..sim.events import Command, Event, ParameterChange, Reset
from .cdr import Template, float64_template, joint_state_template
from .errors import BagError, InvalidBag, NoParameters, NotABag, TruncatedBag
from .format import MCAP_MAGIC, MCAP_MESSAGE, MCAP_MESSAGE_FIELDS, MCAP_RECORD, typestore

#: The outputs the readers decode: relative name → the only type it may have.
OUTPUT_TOPICS = {key: name for key, name in CONTRACT.items()
                 if BY_KEY[key].direction is Direction.OUT}
RUN_PARAMETERS = 'run_parameters'
RESET = 'reset'
SETPOINT = 'setpoint'


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
    """One run read from a bag. Events and outputs carry their position in the file."""

    path: Path
    mcap_path: Path
    parameters: RunParameters               # the first run_parameters: start of the run
    events: list[tuple[int, Event]]         # (file position, event), in file order
    #: The exact joint states: values θ(3) rad, ω(3) rad/s, effort(3) N·m. The bag's
    #: ~/true_joint_states when it has them (its sensors were not all ideal), else its
    #: joint_states (which then are exact).
    joint_states: Signal
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
    #: sensors measured of :attr:`joint_states` (None: joint_states are the exact ones).
    measured: Signal | None = None

    @property
    def dt(self) -> float:
        """Integration step, s."""
        return self.parameters.settings.dt

    @property
    def end_step(self) -> int:
        """The last step with a recorded output (or the start)."""
        ends = [int(s.steps[-1]) for s in (self.joint_states, self.transmission_error)
                if len(s)]
        return max(ends, default=self.parameters.start_step)


def find_mcap(path: str | Path) -> tuple[Path, Path]:
    """(bag directory, its .mcap file) for a rosbag2 directory or an .mcap file path."""
    path = Path(path)
    if not path.exists():
        raise NotABag(f'{path}: no such file or directory')
    if path.is_file():
        if path.suffix != '.mcap':
            raise NotABag(f'{path} is neither a rosbag2 directory nor an '
                           '.mcap file')
        return path.parent, path
    meta = path / 'metadata.yaml'
    candidates: list[Path] = []
    if meta.is_file():
        try:
            document = yaml.safe_load(meta.read_bytes().decode('utf-8'))
            info = document.get('rosbag2_bagfile_information') if isinstance(document,
                                                                              dict) else None
            if not isinstance(info, dict) or not isinstance(
                    info.get('relative_file_paths', []), list):
                raise TypeError('rosbag2_bagfile_information is not a mapping with a list of '
                                'relative_file_paths')
            if info.get('storage_identifier') != 'mcap':
                raise NotABag(f'{path}: storage {info.get("storage_identifier")!r}'
                               ' is not mcap')
            candidates = [path / Path(p).name for p in info.get('relative_file_paths', [])]
        except (yaml.YAMLError, KeyError, TypeError, AttributeError, UnicodeDecodeError,
                OSError) as exc:
            raise NotABag(f'{meta}: not a rosbag2 metadata file ({exc})') from None
    else:
        candidates = sorted(path.glob('*.mcap'))
    candidates = [c for c in candidates if c.is_file()]
    if not candidates:
        raise NotABag(f'{path} is not a rosbag2 directory: no metadata.yaml '
                       'naming an .mcap file, and no .mcap file in it')
    if len(candidates) > 1:
        raise InvalidBag(f'{path} holds {len(candidates)} .mcap files; a table_sim '
                       'run is one file')
    return path, candidates[0]


def _relative(topic: str) -> str:
    return topic.rstrip('/').rsplit('/', 1)[-1]


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


#: Where a Message record's length, channel id and log time sit (MCAP_MESSAGE: opcode,
#: length, channel id, sequence, log time, publish time).
_LENGTH_AT = struct.calcsize('<B')
_CHANNEL_AT = MCAP_RECORD.size
_LOG_TIME_AT = struct.calcsize('<BQHI')
#: Output topics of fixed layout, read in bulk (clock: log times only, nothing decoded).
BULK_TOPICS = ('joint_states', 'transmission_error', 'mesh_state', 'clock',
               'true_joint_states')


def _wanted(rel: str, msgtype: str) -> str | None:
    """'bulk', 'message' (decoded one by one) or None (not read) for a topic."""
    if CONTRACT.get(rel) != msgtype:
        return None
    return 'bulk' if rel in BULK_TOPICS else 'message'


def _gather(buf: np.ndarray, starts: np.ndarray, width: int) -> np.ndarray:
    """(len(starts), width) uint8: ``width`` bytes of ``buf`` from each start."""
    return buf[starts[:, None] + np.arange(width, dtype=np.int64)]


def _decompress(chunk: Chunk) -> bytes:
    """A chunk's records, checked against its CRC (when it has one)."""
    if chunk.compression == 'zstd':
        import zstandard
        data = zstandard.decompress(chunk.data, chunk.uncompressed_size)
    elif chunk.compression == 'lz4':
        import lz4.frame
        data = lz4.frame.decompress(chunk.data)
    elif chunk.compression == '':
        data = chunk.data
    else:
        raise ValueError(f'unsupported chunk compression {chunk.compression!r}')
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise ValueError('the chunk\'s records do not match its CRC')
    return data


@dataclass
class _Kept:
    """The messages of one channel the reader keeps, in file order: positions in the
    file's message sequence, log times (ns), and their bytes as parts, each either an
    (n, length) uint8 matrix (a chunk's messages of one length) or a list of bytes."""

    order: list[np.ndarray] = field(default_factory=list)
    log_time: list[np.ndarray] = field(default_factory=list)
    parts: list[np.ndarray | list[bytes]] = field(default_factory=list)


class _Scan:
    """One pass over an MCAP file: channels, and the messages of the topics read."""

    def __init__(self) -> None:
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, tuple[str, str]] = {}
        self.kept: dict[int, _Kept] = {}
        self.first: dict[int, int] = {}     # channel → its first message's position
        self.count = 0

    def _schema(self, record: Schema) -> None:
        self.schemas[record.id] = record.name

    def _channel(self, record: Channel) -> None:
        self.channels[record.id] = (record.topic, self.schemas.get(record.schema_id, ''))

    def message(self, record: Message) -> None:
        if record.channel_id not in self.channels:
            raise InvalidBag(f'a message on channel {record.channel_id}, which no '
                           'channel record declares')
        self._keep(record.channel_id, np.array([self.count]), np.array([record.log_time]),
                   [record.data])
        self.count += 1

    def _keep(self, channel: int, order: np.ndarray, log_time: np.ndarray,
              part: np.ndarray | list[bytes]) -> None:
        self.first.setdefault(channel, int(order[0]))
        topic, msgtype = self.channels[channel]
        if _wanted(_relative(topic), msgtype) is None:
            return
        kept = self.kept.setdefault(channel, _Kept())
        kept.order.append(order)
        kept.log_time.append(log_time.astype(np.int64))
        kept.parts.append(part)

    def chunk(self, chunk: Chunk) -> None:
        """A chunk's records; raises (and keeps nothing of it) if the chunk is damaged."""
        data = _decompress(chunk)
        end = len(data)
        at: list[int] = []
        records: list[Schema | Channel] = []
        pos = 0
        unpack = MCAP_RECORD.unpack_from
        while pos < end:
            opcode, length = unpack(data, pos)
            body = pos + MCAP_RECORD.size
            if body + length > end:
                raise ValueError(f'a record of {length} bytes runs past the end of its chunk')
            if opcode == Opcode.MESSAGE:
                if length < MCAP_MESSAGE_FIELDS:
                    raise ValueError(f'a message record of {length} bytes')
                at.append(pos)
            elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):
                stream = ReadDataStream(io.BytesIO(data[body:body + length]))
                records.append(Schema.read(stream) if opcode == Opcode.SCHEMA
                               else Channel.read(stream))
            pos = body + length
        for record in records:          # the chunk is whole: take what it declares
            (self._schema if isinstance(record, Schema) else self._channel)(record)
        if not at:
            return
        buf = np.frombuffer(data, dtype=np.uint8)
        starts = np.array(at, dtype=np.int64)
        size = (_gather(buf, starts + _LENGTH_AT, 8).view('<u8')[:, 0].astype(np.int64)
                - MCAP_MESSAGE_FIELDS)
        channel = _gather(buf, starts + _CHANNEL_AT, 2).view('<u2')[:, 0]
        log_time = _gather(buf, starts + _LOG_TIME_AT, 8).view('<u8')[:, 0]
        starts += MCAP_MESSAGE.size
        order = self.count + np.arange(len(at), dtype=np.int64)
        present = np.unique(channel).tolist()
        unknown = set(present) - set(self.channels)
        if unknown:
            raise ValueError(f'messages on channels {sorted(unknown)}, which no channel '
                             'record declares')
        for c in present:
            mine = np.flatnonzero(channel == c)
            sizes = size[mine]
            topic, msgtype = self.channels[c]
            if _wanted(_relative(topic), msgtype) == 'bulk' and np.all(sizes == sizes[0]):
                part: np.ndarray | list[bytes] = _gather(buf, starts[mine], int(sizes[0]))
            else:
                part = [data[a:a + n] for a, n in zip(starts[mine].tolist(), sizes.tolist())]
            self._keep(c, order[mine], log_time[mine], part)
        self.count += len(at)


_CHUNK_HEAD = struct.Struct('<QQQII')   # start, end time, uncompressed size, CRC, len(compression)
#: Longest record read, bytes (a corrupt length is taken for a cut file, not allocated).
RECORD_SIZE_LIMIT = 1 << 30


def _chunk(body: memoryview) -> Chunk:
    start, end, size, crc, n = _CHUNK_HEAD.unpack_from(body, 0)
    at = _CHUNK_HEAD.size
    compression = bytes(body[at:at + n]).decode()
    (length,) = struct.unpack_from('<Q', body, at + n)
    data = bytes(body[at + n + 8:at + n + 8 + length])
    if len(data) != length:
        raise ValueError(f'a chunk holds {len(data)} of its {length} bytes of records')
    return Chunk(compression=compression, data=data, message_end_time=end,
                 message_start_time=start, uncompressed_crc=crc, uncompressed_size=size)


def scan(mcap_path: Path, status: dict[str, Any]) -> _Scan:
    """The file's records in order: a killed
    writer's file reads up to its last whole chunk (``status['truncated']`` says why),
    and so does one with a damaged chunk. Keeps the messages of the topics
    :func:`read_run` uses, undecoded. Message indexes and the summary are never used:
    they only repeat what the data section says, and a damaged copy must not
    override it. The summary is checked against the footer's CRC, and
    ``status['summary']`` says if it is damaged (the data section is read either
    way, as MCAP's own recovery rebuilds the index from it)."""
    result = _Scan()
    try:
        data = memoryview(mcap_path.read_bytes())
    except OSError as exc:
        raise NotABag(f'{mcap_path}: cannot be read: {exc.strerror or exc}') from None
    if bytes(data[:len(MCAP_MAGIC)]) != MCAP_MAGIC:
        if not MCAP_MAGIC.startswith(bytes(data)):
            raise NotABag(f'{mcap_path} is not an MCAP file')
        status['truncated'] = (f'{mcap_path.name} ends after {len(data)} bytes, within its '
                               'magic: the recording was not closed (killed?)')
        return result
    pos, end = len(MCAP_MAGIC), len(data)
    while True:
        if pos + MCAP_RECORD.size > end:
            status['truncated'] = (f'{mcap_path.name} ends without its summary after {pos} '
                                   'bytes: the recording was not closed (killed?)')
            break
        opcode, length = MCAP_RECORD.unpack_from(data, pos)
        body = pos + MCAP_RECORD.size
        if length > RECORD_SIZE_LIMIT or body + length > end:
            status['truncated'] = (f'{mcap_path.name} ends without its summary after {pos} '
                                   f'bytes (a record of {length} bytes is cut short): the '
                                   'recording was not closed (killed?)')
            break
        record = data[body:body + length]
        try:
            if opcode == Opcode.CHUNK:
                result.chunk(_chunk(record))
            elif opcode == Opcode.MESSAGE:
                result.message(Message.read(ReadDataStream(io.BytesIO(record)), length))
            elif opcode == Opcode.SCHEMA:
                result._schema(Schema.read(ReadDataStream(io.BytesIO(record))))
            elif opcode == Opcode.CHANNEL:
                result._channel(Channel.read(ReadDataStream(io.BytesIO(record))))
            elif opcode == Opcode.DATA_END:
                status['summary'] = _summary_damage(mcap_path.name, data, body + length)
                break
            elif opcode == Opcode.FOOTER:
                break
        except BagError:
            raise
        except Exception as exc:  # noqa: BLE001 - zstd or CRC errors, a cut or bad record
            status['truncated'] = (f'{mcap_path.name} is damaged after {pos} bytes: '
                                   f'{type(exc).__name__}: {exc}')
            break
        pos = body + length
    return result


_FOOTER = struct.Struct('<BQQQI')     # opcode, length, summary start, offsets start, CRC


def _summary_damage(name: str, data: memoryview, summary_start: int) -> str | None:
    """Why the summary section after the data section's end (at ``summary_start``) and
    the footer do not check out, or None if they do (the footer's ``summary_crc``
    covers the summary and the footer up to that field; 0 means not computed)."""
    at = len(data) - len(MCAP_MAGIC) - _FOOTER.size
    if at < summary_start or bytes(data[len(data) - len(MCAP_MAGIC):]) != MCAP_MAGIC:
        return f'{name} has no valid footer after its data section'
    opcode, length, start, offsets, crc = _FOOTER.unpack_from(data, at)
    if opcode != Opcode.FOOTER or length != _FOOTER.size - MCAP_RECORD.size:
        return f'{name} has no valid footer after its data section'
    if start not in (0, summary_start) or (offsets and not start <= offsets <= at):
        return f'{name}: its footer points the summary to byte {start}, not {summary_start}'
    if crc and zlib.crc32(data[summary_start if start else at:at + _FOOTER.size - 4]) != crc:
        return f'{name}: its summary section does not match the CRC in its footer (damaged)'
    return None


def _fixed_bytes(template: Template) -> np.ndarray:
    """Mask of the template's bytes that fix the layout: all but the stamps, the values and
    the bytes no decoder reads (:attr:`Template.free`: the encapsulation options and the
    alignment padding, which rclpy leaves uninitialized)."""
    fixed = np.ones(len(template.bytes), dtype=bool)
    for f in [*template.stamps, *template.fields]:
        fixed[f.offset:f.offset + f.codec.size] = False
    for start, end in template.free:
        fixed[start:end] = False
    return fixed


def _bulk(parts: list[np.ndarray | list[bytes]], template: Template | None, width: int,
          one: Any) -> tuple[np.ndarray, np.ndarray]:
    """Values (n, width) and header stamps (n,) ns (0 if unstamped) of messages.

    A message whose bytes equal ``template``'s outside its stamp and values (``width``
    of them) is read in place with NumPy; any other is ``one(bytes) -> (values, stamp)``
    (``rosbags``), and every one if ``template`` is None.
    """
    n = sum(len(p) for p in parts)
    values = np.empty((n, width))
    stamps = np.zeros(n, dtype=np.int64)
    if template is not None:
        assert sum(f.codec.size for f in template.fields) == 8 * width
        fixed = _fixed_bytes(template)
        reference = np.frombuffer(template.bytes, dtype=np.uint8)[fixed]
    i = 0
    for part in parts:
        k = len(part)
        fits = np.zeros(k, dtype=bool)
        if (template is not None and isinstance(part, np.ndarray)
                and part.shape[1] == len(template.bytes)):
            fits = np.all(part[:, fixed] == reference, axis=1)
            rows = part[fits]
            values[i:i + k][fits] = np.hstack(
                [np.ascontiguousarray(rows[:, f.offset:f.offset + f.codec.size]).view('<f8')
                 for f in template.fields])
            if template.stamps:      # the header's: the layouts read here have one
                o = template.stamps[0].offset
                sec = np.ascontiguousarray(rows[:, o:o + 4]).view('<i4')[:, 0]
                nanosec = np.ascontiguousarray(rows[:, o + 4:o + 8]).view('<u4')[:, 0]
                stamps[i:i + k][fits] = sec.astype(np.int64) * 1_000_000_000 + nanosec
        for j in np.flatnonzero(~fits).tolist():
            raw = part[j].tobytes() if isinstance(part, np.ndarray) else part[j]
            values[i + j], stamps[i + j] = one(raw)
        i += k
    return values, stamps


#: A message decoded one by one: (file order, topic, type name, log time, CDR bytes).
_Message = tuple[int, str, str, int, bytes]
#: A bulk topic's messages as scanned: (file orders, log times, raw messages) per chunk.
_Pieces = list[tuple[np.ndarray, np.ndarray, 'np.ndarray | list[bytes]']]


def read_run(path: str | Path, allow_truncated: bool = False) -> RecordedRun:
    """Read a table_sim recording. Raises :class:`BagError` when it cannot be used."""
    bag_dir, mcap_path = find_mcap(path)
    status: dict[str, Any] = {'truncated': None, 'summary': None}
    found = scan(mcap_path, status)
    topics, names = _topics(path, found)
    one_by_one, bulk = _routes(found)
    reader = _Decoder(path, names)
    first, first_order = _first_parameters(reader, one_by_one, status)
    reader.dt_ns, reader.joints = first.settings.dt * 1e9, list(first.settings.joint_names)
    events, active_path, setpoint = _events(reader, one_by_one, first_order, first)
    signals, stamp_mismatches = _signals(reader, bulk)
    if status['truncated'] and not allow_truncated:
        raise TruncatedBag(f'{path}: {status["truncated"]}')
    exact, measured = signals['joint_states'], None
    if len(signals['true_joint_states']):
        exact, measured = signals['true_joint_states'], exact
    return RecordedRun(bag_dir, mcap_path, first, events, exact,
                       signals['transmission_error'], signals['mesh_state'],
                       active_path.signal(), signals['clock'], topics, found.count,
                       status['truncated'], status['summary'], names, stamp_mismatches,
                       setpoint.signal(), measured)


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
            bulk.setdefault(rel, []).extend(zip(kept.order, kept.log_time, kept.parts))
            continue
        for order, log_time, part in zip(kept.order, kept.log_time, kept.parts):
            one_by_one.extend(zip(order.tolist(), [topic] * len(part), [msgtype] * len(part),
                                  log_time.tolist(), part))
    one_by_one.sort(key=lambda m: m[0])
    return one_by_one, bulk


class _Decoder:
    """Decodes the messages of one bag, every failure a :class:`BagError` naming it:
    ``names`` (relative name → topic) from :func:`_topics`, the step grid (``dt_ns``)
    and the joints from the first run_parameters once read."""

    def __init__(self, path: str | Path, names: dict[str, str]) -> None:
        self.path = path
        self.names = names
        self.store = typestore()
        self.dt_ns = 0.0
        self.joints: list[str] = []

    def decode(self, raw: bytes, msgtype: str, topic: str) -> Any:
        """``raw`` decoded; a message that is not valid CDR of its type is an invalid bag
        (whatever the codec raised)."""
        try:
            return self.store.deserialize_cdr(raw, msgtype)
        except Exception as exc:  # noqa: BLE001 - the codec's errors are of many types
            raise InvalidBag(f'{self.path}: a message on {topic} is not a valid '
                           f'{msgtype} ({type(exc).__name__}: {exc})') from None

    def steps(self, log_time: np.ndarray, topic: str) -> np.ndarray:
        """The steps of these log times, which must lie on the step grid."""
        dt_ns = self.dt_ns
        steps = np.rint(log_time / dt_ns)
        off = np.flatnonzero(np.abs(log_time - steps * dt_ns) > 0.5 + 1e-6 * dt_ns)
        if len(off):
            raise InvalidBag(f'{topic}: log time {int(log_time[off[0]])} ns is not on '
                           f'the step grid of dt = {dt_ns:g} ns')
        return steps.astype(np.int64)

    def _sized(self, msg: Any, topic: str, n: int) -> None:
        if not len(msg.position) == len(msg.velocity) == len(msg.effort) == n:
            raise InvalidBag(f'{self.path}: a message on {topic} has '
                           f'{len(msg.position)} positions, {len(msg.velocity)} velocities '
                           f'and {len(msg.effort)} efforts for {n} names')

    def joint_state(self, raw: bytes, rel: str = 'joint_states') -> tuple[np.ndarray, int]:
        """One joint_states (or true_joint_states) message the bulk decoder could not
        take: its values in the recorded joints' order, and its stamp (ns)."""
        topic = self.names[rel]
        msg = self.decode(raw, OUTPUT_TOPICS[rel], topic)
        try:
            idx = [list(msg.name).index(n) for n in self.joints]
        except ValueError:
            raise InvalidBag(f'{topic}: joints {list(msg.name)} do '
                           f'not include {self.joints}') from None
        self._sized(msg, topic, len(msg.name))
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        return np.concatenate([msg.position[idx], msg.velocity[idx], msg.effort[idx]]), stamp

    def mesh_state(self, raw: bytes) -> tuple[np.ndarray, int]:
        topic = self.names['mesh_state']
        msg = self.decode(raw, OUTPUT_TOPICS['mesh_state'], topic)
        self._sized(msg, topic, 2)
        return np.concatenate([msg.position, msg.velocity, msg.effort]), 0

    def float64(self, raw: bytes) -> tuple[np.ndarray, int]:
        topic = self.names['transmission_error']
        return np.array([self.decode(raw, OUTPUT_TOPICS['transmission_error'], topic).data]), 0

    def mesh_template(self, parts: list[np.ndarray | list[bytes]]) -> Template | None:
        """The layout of the first mesh_state message's names (the node's: one δ1, δ3)."""
        if not parts:
            return None
        raw = parts[0][0].tobytes() if isinstance(parts[0], np.ndarray) else parts[0][0]
        msg = self.decode(raw, OUTPUT_TOPICS['mesh_state'], self.names['mesh_state'])
        return joint_state_template(list(msg.name)) if len(msg.name) == 2 else None

    def layout(self, rel: str) -> tuple[Any, int, Any]:
        """(the template of a bulk topic from its parts, values per message, the decoder
        of one message the template does not fit)."""
        if rel == 'joint_states':
            return lambda parts: joint_state_template(self.joints), 9, self.joint_state
        if rel == 'true_joint_states':
            return (lambda parts: joint_state_template(self.joints), 9,
                    lambda raw: self.joint_state(raw, rel))
        if rel == 'transmission_error':
            return lambda parts: float64_template(), 1, self.float64
        return self.mesh_template, 6, self.mesh_state


def _first_parameters(reader: _Decoder, one_by_one: list[_Message],
                      status: dict[str, Any]) -> tuple[RunParameters, int]:
    """The first run_parameters message and its file order; a bag without one cannot be
    re-simulated."""
    for order, topic, msgtype, _, data in one_by_one:
        if _relative(topic) == RUN_PARAMETERS and msgtype == 'std_msgs/msg/String':
            return _parse(reader.decode(data, msgtype, topic).data, topic), order
    path = reader.path
    if status['truncated']:
        raise TruncatedBag(f'{path}: {status["truncated"]}; no run_parameters '
                       'message is readable before that')
    raise NoParameters(f'{path} holds no run_parameters message: the model '
                   'cannot be rebuilt from it (recorded by something other than '
                   "table_sim's record parameter?)")


def _events(reader: _Decoder, one_by_one: list[_Message], first_order: int,
            first: RunParameters
            ) -> tuple[list[tuple[int, Event]], _Collector, _Collector]:
    """The inputs, parameter changes and resets with their file order, and the
    active_path and setpoint samples, from the messages decoded one by one."""
    path = reader.path
    events: list[tuple[int, Event]] = []
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
            stamp_mismatches += zip(log_time[sort][off].tolist(), stamps[sort][off].tolist())
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
    'find_mcap',
    'read_run',
    'scan',
]
