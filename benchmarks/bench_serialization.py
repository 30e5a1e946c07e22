"""The hand-written bag code against the libraries the package depends on, on the node's
own message stream: prints one table, in one run, on this machine.

    . scripts/env.sh && python benchmarks/bench_serialization.py [BAG]

The stream is what table_sim records every tick (clock, joint_states, mesh_state,
transmission_error), its values taken from a recorded run (default: the checked-in
``steady_drive`` bag), tiled in time to ``TICKS`` ticks, and encoded the node's way
(:class:`screwgear_ros.bag.cdr.MessageBundle` of the templates :class:`RunIO` uses). Three
comparisons, each beside its anchor from the same run:

* serializer: ``MessageBundle.encode`` (one ``struct.pack`` a tick) against ``rosbags``'
  ``serialize_cdr`` of the same messages, built as ``rosbags`` message objects (what the
  node would have to do with it); the payloads are compared byte for byte;
* writer: :class:`screwgear_ros.bag.mcap_writer.McapWriter`, the way the recorder's
  writer thread drives it (``add_rows``, a batch of ticks at a time) and message by
  message (``add``), against ``mcap.writer.Writer`` (``add_message``), both zstd chunks of
  the recorder's ``CHUNK_SIZE``, to a file; the files' messages are compared;
* scanner: :func:`screwgear_ros.bag.mcap_scan.scan` (what ``read_run`` does first)
  against ``mcap``'s ``StreamReader`` (every record, in file order, as ``scan`` reads
  them) and ``make_reader(...).iter_messages()`` (through the summary's index), on the
  file the writer wrote.

Each figure is the best of ``REPEAT`` timings (a shared machine is noisy: compare the
ratios, run twice).
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from screwgear_ros.bag import cdr
from screwgear_ros.bag.format import (
    MCAP_PROFILE,
    MESSAGE_ENCODING,
    SCHEMA_ENCODING,
    message_definition,
    typestore,
)
from screwgear_ros.bag.mcap_scan import scan
from screwgear_ros.bag.mcap_writer import McapWriter
from screwgear_ros.bag.reader import read_run
from screwgear_ros.bag.recorder import BATCH_PERIOD, CHUNK_SIZE
from screwgear_ros.interface import CONTRACT
from screwgear_ros.ros.messages import MESH_NAMES

ROOT = Path(__file__).resolve().parents[1]
#: Ticks of the stream (the recorded run's, tiled in time).
TICKS = 20_000
#: Timings per figure; the best is shown.
REPEAT = 3
#: The per-tick topics, in RunIO's order.
KEYS = ('clock', 'joint_states', 'mesh_state', 'transmission_error')


def best(work: Callable[[], Any]) -> tuple[float, Any]:
    """(best wall time of REPEAT runs, s; the last result)."""
    times, result = [], None
    for _ in range(REPEAT):
        start = time.perf_counter()
        result = work()
        times.append(time.perf_counter() - start)
    return min(times), result


def stream(bag: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """(log times ns, joint rows (n, 9), mesh rows (n, 6), transmission errors (n,),
    joint names) of TICKS ticks: the recorded samples, tiled in time."""
    run = read_run(bag)
    n = min(len(run.joint_states), len(run.mesh_state), len(run.transmission_error))
    dt_ns = round(run.dt * 1e9)
    steps = run.joint_states.steps[:n]
    reps = -(-TICKS // n)
    span = int(steps[-1] - steps[0]) + 1
    times = np.concatenate([(steps - steps[0] + k * span) * dt_ns for k in range(reps)])
    tile = lambda a: np.concatenate([a[:n]] * reps)[:TICKS]
    return (times[:TICKS].astype(np.int64), tile(run.joint_states.values),
            tile(run.mesh_state.values), tile(run.transmission_error.values[:, 0]),
            list(run.parameters.settings.joint_names))


def encode_bundle(bundle: cdr.MessageBundle, t: np.ndarray, js: np.ndarray, mesh: np.ndarray,
                  te: np.ndarray) -> list[list[bytes]]:
    """The node's way: one MessageBundle.encode a tick, from the plant's float values."""
    out = []
    for k in range(len(t)):
        j, m = js[k].tolist(), mesh[k].tolist()
        out.append(bundle.encode(int(t[k]), j[0:3], j[3:6], j[6:9], m[0:2], m[2:4], m[4:6],
                                 (float(te[k]),)))
    return out


def encode_rosbags(store: Any, names: list[str], t: np.ndarray, js: np.ndarray,
                   mesh: np.ndarray, te: np.ndarray) -> list[list[bytes]]:
    """The same messages as rosbags message objects, serialized by rosbags."""
    T = store.types
    Time, Header = T['builtin_interfaces/msg/Time'], T['std_msgs/msg/Header']
    JointState, Float64, Clock = (T['sensor_msgs/msg/JointState'], T['std_msgs/msg/Float64'],
                                  T['rosgraph_msgs/msg/Clock'])
    ser = store.serialize_cdr
    mesh_names = list(MESH_NAMES)
    out = []
    for k in range(len(t)):
        sec, nanosec = divmod(int(t[k]), 1_000_000_000)
        stamp = Time(sec=sec, nanosec=nanosec)
        header = Header(stamp=stamp, frame_id='')
        j, m = js[k], mesh[k]
        out.append([
            bytes(ser(Clock(clock=stamp), 'rosgraph_msgs/msg/Clock')),
            bytes(ser(JointState(header=header, name=names, position=j[0:3].copy(),
                                 velocity=j[3:6].copy(), effort=j[6:9].copy()),
                      'sensor_msgs/msg/JointState')),
            bytes(ser(JointState(header=header, name=mesh_names, position=m[0:2].copy(),
                                 velocity=m[2:4].copy(), effort=m[4:6].copy()),
                      'sensor_msgs/msg/JointState')),
            bytes(ser(Float64(data=float(te[k])), 'std_msgs/msg/Float64'))])
    return out


def channels(register_schema: Callable[..., int], register_channel: Callable[..., int]
             ) -> list[int]:
    """The four per-tick channels, with the bag's schemas."""
    ids, schemas = [], {}
    for key in KEYS:
        msgtype = CONTRACT[key]
        if msgtype not in schemas:
            schemas[msgtype] = register_schema(msgtype, SCHEMA_ENCODING,
                                               message_definition(msgtype)[0].encode())
        ids.append(register_channel(f'/{key}', MESSAGE_ENCODING, schemas[msgtype], {}))
    return ids


