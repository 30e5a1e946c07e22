"""How the kernels are compiled (screwgear_ros.physics.jit): without numba's reference counting
they give the same bits, and a kernel that allocates cannot be declared without it.

Independent reference: the same kernels compiled with the reference counting on, in a
second process with its own numba cache (numba's cache key does not include the
compile options, so sharing the cache would load the other variant).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from numba.core.errors import TypingError

from screwgear_ros.numerics.integrator import advance
from screwgear_ros.params.table import TableParams
from screwgear_ros.physics import jit
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.packed import Drive, pack

#: A run through reversals (conventional: backlash impacts, contact changes located)
#: with the drive line's corner crossed; the state and outputs after every 20-step tick.
RUN = '''
import json, sys
import numpy as np
from screwgear_ros.numerics.integrator import OBSERVED, advance_observed
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.packed import Drive, pack
from screwgear_ros.params.table import TableParams

def run(mode):
    p = TableParams(table_damping=8867.0, ste_phases=(0.4,), mode=mode,
                    drive_no_load_speed=40.0, drive_stall_torque=900.0)
    m = pack(p)
    y, backup, out = equilibrium_state(p), np.empty(6), np.empty(OBSERVED)
    rows, changes, step = [], 0, 0
    for torque, direction, load in [(400.0, 1.0, 0.0), (400.0, -1.0, 5.0), (800.0, 1.0, -50.0)]:
        for _ in range(40):
            changes += advance_observed(y, backup, out, step, 20, 50e-6, m,
                                        Drive(torque, direction, load), True)
            step += 20
            rows.append(out.tobytes().hex())
    return rows, changes
'''


def counted_variant_rows(mode: str, tmp_path) -> tuple[list[str], int]:
    """RUN in a second process whose kernels keep numba's reference counts."""
    script = ('import screwgear_ros.physics.jit as j\n'
              'from numba import njit\n'
              'j.kernel = njit(**j.OPTIONS)\n'
              'j.inline_kernel = njit(inline="always", **j.OPTIONS)\n'
              + RUN + 'json.dump(run(sys.argv[1]), sys.stdout)\n')
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / 'numba_cache'))
    proc = subprocess.run([sys.executable, '-P', '-c', script, mode], env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    rows, changes = json.loads(proc.stdout)
    return rows, changes


@pytest.mark.ros
@pytest.mark.parametrize('mode', ['conventional', 'anti_backlash'])
def test_without_reference_counts_the_kernels_give_the_same_bits(mode, tmp_path):
    namespace: dict = {}
    exec(RUN, namespace)  # noqa: S102 - the test's own source, run without refcounts
    rows, changes = namespace['run'](mode)
    counted, counted_changes = counted_variant_rows(mode, tmp_path)
    assert len(rows) == len(counted) == 120
    assert rows == counted and changes == counted_changes
    if mode == 'conventional':
        assert changes > 0          # the run went through located impacts
    assert len(set(rows)) == len(rows)   # the table moved: every tick is different


def test_the_rk4_kernel_is_compiled_without_reference_counts():
    """The node's RK4 (advance, with its located steps inlined) as its options compile
    it, and, as the control that the check can fail, with numba's runtime on: only the
    latter counts references. Compiled afresh (uncached: numba cannot show the code of
    a function loaded from its cache)."""
    from numba import njit

    p = TableParams()
    m = pack(p)
    args = (equilibrium_state(p), 0, 20, 50e-6, m, Drive(1.0, 1.0, 0.0), True)

    def llvm(options: dict) -> str:
        fresh = njit(**{**options, 'cache': False})(advance.py_func)
        fresh(*args)
        return next(iter(fresh.inspect_llvm().values()))

    assert advance.targetoptions.get('_nrt') is False
    assert 'NRT_incref' in llvm(jit.OPTIONS)
    assert 'NRT_incref' not in llvm(jit.NO_ALLOCATION)


def test_a_kernel_that_allocates_cannot_be_declared_as_one_that_does_not():
    """Two functions, not one: numba's cache does not key on the options, so the one
    compiled with the runtime would be loaded for the other from then on."""
    def allocates(n):
        return np.zeros(n)

    def allocates_with_the_runtime(n):
        return np.zeros(n)

    with pytest.raises(TypingError):
        jit.kernel(allocates)(3)
    assert list(jit.allocating_kernel(allocates_with_the_runtime)(3)) == [0.0, 0.0, 0.0]
