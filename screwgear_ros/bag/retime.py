"""Simulation steps for a bag whose log times are a recorder's arrival times.

table_sim's own recorder logs every message at the simulation time of its step
(docs/recording.md, the bag contract), and so do ``ros2 bag convert`` and ``reindex`` of
such a bag. ``ros2 bag record`` logs the wall time each message arrived instead. Such a
bag is recognized by its stamped outputs (``mesh_state``, ``joint_states``), whose header
stamp is the simulation time of their tick and differs from their log time, and
:func:`retime` then gives every kept message the simulation time it belongs to, in place
of its log time:

* ``joint_states``, ``~/true_joint_states``, ``mesh_state`` and ``/clock``: their stamp.
  A lockstep node re-sends the last ``joint_states`` while it waits for an answer: a
  repeat of a stamp already read is dropped.
* ``transmission_error`` (no stamp): one per tick like ``mesh_state``, never re-sent, so
  the k-th from the end is the tick of the k-th ``mesh_state`` from the end (a recorder
  that subscribed to it a little later than to ``mesh_state`` misses only the first).
* the lockstep answers (``cmd_effort``, ``joint_commands``): when there is one for each
  tick that ran on one, the n-th sent answered the n-th tick (:func:`_answer_ticks`):
  the order in which a recorder takes messages of different topics is not the order
  they were sent in, but each topic's own order is kept;
* everything else (other inputs, setpoint, run_parameters, reset, active_path): the time of
  the last stamped output that arrived before it. In lockstep that is the step it took
  effect at: the controller's answer to tick k's outputs is applied at the first step of
  tick k+1, which is the step of tick k's outputs; the node publishes a tick's
  run_parameters, reset and active_path before that tick's outputs. A message that
  arrived before any output (the latched run_parameters and active_path a recorder gets
  when it subscribes) belongs to the first.

The messages are then ordered as table_sim writes them: by step, a step's outputs before
the events applied at it (:func:`_reorder`). A wrong guess cannot pass: ``check_run``
replays the inputs where they were put, and a misplaced one makes other outputs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..interface import ANSWER_TOPICS
from .errors import InvalidBag
from .mcap_scan import _relative

#: Stamped outputs: the header's (or the clock's) time is at the same place in each.
STAMPED = ('joint_states', 'true_joint_states', 'mesh_state', 'clock')
_DEDUPED = ('joint_states', 'true_joint_states')
#: Per-tick outputs without a stamp, and the stamped per-tick topic they follow.
PER_TICK = {'transmission_error': 'mesh_state'}


def _rows(part: np.ndarray | list[bytes]) -> list[bytes]:
    return [r.tobytes() for r in part] if isinstance(part, np.ndarray) else list(part)


def _stamp(raw: bytes) -> int:
    """The time in the first 8 bytes after the CDR header (header.stamp, clock), ns."""
    if len(raw) < 12 or raw[1] not in (0, 1):
        raise ValueError('not CDR with a stamp')
    order = '<' if raw[1] == 1 else '>'
    sec = int(np.frombuffer(raw[4:8], dtype=f'{order}i4')[0])
    nanosec = int(np.frombuffer(raw[8:12], dtype=f'{order}u4')[0])
    return sec * 1_000_000_000 + nanosec


def _by_topic(found: Any) -> dict[str, list[int]]:
    """Relative topic name → the kept channels of it."""
    topics: dict[str, list[int]] = {}
    for channel in found.kept:
        topics.setdefault(_relative(found.channels[channel][0]), []).append(channel)
    return topics


def arrival_times(found: Any) -> bool:
    """Whether the bag's log times are arrival times: its first ``mesh_state`` (else
    ``joint_states``) is logged at another time than its stamp."""
    topics = _by_topic(found)
    for rel in ('mesh_state', 'joint_states'):
        for channel in topics.get(rel, []):
            kept = found.kept[channel]
            if kept.parts:
                try:
                    stamp = _stamp(_rows(kept.parts[0][:1])[0])
                except ValueError:
                    return False       # the decoder says what is wrong with it
                return stamp != int(kept.log_time[0][0])
    return False


def retime(found: Any, path: object) -> None:
    """Replace the log times of ``found``'s kept messages by their simulation times
    (the module docstring) and their order by the one table_sim writes, in place."""
    topics = _by_topic(found)
    ticks: list[tuple[np.ndarray, np.ndarray]] = []     # (orders, times) of stamped ones
    for rel in STAMPED:
        for channel in topics.get(rel, []):
            _stamps(found, channel, rel, path)
            if rel != 'clock':
                kept = found.kept[channel]
                ticks += zip(kept.order, kept.log_time, strict=True)
    if not ticks:
        return
    order = np.concatenate([o for o, _ in ticks])
    times = np.concatenate([t for _, t in ticks])
    sort = np.argsort(order, kind='stable')
    order, times = order[sort], np.maximum.accumulate(times[sort])
    answers = [c for key in ANSWER_TOPICS for c in topics.get(key, [])]
    counted = _answer_ticks(found, answers, np.unique(times))
    for rel, channels in topics.items():
        if rel in STAMPED:
            continue
        for channel in channels:
            kept = found.kept[channel]
            if rel in PER_TICK:
                _align(kept, found, topics.get(PER_TICK[rel], []), path)
            elif channel in counted:
                kept.log_time[:] = counted[channel]
            else:
                for i, at in enumerate(kept.order):
                    before = np.searchsorted(order, at, side='left') - 1
                    kept.log_time[i] = times[np.maximum(before, 0)]
    _reorder(found, topics)


def _stamps(found: Any, channel: int, rel: str, path: object) -> None:
    """A stamped topic's log times := its stamps; a repeated joint_states dropped."""
    kept = found.kept[channel]
    seen: set[int] = set()
    for i, part in enumerate(kept.parts):
        try:
            times = np.array([_stamp(raw) for raw in _rows(part)], dtype=np.int64)
        except ValueError:
            raise InvalidBag(f'{path}: a message on {found.channels[channel][0]} '
                             'carries no stamp') from None
        keep = np.ones(len(times), dtype=bool)
        if rel in _DEDUPED:
            for j, t in enumerate(times.tolist()):
                keep[j] = t not in seen
                seen.add(t)
        kept.log_time[i] = times[keep]
        kept.order[i] = kept.order[i][keep]
        kept.parts[i] = (part[keep] if isinstance(part, np.ndarray)
                         else [raw for raw, k in zip(part, keep.tolist(), strict=True) if k])


