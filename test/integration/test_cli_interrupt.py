"""Ctrl-C on an offline tool: one line saying what it had not finished, exit 130, no
traceback; a recording it was making is closed and reads back (rosbags, a second
reader)."""

from __future__ import annotations

import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

from screwgear_ros.cli import EXIT_INTERRUPTED

#: Long enough that the interrupt always lands while the run is going.
LONG_SCENARIO = ('parameters: {command_timeout: 0.0}\nduration: 600.0\n'
                 'controller: {use: demo}\n'
                 'setpoint: {profile: steps, points: [[0.0, 0.01], [1.0, -0.01]]}\n')


def _interrupt_when_recording(args: list[str], bag: Path) -> subprocess.CompletedProcess:
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120.0
        # The tool is in its run once its bag has grown past what the start writes (the
        # header, the parameters, the URDF): ticks are being recorded.
        sizes: list[int] = []
        while len(set(sizes)) < 2:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, 'the run never started recording'
            sizes += [p.stat().st_size for p in bag.glob('*.mcap') if p.stat().st_size > 4096]
            time.sleep(0.2)
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30.0)
        return subprocess.CompletedProcess(args, proc.returncode, out,
                                           err + f'\n(stopped {time.monotonic() - sent:.2f} s '
                                           'after SIGINT)')
    finally:
        proc.kill()


@pytest.mark.ros
def test_run_scenario_stops_on_sigint_with_its_recording_closed(tmp_path: Path) -> None:
    scenario = tmp_path / 'long.yaml'
    scenario.write_text(LONG_SCENARIO)
    bag = tmp_path / 'bag'
    exe = shutil.which('run_scenario')
    assert exe is not None
    done = _interrupt_when_recording([exe, str(scenario), '--record', str(bag)], bag)
    assert done.returncode == EXIT_INTERRUPTED, done.stderr
    assert 'interrupted (SIGINT)' in done.stderr and 'Traceback' not in done.stderr, \
        done.stderr
    with AnyReader([bag]) as reader:
        states = [c for c in reader.connections if c.topic.endswith('/joint_states')]
        assert states and sum(1 for _ in reader.messages(connections=states)) > 0


@pytest.mark.ros
def test_an_interrupt_at_any_moment_leaves_a_bag_that_reads_or_none(tmp_path: Path) -> None:
    """SIGINT from the moment the bag's file exists on, at seeded delays: the tool exits
    130 without a traceback, and what it leaves is a bag rosbags reads, or nothing (a
    start cut short writes no half bag)."""
    scenario = tmp_path / 'long.yaml'
    scenario.write_text(LONG_SCENARIO)
    exe = shutil.which('run_scenario')
    assert exe is not None
    for k, delay in enumerate((0.0, 0.02, 0.05, 0.1, 0.3)):
        bag = tmp_path / f'bag{k}'
        proc = subprocess.Popen([exe, str(scenario), '--record', str(bag)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 120.0
            while not any(bag.glob('*.mcap')):
                assert proc.poll() is None, proc.communicate()
                assert time.monotonic() < deadline, 'the run never started recording'
                time.sleep(0.002)
            time.sleep(delay)
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=60.0)
        finally:
            proc.kill()
        assert proc.returncode == EXIT_INTERRUPTED and 'Traceback' not in err, err
        if bag.exists():
            with AnyReader([bag]) as reader:
                assert reader.connections, f'{bag}: a bag with no topic'
