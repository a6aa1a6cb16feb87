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

from dataclasses import dataclass

import numpy as np

from .core import (Engine, Result, GenerationalSolver, Stopping, binomial_crossover, distinct_indices, greedy_replace, init_population,
                   repair_midpoint)


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


@dataclass(frozen=True)
class PaperOptions(Stopping):
    """The paper's AHDE has no tuning knob of its own: F and CR follow the adaptive law."""
    bit_flip: float = 0.0                   # probability of flipping each trial bit after eq. (23); not in the paper


class AHDEPaper(GenerationalSolver):
    """The paper's AHDE, one generation per ``step``."""

    def init_population(self) -> None:
        self.real, self.bits = init_population(self.rng, self.bounds, self.n_bits, self.options.pop)
        self.cost = self.counter(self.real, self.bits)
        self.history.append(float(self.cost.min()))
        self.im = 1.0                                      # IM = 1 in the first generation

    def step(self) -> None:
        rng, o = self.rng, self.options
        self.generation += 1
        real, bits, cost = self.real, self.bits, self.cost
        best = int(np.argmin(cost))
        cr_r, cr_b, f_r = adaptive_rates(rng, self.im, o.pop)
        trial_real = repair_midpoint(binomial_crossover(rng, real, real_mutation(rng, real, best, f_r), cr_r), real,
                                     self.bounds)
        trial_bits = bits
        if self.n_bits:
            trial_bits = binomial_crossover(rng, bits, binary_mutation(rng, bits, best), cr_b).astype(bool)
            if o.bit_flip > 0:
                trial_bits = trial_bits ^ (rng.random(trial_bits.shape) < o.bit_flip)
        trial_cost = self.counter(trial_real, trial_bits)
        (self.real, self.bits), self.cost = greedy_replace((real, bits), (trial_real, trial_bits), cost,
                                                           trial_cost)   # eq. (22)
        self.end_generation(self.cost.min())
        self.im = improvement_measure(self.history[-2], self.history[-1])

    def result(self) -> Result:
        best = int(np.argmin(self.cost))
        return self.make_result(self.real[best].copy(), self.bits[best].copy(), self.cost[best])


ENGINE = Engine("AHDE-paper", AHDEPaper, PaperOptions)
