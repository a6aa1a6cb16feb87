"""L-SHADE: success-history adaptive DE with linear population size reduction.

R. Tanabe and A. Fukunaga, "Improving the search performance of SHADE using linear population
size reduction", IEEE CEC 2014. current-to-pbest/1/bin with an external archive; F and CR drawn
around H memory cells (Cauchy / normal, scale 0.1) that learn from the successful values
(weighted Lehmer means); the population shrinks linearly from its initial size to 4 over the
budget. Bounds: midpoint repair towards the parent.

Bits are evolved as random keys: each bit is a real key in [0, 1] in the same vector, read as
``key > 0.5``; groups of bits that must be one-hot (``onehot``) are read as the argmax of their
keys, so they are always valid and every option stays reachable (no bias, no freezing).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .core import Engine, Result, Solver, Stopping, binomial_crossover, end_generation, repair_midpoint

TERMINAL = -1.0


def keys_to_bits(keys: np.ndarray, onehot: Sequence[Sequence[int]] = ()) -> np.ndarray:
    """Random keys (pop, B) -> bits; each one-hot group set at the argmax of its keys."""
    bits = keys > 0.5
    for group in onehot:
        g = np.asarray(group)
        bits[:, g] = False
        bits[np.arange(keys.shape[0]), g[np.argmax(keys[:, g], axis=1)]] = True
    return bits


def lehmer(values: np.ndarray, weights: np.ndarray) -> float:
    return float(np.sum(weights * values ** 2) / max(np.sum(weights * values), 1e-300))


def run(cost: Callable[[np.ndarray], np.ndarray], bounds: np.ndarray, rng: np.random.Generator, *,
        pop: int, max_evals: int, init: np.ndarray | None = None, pop_min: int = 4, memory: int = 6,
        p_best: float = 0.11, archive_rate: float = 2.6, history: list[float] | None = None,
        target: float | None = None, stagnation: int | None = None, callback=None) -> tuple[np.ndarray, np.ndarray, str]:
    """The L-SHADE loop on a real vector; returns the final population, its costs and the stop reason."""
    d = bounds.shape[0]
    lo, hi = bounds[:, 0], bounds[:, 1]
    x = lo + rng.random((pop, d)) * (hi - lo)
    if init is not None and len(init):
        # a refinement: the starting points, and half the population drawn around them (5 % of
        # each range), the other half uniform to keep the search global
        starts = np.clip(np.atleast_2d(init)[:pop], lo, hi)
        k = len(starts)
        x[:k] = starts
        near = np.arange(k, max(k, pop // 2))
        if near.size:
            x[near] = np.clip(starts[near % k] + 0.05 * (hi - lo) * rng.standard_normal((near.size, d)), lo, hi)
    f = cost(x)
    nfe = pop
    history = history if history is not None else []
    history.append(float(f.min()))
    m_f, m_cr = np.full(memory, 0.5), np.full(memory, 0.5)
    k = 0
    archive = np.empty((0, d))
    stop = "budget"
    gen = 0
    while nfe + x.shape[0] <= max_evals:
        gen += 1
        n = x.shape[0]
        r = rng.integers(0, memory, n)
        cr = np.where(m_cr[r] == TERMINAL, 0.0, np.clip(rng.normal(m_cr[r], 0.1), 0.0, 1.0))
        fv = m_f[r] + 0.1 * np.tan(np.pi * (rng.random(n) - 0.5))
        bad = fv <= 0
        while np.any(bad):
            fv[bad] = m_f[r[bad]] + 0.1 * np.tan(np.pi * (rng.random(bad.sum()) - 0.5))
            bad = fv <= 0
        fv = np.minimum(fv, 1.0)
        order = np.argsort(f)
        top = max(2, int(round(p_best * n)))
        pbest = order[rng.integers(0, top, n)]
        r1 = (np.arange(n) + rng.integers(1, n, n)) % n                      # != i
        pool = np.vstack([x, archive]) if len(archive) else x
        r2 = rng.integers(0, len(pool), n)
        clash = (r2 == np.arange(n)) | (r2 == r1)
        for _ in range(8):
            if not clash.any():
                break
            r2[clash] = rng.integers(0, len(pool), clash.sum())
            clash = (r2 == np.arange(n)) | (r2 == r1)
        v = x + fv[:, None] * (x[pbest] - x) + fv[:, None] * (x[r1] - pool[r2])
        u = repair_midpoint(binomial_crossover(rng, x, v, cr), x, bounds)
        fu = cost(u)
        nfe += n
        improved = fu < f
        if improved.any():
            archive = np.vstack([archive, x[improved]])
            df = f[improved] - fu[improved]
            df = np.where(np.isfinite(df), df, 1.0)
            w = df / df.sum() if df.sum() > 0 else np.full(df.size, 1.0 / df.size)
            m_f[k] = lehmer(fv[improved], w)
            s_cr = cr[improved]
            m_cr[k] = TERMINAL if (m_cr[k] == TERMINAL or s_cr.max() == 0) else lehmer(s_cr, w)
            k = (k + 1) % memory
        keep = fu <= f
        x[keep], f[keep] = u[keep], fu[keep]
        n_next = max(pop_min, int(round(pop + (pop_min - pop) * nfe / max_evals)))
        if n_next < n:
            best = np.argsort(f)[:n_next]
            x, f = x[best], f[best]
        cap = int(round(archive_rate * x.shape[0]))
        if len(archive) > cap:
            archive = archive[rng.choice(len(archive), cap, replace=False)]
        reason = end_generation(history, f.min(), gen, callback, target, stagnation)
        if reason:
            stop = reason
            break
    return x, f, stop


@dataclass(frozen=True)
class SHADEOptions(Stopping):
    """L-SHADE's constants are Tanabe & Fukunaga's (CEC 2014)."""
    pop_min: int = 4                        # the population shrinks linearly to this at the end of the budget
    memory: int = 6                         # H, the success-history memory cells of F and CR
    p_best: float = 0.11                    # current-to-pbest/1 draws its pbest from this best share
    archive_rate: float = 2.6               # the archive of replaced parents holds this many times the population


class SHADE(Solver):
    """L-SHADE over the reals and the bit keys, budget pop * (generations + 1) evaluations. Its
    generations run in ``run`` (shared with AHDE-joint's refinements), so ``solve`` calls it."""

    def solve(self) -> Result:
        o, nr, onehot = self.options, self.bounds.shape[0], self.problem.onehot
        full = np.vstack([self.bounds, np.tile([0.0, 1.0], (self.n_bits, 1))]) if self.n_bits else self.bounds
        cost = lambda z: self.counter(z[:, :nr], keys_to_bits(z[:, nr:], onehot))
        x, f, self.stop = run(cost, full, self.rng, pop=o.pop, max_evals=o.pop * (o.generations + 1), pop_min=o.pop_min,
                              memory=o.memory, p_best=o.p_best, archive_rate=o.archive_rate, history=self.history,
                              target=o.target, stagnation=o.stagnation, callback=o.callback)
        best = int(np.argmin(f))
        return self.make_result(x[best, :nr].copy(), keys_to_bits(x[best:best + 1, nr:], onehot)[0], f[best])


ENGINE = Engine("SHADE", SHADE, SHADEOptions)
