"""What every engine shares: the objective contract, bound repair, budget and result.

An objective takes the whole population at once, ``cost(real, bits)`` with ``real`` of shape
(pop, D) and ``bits`` a boolean array of shape (pop, B), and returns the cost of each individual
(shape (pop,)), to be minimised. The paper maximises the fitness 1/(sum|G| + eps) (eq. 24), a
decreasing function of the same cost, so every comparison is the same; results report both.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np

EPS = 1e-12


class Objective(Protocol):
    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray: ...


@dataclass
class Result:
    """Best individual, its cost and fitness, and the run's accounting."""
    real: np.ndarray
    bits: np.ndarray
    cost: float
    history: list[float]                   # best cost after each generation (index 0: initial population)
    evaluations: int
    generations: int
    wall_s: float
    objective_s: float
    stop: str = "budget"
    extra: dict = field(default_factory=dict)

    @property
    def fitness(self) -> float:
        return fitness(self.cost)

    @property
    def overhead_s(self) -> float:
        """Time spent outside the objective: the engine's own cost."""
        return self.wall_s - self.objective_s


def fitness(cost: float | np.ndarray, eps: float = EPS) -> float | np.ndarray:
    """The paper's fitness, eq. (24): 1 / (sum |G| + eps)."""
    return 1.0 / (np.asarray(cost) + eps)


class Counter:
    """Wraps an objective: counts evaluations and the time spent inside it."""

    def __init__(self, objective: Objective) -> None:
        self.objective = objective
        self.evaluations = 0
        self.seconds = 0.0

    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        cost = np.asarray(self.objective(real, bits), dtype=float).reshape(-1)
        self.seconds += time.perf_counter() - t0
        n = max(real.shape[0], bits.shape[0])
        self.evaluations += n
        if cost.shape[0] != n:
            raise ValueError(f"objective returned {cost.shape[0]} costs for {real.shape[0]} individuals")
        return np.where(np.isfinite(cost), cost, np.inf)


def check_bounds(bounds: np.ndarray | list) -> np.ndarray:
    b = np.asarray(bounds, dtype=float).reshape(-1, 2)
    if b.size and (np.any(~np.isfinite(b)) or np.any(b[:, 0] > b[:, 1])):
        raise ValueError("bounds must be finite [low, high] pairs with low <= high")
    return b


def init_population(rng: np.random.Generator, bounds: np.ndarray, n_bits: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Uniform reals within bounds, fair random bits."""
    lo, hi = bounds[:, 0], bounds[:, 1]
    real = lo + rng.random((size, bounds.shape[0])) * (hi - lo)
    bits = rng.random((size, n_bits)) < 0.5
    return real, bits


def repair_midpoint(trial: np.ndarray, parent: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """A coordinate outside its bounds goes half-way between the parent and the violated bound,
    so individuals approach a bound geometrically instead of piling up on it."""
    lo, hi = bounds[:, 0], bounds[:, 1]
    out = np.where(trial < lo, (lo + parent) / 2, trial)
    return np.where(out > hi, (hi + parent) / 2, out)


def stop_reason(history: list[float], target: float | None, stagnation: int | None, rtol: float = 1e-12) -> str | None:
    """'target' when the best cost reaches ``target``; 'stagnation' after that many generations
    without relative improvement."""
    if target is not None and history[-1] <= target:
        return "target"
    if stagnation and len(history) > stagnation:
        old = history[-1 - stagnation]
        if old - history[-1] <= rtol * max(abs(old), EPS):
            return "stagnation"
    return None


def distinct_indices(rng: np.random.Generator, size: int, count: int, exclude_self: bool = True) -> np.ndarray:
    """For each individual i, ``count`` distinct random indices, all different from i (vectorised)."""
    if size < count + (1 if exclude_self else 0):
        raise ValueError(f"population of {size} is too small for {count} distinct partners")
    keys = rng.random((size, size))
    if exclude_self:
        keys[np.arange(size), np.arange(size)] = np.inf
    return np.argsort(keys, axis=1)[:, :count]


def binomial_crossover(rng: np.random.Generator, target: np.ndarray, mutant: np.ndarray, cr: np.ndarray | float) -> np.ndarray:
    """Eq. (21): take the mutant's coordinate where rand <= CR or at one random index j_rand."""
    n, d = target.shape
    if d == 0:
        return target.copy()
    cr = np.broadcast_to(np.asarray(cr, dtype=float).reshape(-1, 1) if np.ndim(cr) else cr, (n, 1))
    take = rng.random((n, d)) <= cr
    take[np.arange(n), rng.integers(0, d, n)] = True
    return np.where(take, mutant, target)


def select(cost: np.ndarray, trial_cost: np.ndarray) -> np.ndarray:
    """Eq. (22): a trial replaces its parent only when strictly fitter (lower cost)."""
    return trial_cost < cost


def greedy_replace(population: tuple[np.ndarray, ...], trials: tuple[np.ndarray, ...], cost: np.ndarray,
                   trial_cost: np.ndarray) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Eq. (22) applied: each array of the population takes the rows of its trial that are fitter."""
    better = select(cost, trial_cost)
    return tuple(np.where(better[:, None], t, x) for x, t in zip(population, trials)), np.where(better, trial_cost, cost)


def end_generation(history: list[float], best: float, generation: int, callback, target: float | None,
                   stagnation: int | None) -> str | None:
    """Record the generation's best cost, tell the callback, and say whether to stop (and why)."""
    history.append(float(best))
    if callback:
        callback(generation, history[-1])
    return stop_reason(history, target, stagnation)


Engine = Callable[..., Result]
