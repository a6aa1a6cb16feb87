"""Nelder-Mead: a downhill simplex without ``scipy.optimize``.

Why: importing ``scipy.optimize`` costs about 0.34 s of CPU (least of 5, after bgfdi's own imports)
in every process that touches it, and the diagnosis needs only its Nelder-Mead (the polish of a
degradation model's fit along a curved valley). This is the algorithm of scipy's
``_minimize_neldermead`` (scipy 1.17, ``scipy/optimize/_optimize.py``) step for step: the same
initial simplex (5 % of each nonzero coordinate, 0.00025 for a zero one, or ``initial_simplex``),
the same reflection, expansion, outside and inside contraction and shrink coefficients (Gao and
Han's adaptive ones with ``adaptive=True``), the same bounds handling (every trial point clipped; a
starting vertex above its upper bound reflected inside), the same stopping test (``xatol`` on every
vertex's distance to the best, ``fatol`` on every value's), the same ``maxiter``/``maxfev`` defaults
(200 per variable when neither is given) and the same sorts, so it returns the same ``x`` and
``fun`` as ``scipy.optimize.minimize(func, x0, method="Nelder-Mead", options=..., bounds=...)``
(``tests/test_simplex.py`` checks it against scipy on smooth, bounded, noisy and evaluation-limited
problems).

Not carried over: callbacks, ``return_all``, ``disp`` and scipy's warning for a start outside
the bounds (the start is clipped, as scipy does after warning).

>>> import numpy as np
>>> r = nelder_mead(lambda x: float((x[0] - 1) ** 2 + 10 * (x[1] + 0.5) ** 2), [0.0, 0.0],
...                 xatol=1e-8, fatol=1e-12)
>>> np.round(r.x, 6).tolist(), r.status
([1.0, -0.5], 0)
>>> nelder_mead(lambda x: float(x @ x), [2.0], bounds=[(0.5, None)]).x.tolist()
[0.5]
"""
from __future__ import annotations

from typing import Callable, NamedTuple, Sequence

import numpy as np

NONZERO_STEP = 0.05       # a nonzero start coordinate's vertex: (1 + 5 %) times it (scipy's nonzdelt)
ZERO_STEP = 0.00025       # a zero one's vertex: this value (scipy's zdelt)

MESSAGES = {0: "Optimization terminated successfully.",
            1: "Maximum number of function evaluations has been exceeded.",
            2: "Maximum number of iterations has been exceeded."}


class SimplexResult(NamedTuple):
    """The best vertex ``x`` and its value ``fun``; ``nfev`` evaluations in ``nit`` iterations;
    ``status`` 0 (converged), 1 (``maxfev`` reached) or 2 (``maxiter`` reached), as scipy's;
    the final simplex sorted by value (``simplex``, ``values``)."""
    x: np.ndarray
    fun: float
    nfev: int
    nit: int
    status: int
    simplex: np.ndarray
    values: np.ndarray

    @property
    def success(self) -> bool:
        return self.status == 0

    @property
    def message(self) -> str:
        return MESSAGES[self.status]


class _Spent(Exception):
    """The evaluation budget is spent (scipy's ``_MaxFuncCallError``)."""


