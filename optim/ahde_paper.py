"""AHDE exactly as Yu & Wang (2014) give it (Sec. III-C, eqs. 20-28): used to reproduce Table VI.

Real part, DE/best/1/bin: V = X_best + F_r (X_r1 - X_r2) (20), binomial crossover with CR_r and a
forced index j_rand (21), greedy selection f(H) > f(X) (22). Binary part, on the same individuals
and the same fitness: V = X_best OR (F_b AND (X_r1 XOR X_r2)) with F_b a random bit vector (23),
the same crossover with CR_b. Adaptation (25)-(28): with s = sin(pi/2 * IM) and
IM = F_best(G-1) / F_best(G), CR_r = s*rand, CR_b = s*rand, F_r = 2*s*rand; ``rand`` is drawn per
individual and generation (the paper does not say; per individual is the usual DE reading).
IM = 1 in the first generation. Bounds: a coordinate that leaves its interval goes half-way
back to its parent (repair_midpoint).

Known weakness, kept on purpose (``bit_flip`` = 0 here): eq. (23) can only *set* bits, and once
the bit population agrees every XOR is 0, so the discrete part freezes. ``optim.ahde`` measures
and fixes it.
"""
from __future__ import annotations

import time

import numpy as np

from .core import (Counter, Result, binomial_crossover, check_bounds, distinct_indices, end_generation,
                   greedy_replace, init_population, repair_midpoint)


def adaptive_rates(rng: np.random.Generator, im: float, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eqs. (25)-(27): CR_r, CR_b in [0, s], F_r in [0, 2s], s = sin(pi/2 * IM)."""
    s = np.sin(np.pi / 2 * float(np.clip(im, 0.0, 1.0)))
    return s * rng.random(size), s * rng.random(size), 2 * s * rng.random(size)


def improvement_measure(best_prev: float, best_now: float, eps: float = 1e-12) -> float:
    """Eq. (28) with fitness = 1/(cost + eps): IM = F_best(G-1)/F_best(G) = (c_G + eps)/(c_G-1 + eps)."""
    return (best_now + eps) / (best_prev + eps)


def real_mutation(rng: np.random.Generator, real: np.ndarray, best: int, f: np.ndarray) -> np.ndarray:
    """Eq. (20), DE/best/1."""
    r = distinct_indices(rng, real.shape[0], 2)
    return real[best] + f[:, None] * (real[r[:, 0]] - real[r[:, 1]])


def binary_mutation(rng: np.random.Generator, bits: np.ndarray, best: int) -> np.ndarray:
    """Eq. (23): X_best OR (F_b AND (X_r1 XOR X_r2)), F_b a fresh random bit vector per individual."""
    r = distinct_indices(rng, bits.shape[0], 2)
    fb = rng.random(bits.shape) < 0.5
    return bits[best] | (fb & (bits[r[:, 0]] ^ bits[r[:, 1]]))


def minimize(objective, bounds, n_bits: int = 0, *, pop: int = 150, generations: int = 300, seed: int | None = 0,
             target: float | None = None, stagnation: int | None = None, bit_flip: float = 0.0,
             callback=None, **_ignored) -> Result:
    """Run the paper's AHDE; ``bit_flip`` > 0 adds a bit-flip mutation (not in the paper)."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    bounds = check_bounds(bounds)
    cost_fn = Counter(objective)
    real, bits = init_population(rng, bounds, n_bits, pop)
    cost = cost_fn(real, bits)
    history = [float(cost.min())]
    im = 1.0
    stop = "budget"
    for g in range(1, generations + 1):
        best = int(np.argmin(cost))
        cr_r, cr_b, f_r = adaptive_rates(rng, im, pop)
        trial_real = repair_midpoint(binomial_crossover(rng, real, real_mutation(rng, real, best, f_r), cr_r), real, bounds)
        trial_bits = bits
        if n_bits:
            trial_bits = binomial_crossover(rng, bits, binary_mutation(rng, bits, best), cr_b).astype(bool)
            if bit_flip > 0:
                trial_bits = trial_bits ^ (rng.random(trial_bits.shape) < bit_flip)
        trial_cost = cost_fn(trial_real, trial_bits)
        (real, bits), cost = greedy_replace((real, bits), (trial_real, trial_bits), cost, trial_cost)   # eq. (22)
        reason = end_generation(history, cost.min(), g, callback, target, stagnation)
        im = improvement_measure(history[-2], history[-1])
        if reason:
            stop = reason
            break
    best = int(np.argmin(cost))
    return Result(real[best].copy(), bits[best].copy(), float(cost[best]), history, cost_fn.evaluations,
                  len(history) - 1, time.perf_counter() - t0, cost_fn.seconds, stop)
