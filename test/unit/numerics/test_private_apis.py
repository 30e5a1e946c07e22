"""The private APIs of dependencies the package relies on are still there, and the
package says so clearly when an upgrade removes them.

* SciPy's ``scipy.integrate._ivp.dop853_coefficients``: the DOP853 tableau of
  :mod:`screwgear_ros.numerics.dop853`;
* numba's ``_nrt`` compile option: the kernels without reference counting of
  :mod:`screwgear_ros.physics.jit`.

A failure here names the API and the versions the suite passed with (constraints.txt),
so an upgrade that breaks one is caught by name, not by a wrong number elsewhere.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from paths import ROOT

CONSTRAINTS = ROOT / 'constraints.txt'


def pinned(package: str) -> str:
    """The version constraints.txt pins ``package`` to."""
    for line in CONSTRAINTS.read_text().splitlines():
        name, _, version = line.split('#')[0].strip().partition('==')
        if name.lower() == package.lower():
            return version
    raise AssertionError(f'constraints.txt pins no {package}')


def broken(api: str, package: str, detail: object) -> str:
    """The failure message: which private API, installed and pinned versions."""
    module = __import__(package)
    return (f'private API {api} of {package} {module.__version__} is gone or changed '
            f'({detail}); the suite passed with {package}=={pinned(package)} '
            '(constraints.txt)')


def test_scipy_dop853_coefficients():
    """The tableau's names, shapes and the order conditions that make it DOP853's:
    weights summing to 1, each row of A summing to its node, the order-5 error
    weights annihilating constants."""
    api = 'scipy.integrate._ivp.dop853_coefficients'
    try:
        from scipy.integrate._ivp import dop853_coefficients as t
    except ImportError as error:
        pytest.fail(broken(api, 'scipy', error))
    missing = [n for n in ('N_STAGES', 'A', 'B', 'C', 'E3', 'E5') if not hasattr(t, n)]
    assert not missing, broken(api, 'scipy', f'no {missing}')
    n = t.N_STAGES
    assert n == 12, broken(api, 'scipy', f'N_STAGES {n}')
    a, b, c = np.asarray(t.A)[:n, :n], np.asarray(t.B), np.asarray(t.C)[:n]
    assert b.shape == (n,) and len(t.E3) == len(t.E5) == n + 1, broken(api, 'scipy', 'shapes')
    assert abs(b.sum() - 1.0) < 1e-14, broken(api, 'scipy', f'sum(B) = {b.sum()}')
    assert np.allclose(a.sum(axis=1), c, rtol=0, atol=1e-14), broken(api, 'scipy', 'A, C')
    assert abs(np.sum(t.E5)) < 1e-14, broken(api, 'scipy', f'sum(E5) = {np.sum(t.E5)}')


def test_numba_nrt_option():
    """``_nrt=False`` still compiles a kernel without numba's reference counting: the
    same kernels keep the counts without it (the control that the check can fail). A
    call from one kernel to another counts its array argument up and down."""
    from numba import njit

    x = np.array([1.0, 0.0, 2.0])

    def llvm(**options) -> str:
        @njit(cache=False, **options)
        def signed(x, i):
            return x[i] if x[i] > 0.5 else -x[i]

        @njit(cache=False, **options)
        def total(x, n):
            s = 0.0
            for i in range(n):
                s += signed(x, i % 3)
            return s

        assert total(x, 3) == 3.0
        return next(iter(total.inspect_llvm().values()))

    try:
        without = llvm(_nrt=False)
    except Exception as error:  # noqa: BLE001 - any failure says the private API moved
        pytest.fail(broken("the compile option '_nrt'", 'numba', error))
    assert 'NRT_incref' in llvm(), 'the control kernel counts no reference: check is void'
    assert 'NRT_incref' not in without, broken("the compile option '_nrt'", 'numba',
                                                'the kernel still counts references')


@pytest.mark.ros
def test_the_tableau_is_scipys_without_importing_scipy_integrate():
    """The tableau is loaded from SciPy's file, not by importing ``scipy.integrate``
    (which check_run does not use), and holds SciPy's coefficients bit for bit."""
    script = ('import sys, numpy as np\n'
              'import screwgear_ros.numerics.dop853_tableau as t\n'
              "print('scipy.integrate' in sys.modules)\n"
              'from scipy.integrate._ivp import dop853_coefficients as s\n'
              'n = s.N_STAGES\n'
              'print(n == t.N_STAGES and all(np.array_equal(a, b) for a, b in ('
              '(t.A, s.A[:n, :n]), (t.B, s.B), (t.C, s.C[:n]), (t.E3, s.E3), (t.E5, s.E5))))\n')
    proc = subprocess.run([sys.executable, '-P', '-c', script], capture_output=True,
                          text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ['False', 'True'], proc.stdout


# The children make the installed numba or SciPy look like an upgrade that dropped the
# API, then import the package's module that uses it: SciPy's module blocked by name,
# or a SciPy tree (first on the path) without the module's file.
SCIPY_GONE = '''
import sys
sys.modules['scipy.integrate._ivp.dop853_coefficients'] = None
import screwgear_ros.numerics.dop853
'''
SCIPY_MOVED = '''
import pathlib, sys, tempfile
root = pathlib.Path(tempfile.mkdtemp())
(root / 'scipy' / 'integrate' / '_ivp').mkdir(parents=True)
(root / 'scipy' / '__init__.py').write_text("__version__ = '99.0.0'")
(root / 'scipy' / 'integrate' / '__init__.py').write_text('')
(root / 'scipy' / 'integrate' / '_ivp' / '__init__.py').write_text('')
sys.path.insert(0, str(root))
import screwgear_ros.numerics.dop853
'''
NRT_GONE = '''
from numba.core import options
del options.DefaultOptions._nrt
import numba.core.cpu as cpu
for cls in cpu.CPUTargetOptions.__mro__:
    if '_nrt' in vars(cls):
        delattr(cls, '_nrt')
import screwgear_ros.physics.jit
'''


@pytest.mark.ros
@pytest.mark.parametrize('script, names', [
    (SCIPY_GONE, ['scipy.integrate._ivp.dop853_coefficients', 'constraints.txt']),
    (SCIPY_MOVED, ['scipy.integrate._ivp.dop853_coefficients', 'constraints.txt']),
    (NRT_GONE, ["'_nrt'", 'numba', 'constraints.txt']),
], ids=['scipy_dop853_coefficients', 'scipy_dop853_coefficients_file', 'numba_nrt'])
def test_the_package_names_a_missing_private_api(script, names):
    proc = subprocess.run([sys.executable, '-P', '-c', script], capture_output=True,
                          text=True, timeout=300, check=False)
    assert proc.returncode != 0, 'the import went on without the private API'
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith('ImportError: screwgear_ros'), proc.stderr[-2000:]
    for name in names:
        assert name in last, last