def _bounds(bounds: Sequence | np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` float arrays of length n from (low, high) pairs, None for no bound."""
    pairs = list(bounds)
    if len(pairs) != n:
        raise ValueError(f"Nelder-Mead: {len(pairs)} bounds for {n} variables")
    lo = np.array([-np.inf if p[0] is None else float(p[0]) for p in pairs])
    hi = np.array([np.inf if p[1] is None else float(p[1]) for p in pairs])
    if (lo > hi).any():
        raise ValueError("Nelder-Mead: a lower bound is greater than its upper bound")
    return lo, hi


def nelder_mead(func: Callable[[np.ndarray], float], x0: Sequence[float] | np.ndarray, *,
                initial_simplex: np.ndarray | None = None, xatol: float = 1e-4, fatol: float = 1e-4,
                maxiter: float | None = None, maxfev: float | None = None, adaptive: bool = False,
                bounds: Sequence | np.ndarray | None = None) -> SimplexResult:
    """Minimise the scalar ``func(x)`` from ``x0`` by Nelder-Mead, as
    ``scipy.optimize.minimize(func, x0, method="Nelder-Mead", bounds=bounds, options={...})``
    with these options does (module docstring). ``func`` receives a copy of each point."""
    x0 = np.atleast_1d(x0).flatten()
    dtype = x0.dtype if np.issubdtype(x0.dtype, np.inexact) else np.float64
    x0 = np.asarray(x0, dtype=dtype)
    if adaptive:
        dim = float(len(x0))
        rho, chi, psi, sigma = 1, 1 + 2 / dim, 0.75 - 1 / (2 * dim), 1 - 1 / dim
    else:
        rho, chi, psi, sigma = 1, 2, 0.5, 0.5
    lower = upper = None
    if bounds is not None:
        lower, upper = _bounds(bounds, len(x0))
        x0 = np.clip(x0, lower, upper)
    if initial_simplex is None:
        n = len(x0)
        sim = np.empty((n + 1, n), dtype=x0.dtype)
        sim[0] = x0
        for k in range(n):
            y = np.array(x0, copy=True)
            y[k] = (1 + NONZERO_STEP) * y[k] if y[k] != 0 else ZERO_STEP
            sim[k + 1] = y
    else:
        sim = np.atleast_2d(initial_simplex).copy()
        sim = np.asarray(sim, dtype=sim.dtype if np.issubdtype(sim.dtype, np.inexact) else np.float64)
        if sim.ndim != 2 or sim.shape[0] != sim.shape[1] + 1:
            raise ValueError("Nelder-Mead: initial_simplex must have shape (N + 1, N)")
        if len(x0) != sim.shape[1]:
            raise ValueError("Nelder-Mead: initial_simplex does not match the length of x0")
        n = sim.shape[1]
    if maxiter is None and maxfev is None:
        maxiter = maxfev = n * 200
    elif maxiter is None:
        maxiter = n * 200 if maxfev == np.inf else np.inf
    elif maxfev is None:
        maxfev = n * 200 if maxiter == np.inf else np.inf
    if bounds is not None:
        # a vertex above its upper bound is reflected inside, then every vertex clipped
        sim = np.clip(np.where(sim > upper, 2 * upper - sim, sim), lower, upper)

    calls = 0

    def f(x: np.ndarray) -> float:
        nonlocal calls
        if calls >= maxfev:
            raise _Spent
        calls += 1
        fx = func(np.copy(x))
        if not np.isscalar(fx):
            try:
                fx = np.asarray(fx).item()
            except (TypeError, ValueError) as e:
                raise ValueError("Nelder-Mead: the objective must return a scalar") from e
        return fx

    def clip(x: np.ndarray) -> np.ndarray:
        return x if bounds is None else np.clip(x, lower, upper)

    fsim = np.full((n + 1,), np.inf, dtype=float)
    try:
        for k in range(n + 1):
            fsim[k] = f(sim[k])
    except _Spent:
        pass
    finally:
        ind = np.argsort(fsim)
        sim, fsim = np.take(sim, ind, 0), np.take(fsim, ind, 0)
    ind = np.argsort(fsim)
    fsim = np.take(fsim, ind, 0)
    sim = np.take(sim, ind, 0)

    iterations = 1
    while calls < maxfev and iterations < maxiter:
        try:
            if (np.max(np.ravel(np.abs(sim[1:] - sim[0]))) <= xatol
                    and np.max(np.abs(fsim[0] - fsim[1:])) <= fatol):
                break
            xbar = np.add.reduce(sim[:-1], 0) / n
            xr = clip((1 + rho) * xbar - rho * sim[-1])
            fxr = f(xr)
            shrink = False
            if fxr < fsim[0]:
                xe = clip((1 + rho * chi) * xbar - rho * chi * sim[-1])
                fxe = f(xe)
                if fxe < fxr:
                    sim[-1], fsim[-1] = xe, fxe
                else:
                    sim[-1], fsim[-1] = xr, fxr
            elif fxr < fsim[-2]:
                sim[-1], fsim[-1] = xr, fxr
            else:
                if fxr < fsim[-1]:              # outside contraction
                    xc = clip((1 + psi * rho) * xbar - psi * rho * sim[-1])
                    fxc = f(xc)
                    if fxc <= fxr:
                        sim[-1], fsim[-1] = xc, fxc
                    else:
                        shrink = True
                else:                           # inside contraction
                    xcc = clip((1 - psi) * xbar + psi * sim[-1])
                    fxcc = f(xcc)
                    if fxcc < fsim[-1]:
                        sim[-1], fsim[-1] = xcc, fxcc
                    else:
                        shrink = True
                if shrink:
                    for j in range(1, n + 1):
                        sim[j] = clip(sim[0] + sigma * (sim[j] - sim[0]))
                        fsim[j] = f(sim[j])
            iterations += 1
        except _Spent:
            pass
        ind = np.argsort(fsim)
        sim, fsim = np.take(sim, ind, 0), np.take(fsim, ind, 0)

    status = 1 if calls >= maxfev else 2 if iterations >= maxiter else 0
    return SimplexResult(x=sim[0], fun=np.min(fsim), nfev=calls, nit=iterations, status=status,
                         simplex=sim, values=fsim)
