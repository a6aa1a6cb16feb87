"""Which implementation runs the objective's generic heavy parts: numba's, when it is installed
(the ``fast`` extra) and not switched off, else numpy's.

The parts are the ones a profile of identification names and that do not depend on the model:
eq. (19)'s RK4 over the population (a Python loop of ~100 steps of ~40 numpy calls on (pop,)
arrays, ~4 ms per call), eq. (17) and eq. (15)'s profiles (one pass instead of ten over
(pop, samples) arrays; eq. 15's sign of a sine read from the phase's half-period), eqs. (16) and
(18) but their exponentials (numpy's, taken in place between two compiled passes), and the
weighted median that solves a linear fault's magnitude. Both paths give the same numbers
(tests/test_kernels.py: equal arrays, and 1e-9 relative on the objective's costs on random
populations); nothing whose last bits would differ is compiled: the filter's sums (numpy's are
BLAS's) and the exponentials and sines of eqs. (16), (18) and of the ARRs (numpy's are SIMD
code), since the Coulomb terms' sign of a filtered derivative turns 1e-15 into 3e-5 of a cost. The
model-specific part, the ARR expressions, stays in numpy (a JIT per model would cost each process
seconds: CI runs ~1000 tests in many processes).

``BGFDI_NUMBA=0`` in the environment, or ``use_numba(False)``, selects the numpy path (the
reference the tests compare with). The compiled code is cached on disk by numba (``cache=True``;
``NUMBA_CACHE_DIR`` where the package directory is read-only): the first process on a machine
compiles (about 2 s), later ones load it.

>>> before = use_numba(False)
>>> enabled()
False
>>> _ = use_numba(before)
"""
from __future__ import annotations

from types import ModuleType


def _switch() -> ModuleType:
    """:mod:`optim.kernels`, which holds the one switch for both packages' compiled code (imported
    when first asked: the optim package brings its engines)."""
    from optim import kernels
    return kernels


def use_numba(on: bool) -> bool:
    """Switch the numba path on or off (for this process, the engines' DE arithmetic too);
    returns whether it was in use before."""
    before = enabled()
    _switch().use_numba(on)
    return before


def enabled() -> bool:
    """True when the compiled kernels run (numba importable and not switched off)."""
    return jit() is not None


def jit() -> ModuleType | None:
    """:mod:`fdi._jit` (numba imported on first use, not at start-up), or None without numba or
    switched off (then numba is not even imported)."""
    return _switch().compiled("fdi._jit")
