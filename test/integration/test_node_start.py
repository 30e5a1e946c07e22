"""The node's start loads only what its first joint_states needs (issue 12's fast start).

In a fresh interpreter, table_sim is constructed on real rclpy and its run started up to
the first outputs (``RunIO.start``: the URDF, the active path, joint_states); then the
modules only the tools need must still be unimported: check_run's DOP853 and the
SciPy integrators, rosbags' typestore, the MCAP writer, matplotlib, the normalized
model. Nor does it import SciPy's linear algebra, which numba's start probes for
(``warmup.without_blas_probe``), and an import of it after the start works. Nor numba's
typing and lowering registries, which only a compile uses
(``warmup.loads_without_registries``): the kernels it loads give the bits numba's own
load gives, and numba compiles as usual afterwards. And ``warmup.kernels()`` still finds
every kernel module it compiles at install time, while ``compiled_now`` (which the node
calls) imports none of them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

#: Loaded by the tools (check_run, plot_run, recording), never by a start that does not
#: record (runs.run_io, which makes a tick's messages, is the node's own).
TOOLS_ONLY = ('scipy.integrate', 'scipy.optimize', 'rosbags', 'mcap', 'matplotlib',
              'screwgear_ros.runs.check', 'screwgear_ros.runs.plot',
              'screwgear_ros.runs.compare', 'screwgear_ros.runs.replay_in_process',
              'screwgear_ros.runs.session_record', 'screwgear_ros.numerics.dop853',
              'screwgear_ros.numerics.dop853_stages', 'screwgear_ros.paper.normalized',
              'screwgear_ros.numerics.reference', 'screwgear_ros.paper.floquet')

#: Imported by the first refresh of numba's CPU target (its registries of what it can
#: compile), which a start that loads its kernels from the cache skips.
REGISTRIES = ('numba.np.arraymath', 'numba.np.linalg', 'numba.np.npyimpl',
              'numba.np.npdatetime', 'numba.cpython.unicode', 'numba.cpython.listobj',
              'numba.typed.typeddict', 'numba.typed.listobject', 'numba.core.optional')

START = '''
import sys, threading
import rclpy
from rclpy.signals import SignalHandlerOptions
from screwgear_ros.ros.node import TableSim
rclpy.init(args=['--ros-args', '-r', '__ns:=/start_test'],
           signal_handler_options=SignalHandlerOptions.NO)
node = TableSim(threading.Event())
node.io.start(node.session)
assert node.io.last_joint_states is not None
loaded = sorted(m for m in sys.modules if any(m == t or m.startswith(t + '.') for t in {tools!r}))
node.destroy_node()
rclpy.try_shutdown()
print(loaded)
'''


def _run(code: str, **env: str) -> str:
    proc = subprocess.run([sys.executable, '-P', '-c', code], capture_output=True, text=True,
                          check=False, timeout=120, env={**os.environ, **env})
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.strip().splitlines()[-1]


@pytest.mark.ros
def test_the_start_up_to_the_first_joint_states_loads_no_tool_module():
    assert _run(START.format(tools=TOOLS_ONLY)) == '[]'


#: After START with tools=('scipy.linalg',): what the start loaded of it, whether numba's
#: target saw BLAS, that scipy.linalg imports and works afterwards, whether the start
#: compiled any kernel.
AFTER_START = ('blas = getattr(sys.modules.get("numba.np.arraymath"), "_HAVE_BLAS", False)\n'
               'import scipy.linalg, numpy as np\n'
               'from screwgear_ros.numerics.kernels import compiled_now\n'
               'print([loaded, blas, float(scipy.linalg.det(np.eye(2) * 3.0)), '
               'compiled_now() > 0])\n')


@pytest.mark.ros
def test_the_start_skips_numbas_blas_probe_and_leaves_scipy_linalg_importable(tmp_path):
    start = START.format(tools=('scipy.linalg',)).replace('print(loaded)\n', '')
    assert _run(start + AFTER_START, NUMBA_DISABLE_JIT='0') == "[[], False, 9.0, False]"
    # with an empty cache the node compiles its kernels within the block, and they work
    assert _run(start + AFTER_START, NUMBA_DISABLE_JIT='0',
                NUMBA_CACHE_DIR=str(tmp_path)) == "[[], False, 9.0, True]"
    # without the node, numba's probe finds SciPy's BLAS here: the tests above show a skip
    assert _run('from screwgear_ros.sim.session import Session\n'
                'from screwgear_ros.params.table import TableParams, SimSettings\n'
                'Session(TableParams(), SimSettings())\n'
                'from numba.np.arraymath import _HAVE_BLAS\n'
                'print(_HAVE_BLAS)\n', NUMBA_DISABLE_JIT='0') == 'True'


def test_numba_still_has_the_private_cache_methods_the_start_replaces_a_load_with():
    """loads_without_registries falls back to numba's own load when these are gone: the
    start is then slower, and this names why."""
    from numba.core.caching import Cache
    from numba.core.runtime.nrt import rtsys
    missing = [name for name in ('load_overload', '_load_overload',
                                 '_guard_against_spurious_io_errors') if not hasattr(Cache, name)]
    assert not missing, (f'numba.core.caching.Cache has no {missing}: the node start loads its '
                         "kernels numba's own way (screwgear_ros/numerics/kernels.py)")
    assert callable(rtsys.initialize)


@pytest.mark.ros
def test_a_warm_start_loads_no_registry_of_numba():
    assert _run(START.format(tools=REGISTRIES), NUMBA_DISABLE_JIT='0') == '[]'


#: After START: the joint positions the start published and the plant's state after 50
#: steps, bit for bit (hex), then what numba compiles afterwards (a function of its own,
#: uncached: the compile loads the registries itself).
AFTER_START_BITS = (
    'import json, numba, numpy as np\n'
    'first = [*node.session.measured.position]\n'
    'node.session.plant.advance(50)\n'
    'bits = [float(v).hex() for v in [*first, *node.session.plant.state]]\n'
    'total = numba.njit(lambda x: np.sort(x).sum())(np.array([3.0, 1.0, 2.0]))\n'
    'print(json.dumps([bits, float(total), "numba.np.arraymath" in sys.modules]))\n')
#: The same first outputs and 50 steps from a Session made without the node (numba's own
#: load, its registries refreshed first).
SESSION_BITS = (
    'import json, sys\n'
    'from screwgear_ros.sim.session import Session\n'
    'from screwgear_ros.params.table import TableParams, SimSettings\n'
    'session = Session(TableParams(), SimSettings())\n'
    'first = [*session.measured.position]\n'
    'session.plant.advance(0)\n'
    'session.plant.advance(50)\n'
    'print(json.dumps([[float(v).hex() for v in [*first, *session.plant.state]], '
    '"numba.np.arraymath" in sys.modules]))\n')


@pytest.mark.ros
def test_kernels_loaded_without_the_registries_give_numbas_bits_and_numba_compiles_after():
    start = START.format(tools=()).replace('print(loaded)\n', '').replace(
        'node.destroy_node()\nrclpy.try_shutdown()\n', '')
    bits, total, registries = json.loads(_run(start + AFTER_START_BITS, NUMBA_DISABLE_JIT='0'))
    assert (total, registries) == (6.0, True)
    reference, refreshed = json.loads(_run(SESSION_BITS, NUMBA_DISABLE_JIT='0'))
    assert refreshed
    assert bits == reference


@pytest.mark.ros
def test_the_start_without_jit_loads_no_tool_module_either():
    assert _run(START.format(tools=TOOLS_ONLY), NUMBA_DISABLE_JIT='1') == '[]'


@pytest.mark.ros
def test_warmup_finds_every_kernel_module_and_compiled_now_imports_none():
    code = ('import json, sys\n'
            'from screwgear_ros.numerics import kernels as warmup\n'
            'import screwgear_ros.sim.session  # the kernels a node start loads\n'
            'warmup.compiled_now()\n'
            'before = {k.py_func.__module__ for k in warmup.kernels(imported_only=True)}\n'
            'unloaded = [m for m in ("screwgear_ros.numerics.dop853",\n'
            '                        "screwgear_ros.numerics.dop853_stages",\n'
            '                        "screwgear_ros.paper.normalized",\n'
            '                        "screwgear_ros.paper.floquet") if m not in sys.modules]\n'
            'every = {k.py_func.__module__ for k in warmup.kernels()}\n'
            'print(json.dumps([sorted(before), unloaded, sorted(every)]))\n')
    before, unloaded, every = json.loads(_run(code, NUMBA_DISABLE_JIT='0'))
    assert before == sorted(f'screwgear_ros.{m}'
                            for m in ('physics.friction', 'physics.mesh', 'physics.drive',
                                      'physics.motion', 'numerics.integrator'))
    assert unloaded == ['screwgear_ros.numerics.dop853', 'screwgear_ros.numerics.dop853_stages',
                        'screwgear_ros.paper.normalized', 'screwgear_ros.paper.floquet']
    assert every == sorted(f'screwgear_ros.{m}'
                           for m in ('physics.friction', 'physics.mesh', 'physics.drive',
                                     'physics.motion', 'numerics.integrator', 'paper.normalized',
                                     'numerics.dop853', 'numerics.dop853_stages',
                                     'paper.floquet'))