def _answer_ticks(found: Any, channels: list[int], ticks: np.ndarray
                  ) -> dict[int, list[np.ndarray]]:
    """Lockstep: each tick but the last ran on one answer (``cmd_effort`` or
    ``joint_commands``) to the tick before, applied at that tick's step. With as many
    answers as that or more, the n-th (in the order they were sent) is tick n's, and
    those after answered the last tick, which the stopped node never applied (and a
    controller may send a last command as it stops). Channel → log time parts; empty
    when there are fewer answers than ticks that ran on one."""
    if not channels:
        return {}
    orders = [(o, c, i, j) for c in channels
              for i, part in enumerate(found.kept[c].order) for j, o in enumerate(part.tolist())]
    ran = len(ticks) - 1
    if len(orders) < ran or ran < 1:
        return {}
    orders.sort()
    result = {c: [np.empty(len(p), np.int64) for p in found.kept[c].order] for c in channels}
    for n, (_, c, i, j) in enumerate(orders):
        result[c][i][j] = ticks[min(n, ran)]
    return result


def _reorder(found: Any, topics: dict[str, list[int]]) -> None:
    """Order the kept messages as table_sim writes them: by step, a step's outputs
    before the events applied at it, else as they arrived."""
    outputs = {c for rel in (*STAMPED, *PER_TICK) for c in topics.get(rel, [])}
    olds, keys, ranks = [], [], []
    for channel, kept in found.kept.items():
        for o, t in zip(kept.order, kept.log_time, strict=True):
            olds.append(o)
            keys.append(t)
            ranks.append(np.full(len(o), 0 if channel in outputs else 1))
    old, key, rank = map(np.concatenate, (olds, keys, ranks))
    new = np.empty(len(old), np.int64)
    new[np.lexsort((old, rank, key))] = np.arange(len(old))
    by_old = np.argsort(old)
    for kept in found.kept.values():
        for i, o in enumerate(kept.order):
            kept.order[i] = new[by_old[np.searchsorted(old, o, sorter=by_old)]]
def _align(kept: Any, found: Any, leaders: list[int], path: object) -> None:
    """The k-th message from the end gets the time of the k-th of the leader topic's
    from the end."""
    lead = np.concatenate([t for c in leaders for t in found.kept[c].log_time]
                          or [np.empty(0, np.int64)])
    n = sum(len(t) for t in kept.log_time)
    if n > len(lead):
        raise InvalidBag(f'{path}: {n} transmission_error messages for {len(lead)} '
                         'mesh_state: their ticks cannot be told')
    mine = lead[len(lead) - n:]
    at = 0
    for i, t in enumerate(kept.log_time):
        kept.log_time[i] = mine[at:at + len(t)]
        at += len(t)


__all__ = ['arrival_times', 'retime']
