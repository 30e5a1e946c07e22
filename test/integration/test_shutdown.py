"""ros.shutdown.stop_on_signals: a burst of stop signals sets the event and never hangs.

A node orphaned by a SIGKILLed replay_run got SIGINT once per thread its parent lost
(PR_SET_PDEATHSIG is per thread) and hung: each Python handler called Event.set inside
the previous one's, which held the event's lock. The child here makes both hazards
likely: it holds the event's lock most of the time (Event.wait in a loop, as close()
holds it in Event.set) while 1000 signals arrive. With handlers that set the event
themselves, 9 of 20 such children hung at 200 signals, and each of 4 runs of this test
failed at 1000.

The last signals of a burst may come while the process already tears itself down; the
interpreter then resets the Python-level handlers to the default action, and a late
SIGINT killed a child that had stopped cleanly (status -2, a shell's 130).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from ros_procs import STARTUP_TIMEOUT, Peer, start_process
from sensor_msgs.msg import JointState

CHILD = '''
from screwgear_ros.ros.shutdown import stop_on_signals
stop = stop_on_signals()
print('ready', flush=True)
while not stop.is_set():
    stop.wait(0)
print('stopped', flush=True)
'''
CHILDREN = 8             # each one a chance to catch a hang
BURST = 1000             # signals sent to each child, back to back
HANG = 60.0              # s: a child that needs longer hung (it normally ends at once)


@pytest.mark.ros
@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM])
def test_a_burst_of_stop_signals_sets_the_event_without_hanging(signum):
    children = [subprocess.Popen([sys.executable, '-P', '-c', CHILD], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True) for _ in range(CHILDREN)]
    try:
        for child in children:
            assert child.stdout.readline().strip() == 'ready', child.stderr.read()
            for _ in range(BURST):
                os.kill(child.pid, signum)
        for child in children:
            out, err = child.communicate(timeout=HANG)
            assert child.returncode == 0 and out.strip() == 'stopped', (out, err)
            assert 'Traceback' not in err, err
    finally:
        for child in children:
            if child.poll() is None:
                child.kill()
                child.wait()


# A shell whose teardown (at interpreter exit, after the atexit callbacks) takes until
# the test says so: it reports the teardown, then blocks reading stdin.
SLOW_TEARDOWN_CHILD = '''
import sys
from screwgear_ros.ros.shutdown import stop_on_signals

class Teardown:
    def __del__(self, stdin=sys.stdin, stdout=sys.stdout):
        stdout.write('tearing down\\n')
        stdout.flush()
        stdin.read()

stop = stop_on_signals()
resource = Teardown()
print('ready', flush=True)
stop.wait()
print('stopped', flush=True)
'''
SPACING = 0.3            # s between the signals of a slow burst (a hurried Ctrl-C)


@pytest.mark.ros
@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_stop_signals_during_the_interpreters_teardown_end_in_exit_0(signum):
    child = subprocess.Popen([sys.executable, '-P', '-c', SLOW_TEARDOWN_CHILD],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == 'ready', child.stderr.read()
        child.send_signal(signum)
        assert child.stdout.readline().strip() == 'stopped'
        assert child.stdout.readline().strip() == 'tearing down'
        for _ in range(2):
            child.send_signal(signum)
            time.sleep(SPACING)
        assert child.poll() is None, f'killed in its teardown: {child.returncode}'
        child.stdin.close()
        assert child.wait(timeout=HANG) == 0, child.stderr.read()
        assert 'Traceback' not in child.stderr.read()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()


@pytest.mark.ros
def test_three_sigints_in_a_row_stop_the_node_with_exit_0(tmp_path):
    """Ctrl-C pressed three times, 0.3 s apart, at a running table_sim."""
    node = start_process('table_sim', workdir=tmp_path)
    try:
        with Peer('test_three_sigints') as peer:
            peer.subscribe('/joint_states', JointState).wait_for(
                lambda m: True, STARTUP_TIMEOUT, 'joint_states of the started node')
        for _ in range(3):
            if node.alive():
                node.popen.send_signal(signal.SIGINT)
            time.sleep(SPACING)
        code = node.popen.wait(timeout=HANG)
        stderr = node.output()[1]
        assert code == 0, f'exit code {code}; stderr:\n{stderr[-3000:]}'
        assert 'Traceback' not in stderr, stderr[-3000:]
    finally:
        node.kill()
