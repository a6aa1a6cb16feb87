"""Which implementation runs the objective's generic heavy parts: C built once per machine
(:mod:`optim.native`, ``fdi/kernels.c``), numba's (the ``fast`` extra), or numpy's; the one switch
is :mod:`optim.kernels` (``BGFDI_KERNELS``: auto, c, numba, numpy).

The parts are the ones a profile of identification names and that do not depend on the model:
eq. (19)'s RK4 over the population (a Python loop of ~100 steps of ~40 numpy calls on (pop,)
arrays, ~4 ms per call), eq. (17) and eq. (15)'s profiles (one pass instead of ten over
(pop, samples) arrays; eq. 15's sign of a sine read from the phase's half-period), eqs. (16) and
(18) (with the kernels' own exponential, written to vectorise: :func:`fdi.profiles._exp`), the weighted
median that solves a linear fault's magnitude, an intermittent fault's square wave as the
smoothing filter sees it (:func:`fdi.derivatives.edges_seen`: a solved fault's unit step; 100
rows 5.2 -> 0.4 ms), and the fused objective (:mod:`fdi.fused`). All
paths give the same numbers (tests/test_kernels.py: equal arrays, and 1e-9 relative on the
objective's costs on random populations; C and numba equal to the bit): the filter's sums are
numpy's order, not BLAS's, since the Coulomb terms' sign of a filtered derivative turns 1e-15 into
3e-5 of a cost; the exponentials of eqs. (16), (18) are the kernels' own, within 1 ulp of the
correctly rounded value (numpy's SIMD exponential differs from either in the last bit). The model-specific part, the ARR expressions, runs as tapes (:mod:`fdi.tape`) in the
generic kernel: no compilation per model.

Built C libraries are kept in bgfdi's disk cache (:mod:`fdi.diskcache`: signed entries in a
private folder), so only the first process on a machine runs the compiler (about a second);
numba keeps its machine code on disk too (``NUMBA_CACHE_DIR`` where the package directory is
read-only).

>>> before = use_numba(False)
>>> enabled()
False
>>> _ = use_numba(before)
"""
from __future__ import annotations

from types import ModuleType


_optim: tuple | None = None     # (optim.kernels, optim.native) once imported


def _switch() -> ModuleType:
    """:mod:`optim.kernels`, which holds the one switch for both packages' compiled code (imported
    when first asked: the optim package brings its engines), with the disk cache as the store of
    built C libraries. (The modules kept after the first call: every objective call asks, and
    three import statements cost ~3 us.)"""
    global _optim
    if _optim is None:
        from optim import kernels, native
        _optim = (kernels, native)
    kernels, native = _optim
    if native._store is None:
        from . import diskcache
        native.use_store(diskcache)         # fetch, store, ready: optim.native.Store's protocol
    return kernels


def use_numba(on: bool) -> bool:
    """Switch the numba path on or off (for this process, the engines' DE arithmetic too);
    returns whether it was in use before."""
    before = enabled()
    _switch().use_numba(on)
    return before


def enabled() -> bool:
    """True when compiled kernels run (C or numba)."""
    return jit() is not None


def jit() -> ModuleType | None:
    """:mod:`fdi._native` (C) or :mod:`fdi._jit` (numba, imported on first use, not at start-up), or
    None on the numpy path (then neither is loaded)."""
    return _switch().compiled("fdi")


def cheap() -> bool:
    """Whether :func:`jit` spares this process numba's start (loaded already, or C: ~75 ms the
    first time), so that small work may run compiled once it has cost that much
    (:func:`optim.kernels.cheap`)."""
    return _switch().cheap("fdi")


def use(path: str) -> str:
    """Choose the kernels' path for this process (``auto``, ``c``, ``numba``, ``numpy``); returns
    the one chosen before (:func:`optim.kernels.use`)."""
    return _switch().use(path)


def path() -> str:
    """The path that runs: ``c``, ``numba`` or ``numpy``."""
    jit()
    return _switch().path()


def available() -> list[str]:
    """The compiled paths this machine can run (:func:`optim.kernels.available`)."""
    return _switch().available()
