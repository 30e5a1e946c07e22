"""ros.shutdown.stop_on_signals: a burst of stop signals sets the event and never hangs.

A node orphaned by a SIGKILLed replay_run got SIGINT once per thread its parent lost
(PR_SET_PDEATHSIG is per thread) and hung: each Python handler called Event.set inside
the previous one's, which held the event's lock. The child here makes both hazards
likely: it holds the event's lock most of the time (Event.wait in a loop, as close()
holds it in Event.set) while 1000 signals arrive. With handlers that set the event
themselves, 9 of 20 such children hung at 200 signals, and each of 4 runs of this test
failed at 1000.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

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


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM])
def test_a_burst_of_stop_signals_sets_the_event_without_hanging(signum):
    children = [subprocess.Popen([sys.executable, '-c', CHILD], stdout=subprocess.PIPE,
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
