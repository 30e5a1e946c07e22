"""The verdicts of replay_run --compare name what they checked.

- a lockstep comparison against an original that holds only its start sample (a run of
  length 0, or a bag whose main chunk was lost) compared no run: never IDENTICAL;
- a free-running replay whose outputs are what its events make is CONSISTENT, not a
  PASS: the verdict line carries the timing difference and the largest signal
  difference, and one line says why such a replay cannot reproduce the original.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from bag_runs import copy_bag
from paths import DATA

from screwgear_ros.bag.reader import RecordedRun, read_run
from screwgear_ros.runs.compare import (
    WHY_NOT_THE_SAME,
    compare_runs,
    exact_comparison,
    format_comparison,
    format_exact,
    shift_event,
)
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.sim.events import Command


def test_a_replay_of_a_start_sample_only_original_is_not_identical(tmp_path: Path) -> None:
    copy_bag(DATA / 'steady_drive', tmp_path / 'start',
             lambda topic, msgtype, t, raw: (t, raw) if t == 0 else None)
    start_only = read_run(tmp_path / 'start')
    assert len(start_only.joint_states) == 1
    for new in (start_only, read_run(DATA / 'steady_drive')):
        exact = exact_comparison(start_only, new)
        assert not exact.ok and exact.nothing_compared is not None, format_exact(exact)
        assert 'after the start' in exact.nothing_compared
        assert 'IDENTICAL' not in format_exact(exact)


def _landed_late(run: RecordedRun) -> RecordedRun:
    """``run`` as a free-running replay makes it when its first command lands a publish
    tick late: the event moved, the outputs what the moved event makes."""
    index = next(k for k, (_, e) in enumerate(run.events) if isinstance(e, Command))
    late = shift_event(run, index, run.parameters.settings.steps_per_publish)
    made = replay_in_process(late)
    return dataclasses.replace(
        late, true_joint_states=dataclasses.replace(late.true_joint_states,
                                                     values=made.joint_states),
        transmission_error=dataclasses.replace(late.transmission_error,
                                               values=made.transmission_error[:, None]))


def test_a_consistent_free_running_replay_says_consistent_with_its_differences() -> None:
    original = read_run(DATA / 'steady_drive')
    replay = _landed_late(original)
    comparison = compare_runs(original, replay)
    assert comparison.ok and not comparison.identical
    text = format_comparison(comparison)
    verdict = next(line for line in text.splitlines() if 'RESULT' in line)
    assert verdict.startswith('  RESULT: CONSISTENT (timing differs by up to 1 publish '
                              'ticks, largest signal difference '), text
    largest = comparison.largest()
    assert largest is not None and largest.max_diff > 0.0
    assert f'{largest.name} {largest.max_diff:.3g} {largest.unit}' in verdict
    # the signal furthest off against its own size in the original
    relative = {s.name: s.max_diff / s.scale for s in comparison.signals if s.scale}
    assert max(relative, key=relative.__getitem__) == largest.name
    assert WHY_NOT_THE_SAME in text and 'PASS' not in text


def test_an_identical_free_running_replay_needs_no_excuse() -> None:
    original = read_run(DATA / 'steady_drive')
    text = format_comparison(compare_runs(original, original))
    assert 'RESULT: CONSISTENT (timing differs by up to 0 publish ticks' in text
    assert WHY_NOT_THE_SAME not in text


def test_an_inconsistent_free_running_replay_says_so() -> None:
    original = read_run(DATA / 'steady_drive')
    index = next(k for k, (_, e) in enumerate(original.events) if isinstance(e, Command))
    moved = shift_event(original, index, original.parameters.settings.steps_per_publish)
    text = format_comparison(compare_runs(original, moved))
    assert 'RESULT: INCONSISTENT' in text and 'PASS' not in text
