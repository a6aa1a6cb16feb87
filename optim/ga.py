"""Genetic algorithm baselines of the paper's comparison (Sec. IV-D, Table VI): GA and AGA.

Binary encoding: every real on ``bits_per_real`` bits (the paper: 5, i.e. 32 levels between its
bounds), the problem's own bits (FDV zeta, eta) as they are. Elitism (the best individual is
kept), fitness-proportional (roulette) selection on the fitness 1/(cost + eps), one-point
crossover with probability pc, bitwise mutation with probability pm (paper: 0.55 and 0.08).

AGA adapts pc and pm from the success of each operator (Sec. IV-D, after [17]): each generation,
the share of crossover children fitter than the mean of their parents, and of mutated
individuals fitter than before the mutation, is measured; an operator whose success exceeds
``aim`` has its rate raised by 10 %, otherwise lowered by 10 % (pc in [0.05, 0.95], pm in
[0.001, 0.3]).
"""
from __future__ import annotations

import time

import numpy as np

from .core import EPS, Counter, Result, check_bounds, end_generation


def decode(genes: np.ndarray, bounds: np.ndarray, bits_per_real: int) -> np.ndarray:
    """Gray-free binary decoding: each group of bits is an integer mapped onto [low, high]."""
    n, d = genes.shape[0], bounds.shape[0]
    g = genes[:, : d * bits_per_real].reshape(n, d, bits_per_real).astype(np.int64)
    weights = 1 << np.arange(bits_per_real - 1, -1, -1)
    level = (g * weights).sum(axis=2) / (2 ** bits_per_real - 1)
    return bounds[:, 0] + level * (bounds[:, 1] - bounds[:, 0])


def roulette(rng: np.random.Generator, cost: np.ndarray, count: int) -> np.ndarray:
    fit = 1.0 / (np.where(np.isfinite(cost), cost, np.inf) + EPS)
    total = fit.sum()
    p = fit / total if total > 0 and np.isfinite(total) else np.full(cost.size, 1.0 / cost.size)
    return rng.choice(cost.size, size=count, p=p)


def one_point_crossover(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, pc: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Children of parent pairs (rows of a and b); returns the two children and which pairs crossed."""
    n, length = a.shape
    cross = rng.random(n) < pc
    point = rng.integers(1, max(2, length), n)
    mask = (np.arange(length)[None, :] >= point[:, None]) & cross[:, None]
    return np.where(mask, b, a), np.where(mask, a, b), cross


def _run(objective, bounds, n_bits, *, pop, generations, seed, pc, pm, bits_per_real, adaptive, aim,
         target, stagnation, callback) -> Result:
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    bounds = check_bounds(bounds)
    counter = Counter(objective)
    nr = bounds.shape[0]
    length = nr * bits_per_real + n_bits
    split = lambda g: (decode(g, bounds, bits_per_real), g[:, nr * bits_per_real:].astype(bool))
    genes = rng.random((pop, length)) < 0.5
    cost = counter(*split(genes))
    history = [float(cost.min())]
    stop = "budget"
    for gen in range(1, generations + 1):
        elite = int(np.argmin(cost))
        pairs = (pop + 1) // 2
        pa, pb = roulette(rng, cost, pairs), roulette(rng, cost, pairs)
        c1, c2, crossed = one_point_crossover(rng, genes[pa], genes[pb], pc)
        children = np.vstack([c1, c2])[: pop - 1]
        flips = rng.random(children.shape) < pm
        children = children ^ flips
        child_cost = counter(*split(children))
        genes = np.vstack([genes[elite:elite + 1], children])
        parent_mean = np.concatenate([(cost[pa] + cost[pb]) / 2] * 2)[: pop - 1]
        cost = np.concatenate([cost[elite:elite + 1], child_cost])
        if adaptive:
            crossed2 = np.concatenate([crossed, crossed])[: pop - 1]
            mutated = flips.any(axis=1)
            if crossed2.any():
                ok = np.mean(child_cost[crossed2] < parent_mean[crossed2])
                pc = float(np.clip(pc * (1.1 if ok > aim else 0.9), 0.05, 0.95))
            if mutated.any():
                # success of mutation, judged without extra evaluations: mutated children that
                # beat their parents' mean fitness
                ok = np.mean(child_cost[mutated] < parent_mean[mutated])
                pm = float(np.clip(pm * (1.1 if ok > aim else 0.9), 0.001, 0.3))
        reason = end_generation(history, cost.min(), gen, callback, target, stagnation)
        if reason:
            stop = reason
            break
    best = int(np.argmin(cost))
    real, bits = split(genes[best:best + 1])
    return Result(real[0], bits[0], float(cost[best]), history, counter.evaluations, len(history) - 1,
                  time.perf_counter() - t0, counter.seconds, stop, {"pc": pc, "pm": pm})


def minimize(objective, bounds, n_bits: int = 0, *, pop: int = 150, generations: int = 300, seed: int | None = 0,
             pc: float = 0.55, pm: float = 0.08, bits_per_real: int = 5, target=None, stagnation=None,
             callback=None, **_ignored) -> Result:
    """The paper's GA."""
    return _run(objective, bounds, n_bits, pop=pop, generations=generations, seed=seed, pc=pc, pm=pm,
                bits_per_real=bits_per_real, adaptive=False, aim=0.2, target=target, stagnation=stagnation,
                callback=callback)


def minimize_adaptive(objective, bounds, n_bits: int = 0, *, pop: int = 150, generations: int = 300,
                      seed: int | None = 0, pc: float = 0.55, pm: float = 0.08, bits_per_real: int = 5,
                      aim: float = 0.2, target=None, stagnation=None, callback=None, **_ignored) -> Result:
    """AGA: the GA with pc and pm adapted from each operator's success."""
    return _run(objective, bounds, n_bits, pop=pop, generations=generations, seed=seed, pc=pc, pm=pm,
                bits_per_real=bits_per_real, adaptive=True, aim=aim, target=target, stagnation=stagnation,
                callback=callback)
