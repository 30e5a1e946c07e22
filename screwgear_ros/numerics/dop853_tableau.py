"""The Dormand–Prince 8(5,3) tableau the compiled DOP853 (:mod:`.dop853`) steps with: the
published coefficients, taken at import from SciPy's private
``scipy.integrate._ivp.dop853_coefficients``, and an ImportError naming it when an
upgrade of SciPy moved it.
"""

from __future__ import annotations

import numpy as np
import scipy

#: SciPy's private module of the tableau, and the names taken from it.
TABLEAU_MODULE = 'scipy.integrate._ivp.dop853_coefficients'
TABLEAU_NAMES = ('N_STAGES', 'A', 'B', 'C', 'E3', 'E5')
try:
    from scipy.integrate._ivp import dop853_coefficients as _tableau
    _missing = [name for name in TABLEAU_NAMES if not hasattr(_tableau, name)]
except ImportError as _error:
    _missing = [f'the module ({_error})']
if _missing:
    # Private to SciPy: an upgrade may move it; say so instead of an AttributeError.
    raise ImportError(
        f"screwgear_ros's DOP853 takes its tableau from SciPy's private {TABLEAU_MODULE}, "
        f'and SciPy {scipy.__version__} lacks {", ".join(_missing)}. Install the versions '
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
