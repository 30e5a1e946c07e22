"""Compile the numba kernels once, at install time, so no start of the node compiles.

numba compiles a ``@njit(cache=True)`` function on its first call and keeps the machine
code in the package's ``__pycache__``; later processes load it in a fraction of a
second. ``scripts/setup_venv.sh`` runs ``python -m screwgear_ros.numerics.warmup`` after every
install (on a colcon install, run ``ros2 run screwgear_ros warmup`` once after the
build), so the node's first start is as fast as every other.

:func:`compiled_now` tells a caller (the node) whether something was compiled in this
process, i.e. whether the cache was missing. It looks only at the kernel modules this
process imported (a module never imported compiled nothing), so importing it costs the
node nothing beyond what it runs: check_run's DOP853 (:mod:`screwgear_ros.numerics.dop853`, which
imports SciPy, about half a second) and :mod:`screwgear_ros.paper.normalized` are imported by
:func:`warm`, not here.

:func:`without_blas_probe` spares the node's start numba's probe of SciPy's BLAS, which
the kernels do not use.
"""

from __future__ import annotations

import importlib
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from ..params.table import MeshPhase, Mode, SimSettings, TableParams
from ..sim.events import Command
from ..sim.session import ROW, Session
from ..sim.status import contact_states, mesh_frequency_ratio

#: The modules holding the core's compiled functions.
_MODULES = ('physics.friction', 'physics.mesh', 'physics.drive', 'physics.motion',
            'numerics.integrator', 'paper.normalized', 'numerics.dop853',
            'numerics.dop853_stages', 'paper.floquet')


def kernels(imported_only: bool = False) -> list:
    """Every compiled function of the core; with ``imported_only`` only those of the
    kernel modules this process has imported (without importing the others)."""
    names = [f'screwgear_ros.{name}' for name in _MODULES]
    modules = ([sys.modules[n] for n in names if n in sys.modules] if imported_only
               else [importlib.import_module(n) for n in names])
    # a kernel counts once, in the module that defines it, not in each that imports it
    return [obj for module in modules for obj in vars(module).values()
            if hasattr(obj, 'stats') and hasattr(obj, 'py_func')
            and obj.py_func.__module__ == module.__name__]


def compiled_now() -> int:
    """How many kernel signatures this process compiled instead of loading them."""
    return sum(sum(k.stats.cache_misses.values()) for k in kernels(imported_only=True))


@contextmanager
def without_blas_probe() -> Iterator[None]:
    """Within: ``scipy.linalg`` cannot be imported, unless it already was.

    The first compiled function a process loads starts numba's CPU target, which imports
    ``scipy.linalg.cython_blas`` once to learn whether BLAS is there
    (``numba.np.arraymath._HAVE_BLAS``; an ImportError means no). Importing
    ``scipy.linalg`` costs 0.14 s of the node's 0.55 s to its first joint_states, and no
    kernel calls BLAS (the linear algebra of parameter checks and reports is NumPy's,
    outside the kernels). ``None`` in ``sys.modules`` is Python's way to make an import
    fail; it is lifted on the way out, so a later import in the process works as usual.

    What it leaves behind, and why that is safe here:

    * ``_HAVE_BLAS`` stays False in this process: a kernel compiled later with
      ``np.convolve`` or ``np.correlate`` would take numba's loop instead of BLAS;
    * a kernel compiled *within* (the cache was missing) that calls ``np.dot`` or
      ``np.linalg`` would fail to compile: none does, and a test compiles the node's
      kernels within it into an empty cache;
    * it is process-wide: the node enters it before any other thread of its own runs
      Python that imports (its signal thread only reads a pipe).
    """
    if 'scipy.linalg' in sys.modules:
        yield
        return
    sys.modules['scipy.linalg'] = None     # type: ignore[assignment]
    try:
        yield
    finally:
        if sys.modules.get('scipy.linalg', 0) is None:
            del sys.modules['scipy.linalg']


def warm() -> int:
    """Run every kernel the node and the tools use, in every mode; the number compiled."""
    for mode in Mode:
        for phase in MeshPhase:
            session = Session(TableParams(mode=mode, mesh_phase=phase,
                                          preload_torque=0.0 if mode is Mode.CONVENTIONAL
                                          else 350.0), SimSettings())
            session.submit(Command('cmd_effort', [10.0]))
            session.tick()
            session.advance(2, rows=np.empty((2, ROW)))     # replays, check_run
            contact_states(session.plant.params, session.last_outputs)     # diagnostics, markers
            mesh_frequency_ratio(session.plant.params, session.last_outputs)
    from ..paper import floquet, normalized
    from . import dop853
    normalized.response(normalized.NormalizedParams(), 1.0)
    dop853.warm()                    # check_run's reference solver
    floquet.monodromy(0.05, 0.1, 2.0, steps=64)    # the report's Floquet maps
    return compiled_now()


def main() -> int:
    start = time.perf_counter()
    compiled = warm()
    loaded = sum(sum(k.stats.cache_hits.values()) for k in kernels())
    print(f'screwgear_ros warmup: {compiled} kernel signatures compiled and cached, '
          f'{loaded} loaded from the cache, {time.perf_counter() - start:.1f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
