"""scipy.optimize.differential_evolution as an outside reference, on the same budget.

Bits are integer variables in [0, 1] (``integrality``); the population is vectorised
(``vectorized=True``, x of shape (D, S)); no final polishing, so the evaluations are those of the
evolution only. scipy sizes its population as popsize * D: popsize is chosen to match ``pop``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core import Engine, Options, Result, Solver


@dataclass(frozen=True)
class ScipyDEOptions(Options):
    """scipy's own settings are fixed (no polish, tol 0, deferred updating, random init): a reference
    on the same budget, not a tuned engine."""


class ScipyDE(Solver):
    """scipy's loop runs the generations, so ``solve`` calls it."""

    def solve(self) -> Result:
        from scipy.optimize import differential_evolution     # here: importing scipy.optimize takes 0.4 s

        o, nr, nb = self.options, self.bounds.shape[0], self.n_bits
        d = nr + nb
        full = [tuple(b) for b in self.bounds] + [(0.0, 1.0)] * nb

        def f(x: np.ndarray) -> np.ndarray:
            x = np.atleast_2d(x.T) if x.ndim == 2 else x[None, :]
            return self.counter(x[:, :nr], np.rint(x[:, nr:]).astype(bool))

        def track(intermediate_result) -> None:
            self.history.append(float(intermediate_result.fun))
            if o.callback:
                o.callback(len(self.history), self.history[-1])

        res = differential_evolution(f, full, popsize=max(1, int(round(o.pop / d))), maxiter=o.generations,
                                     seed=o.seed, polish=False, tol=0, atol=0, vectorized=True, updating="deferred",
                                     integrality=[False] * nr + [True] * nb, callback=track, init="random")
        x = np.asarray(res.x)
        return self.make_result(x[:nr], np.rint(x[nr:]).astype(bool), res.fun, generations=len(self.history))


ENGINE = Engine("scipy-DE", ScipyDE, ScipyDEOptions)
