"""Scan an MCAP file's data section record by record, without trusting its summary.

:func:`scan` reads schemas, channels and chunks in file order (``mcap``'s record classes
for their bodies), locates a chunk's message records in one NumPy pass, and keeps the
messages the readers need: those of the fixed-layout output topics as raw rows, the
others one by one; topics no reader uses are skipped undecoded. A file whose writer was
killed scans up to its last complete chunk, and says why it ends early.

Why not ``mcap``'s readers: its ``StreamReader`` builds a record object per message and
its indexed reader trusts the summary, which a damaged copy may contradict; locating a
chunk's messages in one NumPy pass costs a fraction of either
(``benchmarks/bench_serialization.py`` measures the three on a file of the node's ticks).
"""

from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Schema

from ..interface import BY_KEY, CONTRACT, Direction
from .errors import BagError, InvalidBag, NotABag
from .format import MCAP_MAGIC, MCAP_MESSAGE, MCAP_MESSAGE_FIELDS, MCAP_RECORD

#: The outputs the readers decode: relative name → the only type it may have.
OUTPUT_TOPICS = {key: name for key, name in CONTRACT.items()
                 if BY_KEY[key].direction is Direction.OUT}
RUN_PARAMETERS = 'run_parameters'
RESET = 'reset'
SETPOINT = 'setpoint'


def _relative(topic: str) -> str:
    return topic.rstrip('/').rsplit('/', 1)[-1]


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
            if isinstance(record, Schema):
                self._schema(record)
            else:
                self._channel(record)
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
                part = [data[a:a + n] for a, n in zip(starts[mine].tolist(), sizes.tolist(), strict=False)]
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


