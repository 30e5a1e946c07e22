"""Record a run as a rosbag2 directory with MCAP storage, off the real-time path.

:class:`RunRecorder` takes messages from the node's pacing thread through a bounded
queue and writes them on its own writer thread (serializing those that are not CDR
bytes yet), so a slow disk never stalls the integrator: when the queue is full a message
is dropped and counted, never waited for. Except by a producer that has no deadline and
says so (``write_group(..., lossless=True)``: the node flat out, in-process runs): once the
queue is half full it waits, up to ``ROOM_TIMEOUT`` at a time, while the writer,
hurried, empties it, so a run as fast as possible records everything: without waiting,
the node flat out produces ticks faster than the writer can take them while it meets
the pacing thread for the interpreter lock at every chunk it compresses and writes, and
most messages would be dropped.

What recording costs the node is mostly how often the two threads meet, not the MCAP
writing: a queue put that wakes the writer, and the writer taking the interpreter
lock from the pacing thread. So :meth:`RunRecorder.write_group` queues a tick's
messages with one put, on a :class:`TopicGroup` checked once when the run starts (no
per-tick topic lookups on either thread), and the writer thread, once it has woken,
writes everything queued and then sleeps ``batch_period`` (10 ms) before it looks
again: it runs at most about 100 times a second whatever the message rate
(``benchmarks/bench_recording.py --speed`` measures it).

The bag is what ``ros2 bag record -s mcap`` on ROS 2 Jazzy writes: a directory with
``metadata.yaml`` and one ``<name>_0.mcap`` (profile ``ros2``, ``ros2msg`` schemas
with the Jazzy definitions, CDR messages, QoS profiles on every channel). Log time
(and publish time) of every message is the simulation time of the step it
describes, in ns.

What survives a crash: ``metadata.yaml`` is written when the bag opens (topics, no
counts) and rewritten when it closes, so even a killed run is a rosbag2 directory.
The MCAP file is flushed to the operating system whenever a chunk is complete
(``chunk_size`` bytes of messages) and at least every ``flush_period`` seconds of
wall time; after ``kill -9`` every flushed chunk reads back, and at most the last
unflushed chunk plus the messages still queued are lost. :meth:`RunRecorder.close`
(Ctrl-C, SIGTERM, normal exit, or interpreter exit as a last resort) drains the
queue and writes the summary, the index and the final ``metadata.yaml``.

What survives a write that fails (a full disk): the first such error stops the
recording at once. The MCAP file is cut back to its last whole chunk (the open chunk
and whatever is still queued are dropped and counted), then closed with its summary
and index, and ``metadata.yaml`` is rewritten with the counts of what the file holds:
the bag reads back, up to the fault, with any reader. The room for those last records
is held from the start in ``RESERVE_NAME``, a file beside the bag that grows with the
recording's index and is deleted at the end, so a full disk still has it. The
recorder's ``on_error`` callback then gets one line saying what failed and what the
bag keeps; :attr:`RunRecorder.error` keeps the error.
"""

from __future__ import annotations

import atexit
import os
import queue
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .bag_files import RESERVE_NAME, BagFiles, TopicGroup, TopicSpec, create_file
from .mcap_writer import McapWriter

#: Default bound of the queue between the node and the writer thread, messages.
QUEUE_SIZE = 200_000
#: Default MCAP chunk size, bytes of uncompressed messages: the most a kill -9 loses.
CHUNK_SIZE = 256 * 1024
#: Default longest wall time between flushes to the operating system, s.
FLUSH_PERIOD = 1.0
#: Default wall time the writer thread sleeps after writing what was queued, s.
BATCH_PERIOD = 0.01
#: Longest a producer that waits for room (write_group's ``lossless``) waits at a time, s;
#: then it goes on, and a full queue drops as it always does.
ROOM_TIMEOUT = 1.0

_STOP = object()


