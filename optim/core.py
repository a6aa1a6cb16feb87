"""What every engine shares: the problem protocol, the options, the solver's phases, the result.

A **problem** (``Problem``) is a vectorised cost ``problem(real, bits)``, with ``real`` of shape
(pop, D) and ``bits`` a boolean array of shape (pop, B), returning the cost of each individual
(shape (pop,)) to be minimised, plus ``bounds()`` (D x 2). It may carry hooks an engine can use
(the bit count, the discrete structure of the bits, the reals each structure reads, a cheaper
objective, starting points); ``pose`` reads them once, with their defaults, into a ``Posed``.
The paper maximises the fitness 1/(sum|G| + eps) (eq. 24), a decreasing function of the same
cost, so every comparison is the same; results report both.

An **engine** is a ``Solver`` class (state and phases, like scipy's
``DifferentialEvolutionSolver``: initial population, generations until converged, polish,
result) with its own frozen ``Options``; ``optim.minimize(problem, engine=..., **options)`` runs
one and refuses an option the engine does not have. A 2-D sphere with no bits:

>>> import numpy as np, optim
>>> sphere = optim.pose(lambda real, bits: ((real - 0.3) ** 2).sum(axis=1), bounds=[[-1, 1], [-1, 1]])
>>> r = optim.minimize(sphere, engine="AHDE", pop=40, generations=60, seed=1)
>>> np.round(r.real, 3).tolist(), r.cost < 1e-6, r.evaluations <= 40 * 61
([0.3, 0.3], True, True)
>>> optim.minimize(sphere, engine="AHDE", patiense=5)
Traceback (most recent call last):
...
TypeError: AHDE: unknown option 'patiense' (did you mean 'patience'?); valid: ...
"""
from __future__ import annotations

import difflib
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field, fields, replace
from numbers import Integral
from typing import Callable, Hashable, Protocol, Sequence

import numpy as np

EPS = 1e-12

Cost = Callable[[np.ndarray, np.ndarray], np.ndarray]


class Problem(Protocol):
    """What an engine minimises. Required: the cost ``__call__(real (pop, D), bits (pop, B)) ->
    (pop,)`` and ``bounds()``, D finite ``[low, high]`` pairs. Optional (read by ``pose``; an
    object without one gets its default, and an engine with no use for one ignores it):

    - ``n_bits`` (0): B, the number of binary decisions;
    - ``onehot`` (()): groups of bit indices of which exactly one is set (each fault's type);
    - ``structure(bits)`` (the bits as a tuple): a hashable key of what the bits decide; patterns
      with one key are one structure (the AHDEs search structures, not patterns);
    - ``family(bits)`` (None: no families): a coarser key whose best structure the AHDE keeps
      through the first rungs of its race and re-polishes at the end, or a ``frozenset`` of keys
      when a structure belongs to several families (the diagnosis: one family per fault and
      type-and-degradation-model, so each model (16)-(19) of each fault has its champion);
    - ``free(bits)`` (None: every real): a boolean mask (D,) of the reals a structure reads;
    - ``coarse(real, bits)`` (None: the cost itself): a cheaper cost that ranks like the cost
      (the diagnosis: every k-th sample), on which the AHDE screens and races;
    - ``init`` (()): starting points, ``(real (D,), bits (B,))`` pairs (the fits of smaller
      candidate sets);
    - ``propose(bits)`` (None: nothing to propose): points the data suggest for the structure of
      ``bits``, an array (k, D) with NaN where the data say nothing (the engine draws those); the
      AHDE screens them with its own draws (the diagnosis: intermittent periods and phases found
      in the residuals, onsets where they left their noise band);
    - ``translate(real, bits_from, bits_to)`` (None: nothing): the point with which the structure of
      ``bits_to`` behaves like ``real`` under ``bits_from``, an array (D,) with NaN where it keeps
      its own (the diagnosis: each fault's profile re-expressed in another degradation model);
      the AHDE's final check starts each family from the winner so translated;
    - ``penalized(cost, bits)`` (None: the cost): the cost an information criterion charges the
      structure of ``bits`` for its parameters, on which the AHDE chooses among its finalists (the
      diagnosis: Schwarz's criterion as an equivalent cost, so that a structure with more
      parameters wins only when its better fit pays for them).
    """

    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray: ...

    def bounds(self) -> np.ndarray: ...