def write_ours(path: Path, t: np.ndarray, ticks: list[list[bytes]], rows: bool) -> None:
    """McapWriter as the recorder drives it: add_rows per batch of ticks, or add."""
    path.unlink(missing_ok=True)
    with open(path, 'xb', buffering=0) as f:
        w = McapWriter(f, CHUNK_SIZE, True)
        w.start(profile=MCAP_PROFILE, library='bench')
        ids = channels(w.register_schema, w.register_channel)
        if rows:
            batch = max(1, round(BATCH_PERIOD / 50e-6))     # ticks of 50 µs a batch period
            sizes = [len(m) for m in ticks[0]]
            for first in range(0, len(ticks), batch):
                chunk = ticks[first:first + batch]
                w.add_rows(ids, [(first, 1)] * len(ids), t[first:first + batch].astype(np.uint64),
                           [b''.join(col) for col in zip(*chunk, strict=True)], sizes)
        else:
            for k, tick in enumerate(ticks):
                for channel, data in zip(ids, tick, strict=True):
                    w.add(channel, k, int(t[k]), data)
        w.finish()


def write_mcap(path: Path, t: np.ndarray, ticks: list[list[bytes]]) -> None:
    """mcap's Writer, the same chunks and compression."""
    path.unlink(missing_ok=True)
    with open(path, 'xb') as f:
        w = Writer(f, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        w.start(profile=MCAP_PROFILE, library='bench')
        ids = channels(lambda name, enc, data: w.register_schema(name, enc, data),
                       lambda topic, enc, sid, meta: w.register_channel(topic, enc, sid, meta))
        for k, tick in enumerate(ticks):
            for channel, data in zip(ids, tick, strict=True):
                w.add_message(channel, int(t[k]), data, int(t[k]), k)
        w.finish()


def messages_of(path: Path) -> list[tuple[int, int, bytes]]:
    """(channel, log time, data) of every message, in file order (mcap's reader)."""
    with open(path, 'rb') as f:
        return [(r.channel_id, r.log_time, r.data) for r in StreamReader(f).records
                if isinstance(r, Message)]


def stream_read(path: Path) -> int:
    with open(path, 'rb') as f:
        return sum(isinstance(r, Message) for r in StreamReader(f).records)


def indexed_read(path: Path) -> int:
    with open(path, 'rb') as f:
        return sum(1 for _ in make_reader(f).iter_messages())


def scan_read(path: Path) -> int:
    return scan(path, {}).count


def main() -> None:
    bag = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / 'test' / 'data' / 'steady_drive'
    t, js, mesh, te, names = stream(bag)
    print(f'stream: {len(t)} ticks x {len(KEYS)} messages from {bag.name}; '
          f'best of {REPEAT}')
    templates = {'clock': cdr.clock_template(), 'joint_states': cdr.joint_state_template(names),
                 'mesh_state': cdr.joint_state_template(MESH_NAMES),
                 'transmission_error': cdr.float64_template()}
    bundle = cdr.MessageBundle([templates[key] for key in KEYS])
    store = typestore()
    ours_s, ours = best(lambda: encode_bundle(bundle, t, js, mesh, te))
    lib_s, lib = best(lambda: encode_rosbags(store, names, t, js, mesh, te))
    same = ours == lib
    per = 1e6 / len(t)
    print(f'\nserializer (us a tick)       hand-written {ours_s * per:8.2f}   '
          f'rosbags {lib_s * per:8.2f}   ratio {lib_s / ours_s:6.1f}x   '
          f'payloads identical: {same}')

    with tempfile.TemporaryDirectory() as tmp:
        a, b, c = Path(tmp) / 'rows.mcap', Path(tmp) / 'add.mcap', Path(tmp) / 'lib.mcap'
        rows_s, _ = best(lambda: write_ours(a, t, ours, rows=True))
        add_s, _ = best(lambda: write_ours(b, t, ours, rows=False))
        mcap_s, _ = best(lambda: write_mcap(c, t, ours))
        equal = messages_of(a) == messages_of(b) == messages_of(c)
        print(f'writer (us a tick)           hand-written add_rows {rows_s * per:8.2f}   '
              f'add {add_s * per:8.2f}   mcap Writer {mcap_s * per:8.2f}   '
              f'ratio {mcap_s / rows_s:6.1f}x (add_rows), {mcap_s / add_s:6.1f}x (add)   '
              f'messages identical: {equal}')
        sizes = ', '.join(f'{p.name} {p.stat().st_size} B' for p in (a, b, c))
        print(f'                             files: {sizes}')

        scan_s, n_scan = best(lambda: scan_read(a))
        stream_s, n_stream = best(lambda: stream_read(a))
        index_s, n_index = best(lambda: indexed_read(a))
        print(f'scanner (us a tick)          hand-written scan {scan_s * per:8.2f}   '
              f'mcap StreamReader {stream_s * per:8.2f}   iter_messages {index_s * per:8.2f}   '
              f'ratio {stream_s / scan_s:6.1f}x (stream), {index_s / scan_s:6.1f}x (indexed)   '
              f'messages {n_scan}/{n_stream}/{n_index}')


if __name__ == '__main__':
    main()
