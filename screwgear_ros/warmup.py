"""Compile the numba kernels once, at install time, so no start of the node compiles.

numba compiles a ``@njit(cache=True)`` function on its first call and keeps the machine
code in the package's ``__pycache__``; later processes load it in a fraction of a
second. ``scripts/setup_venv.sh`` runs ``python -m screwgear_ros.warmup`` after every
install (on a colcon install, run ``ros2 run screwgear_ros warmup`` once after the
build), so the node's first start is as fast as every other.

:func:`compiled_now` tells a caller (the node) whether something was compiled in this
process, i.e. whether the cache was missing.
"""

from __future__ import annotations

import sys
import time

from . import dop853, floquet, integrator, model, normalized
from .events import Command
from .params import MeshPhase, Mode, SimSettings, TableParams
from .session import Session
from .status import contact_states, mesh_frequency_ratio

_MODULES = (model, integrator, normalized, dop853, floquet)


def kernels() -> list:
    """Every compiled function of the core."""
    return [obj for module in _MODULES for obj in vars(module).values()
            if hasattr(obj, 'stats') and hasattr(obj, 'py_func')]


def compiled_now() -> int:
    """How many kernel signatures this process compiled instead of loading them."""
    return sum(sum(k.stats.cache_misses.values()) for k in kernels())


def warm() -> int:
    """Run every kernel the node and the tools use, in every mode; the number compiled."""
    for mode in Mode:
        for phase in MeshPhase:
            session = Session(TableParams(mode=mode, mesh_phase=phase,
                                          preload_torque=0.0 if mode is Mode.CONVENTIONAL
                                          else 350.0), SimSettings())
            session.submit(Command('cmd_effort', [10.0]))
            session.tick()
            contact_states(session.plant.params, session.outputs)     # diagnostics, markers
            mesh_frequency_ratio(session.plant.params, session.outputs)
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