def bits_key(bits: np.ndarray) -> tuple[int, ...]:
    """The default ``structure``: every bit pattern is a structure of its own."""
    return tuple(int(v) for v in bits)


@dataclass(frozen=True, eq=False)
class Posed:
    """A problem as an engine reads it: the cost, bounds and bit count, and every optional hook of
    ``Problem`` resolved to its value or its default (see ``Problem`` for what each means)."""
    cost: Cost
    bounds: np.ndarray
    n_bits: int = 0
    onehot: tuple[tuple[int, ...], ...] = ()
    structure: Callable[[np.ndarray], Hashable] = bits_key
    family: Callable[[np.ndarray], Hashable] | None = None
    free: Callable[[np.ndarray], np.ndarray] | None = None
    coarse: Cost | None = None
    init: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    propose: Callable[[np.ndarray], np.ndarray] | None = None
    translate: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
    penalized: Callable[[float, np.ndarray], float] | None = None

    def __post_init__(self) -> None:
        put = lambda name, value: object.__setattr__(self, name, value)
        put("bounds", check_bounds(self.bounds))
        if isinstance(self.n_bits, bool) or not isinstance(self.n_bits, Integral) or self.n_bits < 0:
            raise ValueError(f"n_bits must be a whole number >= 0, not {self.n_bits!r}")
        put("n_bits", int(self.n_bits))
        put("onehot", tuple(tuple(int(i) for i in g) for g in self.onehot))
        outside = [i for g in self.onehot for i in g if not 0 <= i < self.n_bits]
        if outside:
            raise ValueError(f"onehot names bit {outside[0]}, outside the problem's n_bits = {self.n_bits}")
        init = tuple((np.asarray(r, dtype=float), np.asarray(b, dtype=bool)) for r, b in self.init)
        for r, b in init:
            if r.shape != (self.bounds.shape[0],) or b.shape != (self.n_bits,):
                raise ValueError(f"init: a starting point has {r.size} reals and {b.size} bits; the problem has "
                                 f"{self.bounds.shape[0]} and {self.n_bits}")
        put("init", init)
        put("structure", self.structure or bits_key)

    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        return self.cost(real, bits)


HOOKS = tuple(f.name for f in fields(Posed) if f.name not in ("cost", "bounds"))


def pose(problem: Problem | Cost, **given) -> Posed:
    """``problem`` as an engine reads it: ``bounds`` and each hook of ``Problem`` taken from
    ``given`` if there, else from the problem's attribute of that name (``bounds`` and ``n_bits``
    may be methods), else its default. ``pose(cost, bounds=..., n_bits=...)`` poses a plain
    function; ``pose(obj, init=...)`` adds what an object does not carry."""
    names = ("bounds",) + HOOKS
    unknown = [k for k in given if k not in names]
    if unknown:
        raise TypeError(f"pose: unknown hook {unknown[0]!r}{_close(unknown[0], names)}; valid: {', '.join(names)}")
    if isinstance(problem, Posed):
        return replace(problem, **given) if given else problem
    if not callable(problem):
        raise TypeError(f"pose: a problem is called as cost(real, bits); a {type(problem).__name__} is not callable")
    values = {}
    for name in names:
        value = given[name] if name in given else getattr(problem, name, None)
        if name in ("bounds", "n_bits") and callable(value):
            value = value()
        if value is not None:
            values[name] = value
    if "bounds" not in values:
        raise TypeError("pose: the problem has no bounds(); give bounds=[[low, high], ...]")
    return Posed(problem, **values)


