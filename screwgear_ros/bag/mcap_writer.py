"""The MCAP container of a recording, written record by record (no ``mcap.writer``).

:class:`McapWriter` lays out what the MCAP specification describes: the magic, a
Header, the schemas and channels, then messages in compressed chunks, each followed by
its message indexes; at the end the summary (schemas, channels, statistics, chunk and
metadata indexes, summary offsets) and the footer. It knows nothing of queues, threads
or ROS: :class:`~screwgear_ros.bag.recorder.RunRecorder` drives it from its writer
thread.

A write that fails (a full disk: ``OSError`` ENOSPC) leaves the file as it was after
the last record group written whole: the writer truncates it back there, drops the open
chunk (:attr:`McapWriter.discarded` counts its messages) and re-raises. Only whole
chunks, with their message indexes, count as written (:attr:`McapWriter.written`,
:meth:`McapWriter.counts`), so the counts are what a reader finds. :meth:`finish` can
then still close the file with a summary of what it holds, if the disk has room for it.

Why not ``mcap.writer.Writer``: the recorder's writer thread takes the interpreter lock
from the pacing thread for as long as it writes, and ``Writer.add_message`` costs several
times :meth:`McapWriter.add_rows` (and :meth:`McapWriter.add`) per message; nor does it
cut a file back to its last whole chunk when a write fails
(``benchmarks/bench_serialization.py`` measures both on the node's tick stream and
compares the messages of the files they write).
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from .format import MCAP_MAGIC, MCAP_MESSAGE, MCAP_MESSAGE_FIELDS

_MESSAGE_INDEX = struct.Struct('<BQHI')     # opcode, length, channel id, bytes of entries
_MESSAGE_OPCODE = int(Opcode.MESSAGE)       # per message: a plain int packs faster
_pack_message = MCAP_MESSAGE.pack
#: A Message record's fixed fields (MCAP_MESSAGE, in its order) as NumPy columns, for
#: :meth:`McapWriter.add_rows`.
_MESSAGE_COLUMNS = tuple(zip(('opcode', 'length', 'channel', 'sequence', 'log_time',
                              'publish_time'),
                             [{'B': 'u1', 'H': '<u2', 'I': '<u4', 'Q': '<u8'}[code]
                              for code in MCAP_MESSAGE.format[1:]], strict=False))
assert np.dtype(list(_MESSAGE_COLUMNS)).itemsize == MCAP_MESSAGE.size
_FOOTER_START = struct.Struct('<BQQQ')      # opcode, length, summary start, offsets start


class McapWriter:
    """The MCAP file of a recording: a Header, the schemas and channels, then messages
    in compressed chunks, each followed by its message indexes; at the end the summary
    (schemas, channels, statistics, chunk and metadata indexes, summary offsets) and the
    footer, as the MCAP specification lays them out.

    Why not ``mcap.writer.Writer``: it builds a record object and makes about twenty
    Python calls per message, and the writer thread holds the interpreter lock for all
    of them, which the node's pacing thread then waits for. Here a message is one
    ``struct`` pack appended to the open chunk and two index entries; the rare records
    are the ``mcap`` library's own record classes.
    """

    def __init__(self, stream: Any, chunk_size: int, compression: bool) -> None:
        # ``stream``: a raw binary file (``open(path, 'xb', buffering=0)``), so that
        # every record group reaches the operating system whole, or fails with the
        # number of bytes before the failure known (no buffer of unknown state).
        self._stream = stream
        self._pos = 0            # bytes in the file
        self._good = 0           # bytes in the file after the last record group written whole
        self.added = 0           # messages added (in written chunks, the open one, discarded)
        self.written = 0         # messages in chunks written whole
        self.discarded = 0       # messages in open chunks dropped by a failed write
        self._chunk_size = chunk_size
        self._compress = zstandard.ZstdCompressor().compress if compression else None
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk = bytearray()
        self._index: dict[int, list[int]] = {}     # channel id → log time, offset, ...
        self._chunk_start = self._chunk_end = 0    # log times of the open chunk
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}          # channel id → messages in written chunks
        self._row_layouts: dict[tuple[int, ...], np.dtype] = {}   # add_rows's, by data sizes

    def _write(self, data: bytes | bytearray | memoryview) -> None:
        """Append ``data`` whole to the file, or, if a write fails, truncate the file
        back to the end of the last group written whole, drop the open chunk and
        re-raise."""
        view = memoryview(data)
        done, size = 0, len(view)
        try:
            while done < size:
                done += self._stream.write(view[done:]) or 0
        except BaseException:
            self._pos += done
            self._rewind()
            raise
        self._pos += size

    def _rewind(self) -> None:
        """Back to the end of the last group written whole, without the open chunk."""
        self.discarded += sum(len(entries) for entries in self._index.values()) // 2
        for entries in self._index.values():
            entries.clear()
        self._chunk.clear()
        self._stream.truncate(self._good)
        self._stream.seek(self._good)
        self._pos = self._good

    def _record(self, record: McapRecord) -> tuple[int, int]:
        """Write a record to the file, whole; its offset and length."""
        builder = RecordBuilder()
        record.write(builder)
        data = builder.end()
        offset = self._pos
        self._write(data)
        self._good = self._pos
        return offset, len(data)

    def counts(self) -> dict[int, int]:
        """Channel id → messages in chunks written whole."""
        return dict(self._counts)

    def start(self, profile: str, library: str) -> None:
        self._write(MCAP_MAGIC)
        self._good = self._pos
        self._record(Header(profile=profile, library=library))

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._finish_chunk()
        offset, length = self._record(Metadata(name=name, metadata=data))
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=length, name=name))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._record(schema)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str]) -> int:
        channel = Channel(id=len(self._channels) + 1, topic=topic,
                          message_encoding=message_encoding, schema_id=schema_id,
                          metadata=metadata)
        self._channels.append(channel)
        self._counts[channel.id] = 0
        self._index[channel.id] = []
        self._record(channel)
        return channel.id

    def _spans(self, first: int, last: int) -> None:
        """The open chunk takes messages with log times from ``first`` to ``last``
        (before they are appended to it)."""
        if not self._chunk:
            self._chunk_start, self._chunk_end = first, last
            return
        self._chunk_start = min(self._chunk_start, first)
        self._chunk_end = max(self._chunk_end, last)

    def add(self, channel_id: int, sequence: int, log_time: int, data: bytes) -> None:
        """One message (publish time = log time) into the open chunk; its ``sequence``
        modulo 2³² (MCAP's field is a uint32)."""
        self._spans(log_time, log_time)
        chunk = self._chunk
        offset = len(chunk)
        chunk += _pack_message(_MESSAGE_OPCODE, MCAP_MESSAGE_FIELDS + len(data), channel_id,
                               sequence % 2**32, log_time, log_time)
        chunk += data
        self._index[channel_id] += (log_time, offset)
        self.added += 1
        if len(chunk) >= self._chunk_size:
            self._finish_chunk()

    def add_rows(self, channel_ids: Sequence[int], sequences: Sequence[tuple[int, int]],
                log_times: np.ndarray, columns: Sequence[bytes], sizes: Sequence[int]) -> None:
        """Rows of messages, row i at ``log_times[i]``: in each row one message on each of
        ``channel_ids`` in this order (what a series of ticks records), column k's data
        ``sizes[k]`` bytes each, joined in ``columns[k]``, its sequence numbers
        ``first + i·stride`` for ``sequences[k] = (first, stride)`` (mod 2³²: MCAP's field
        is a uint32). The same records in the same order as one :meth:`add` per message,
        built as NumPy columns instead, which costs the writer thread a fraction of a
        call per message (benchmarks/bench_recording.py). Rows go into the open chunk
        until it holds ``chunk_size`` bytes, as with add()."""
        layout = self._row_layouts.get(tuple(sizes))
        if layout is None:
            layout = self._row_layouts[tuple(sizes)] = np.dtype(
                [(f'{name}{k}', kind) for k, size in enumerate(sizes)
                 for name, kind in (*_MESSAGE_COLUMNS, ('data', f'V{size}'))])
        starts = np.cumsum([0] + [MCAP_MESSAGE.size + size for size in sizes])
        n, row = len(log_times), layout.itemsize
        done = 0
        while done < n:
            room = self._chunk_size - len(self._chunk)
            take = min(n - done, max(1, -(-room // row)))    # the chunk ends full, or the rows end
            t = log_times[done:done + take]
            rows = np.empty(take, layout)
            for k, (channel_id, (first, stride), size) in enumerate(
                    zip(channel_ids, sequences, sizes, strict=False)):
                rows[f'opcode{k}'] = _MESSAGE_OPCODE
                rows[f'length{k}'] = MCAP_MESSAGE_FIELDS + size
                rows[f'channel{k}'] = channel_id
                rows[f'sequence{k}'] = (first + stride * np.arange(done, done + take)) % 2**32
                rows[f'log_time{k}'] = rows[f'publish_time{k}'] = t
                rows[f'data{k}'] = np.frombuffer(columns[k], f'V{size}', take, done * size)
            self._spans(int(t.min()), int(t.max()))
            offset = len(self._chunk)
            self._chunk += rows.tobytes()
            self.added += take * len(channel_ids)
            at = offset + row * np.arange(take, dtype=np.uint64)
            for k, channel_id in enumerate(channel_ids):    # (log time, offset) pairs
                pairs = np.column_stack((t, at + int(starts[k])))
                self._index[channel_id] += pairs.ravel().tolist()
            if len(self._chunk) >= self._chunk_size:
                self._finish_chunk()
            done += take

    def _finish_chunk(self) -> None:
        """Write the open chunk and its message indexes, as one group (nothing if the
        chunk is empty)."""
        if not self._chunk:
            return
        records = bytes(self._chunk)
        data = self._compress(records) if self._compress is not None else records
        chunk = Chunk(compression='zstd' if self._compress is not None else '', data=data,
                      message_start_time=self._chunk_start,
                      message_end_time=self._chunk_end,
                      uncompressed_crc=zlib.crc32(records), uncompressed_size=len(records))
        builder = RecordBuilder()
        chunk.write(builder)
        group = bytearray(builder.end())
        chunk_offset, chunk_length = self._pos, len(group)
        offsets: dict[int, int] = {}
        counts: dict[int, int] = {}
        for channel_id, entries in self._index.items():
            if entries:
                offsets[channel_id] = chunk_offset + len(group)
                n = len(entries)
                group += _MESSAGE_INDEX.pack(Opcode.MESSAGE_INDEX, 6 + 8 * n, channel_id, 8 * n)
                group += struct.pack(f'<{n}Q', *entries)
                counts[channel_id] = n // 2
        self._write(group)                # on failure: rewound, nothing below happens
        self._good = self._pos
        for channel_id, n in counts.items():
            self._counts[channel_id] += n
            self._index[channel_id].clear()
        self.written += sum(counts.values())
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=self._chunk_start, message_end_time=self._chunk_end,
            chunk_start_offset=chunk_offset, chunk_length=chunk_length,
            message_index_offsets=offsets, message_index_length=len(group) - chunk_length,
            compression=chunk.compression, compressed_size=len(data),
            uncompressed_size=len(records)))
        self._chunk.clear()

    def time_range(self) -> tuple[int, int]:
        """First and last log time of the messages added so far, written or in the open
        chunk; (0, 0) before any."""
        chunks = [(c.message_start_time, c.message_end_time) for c in self._chunk_indexes]
        if self._chunk:
            chunks.append((self._chunk_start, self._chunk_end))
        if not chunks:
            return 0, 0
        return min(start for start, _ in chunks), max(end for _, end in chunks)

    def flush(self) -> None:
        """Write the open chunk (the stream is unbuffered: it is then with the
        operating system)."""
        self._finish_chunk()
        self._stream.flush()

    def summary_bound(self) -> int:
        """Bytes that :meth:`finish` writes at most after the open chunk, as the file
        stands: what a recording keeps in reserve for the end of its file."""
        fixed = sum(len(s.data) + len(s.name) + 64 for s in self._schemas) + sum(
            len(c.topic) + sum(len(k) + len(v) + 8 for k, v in c.metadata.items()) + 64
            for c in self._channels)
        per_chunk = 96 + 10 * len(self._channels)
        return 2 * fixed + per_chunk * (len(self._chunk_indexes) + 1) + 64 * (
            len(self._metadata_indexes) + 1) + 1024

    def finish(self) -> None:
        """The last chunk, the data section's end, the summary and the footer (the
        end of the file after the last chunk as one group: written whole, or not at
        all)."""
        self._finish_chunk()
        builder = RecordBuilder()
        DataEnd(data_section_crc=0).write(builder)
        summary_start = self._pos + builder.count
        head = builder.end()
        builder = RecordBuilder()
        offsets: list[SummaryOffset] = []

        def group(opcode: Opcode, records: Sequence[McapRecord]) -> None:
            start = builder.count
            for record in records:
                record.write(builder)
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + start,
                                         group_length=builder.count - start))

        group(Opcode.SCHEMA, self._schemas)
        group(Opcode.CHANNEL, self._channels)
        start, end = self.time_range()
        group(Opcode.STATISTICS, [Statistics(
            message_count=sum(self._counts.values()), schema_count=len(self._schemas),
            channel_count=len(self._channels), attachment_count=0,
            metadata_count=len(self._metadata_indexes), chunk_count=len(self._chunk_indexes),
            message_start_time=start, message_end_time=end,
            channel_message_counts=dict(self._counts))])
        group(Opcode.CHUNK_INDEX, self._chunk_indexes)
        group(Opcode.METADATA_INDEX, self._metadata_indexes)
        offsets_start = summary_start + builder.count
        for offset in offsets:
            offset.write(builder)
        summary = builder.end()
        crc = zlib.crc32(_FOOTER_START.pack(Opcode.FOOTER, 20, summary_start, offsets_start),
                         zlib.crc32(summary))
        builder = RecordBuilder()
        Footer(summary_start=summary_start, summary_offset_start=offsets_start,
               summary_crc=crc).write(builder)
        self._write(b''.join((head, summary, builder.end(), MCAP_MAGIC)))
        self._good = self._pos


__all__ = ['McapWriter']
