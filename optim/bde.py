"""Binary DE alone, for the fault-mode estimator (Yu & Wang 2014, Sec. III-C: 'only part of AHDE
is used ... BDE with the adaptive law (26)').

Mutation (23), binomial crossover with CR_b = sin(pi/2 * IM) * rand (26), greedy selection. A mode
vector is short (one bit per mode variable), so the freeze of eq. (23) matters little here; a
small ``bit_flip`` probability is still offered and is on by default (0.02) to keep the search
alive when the population agrees early.
"""
from __future__ import annotations

import time

import numpy as np

from .ahde_paper import adaptive_rates, binary_mutation, improvement_measure
from .core import Counter, Result, binomial_crossover, end_generation, greedy_replace


def minimize(objective, n_bits: int, *, pop: int = 20, generations: int = 30, seed: int | None = 0,
             target: float | None = None, stagnation: int | None = 10, bit_flip: float = 0.02,
             callback=None) -> Result:
    """Minimise ``objective(real (pop,0), bits (pop,B))`` over B bits."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    cost_fn = Counter(objective)
    empty = np.zeros((pop, 0))
    bits = rng.random((pop, n_bits)) < 0.5
    cost = cost_fn(empty, bits)
    history = [float(cost.min())]
    im, stop = 1.0, "budget"
    for g in range(1, generations + 1):
        best = int(np.argmin(cost))
        _, cr_b, _ = adaptive_rates(rng, im, pop)
        trial = binomial_crossover(rng, bits, binary_mutation(rng, bits, best), cr_b).astype(bool)
        if bit_flip > 0:
            trial = trial ^ (rng.random(trial.shape) < bit_flip)
        trial_cost = cost_fn(empty, trial)
        (bits,), cost = greedy_replace((bits,), (trial,), cost, trial_cost)
        reason = end_generation(history, cost.min(), g, callback, target, stagnation)
        im = improvement_measure(history[-2], history[-1])
        if reason:
            stop = reason
            break
    best = int(np.argmin(cost))
    return Result(np.zeros(0), bits[best].copy(), float(cost[best]), history, cost_fn.evaluations,
                  len(history) - 1, time.perf_counter() - t0, cost_fn.seconds, stop)
