"""warmup: compile every numba kernel once, at install time, so no start of the node
compiles.

numba compiles a ``@njit(cache=True)`` function on its first call and keeps the machine
code in the package's ``__pycache__``; later processes load it in a fraction of a
second. ``scripts/setup_venv.sh`` runs it after every install; on a colcon install, run
``ros2 run screwgear_ros warmup`` once after the build, so the node's first start is as
fast as every other.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

import numpy as np

from ..interface import Input
from ..numerics.kernels import compiled_now, kernels, progress, without_blas_probe
from ..params.table import MeshPhase, Mode, SimSettings, TableParams
from ..sim.events import Command
from ..sim.session import ROW, AdvanceMode, Session
from ..sim.status import contact_states, mesh_frequency_ratio


def warm() -> int:
    """Run every kernel the node and the tools use, in every mode; the number compiled."""
    for mode in Mode:
        for phase in MeshPhase:
            session = Session(TableParams(mode=mode, mesh_phase=phase,
                                          preload_torque=0.0 if mode is Mode.CONVENTIONAL
                                          else 350.0), SimSettings())
            session.submit(Command(Input.CMD_EFFORT, [10.0]))
            session.tick()
            session.advance(2, mode=AdvanceMode.ROWS, rows=np.empty((2, ROW)))     # replays, check_run
            contact_states(session.plant.params, session.last_outputs)     # diagnostics, markers
            mesh_frequency_ratio(session.plant.params, session.last_outputs)
    from ..numerics import dop853
    from ..paper import floquet, normalized
    normalized.response(normalized.NormalizedParams(), 1.0)
    dop853.warm()                    # check_run's reference solver
    floquet.monodromy(0.05, 0.1, 2.0, steps=64)    # the report's Floquet maps
    return compiled_now()


def main(argv: Sequence[str] | None = None) -> int:
    """Compile (or load) every kernel and say how many of each; exit 0."""
    argparse.ArgumentParser(prog='warmup', description=__doc__.split('\n\n')[0]).parse_args(
        argv)
    start = time.perf_counter()
    with progress(say=lambda line: print(line, flush=True)):
        compiled = warm()
    loaded = sum(sum(k.stats.cache_hits.values()) for k in kernels())
    print(f'screwgear_ros warmup: {compiled} kernel signatures compiled and cached, '
          f'{loaded} loaded from the cache, {time.perf_counter() - start:.1f} s')
    return 0


__all__ = ['compiled_now', 'kernels', 'main', 'warm', 'without_blas_probe']

if __name__ == '__main__':
    sys.exit(main())
