"""How the core's numba kernels are compiled: the options, declared once.

Every kernel is cached (compiled once, at install time by :mod:`screwgear_ros.cli.warmup`,
and loaded by every later process) and uses NumPy's error model (a division by zero
gives inf or nan, which the plant's fault check catches, instead of raising).

A kernel that allocates no array (:data:`kernel`, :data:`inline_kernel`: the model, the
node's RK4, the reference's steps) is also compiled without numba's reference counting
of arrays (``_nrt=False``, numba's runtime switched off for it). Every array such a
kernel touches was made by its caller, who keeps it alive for the whole call, so the
counts it would keep change nothing, and keeping them cost most of an RK4 step: each
call of one kernel from another, and each tuple of arrays, counted the arrays up and
down with atomic instructions that numba's pruning cannot remove across the contact
law's branches (numba issue #2350). The same step with and without the counts gives
the same bits (test_jit); without them a step takes a fraction of the time
(docs/performance.md gives the figures). A kernel that allocates
(:data:`allocating_kernel`) keeps the runtime: numba refuses to compile an allocation without it, so a kernel that
starts to allocate cannot keep the wrong decorator unnoticed.

``_nrt`` is private to numba: :func:`require_nrt_option` checks at import that the
installed numba still knows it, so an upgrade that drops it stops the import with a
message saying so (instead of a ``KeyError`` at the first compile deep inside numba).
"""

from __future__ import annotations

from typing import Any

import numba
from numba import njit


def require_nrt_option() -> None:
    """Raise ImportError, naming the API, unless numba still maps the ``_nrt`` option
    to its ``nrt`` compile flag (what :data:`NO_ALLOCATION` relies on)."""
    try:
        from numba.core.compiler import Flags
        from numba.core.cpu import CPUTargetOptions
        flags = CPUTargetOptions.parse_as_flags(Flags(), {'_nrt': False})
        known = flags.nrt is False
        reason = 'it no longer switches the nrt flag off'
    except Exception as error:     # noqa: BLE001  whatever the change is, it is this API that broke
        known, reason = False, f'{type(error).__name__}: {error}'
    if not known:
        raise ImportError(
            f"screwgear_ros needs numba's private compile option '_nrt' (njit(_nrt=False), "
            f'screwgear_ros/physics/jit.py), which numba {numba.__version__} does not support as '
            f'expected ({reason}). Install the versions in constraints.txt '
            '(pip install -c constraints.txt ...), or adapt screwgear_ros/physics/jit.py.')


require_nrt_option()

#: Options of every kernel. Any: numba's typed keywords do not include the private
#: ``_nrt``, and a dict of mixed values matches none of them.
OPTIONS: dict[str, Any] = {'cache': True, 'error_model': 'numpy'}
#: Options of a kernel that allocates no array.
NO_ALLOCATION: dict[str, Any] = {**OPTIONS, '_nrt': False}

#: Decorators: a kernel that allocates nothing, the same inlined into its callers (which
#: compile it with their own options), and a kernel that allocates.
kernel = njit(**NO_ALLOCATION)
inline_kernel = njit(inline='always', **NO_ALLOCATION)
allocating_kernel = njit(**OPTIONS)

__all__ = [
    'NO_ALLOCATION',
    'OPTIONS',
    'allocating_kernel',
    'inline_kernel',
    'kernel',
    'require_nrt_option',
]