class RunRecorder:
    """Writes one run to a new rosbag2/MCAP directory on a background thread.

    A message handed over as ``bytes`` is its CDR and is written as it is (the node's
    outputs and markers, serialized once); any other goes through ``serialize(msg) ->
    bytes`` (the node passes :func:`screwgear_ros.runs.run_io.serialize`) on the writer
    thread, so a message handed to :meth:`write` or :meth:`write_group` belongs to the
    recorder from then on and must not be modified afterwards.

    The queue holds one ``(TopicGroup, log time, messages)`` per :meth:`write` (a group
    of its one topic) or :meth:`write_group`; its bound ``queue_size`` counts messages
    accepted and not yet written.
    """

    def __init__(self, path: str | os.PathLike[str], topics: Sequence[TopicSpec],
                 serialize: Callable[[Any], bytes], *, queue_size: int = QUEUE_SIZE,
                 chunk_size: int = CHUNK_SIZE, flush_period: float = FLUSH_PERIOD,
                 batch_period: float = BATCH_PERIOD, compression: bool = True,
                 on_error: Callable[[str], None] | None = None,
                 open_file: Callable[[Path], Any] = create_file) -> None:
        """``on_error``: called once, on the writer thread, with a line saying what
        failed and what the bag keeps, after the bag was closed at a write error.
        ``open_file``: how the bag's MCAP file and its reserve are created (a new
        unbuffered binary file by default)."""
        self.path = Path(path)
        if self.path.exists() and (not self.path.is_dir() or any(self.path.iterdir())):
            raise FileExistsError(f'{self.path} exists and is not an empty directory; '
                                  'a recording never overwrites')
        names = [t.name for t in topics]
        if len(set(names)) != len(names):
            raise ValueError(f'duplicate topic names in {names}')
        self._serialize = serialize
        self._queue_size = int(queue_size)
        self._flush_period = float(flush_period)
        self._batch_period = float(batch_period)
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._drop_lock = threading.Lock()
        self._dropped = 0
        # Messages queued = accepted − handled; each counter has one writing side
        # (accepted: write()/write_group() under _close_lock; handled: the writer thread).
        self._accepted = 0
        self._handled = 0
        self._error: str | None = None
        self._on_error = on_error
        self._closed = False              # set once, under _close_lock: no more messages
        self._close_called = False        # close() ran (the writer may close on its own)
        self._close_lock = threading.Lock()   # orders write()'s check-and-put against close()
        self._abandon = False
        # A producer waiting for room (write_group(lossless=True)) sets _hurry, so that the
        # writer skips its batch_period sleep, and waits on _progress, which the writer
        # notifies after each batch it handled.
        self._hurry = threading.Event()
        self._progress = threading.Condition()

        self._counts = [0] * len(topics)     # added per topic = its next sequence number
        made = not self.path.exists()
        self._bag = BagFiles(self.path, topics)
        self.path.mkdir(parents=True, exist_ok=True)
        try:
            self._mcap: McapWriter = self._bag.open(open_file, int(chunk_size), compression)
            self._alone = self._bag.alone
        except BaseException:
            # Nothing is recorded before the writer thread runs, so a start cut short
            # (Ctrl-C, a disk with no room) leaves no half-written bag behind.
            self._bag.discard(made)
            raise
        self._thread = threading.Thread(target=self._run, name='run_recorder', daemon=True)
        self._thread.start()
        atexit.register(self.close)

    # ------------------------------------------------------------------ node side

    @property
    def dropped(self) -> int:
        """Messages not recorded: queue full, written after close, or failed to write."""
        return self._dropped + self._mcap.discarded

    @property
    def written(self) -> int:
        """Messages in the MCAP file so far (whole chunks: what a reader finds)."""
        return self._mcap.written

    @property
    def closed(self) -> bool:
        """close() has run (the bag is final)."""
        return self._close_called

    @property
    def error(self) -> str | None:
        """The first write error of the writer thread (e.g. disk full), if any."""
        return self._error

    def write(self, topic: str, sim_time_ns: int, msg: Any) -> None:
        """Queue ``msg`` on ``topic`` at log time ``sim_time_ns``; never blocks.

        Thread-safe. A full queue or a closed recorder drops the message and counts
        it in :attr:`dropped`. An unknown topic is a programming error (ValueError).
        """
        group = self._alone.get(topic)
        if group is None:
            self._undeclared(topic)
        self._put((group, sim_time_ns, (msg,)), 1)

    def group(self, topics: Sequence[str]) -> TopicGroup:
        """The group of these declared topics, in this order (a topic may come more than
        once), for :meth:`write_group`; ValueError for a topic not declared."""
        for topic in topics:
            if topic not in self._alone:
                self._undeclared(topic)
        alone = [self._alone[topic] for topic in topics]
        return TopicGroup(tuple(topics), tuple(g.indexes[0] for g in alone),
                          tuple(g.channel_ids[0] for g in alone))

    def write_group(self, group: TopicGroup, sim_time_ns: int, messages: Sequence[Any],
                    lossless: bool = False) -> None:
        """Queue one message on each of ``group``'s topics, in its order, at log time
        ``sim_time_ns``, with one put; never blocks, unless ``lossless``.

        What a tick records at once (the node's outputs of one step): one queue
        operation instead of one per message, and no topic to look up. Thread-safe. If
        the queue cannot take them all, all are dropped and counted (a tick is recorded
        whole or not at all). ``lossless`` (a producer with no deadline: the node flat out):
        when the queue is half full, first wait until the writer has made room, at most
        ``ROOM_TIMEOUT`` s.
        """
        n = len(messages)
        if n != len(group.topics):
            raise ValueError(f'{n} messages for the {len(group.topics)} topics '
                             f'of {group.topics}')
        if lossless and not self._closed and \
                2 * (self._accepted - self._handled + n) > self._queue_size:
            self._wait_for_room(n)
        self._put((group, sim_time_ns, messages), n)

    def _wait_for_room(self, n: int) -> None:
        """Hurry the writer and wait until the queue, with ``n`` more, is at most half
        full (or the recorder closed), at most ``ROOM_TIMEOUT`` s."""
        with self._progress:
            self._hurry.set()
            self._progress.wait_for(
                lambda: 2 * (self._accepted - self._handled + n) <= self._queue_size
                or self._closed, ROOM_TIMEOUT)

    def _undeclared(self, topic: str) -> NoReturn:
        raise ValueError(f'topic {topic!r} was not declared to the recorder '
                         f'(declared: {", ".join(self._alone)})')

    def _put(self, item: tuple[TopicGroup, int, Sequence[Any]], n: int) -> None:
        """Queue ``item`` (its group, log time and ``n`` messages) or drop it whole."""
        with self._close_lock:    # so that no message slips in behind close()'s stop mark
            if not self._closed and self._accepted - self._handled + n <= self._queue_size:
                self._accepted += n
                self._queue.put(item)
                return
        self._count_drop(n)

    def close(self, timeout: float = 5.0) -> None:
        """Drain the queue and finalize the bag (summary, index, metadata.yaml).

        Idempotent. If draining takes longer than ``timeout`` seconds the rest of
        the queue is dropped (counted) so that the bag is still finalized.
        """
        with self._close_lock:
            if self._close_called:
                return
            self._close_called = self._closed = True
            self._queue.put(_STOP)   # after every message write() accepted
        with self._progress:         # a producer waiting for room: closed, stop waiting
            self._progress.notify_all()
        atexit.unregister(self.close)
        self._thread.join(timeout)
        if self._thread.is_alive():
            self._abandon = True
            self._thread.join()

    # ------------------------------------------------------------------ writer thread

    def _count_drop(self, n: int) -> None:
        with self._drop_lock:
            self._dropped += n

    def _run(self) -> None:
        get, get_nowait, empty = self._queue.get, self._queue.get_nowait, queue.Empty
        next_flush = 0.0          # the first message is flushed at once
        dirty = stop = False
        while not stop:
            # Wait for the first batch, then take everything queued behind it.
            batches: list[Any] = []
            try:
                batches.append(get(timeout=self._flush_period))
                while True:
                    batches.append(get_nowait())
            except empty:
                pass
            if batches and batches[-1] is _STOP:   # close() puts it last: nothing follows
                stop = True
                batches.pop()
            if batches:
                self._write_items(batches)
                dirty = True
                with self._progress:
                    self._progress.notify_all()
            now = time.monotonic()
            if dirty and now >= next_flush and self._error is None:
                try:
                    self._mcap.flush()
                    self._bag.hold_room()
                except Exception as exc:  # noqa: BLE001 - reported through .error
                    self._fail(exc)
                dirty = False
                next_flush = now + self._flush_period
            if self._error is not None:    # stop at the first error: close the bag now
                with self._close_lock:
                    self._closed = True
                with self._progress:
                    self._progress.notify_all()
                stop = True
            if batches and not stop:
                self._hurry.wait(self._batch_period)   # let the next batches gather
                self._hurry.clear()
        self._finish()

    def _write_items(self, items: list[tuple[TopicGroup, int, Sequence[Any]]]) -> None:
        """Write queued items in order: consecutive items on one group whose messages are
        bytes of unchanging sizes (the node's ticks, one after the other) in one go
        (:meth:`_write_rows`), anything else item by item."""
        i, n = 0, len(items)
        while i < n:
            group = items[i][0]
            j = i + 1
            while j < n and items[j][0] is group:
                j += 1
            if j - i < 2 or not self._write_rows(group, items[i:j]):
                for item in items[i:j]:
                    self._write_item(*item)
            i = j

    def _write_rows(self, group: TopicGroup, rows: list[tuple[TopicGroup, int, Sequence[Any]]]
                    ) -> bool:
        """The items of ``rows`` (all on ``group``) with :meth:`McapWriter.add_rows`; False
        (nothing written) unless every message is bytes and each topic's are one size,
        or after an error (the item-by-item path counts the drops)."""
        if self._abandon or self._error is not None:
            return False
        columns = list(zip(*(messages for _, _, messages in rows), strict=False))
        sizes = []
        for column in columns:
            if set(map(type, column)) != {bytes}:
                return False
            size = set(map(len, column))
            if len(size) != 1 or 0 in size:
                return False
            sizes.append(size.pop())
        counts, indexes, mcap = self._counts, group.indexes, self._mcap
        # A topic that comes m times in the group: its r-th place gets first + r, then +m.
        sequences = [(counts[index] + indexes[:k].count(index), indexes.count(index))
                     for k, index in enumerate(indexes)]
        n = len(rows) * len(indexes)
        added = mcap.added
        try:
            mcap.add_rows(group.channel_ids, sequences,
                          np.array([t for _, t, _ in rows], dtype=np.uint64),
                          [b''.join(column) for column in columns], sizes)
        except Exception as exc:  # noqa: BLE001 - reported through .error
            self._fail(exc)
            self._count_drop(n - (mcap.added - added))   # the writer counts what it dropped
        else:
            for index in indexes:
                counts[index] += len(rows)
        self._handled += n
        return True

    def _write_item(self, group: TopicGroup, log_time: int, messages: Sequence[Any]) -> None:
        """Write one queued item's messages in order (or count them dropped after an
        error or when close() gave up waiting)."""
        counts, serialize, mcap = self._counts, self._serialize, self._mcap
        log_time = int(log_time)
        added = mcap.added
        if not self._abandon and self._error is None:
            for index, channel_id, msg in zip(group.indexes, group.channel_ids, messages, strict=False):
                try:
                    mcap.add(channel_id, counts[index], log_time,      # counts: the sequence
                             msg if msg.__class__ is bytes else serialize(msg))
                except Exception as exc:  # noqa: BLE001 - reported through .error
                    self._fail(exc)       # the rest of the item is dropped below
                    break
                counts[index] += 1
        added = mcap.added - added        # a failed write's chunk: the writer counts it
        if added < len(messages):
            self._count_drop(len(messages) - added)
        self._handled += len(messages)

    def _fail(self, exc: BaseException) -> None:
        if self._error is None:
            self._error = f'{type(exc).__name__}: {exc}'

    def _finish(self) -> None:
        """Count what is left, write summary and index, close, rewrite metadata.yaml;
        after an error, say once what the bag keeps."""
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not _STOP:
                self._count_drop(len(item[2]))
                self._handled += len(item[2])
        unfinished = self._bag.finish(self._fail)
        with self._progress:
            self._progress.notify_all()
        if self._error is not None and self._on_error is not None:
            start, end = self._mcap.time_range()
            self._on_error(
                f'recording failed: {self._error}. Recording stopped; {self.path} keeps the '
                f'{self.written} messages written before the fault'
                + (f' (log times {start * 1e-9:.3f} to {end * 1e-9:.3f} s)' if self.written
                   else '')
                + f'; {self.dropped} dropped' + (unfinished or '; the bag is closed and '
                                                 'reads back up to the fault'))


__all__ = [
    'BATCH_PERIOD',
    'CHUNK_SIZE',
    'FLUSH_PERIOD',
    'QUEUE_SIZE',
    'RESERVE_NAME',
    'ROOM_TIMEOUT',
    'RunRecorder',
    'TopicGroup',
    'TopicSpec',
]
