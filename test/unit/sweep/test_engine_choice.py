"""sweep's defaults that depend on the machine: the workers it picks from the cores
free now, and its progress in a log (lines, no carriage returns)."""

from __future__ import annotations

import io

from screwgear_ros.sweep.engine import free_workers
from screwgear_ros.sweep.progress import STEP, Lines, progress_bar


def test_auto_workers_are_the_free_cores_and_one_on_a_busy_machine():
    busy = free_workers(300, load=7.0, allowed=2)
    assert busy.count == 1 and 'busy' in busy.why and '7.0 busy now' in busy.why
    assert free_workers(300, load=0.1, allowed=2).count == 2
    assert free_workers(300, load=1.2, allowed=4).count == 3
    assert free_workers(300, load=0.0, allowed=8).count == 8
    assert free_workers(3, load=0.0, allowed=8).count == 3        # no idle worker
    assert free_workers(1, load=0.0, allowed=8).count == 1


def test_progress_in_a_log_is_a_line_every_few_percent():
    stream = io.StringIO()
    bar = progress_bar(200, 10, 0, stream)
    assert isinstance(bar, Lines)
    for k in range(190):
        bar.update(k // 50)
    bar.close()
    text = stream.getvalue()
    assert '\r' not in text
    lines = text.splitlines()
    assert len(lines) == 100 // STEP - 1          # from 5 % (10 of 200) to 100 %
    assert lines[-1].startswith('sweep: 200/200 runs (100 %), 3 failures')


def test_a_run_with_a_time_limit_beyond_any_timer_runs(tmp_path):
    from screwgear_ros.sweep.model import Bundle, RunSpec
    from screwgear_ros.sweep.worker import Status, execute

    bundle = Bundle('scenario.yaml', 'duration: 0.01\n', (), (), ('max_abs_te_m',), 1.0e300)
    outcome = execute(bundle, RunSpec(0, 0, (), (), 'k'))
    assert outcome.status is Status.OK, outcome.reason