@dataclass(frozen=True)
class Options:
    """What every engine takes: its budget, seed and progress callback. Each engine's options
    derive from this and redefine the defaults it needs."""
    pop: int = 150                          # population size (the paper's Table VI: 150)
    generations: int = 300                  # at most pop * (generations + 1) evaluations (Table VI: 300 iterations)
    seed: int | None = 0                    # the random generator's seed: the same seed gives the same run
    callback: Callable[[int, float], object] | None = None   # told (generation, best cost) after each generation

    def __post_init__(self) -> None:
        for name, low in (("pop", 1), ("generations", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Integral) or value < low:
                raise ValueError(f"{type(self).__name__}.{name} must be a whole number >= {low}, not {value!r}")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


@dataclass(frozen=True)
class Stopping(Options):
    """The options of an engine that may stop before its budget."""
    target: float | None = None             # stop once the best cost is at most this
    stagnation: int | None = None           # stop after this many generations without relative improvement


def _close(name: str, valid: Sequence[str]) -> str:
    near = difflib.get_close_matches(name, valid, n=1)
    return f" (did you mean {near[0]!r}?)" if near else ""


def configure(engine: str, cls: type[Options], options: Options | None = None,
              overrides: dict | None = None) -> Options:
    """``options`` (or ``cls``'s defaults) with ``overrides`` applied. An option ``cls`` does not
    have is refused (TypeError) in one line naming it, the nearest valid name and the valid ones."""
    overrides = overrides or {}
    valid = cls.names()
    unknown = [k for k in overrides if k not in valid]
    if unknown:
        raise TypeError(f"{engine}: unknown option {unknown[0]!r}{_close(unknown[0], valid)}; "
                        f"valid: {', '.join(valid)}")
    if options is None:
        return cls(**overrides)
    if type(options) is not cls:
        raise TypeError(f"{engine}: options must be {cls.__name__}, not {type(options).__name__}")
    return replace(options, **overrides) if overrides else options


@dataclass(frozen=True)
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



class Solver(ABC):
    """One run of an engine on a posed problem: its state (random generator, evaluation counter,
    history, stop reason), as scipy's ``DifferentialEvolutionSolver`` holds it; ``solve`` runs it.
    Engines that go generation by generation derive from :class:`GenerationalSolver`; an engine
    whose loop lives elsewhere (scipy's, L-SHADE's) implements ``solve`` itself."""

    def __init__(self, problem: Posed, options: Options) -> None:
        self.problem, self.options = problem, options
        self.rng = np.random.default_rng(options.seed)
        self.bounds = problem.bounds
        self.n_bits = problem.n_bits
        self.counter = Counter(problem.cost)
        self.history: list[float] = []             # best cost after each generation (0: the initial population)
        self.generation = 0
        self.stop: str | None = None               # why the run stopped, once it has
        self.started = time.perf_counter()

    @abstractmethod
    def solve(self) -> Result:
        """Run to the end; the best point found."""

    def converged(self) -> bool:
        """Stopped by a rule (``stop`` set) or at the last generation of the budget."""
        return self.stop is not None or self.generation >= self.options.generations

    def end_generation(self, best: float) -> None:
        """Record the generation's best cost, tell the callback, and stop on the engine's rules
        (``target``, ``stagnation`` of ``Stopping`` options)."""
        o = self.options
        self.stop = end_generation(self.history, best, self.generation, o.callback, getattr(o, "target", None),
                                   getattr(o, "stagnation", None))

    def make_result(self, real: np.ndarray, bits: np.ndarray, cost: float, extra: dict | None = None,
                    generations: int | None = None) -> Result:
        return Result(real, bits, float(cost), self.history, self.counter.evaluations,
                      len(self.history) - 1 if generations is None else generations,
                      time.perf_counter() - self.started, self.counter.seconds, self.stop or "budget", extra or {})


class GenerationalSolver(Solver):
    """A solver by phases: ``init_population``, then ``step`` (one generation) until ``converged``,
    then ``polish``, and ``result``."""

    def solve(self) -> Result:
        self.init_population()
        while not self.converged():
            self.step()
        self.polish()
        return self.result()

    @abstractmethod
    def init_population(self) -> None:
        """The first population, evaluated."""

    @abstractmethod
    def step(self) -> None:
        """One generation."""

    def polish(self) -> None:
        """After the generations: nothing unless the engine refines its best."""

    @abstractmethod
    def result(self) -> Result:
        """The best point found, with the run's history and counts."""


@dataclass(frozen=True)
class Engine:
    """A name of ``optim.ENGINES``: the solver class and its options class."""
    name: str
    solver: type[Solver]
    options: type[Options]

    def minimize(self, problem: Problem | Posed, options: Options | None = None, **overrides) -> Result:
        """Run on ``problem`` (posed as by ``pose``) with ``options`` (this engine's class, or its
        defaults) and ``overrides`` of single fields."""
        return self.solver(pose(problem), configure(self.name, self.options, options, overrides)).solve()
