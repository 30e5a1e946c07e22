"""Where the core's compiled functions are, and whether this process compiled any.

:func:`compiled_now` tells a caller (the node) whether something was compiled in this
process, i.e. whether numba's cache was missing. It looks only at the kernel modules
this process imported (a module never imported compiled nothing), so asking costs the
node nothing beyond what it runs. The kernel modules are named, not imported, here: a
start of the node must not import check_run's solver or the report's.

:func:`without_blas_probe` spares the node's start numba's probe of SciPy's BLAS, which
the kernels do not use, and :func:`loads_without_registries` the registries of what
numba can compile, which a kernel loaded from the cache does not need. Compiling every kernel ahead of time is
:mod:`screwgear_ros.cli.warmup`.
"""

from __future__ import annotations

import importlib
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

#: The modules holding the core's compiled functions.
_MODULES = ('physics.friction', 'physics.mesh', 'physics.drive', 'physics.motion',
            'numerics.integrator', 'paper.normalized', 'numerics.dop853',
            'numerics.dop853_stages', 'paper.floquet')


def kernels(imported_only: bool = False) -> list[Any]:
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


@contextmanager
def loads_without_registries() -> Iterator[None]:
    """Within: a kernel numba loads from its cache is loaded without first loading the
    CPU target's typing and lowering registries, which only a compile uses.

    numba refreshes its CPU target before every load from the cache (its
    ``Cache.load_overload``), and the first refresh in a process imports the
    implementations of everything numba can compile (``numba.np``, ``numba.cpython``,
    ``numba.typed``, ...) and registers them: most of a node start's wait for its first
    joint_states beyond numba's import, for code that is already machine code. A loaded
    kernel needs only numba's runtime, whose symbols its code links to
    (``rtsys.initialize``, which that refresh also makes); that is all it gets here.

    What it leaves as numba's own, and why that is safe:

    * a compile (the cache was missing) refreshes the target itself
      (``CompilerBase.__init__``), within or not, so it has every registry;
    * the machine code, its environment and the dispatcher's entry are those of numba's
      own load: the same bits;
    * a load after the block refreshes first, as numba always does (the registries are
      loaded once then); the node's kernels are all loaded within;
    * it is process-wide, like :func:`without_blas_probe`, and entered on the same
      terms; with a numba whose cache lacks these methods it changes nothing (the load
      is then numba's, with its refresh).
    """
    from numba.core.caching import Cache
    from numba.core.runtime.nrt import rtsys
    load = Cache.load_overload
    if not all(hasattr(Cache, name) for name in ('_load_overload',
                                                  '_guard_against_spurious_io_errors')):
        yield
        return

    def load_overload(self: Any, sig: Any, target_context: Any) -> Any:
        rtsys.initialize(target_context)       # the loaded code links to the runtime
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    Cache.load_overload = load_overload        # type: ignore[method-assign]
    try:
        yield
    finally:
        Cache.load_overload = load             # type: ignore[method-assign]


#: Kernels a first warm-up compiles into an empty cache (of the :func:`kernels` defined,
#: the node and the tools call these; measured), for the progress lines' "of about". An
#: estimate: a kernel added since, or one more signature a CPU needs, may exceed it, and
#: the lines then say so instead of counting past their total (:func:`progress_line`).
FIRST_COMPILE = 52


def compiled_kernels(every: list[Any]) -> int:
    """How many of the kernels ``every`` this process has compiled (at least one
    signature made, not loaded from the cache)."""
    return sum(1 for k in every if sum(k.stats.cache_misses.values()))


def progress_line(done: int, expected: int, seconds: float) -> str:
    """The progress line after ``done`` kernels in ``seconds``, with ``expected`` the
    estimate of the whole: never a count past its own total.

    Examples
    --------
    >>> progress_line(30, 52, 95.2)
    'screwgear_ros warmup: compiling kernels: 30 done of about 52, 95 s'
    >>> progress_line(53, 52, 301.0)
    'screwgear_ros warmup: compiling kernels: 53 done (more than the 52 expected; nearly there), 301 s'
    """
    if done < expected:
        count = f'{done} done of about {expected}'
    elif done == expected:
        count = f'{done} done of about {expected} (nearly there)'
    else:
        count = f'{done} done (more than the {expected} expected; nearly there)'
    return f'screwgear_ros warmup: compiling kernels: {count}, {seconds:.0f} s'


@contextmanager
def progress(period: float = 5.0, say: Callable[[str], None] = print,
             every: list[Any] | None = None, expected: int = FIRST_COMPILE) -> Iterator[None]:
    """Within: every ``period`` s in which more of the kernels ``every`` (default: all,
    :func:`kernels`) were compiled, ``say`` :func:`progress_line` (a first compile takes
    minutes; with the cache in place nothing is compiled and nothing said). ``expected``:
    the estimate of how many a first compile makes."""
    every = kernels() if every is None else every
    finished = threading.Event()
    start = time.perf_counter()

    def report() -> None:
        last = 0
        while not finished.wait(period):
            done = compiled_kernels(every)
            if done != last:
                say(progress_line(done, expected, time.perf_counter() - start))
                last = done

    thread = threading.Thread(target=report, name='warmup progress', daemon=True)
    thread.start()
    try:
        yield
    finally:
        finished.set()
        thread.join()


__all__ = ['FIRST_COMPILE', 'compiled_kernels', 'compiled_now', 'kernels',
           'loads_without_registries', 'progress', 'progress_line', 'without_blas_probe']
