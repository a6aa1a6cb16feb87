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

from dataclasses import dataclass

import numpy as np

from .core import EPS, Engine, Result, GenerationalSolver, Stopping


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


@dataclass(frozen=True)
class GAOptions(Stopping):
    """The paper's GA (Sec. IV-D): its rates are Table VI's."""
    pc: float = 0.55                        # one-point crossover probability (Table VI: 0.55)
    pm: float = 0.08                        # bitwise mutation probability (Table VI: 0.08)
    bits_per_real: int = 5                  # the paper's chromosomes: 5 bits per real, 32 levels


@dataclass(frozen=True)
class AGAOptions(GAOptions):
    """AGA: pc and pm start at the GA's and adapt."""
    aim: float = 0.2                        # an operator whose success share exceeds this has its rate raised by 10 %


class GA(GenerationalSolver):
    """Elitist roulette GA, one generation per ``step``; ``adapt`` is AGA's."""

    def init_population(self) -> None:
        o = self.options
        self.pc, self.pm = o.pc, o.pm
        self.length = self.bounds.shape[0] * o.bits_per_real + self.n_bits
        self.genes = self.rng.random((o.pop, self.length)) < 0.5
        self.cost = self.counter(*self.split(self.genes))
        self.history.append(float(self.cost.min()))

    def split(self, genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Genes -> (reals decoded, the problem's own bits)."""
        b = self.options.bits_per_real
        return decode(genes, self.bounds, b), genes[:, self.bounds.shape[0] * b:].astype(bool)

    def step(self) -> None:
        rng, pop, cost = self.rng, self.options.pop, self.cost
        self.generation += 1
        elite = int(np.argmin(cost))
        pairs = (pop + 1) // 2
        pa, pb = roulette(rng, cost, pairs), roulette(rng, cost, pairs)
        c1, c2, crossed = one_point_crossover(rng, self.genes[pa], self.genes[pb], self.pc)
        children = np.vstack([c1, c2])[: pop - 1]
        flips = rng.random(children.shape) < self.pm
        children = children ^ flips
        child_cost = self.counter(*self.split(children))
        self.genes = np.vstack([self.genes[elite:elite + 1], children])
        parent_mean = np.concatenate([(cost[pa] + cost[pb]) / 2] * 2)[: pop - 1]
        self.cost = np.concatenate([cost[elite:elite + 1], child_cost])
        self.adapt(child_cost, parent_mean, np.concatenate([crossed, crossed])[: pop - 1], flips.any(axis=1))
        self.end_generation(self.cost.min())

    def adapt(self, child_cost: np.ndarray, parent_mean: np.ndarray, crossed: np.ndarray, mutated: np.ndarray) -> None:
        """The plain GA keeps its rates."""

    def result(self) -> Result:
        best = int(np.argmin(self.cost))
        real, bits = self.split(self.genes[best:best + 1])
        return self.make_result(real[0], bits[0], self.cost[best], {"pc": self.pc, "pm": self.pm})


class AGA(GA):
    """The GA with pc and pm adapted from each operator's success."""

    def adapt(self, child_cost: np.ndarray, parent_mean: np.ndarray, crossed: np.ndarray, mutated: np.ndarray) -> None:
        aim = self.options.aim
        if crossed.any():
            ok = np.mean(child_cost[crossed] < parent_mean[crossed])
            self.pc = float(np.clip(self.pc * (1.1 if ok > aim else 0.9), 0.05, 0.95))
        if mutated.any():
            # success of mutation, judged without extra evaluations: mutated children that
            # beat their parents' mean fitness
            ok = np.mean(child_cost[mutated] < parent_mean[mutated])
            self.pm = float(np.clip(self.pm * (1.1 if ok > aim else 0.9), 0.001, 0.3))


ENGINE = Engine("GA", GA, GAOptions)
ADAPTIVE = Engine("AGA", AGA, AGAOptions)
