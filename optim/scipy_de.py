"""scipy.optimize.differential_evolution as an outside reference, on the same budget.

Bits are integer variables in [0, 1] (``integrality``); the population is vectorised
(``vectorized=True``, x of shape (D, S)); no final polishing, so the evaluations are those of the
evolution only. scipy sizes its population as popsize * D: popsize is chosen to match ``pop``.
"""
from __future__ import annotations

import time

import numpy as np

from .core import Counter, Result, check_bounds


def minimize(objective, bounds, n_bits: int = 0, *, pop: int = 150, generations: int = 300, seed: int | None = 0,
             callback=None, **_ignored) -> Result:
    from scipy.optimize import differential_evolution     # here: importing scipy.optimize takes 0.4 s

    t0 = time.perf_counter()
    bounds = check_bounds(bounds)
    nr = bounds.shape[0]
    counter = Counter(objective)
    d = nr + n_bits
    full = [tuple(b) for b in bounds] + [(0.0, 1.0)] * n_bits
    history: list[float] = []

    def f(x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(x.T) if x.ndim == 2 else x[None, :]
        c = counter(x[:, :nr], np.rint(x[:, nr:]).astype(bool))
        return c

    def track(intermediate_result):
        history.append(float(intermediate_result.fun))
        if callback:
            callback(len(history), history[-1])

    res = differential_evolution(f, full, popsize=max(1, int(round(pop / d))), maxiter=generations, seed=seed,
                                 polish=False, tol=0, atol=0, vectorized=True, updating="deferred",
                                 integrality=[False] * nr + [True] * n_bits, callback=track, init="random")
    x = np.asarray(res.x)
    return Result(x[:nr], np.rint(x[nr:]).astype(bool), float(res.fun), history, counter.evaluations,
                  len(history), time.perf_counter() - t0, counter.seconds, "budget")
