"""The Dormand–Prince 8(5,3) tableau the compiled DOP853 (:mod:`.dop853`) steps with: the
published coefficients, taken at import from SciPy's private
``scipy.integrate._ivp.dop853_coefficients``, and an ImportError naming it when an
upgrade of SciPy moved it.

That module is data and imports only NumPy, but importing it by name imports the whole
``scipy.integrate`` package first (its quadratures, ``scipy.special``, ``scipy.sparse``,
``scipy.optimize``), which ``check_run`` never uses: so it is loaded from its file in
SciPy's installed tree, without the packages above it. When ``scipy.integrate`` is
imported already (or an import of the module is blocked in ``sys.modules``), the import
system's answer is taken instead, so there is one source either way.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

#: SciPy's private module of the tableau, and the names taken from it.
TABLEAU_MODULE = 'scipy.integrate._ivp.dop853_coefficients'
TABLEAU_NAMES = ('N_STAGES', 'A', 'B', 'C', 'E3', 'E5')


def _tableau_file() -> Path | None:
    """The tableau module's source file in SciPy's installed tree, without importing
    SciPy (None when SciPy is not installed as a directory of sources)."""
    spec = importlib.util.find_spec('scipy')
    roots = [] if spec is None else list(spec.submodule_search_locations or [])
    for root in roots:
        path = Path(root, *TABLEAU_MODULE.split('.')[1:]).with_suffix('.py')
        if path.is_file():
            return path
    return None


def _load_tableau() -> ModuleType:
    """SciPy's tableau module: by name when the import system already holds it (or
    blocks it), else from its file; ImportError when neither finds it."""
    if TABLEAU_MODULE in sys.modules or 'scipy.integrate' in sys.modules:
        return importlib.import_module(TABLEAU_MODULE)
    path = _tableau_file()
    if path is None:        # not a tree of sources: the import system may still know it
        return importlib.import_module(TABLEAU_MODULE)
    spec = importlib.util.spec_from_file_location(TABLEAU_MODULE, path)
    if spec is None or spec.loader is None:
        raise ImportError(f'no loader for {path}')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _scipy_version() -> str:
    """The installed SciPy's version, for the message (the imported one's if any)."""
    if getattr(sys.modules.get('scipy'), '__version__', None):
        return str(sys.modules['scipy'].__version__)
    import importlib.metadata  # only for the message
    try:
        return importlib.metadata.version('scipy')
    except importlib.metadata.PackageNotFoundError:
        return '(not installed)'


try:
    _tableau = _load_tableau()
    _missing = [name for name in TABLEAU_NAMES if not hasattr(_tableau, name)]
except ImportError as _error:
    _missing = [f'the module ({_error})']
if _missing:
    # Private to SciPy: an upgrade may move it; say so instead of an AttributeError.
    raise ImportError(
        f"screwgear_ros's DOP853 takes its tableau from SciPy's private {TABLEAU_MODULE}, "
        f'and SciPy {_scipy_version()} lacks {", ".join(_missing)}. Install the versions '
        'in constraints.txt (pip install -c constraints.txt ...), or adapt '
        'screwgear_ros/numerics/dop853_tableau.py.')

#: Stages of the 8th-order step (the 13th evaluation is f at the new point, reused).
N_STAGES = _tableau.N_STAGES
#: The tableau (C nodes, A coupling, B weights, E3/E5 error weights incl. the new point).
A = np.ascontiguousarray(_tableau.A[:N_STAGES, :N_STAGES], dtype=np.float64)
B = np.ascontiguousarray(_tableau.B, dtype=np.float64)
C = np.ascontiguousarray(_tableau.C[:N_STAGES], dtype=np.float64)
E3 = np.ascontiguousarray(_tableau.E3, dtype=np.float64)
E5 = np.ascontiguousarray(_tableau.E5, dtype=np.float64)
#: The tableau as :func:`integrate` takes it: A, B, C, E3, E5.
Tableau = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
TABLEAU: Tableau = (A, B, C, E3, E5)


__all__ = [
    'E3',
    'E5',
    'N_STAGES',
    'TABLEAU',
    'TABLEAU_MODULE',
    'TABLEAU_NAMES',
    'A',
    'B',
    'C',
    'Tableau',
]
