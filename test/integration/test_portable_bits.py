"""The checked-in bags replay bit for bit with kernels compiled for another CPU.

The bags were recorded on one machine; the kernels are compiled for the CPU they run on
(numba targets the host unless ``NUMBA_CPU_NAME`` says otherwise). Replaying a bag on
another CPU must still give its recorded outputs bit for bit: no kernel may depend on
instructions or instruction selection only some CPUs have (fused multiply-adds,
vector widths). A second process compiles the kernels for numba's ``generic`` x86-64
CPU (numba keys its cache on the CPU, so these never mix with the host's) and replays
every bag in-process (test_replay does the same on the host's kernels).
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest
from bag_runs import BAGS
from paths import DATA

REPLAY = '''
import json, sys
import numpy as np
from numba import config
from screwgear_ros.numerics import integrator
from screwgear_ros.bag.reader import read_run
from screwgear_ros.runs.replay_in_process import replay_in_process

report = {}
for path in sys.argv[1:]:
    run = read_run(path)
    replay = replay_in_process(run)
    report[path] = dict(
        samples=len(run.joint_states),
        joint_states=bool(np.array_equal(replay.joint_states, run.joint_states.values)),
        transmission_error=bool(np.array_equal(replay.transmission_error,
                                               run.transmission_error.values[:, 0])),
        fault=replay.fault is None)
codegen = integrator.advance.targetctx.codegen()
report['cpu'] = [config.CPU_NAME, codegen.magic_tuple()[1]]
json.dump(report, sys.stdout)
'''


@pytest.mark.ros
@pytest.mark.skipif(platform.machine() not in ('x86_64', 'AMD64'),
                    reason="numba's 'generic' CPU name is x86-64's")
def test_the_bags_replay_bit_for_bit_with_generic_x86_64_kernels():
    env = {**os.environ, 'NUMBA_CPU_NAME': 'generic'}
    env.pop('NUMBA_CPU_FEATURES', None)
    proc = subprocess.run([sys.executable, '-P', '-c', REPLAY, *(str(DATA / b) for b in BAGS)],
                          env=env, capture_output=True, text=True, timeout=1800, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = json.loads(proc.stdout)
    assert report.pop('cpu') == ['generic', 'generic']      # really compiled for generic
    for bag, result in report.items():
        assert result['samples'] > 500, bag
        assert result['joint_states'] and result['transmission_error'], (bag, result)
        assert result['fault'], bag
