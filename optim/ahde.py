"""The improved AHDE, bgfdi's default identification engine: structures raced, reals by DE.

The paper's AHDE (``optim.ahde_paper``) evolves real and binary decisions on one population. Measured
on identification problems of the paper's shape (``bgfdi bench optim``), its binary mutation (23)
can only set bits, so the discrete part freezes, and a joint search needs the paper's whole budget
(100 x 151 evaluations per candidate set) to settle the discrete part. But the discrete part is
small and known: a *structure* (each fault's type and degradation model, ``structure(bits)``) takes
one of a few dozen values, and each structure leaves only a few reals free (``free(bits)``: an
abrupt fault has one value, an incipient fault of model (16) one coefficient). So this engine

1. **enumerates** every structure (the valid bit patterns: one bit set in each one-hot group, any
   value elsewhere, deduplicated by ``structure``); when there are more than ``max_structures`` it
   starts from a random sample of them and adds the one-decision neighbours of the leader after
   every rung, so every structure stays reachable;
   Given starting points (``init``: the fit of a smaller candidate set, extended by no-op faults),
   the race starts instead from their structures and those one decision away from the best of
   them, and grows from the leader's neighbours: a superset is searched around what is known;
2. **races** them by successive halving (Jamieson & Talwalkar 2016): each structure gets a small
   DE population over its free reals only (the best ``2 d + 4`` of a Latin hypercube screen), all
   structures advance together (one vectorised objective call per generation), and after each rung
   the best third continue with twice the generations of the rung before; during the first
   ``protect`` rungs the best structure of each ``family`` (for the diagnosis: each fault's type,
   the degradation model left out) stays too while within ``spare`` of the leader: a family
   whose basin is narrow (an intermittent period, coupled with the onset) is found *near* its
   basin by the screen and costs more than a smooth fit of another family after two generations
   (measured on CyCab scenario 1: {beta_theta1} found its intermittent fault in 3 of 8 seeds
   without this, 6 of 8 with it);
   Screen and race may run on a cheaper objective, ``coarse`` (the diagnosis: every k-th sample),
   as they only rank structures (multi-fidelity successive halving, Li et al. 2018);
3. re-evaluates the **two finalists** on the objective and runs them to convergence (the
   population's cost spread within ``tol`` of its best, or no improvement for ``patience``
   generations, or the budget), then redraws them around their best points, 10 % of each range,
   while that improves, then the leader alone at 1 % (a
   population collapses in a narrow ridge before its bottom: R4 4 % off on 2 of 20 seeds of
   scenario 1 without the 1 % round);
4. **revives** a structure left behind: every other structure (and the winner's one-decision
   neighbours) gets the winner's best reals where their free reals coincide, one objective call;
   when one beats the winner it joins the final (measured: "R4 intermittent + beta_theta1
   intermittent", cost 1548, became "R4 abrupt + beta_theta1 intermittent", cost 205, once the
   period was carried over). The better finalist wins, and the runner-up's cost over the winner's
   is the **discrimination margin** (near 1: the data hardly separate the two).

Inside a structure: DE/current-to-pbest/1/bin (Zhang & Sanderson 2009) with jDE self-adapted F and
CR per individual (Brest et al. 2006), midpoint bound repair, greedy selection (eq. 22).

Budget: at most ``pop * (generations + 1)`` evaluations, the paper's budget, but the race stops when
the finalists have converged (evaluations of both fidelities count); on CyCab scenario 2 it uses
about a sixth of it (``bgfdi bench diagnose``).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from numbers import Integral
from typing import Hashable

import numpy as np

from . import kernels
from .core import Counter, Engine, Options, Posed, Result, GenerationalSolver

@dataclass
class Branch:
    """One structure in the race: its bits, the reals it leaves free, and its DE population."""
    key: Hashable
    bits: np.ndarray
    free: np.ndarray                       # indices of the free reals
    x: np.ndarray                          # (P, D)
    f: np.ndarray                          # (P,)
    F: np.ndarray                          # jDE scale factor per individual
    CR: np.ndarray                         # jDE crossover rate per individual
    stale: int = 0                         # generations without improvement of the best

    @property
    def best(self) -> float:
        return float(self.f.min())

    def converged(self, tol: float, patience: int) -> bool:
        if self.stale >= patience:
            return True
        low = self.f.min()
        if not np.isfinite(low):          # every point invalid: no spread to judge (inf - inf)
            return False
        return float(self.f.max() - low) <= tol * max(abs(float(low)), 1e-300)


@dataclass(frozen=True)
class Snapshot:
    """An AHDE run stopped before its final check (``recheck=False``), as ``resume`` continues it:
    every raced structure's population, the finalists, the evaluations spent, the history and the
    random generator's state. Plain arrays: it crosses process boundaries."""
    branches: tuple                        # (key, bits, free, x, f, F, CR, stale) per structure
    finalists: tuple                       # the finalists' keys
    evaluations: int
    history: tuple
    rng: dict
    race: tuple | None = None              # stopped inside the race (``pause``): survivors' keys, rung state
    gain: float | None = None              # paused: the race's best, relative improvement over the last rung
    init: tuple = ()                       # the starting points it was posed with: a continued run reads them here
    settled: bool = True                   # False: the finalists converged, their restarts and revivals still to run

    @property
    def paused(self) -> bool:
        """Whether the run stopped inside the race (``pause``), not before its final check."""
        return self.race is not None


@dataclass(frozen=True)
class AHDEOptions(Options):
    """The racing AHDE's knobs. ``pop`` and ``generations`` set the budget only, pop * (generations
    + 1) evaluations (the paper's identification settings: population 100, 150 iterations); the
    race sizes its own populations (``per_dim``)."""
    pop: int = 100
    generations: int = 150
    target: float | None = None
    """Stop once the best cost is at most this."""
    tol: float = 1e-4
    """A structure has converged when its population's cost spread is within ``tol`` of its best;
    an improvement smaller than ``tol`` (relative) counts as none."""
    patience: int = 15
    """...or after this many generations without improvement."""
    eta: int = 3
    """Successive halving keeps the best 1/eta of the structures after each rung (the best third)."""
    first_rung: int = 2
    """Generations of the first rung; each rung after doubles them."""
    screen: int = 3000
    """Evaluations of the Latin-hypercube screen shared by the structures (at most a third of the
    budget left)."""
    screen_each: int = 50
    """At most this many screen points per structure (a singleton's six structures need not take
    a pair's 3000; measured on scenario 2 with the coarse fidelity: identification in 1.4 s)."""
    spare: float = 0.5
    """Structures within this share of the leader's cost survive a rung as well (halved each rung);
    starting points within it of the best seed the race."""
    restarts: int = 3
    """Rounds of redrawing the converged finalists around their best points."""
    finest: float = 0.01
    """The smallest restart radius, as a share of each range: the leader alone at 1 % after 10 %
    stops improving (scenario 1: R4 4 % off in 2 of 20 seeds without the 1 % round). Rounds at
    0.1 % and 0.01 % (for a 0.7 s period's basin, 0.05 % of its range, now seeded from the
    residuals' spectrum) spent the budget around the first basin: the tutorial's eq. (16) drift was
    left at an onset of 7.87 s and eq. (17) (cost 1965) for the truth's 5.3 s (cost 1853)."""
    revivals: int = 2
    """Times a structure left behind may come back with the winner's reals (measured: "R4 abrupt +
    beta_theta1 intermittent" went from cost 1548 to 205 once the winner's period was carried over)."""
    per_dim: int = 2
    """A structure with d free reals races a DE population of per_dim * d + 4."""
    max_structures: int = 256
    """More structures than this: the race starts from a random sample and grows from the leader's
    neighbours."""
    reach: float = 3.0
    """A family's champion stays through the first ``protect`` rungs while its cost is within
    (1 + reach) times the leader's."""
    recheck: bool = True
    """The final check (``AHDE.recheck``): each family's best re-polished at its bottom. It costs
    as much as the race (a diagnosis of CyCab scenario 2: 17 000 of 49 000 evaluations); a caller
    that runs many problems and needs the check on few (the diagnosis: the candidate sets that may
    win) runs without it first. Skipping families out of reach at their rim loses the check's point:
    synthetic intermittent + eq. (19), 16 of 20 seeds with every family, 5 of 20 within 4x."""
    resume: Snapshot | None = None
    """Continue a run made with ``recheck=False`` (its result's ``extra["snapshot"]``) at its final
    check, the race and the polish not run again: a caller that needs the check on few of many
    problems (the diagnosis: the candidate sets that may win) runs them all without it first.
    A snapshot of a ``pause``d run continues its race where it stopped: the run ends exactly as
    one never paused would."""
    settle_later: bool = False
    """With ``recheck=False``: the finalists run to convergence on the objective, and their restarts
    and revivals wait for ``resume`` with the final check (the snapshot's ``settled`` False): a
    caller that needs the settled fit of few of many problems (the diagnosis: its single faults,
    settled only where they may win)."""
    pause: int | None = None
    """Stop the race once this many rungs are run (0: right after the screen) and return its leader,
    costed on the objective itself, with the run's state (``extra["snapshot"]``, with the race's
    ``gain`` over its last rung) for ``resume``, which pauses again at a later rung if asked: a
    caller racing several problems on one scale drops those far behind and stalled before they
    cost more (successive halving across problems; the diagnosis races its candidate sets of one
    size)."""
    protect: int = 3
    """During the first ``protect`` rungs each ``family``'s best structure stays while within
    ``spare`` of the leader (CyCab scenario 1: beta_theta1's intermittent fault found in 3 of 8 seeds
    without, 6 of 8 with)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        for name, low in (("patience", 1), ("eta", 2), ("first_rung", 1), ("screen", 0), ("screen_each", 1),
                          ("restarts", 0), ("revivals", 0), ("per_dim", 1), ("max_structures", 1), ("protect", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Integral) or value < low:
                raise ValueError(f"AHDEOptions.{name} must be a whole number >= {low}, not {value!r}")
        if self.pause is not None and (isinstance(self.pause, bool) or not isinstance(self.pause, Integral)
                                       or self.pause < 0):
            raise ValueError(f"AHDEOptions.pause must be None or a whole number >= 0, not {self.pause!r}")
        for name in ("tol", "spare", "finest", "reach"):
            if not getattr(self, name) > 0:
                raise ValueError(f"AHDEOptions.{name} must be > 0, not {getattr(self, name)!r}")


class AHDE(GenerationalSolver):
    """Structure racing with per-structure DE. Phases: ``init_population`` screens the structures,
    each ``step`` is one rung of the race, ``converged`` once two finalists remain, ``polish``
    refines, revives and settles them, ``result`` names the winner and the margin."""

    def __init__(self, problem: Posed, options: AHDEOptions) -> None:
        super().__init__(problem, options)
        self.onehot = [tuple(g) for g in problem.onehot]
        self.describe = problem.structure
        self.family = problem.family
        self.propose = problem.propose
        self.translator = problem.translate
        self.penalized = problem.penalized
        self.free = problem.free or (lambda b: np.ones(self.bounds.shape[0], dtype=bool))
        self.budget = options.pop * (options.generations + 1)
        self.init = list(problem.init)
        self.objective = problem.cost
        self.cheap = problem.coarse or problem.cost
        self.counter = Counter(self.cheap)                 # the screen and race run on ``coarse`` when given
        self.branches: dict[Hashable, Branch] = {}
        self.final: list[Branch] = []                      # the finalists, once the race is over
        self.finalists: list[Branch] | None = None         # set by ``polish`` (or a restored final check)
        self.stop = "converged"
        self.settled = True                                # False: the finalists converged, not yet restarted
        self._aranges: dict[int, np.ndarray] = {}
        self._bounds_of: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    # ------------------------------------------------------------------ structures
    def patterns(self) -> tuple[list[np.ndarray], bool]:
        """Every valid bit pattern (and True), or random ones when there are too many (and False)."""
        grouped = {i for g in self.onehot for i in g}
        loose = [i for i in range(self.n_bits) if i not in grouped]
        count = int(np.prod([len(g) for g in self.onehot])) * 2 ** len(loose) if self.n_bits else 1
        exhaustive = count <= 16 * self.options.max_structures
        if exhaustive:
            choices = itertools.product(*self.onehot, *[(None, i) for i in loose])
        else:
            choices = (tuple(self.rng.choice(g) for g in self.onehot) +
                       tuple(i if self.rng.random() < 0.5 else None for i in loose)
                       for _ in range(16 * self.options.max_structures))
        out = []
        for pick in choices:
            bits = np.zeros(self.n_bits, dtype=bool)
            bits[[i for i in pick if i is not None]] = True
            out.append(bits)
        return out, exhaustive

    def neighbours(self, bits: np.ndarray) -> list[np.ndarray]:
        """Patterns one decision away: one group's hot bit moved, or one loose bit flipped."""
        grouped = {i for g in self.onehot for i in g}
        out = []
        for g in self.onehot:
            for i in g:
                if not bits[i]:
                    b = bits.copy()
                    b[list(g)] = False
                    b[i] = True
                    out.append(b)
        for i in range(self.n_bits):
            if i not in grouped:
                b = bits.copy()
                b[i] = not b[i]
                out.append(b)
        return out

    def spawn(self, patterns: list[np.ndarray], limit: int | None = None, screen: int = 0) -> list[Branch]:
        """New branches for the structures of ``patterns`` not yet in the race. Each is screened on
        a Latin hypercube of its free reals, ``screen`` evaluations (at most a third of the budget
        left) shared by the new structures, at most ``screen_each`` and at least a population each
        (a singleton's six structures need not take a pair's screen of 3000), and keeps its best ``2 d + 4`` points as its DE population: a
        wide screen finds the basin of a multimodal structure (an intermittent fault's period)."""
        picked: dict[Hashable, tuple[np.ndarray, np.ndarray]] = {}
        for bits in patterns:
            key = self.describe(bits)
            if key not in self.branches and key not in picked:
                picked[key] = (bits, self.free_reals(bits))
                if limit and len(picked) >= limit:
                    break
        if not picked:
            return []
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        share = min(screen // len(picked), self.options.screen_each,
                    (self.budget - self.counter.evaluations) // 3 // len(picked))
        samples = []
        for key, (bits, free) in picked.items():
            size = max(self.size(free.size), share)
            x = np.broadcast_to((lo + hi) / 2, (size, lo.size)).copy()
            strata = (np.argsort(self.rng.random((size, free.size)), axis=0) + self.rng.random((size, free.size))) / size
            x[:, free] = lo[free] + strata * (hi[free] - lo[free])
            seeds = [np.clip(r, lo, hi) for r, sb in self.init if self.describe(sb) == key]
            if seeds:
                x[:len(seeds)] = seeds[:size]
            samples.append(np.vstack([x, self.proposals(bits, free)]))
        shells = [Branch(key, bits, free, x, np.empty(0), np.empty(0), np.empty(0))
                  for (key, (bits, free)), x in zip(picked.items(), samples)]
        for b, c in zip(shells, self.evaluate_distinct(samples, shells)):
            keep = np.argsort(c, kind="stable")[:self.size(b.free.size)]
            b.x, b.f = b.x[keep], c[keep]
            b.F, b.CR = self.rng.uniform(0.1, 1.0, keep.size), self.rng.random(keep.size)
            self.branches[b.key] = b
        self.record()
        return shells

    def proposals(self, bits: np.ndarray, free: np.ndarray) -> np.ndarray:
        """The problem's ``propose``d points for the structure of ``bits`` (at most 8 ``screen_each``),
        NaN drawn uniformly within the bounds, the reals the structure does not read at their
        midpoints, all within bounds: screened with the structure's own draws."""
        d = self.bounds.shape[0]
        if self.propose is None:
            return np.empty((0, d))
        got = np.asarray(self.propose(bits), dtype=float).reshape(-1, d)[:2 * self.options.screen_each]
        lo, hi = self.bounds[:, 0], self.bounds[:, 1]
        drawn = lo + self.rng.random(got.shape) * (hi - lo)
        x = np.where(np.isnan(got), drawn, got)
        unread = np.ones(d, dtype=bool)
        unread[free] = False
        x[:, unread] = (lo + hi)[unread] / 2
        return np.clip(x, lo, hi)

    def families(self, bits: np.ndarray) -> tuple[Hashable, ...]:
        """The families the structure of ``bits`` belongs to: the ``family`` hook's key, or each key
        of the frozenset it returns (none without the hook)."""
        if self.family is None:
            return ()
        key = self.family(bits)
        return tuple(sorted(key, key=repr)) if isinstance(key, frozenset) else (key,)

    def free_reals(self, bits: np.ndarray) -> np.ndarray:
        """The indices of the reals the structure of ``bits`` reads."""
        return np.flatnonzero(np.asarray(self.free(bits), dtype=bool))

    def size(self, d: int) -> int:
        """The DE population of a structure with d free reals."""
        return self.options.per_dim * d + 4 if d else 1

    # ------------------------------------------------------------------ evaluation and DE
    def evaluate_distinct(self, xs: list[np.ndarray], branches: list[Branch]) -> list[np.ndarray]:
        """:meth:`evaluate` with each branch's repeated rows evaluated once (a screen's proposals
        repeat: the reals a structure does not read are set to their midpoints; scenario 2's
        screens asked 518 rows twice), the costs those of every row as given."""
        kept, back = [], []
        for x in xs:
            rows = np.ascontiguousarray(x)
            if rows.shape[0] > 1 and rows.shape[1]:         # (a problem without reals: nothing to compare)
                key = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
                _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
                if first.size < rows.shape[0]:
                    order = np.argsort(first, kind="stable")   # the distinct rows in the order given
                    rank = np.empty_like(order)
                    rank[order] = np.arange(order.size)
                    kept.append(rows[first[order]])
                    back.append(rank[inverse.reshape(-1)])
                    continue
            kept.append(x)
            back.append(None)
        costs = self.evaluate(kept, branches)
        return [c if b is None else c[b] for c, b in zip(costs, back)]

    def evaluate(self, xs: list[np.ndarray], branches: list[Branch]) -> list[np.ndarray]:
        """One objective call for the rows of every branch; the costs split back per branch."""
        real = np.vstack(xs)
        counts = [x.shape[0] for x in xs]
        bits = np.repeat(np.vstack([b.bits for b in branches]), counts, axis=0)
        cost = self.counter(real, bits)
        out, at = [], 0
        for n in counts:
            out.append(cost[at:at + n])
            at += n
        return out

    def trials(self, b: Branch) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """DE/current-to-pbest/1/bin over the free reals, jDE-adapted F and CR."""
        rng, n = self.rng, b.x.shape[0]
        fast = kernels.jit()
        if fast is not None:               # the same draws in the same order, the arithmetic compiled
            redraw_F, new_F, redraw_CR, new_CR = rng.random(n), rng.uniform(0.1, 1.0, n), rng.random(n), rng.random(n)
            order = b.f.argsort()
            pick = rng.integers(0, max(2, math.ceil(0.2 * n)), n)
            hop1, hop2 = rng.integers(1, n, n), rng.integers(1, n - 1, n)
            cross = rng.random((n, b.free.size))
            forced = rng.integers(0, b.free.size, n)
            lo, hi = self._limits(b.free)
            return fast.trials(b.x, b.free, b.F, b.CR, redraw_F, new_F, redraw_CR, new_CR, order, pick, hop1, hop2,
                               cross, forced, lo, hi)
        F = np.where(rng.random(n) < 0.1, rng.uniform(0.1, 1.0, n), b.F)
        CR = np.where(rng.random(n) < 0.1, rng.random(n), b.CR)
        top = max(2, math.ceil(0.2 * n))
        pbest = b.f.argsort()[rng.integers(0, top, n)]
        rows = self._rows(n)
        r1 = (rows + rng.integers(1, n, n)) % n
        r2 = (r1 + rng.integers(1, n - 1, n)) % n
        same = r2 == rows
        if same.any():
            r2[same] = (r2[same] + 1) % n
        cols = b.free
        xf = b.x[:, cols]
        Fc = F[:, None]
        v = xf + Fc * (xf[pbest] - xf) + Fc * (xf[r1] - xf[r2])
        take = rng.random(v.shape) <= CR[:, None]
        take[rows, rng.integers(0, cols.size, n)] = True
        u = np.where(take, v, xf)
        lo, hi = self._limits(cols)
        low = u < lo
        if low.any():
            u = np.where(low, (lo + xf) / 2, u)
        high = u > hi
        if high.any():
            u = np.where(high, (hi + xf) / 2, u)
        trial = b.x.copy()
        trial[:, cols] = u
        return trial, F, CR

    def trials_of(self, branches: list[Branch]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """``trials`` of each branch in turn (the same draws in the same order): on the C path in one
        call that takes the draws too (:func:`optim._native.trials_batch`), ~5 us a branch where the
        method's numpy draws and kernel call take ~60 (a diagnosis's race makes ~700)."""
        batch = getattr(kernels.jit(), "trials_batch", None)
        if batch is not None:
            got = batch(self.rng, [(b.x, b.free, b.F, b.CR, b.f.argsort(), *self._limits(b.free)) for b in branches])
            if got is not None:
                return got
        return [self.trials(b) for b in branches]

    def _rows(self, n: int) -> np.ndarray:
        """0..n-1 (kept: read-only)."""
        got = self._aranges.get(n)
        if got is None:
            got = self._aranges[n] = np.arange(n)
        return got

    def _limits(self, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of the reals ``cols`` (kept per set of columns: read-only)."""
        key = cols.tobytes()
        got = self._bounds_of.get(key)
        if got is None:
            got = self._bounds_of[key] = (self.bounds[cols, 0], self.bounds[cols, 1])
        return got

    def advance(self, branches: list[Branch], generations: int, until_converged: bool = False) -> None:
        """``generations`` DE generations of every branch, all evaluated together; with
        ``until_converged`` a branch stops early once converged. Stops at the budget."""
        for _ in range(generations):
            live = [b for b in branches
                    if b.free.size and not (until_converged and b.converged(self.options.tol, self.options.patience))]
            if not live:
                return
            if self.counter.evaluations + sum(b.x.shape[0] for b in live) > self.budget:
                self.stop = "budget"
                return
            made = self.trials_of(live)
            costs = self.evaluate([m[0] for m in made], live)
            # each branch's best once per generation (record's minimum over the pool, kept up to date)
            pool = {id(b): b.best for b in (self.final or self.branches.values())}
            for b, (trial, F, CR), c in zip(live, made, costs):
                before = b.best
                better = c < b.f
                if better.any():
                    b.x[better], b.f[better] = trial[better], c[better]
                    b.F[better], b.CR[better] = F[better], CR[better]
                    after = b.best
                else:
                    after = before
                b.stale = 0 if after < before * (1 - self.options.tol) else b.stale + 1
                if id(b) in pool:
                    pool[id(b)] = after
                self.record(min(pool.values()))
            if self.options.target is not None and self.history[-1] <= self.options.target:
                self.stop = "target"
                return

    def record(self, best: float | None = None) -> None:
        """The best cost of the pool (the finalists once the race is over, else every branch) after
        a change, ``best`` when the caller knows it."""
        self.history.append(min(b.best for b in (self.final or self.branches.values())) if best is None else best)
        if self.options.callback:
            self.options.callback(len(self.history) - 1, self.history[-1])

    # ------------------------------------------------------------------ phases
    def ranked(self) -> list[Branch]:
        return sorted(self.branches.values(), key=lambda b: b.best)

    def init_population(self) -> None:
        """The structures to race, each screened and given its DE population: every valid pattern
        (or a sample), or, given starting points, their structures and those one decision away
        from the best of them."""
        o = self.options
        if self.init:
            seeds = [b for _, b in self.init]
            self.spawn(seeds + [n for b in self.leading_seeds() for n in self.neighbours(b)], o.max_structures,
                       o.screen // 4)
            self.complete = False
        else:
            patterns, exhaustive = self.patterns()
            self.spawn(patterns, o.max_structures, o.screen)
            self.complete = exhaustive and len(self.branches) < o.max_structures
        self.survivors = self.ranked()
        self.rung_generations, self.rung_spare, self.rung = o.first_rung, o.spare, 0

    def step(self) -> None:
        """One rung of successive halving: the survivors advance (a converged one stands: it needs no
        more generations to be ranked, and structures that tie, every type of a fault that explains
        nothing, kept all but one per rung while the generations doubled), the leader's neighbours
        join a partial start, migrants cross, and the best third (and those close to the leader, and
        each family's best for the first ``protect`` rungs) go on with twice the generations."""
        o = self.options
        survivors = self.survivors
        self.advance(survivors, self.rung_generations, until_converged=True)
        pool = list(survivors)
        if not self.complete:                               # a partial start: let the leader's neighbours in
            pool += self.spawn(self.neighbours(self.ranked()[0].bits))
        pool.sort(key=lambda b: b.best)
        self.migrate(pool)
        pool.sort(key=lambda b: b.best)
        close = sum(b.best <= pool[0].best * (1 + self.rung_spare) for b in pool)
        survivors = pool[:max(2, int(np.ceil(len(pool) / o.eta)), min(close, len(pool) - 1))]
        if self.rung < o.protect:
            survivors += self.champions(pool, survivors)
        self.survivors = survivors
        self.rung_generations, self.rung_spare = 2 * self.rung_generations, self.rung_spare / 2
        self.rung += 1

    def converged(self) -> bool:
        """The race is over with two finalists left, or a stop (budget, target)."""
        return len(self.survivors) <= 2 or self.stop != "converged"

    def champions(self, pool: list[Branch], survivors: list[Branch]) -> list[Branch]:
        """The best branch of each family (``families``) that has none among the survivors, while
        within ``reach`` of the leader's cost. Two generations rank structures of one family well
        (their reals mean the same), but not a family whose basin is narrow (an intermittent
        fault's period, a second-order drift's coefficients): found near, not in, its basin, it
        costs more than a smooth fit of another family and would leave the race before it can
        descend."""
        kept = {k for b in survivors for k in self.families(b.bits)}
        limit = pool[0].best * (1 + self.options.reach) if pool else np.inf
        out = []
        for b in pool:                                     # best first
            fams = [k for k in self.families(b.bits) if k not in kept]
            if fams and b.best <= limit:
                kept.update(fams)
                out.append(b)
        return out

    def family_bests(self, finalists: list[Branch]) -> list[Branch]:
        """For each family the winner is not in, its structure nearest the winner: the one that
        differs from the winner's families in that family alone (the winner with one fault's type
        or degradation model changed), raced or not (an unraced one joins the race from a plain
        draw); best first. The best structure of a family by its raced cost may differ from the
        winner in another decision as well, and be beaten for that decision alone."""
        if self.family is None:
            return []
        win = min(finalists, key=lambda f: f.best)
        mine = set(self.families(win.bits))
        ids = {id(f) for f in finalists}
        near = [n2 for n1 in self.neighbours(win.bits) for n2 in [n1] + self.neighbours(n1)]
        fresh = [bits for bits in near if self.describe(bits) not in self.branches
                 and len(set(self.families(bits)) - mine) == 1]
        if fresh and self.counter.evaluations + self.size(self.bounds.shape[0]) * len(fresh) <= self.budget:
            self.spawn(fresh)
        best: dict[Hashable, Branch] = {}
        for b in sorted(self.branches.values(), key=lambda b: b.best):
            other = set(self.families(b.bits)) - mine
            if len(other) == 1 and id(b) not in ids and b.free.size:
                best.setdefault(other.pop(), b)
        return sorted({id(b): b for b in best.values()}.values(), key=lambda b: b.best)

    def recheck(self, finalists: list[Branch]) -> None:
        """The final check: each family's best (``family_bests``) settled at its bottom, the winner's
        shared reals offered first; one that beats the winner joins the finalists. A narrow basin
        raced a few generations on the coarse fidelity (a second-order drift, a short period) is
        judged at its bottom, not at its rim (measured on the synthetic intermittent + eq. (19)
        problem: eq. (19) lost to eq. (18) on 20 of 20 seeds without this check).

        All families descend together on the coarse fidelity (restarts around their bests at 10 %,
        1 % and 0.1 % of each range), then those whose best comes within ``spare`` of the winner on
        the objective itself are settled on it. Measured on CyCab scenario 2: the check of the two
        sets that may win cost 16 900 evaluations settled one family at a time on the objective."""
        if self.stop != "converged":
            return
        win = min(finalists, key=lambda f: f.best)
        bests = self.family_bests(finalists)
        if not bests or self.counter.evaluations + sum(2 * b.x.shape[0] for b in bests) > self.budget:
            return
        self.counter.objective = self.cheap
        try:
            for b, f in zip(bests, self.evaluate([b.x for b in bests], bests)):
                b.f, b.stale = f, 0
            for b in bests:
                self.migrate([win, b])
            self.translate(win, bests)
            (level,) = self.evaluate([win.x[win.f.argmin()][None, :]], [win])[0]   # the winner, on this fidelity
            running, reach, generations = list(bests), self.options.reach, 2 * self.options.first_rung
            while running and self.stop == "converged":   # rungs: the families still within reach go on
                self.advance([b for b in running if not b.converged(self.options.tol, self.options.patience)],
                             generations, until_converged=True)
                running = [b for b in running if self.rank(b) <= self.rank_of(level, win) * (1 + reach)]
                if all(b.converged(self.options.tol, self.options.patience) for b in running):
                    break
                reach, generations = reach / 2, 2 * generations
            for scale in (0.1, 0.01, 0.001):         # each family restarted while a round improves it
                if self.stop != "converged" or not running:
                    break
                before = [b.best for b in running]
                for b in running:
                    if self.counter.evaluations + b.x.shape[0] <= self.budget:
                        self.restart(b, scale)
                self.advance(running, self.budget, until_converged=True)
                running = [b for b, c in zip(running, before) if b.best < c * (1 - self.options.tol)]
        finally:
            self.counter.objective = self.objective
        if self.stop != "converged" or self.counter.evaluations + sum(b.x.shape[0] for b in bests) > self.budget:
            return
        for b, f in zip(bests, self.evaluate([b.x for b in bests], bests)):
            b.f, b.stale = f, 0
        close = [b for b in bests if self.rank(b) <= self.rank(win) * (1 + self.options.spare)]
        if close:
            self.advance(close, self.budget, until_converged=True)
        self.checked = [(b.bits.copy(), b.x[int(np.argmin(b.f))].copy(), float(b.best)) for b in bests]
        for b in close:
            if self.rank(b) < self.rank(win) * (1 - self.options.tol):
                finalists.append(b)

    def translate(self, leader: Branch, branches: list[Branch]) -> None:
        """Each branch gets the leader's best point re-expressed in its structure (the problem's
        ``translate``; its shared reals as ``migrant`` takes them), in place of its worst point when
        better: one objective call."""
        if self.translator is None or not branches or self.counter.evaluations + len(branches) > self.budget:
            return
        x = leader.x[leader.f.argmin()]
        rows = []
        for b in branches:
            m = self.migrant(b, leader)[0]
            got = np.asarray(self.translator(x, leader.bits, b.bits), dtype=float)
            rows.append(np.clip(np.where(np.isnan(got), m, got), self.bounds[:, 0], self.bounds[:, 1])[None, :])
        for b, m, c in zip(branches, rows, self.evaluate(rows, branches)):
            worst = int(np.argmax(b.f))
            if c[0] < b.f[worst]:
                b.x[worst], b.f[worst] = m[0], c[0]

    def leading_seeds(self) -> list[np.ndarray]:
        """The bits of the starting points within ``spare`` of the best one (one evaluation each):
        only their neighbours join the race, so a superset is searched around its subsets' best
        fits, not around every subset's."""
        real = np.vstack([r for r, _ in self.init])
        bits = np.vstack([b for _, b in self.init])
        cost = self.counter(np.clip(real, self.bounds[:, 0], self.bounds[:, 1]), bits)
        best = float(np.min(cost))
        return [b for b, c in zip(bits, cost) if c <= best * (1 + self.options.spare) or not np.isfinite(best)]

    def migrate(self, branches: list[Branch]) -> None:
        """Each branch gets a migrant: its best point with the reals it shares with the leader taken
        from the leader's best (an intermittent fault's period found in one structure serves every
        structure where that fault is intermittent); the migrant replaces the branch's worst point
        when it is better."""
        if len(branches) < 2:
            return
        leader = branches[0]
        takers = [b for b in branches[1:] if np.intersect1d(b.free, leader.free).size]
        migrants = [self.migrant(b, leader) for b in takers]
        if not takers or self.counter.evaluations + len(takers) > self.budget:
            return
        for b, m, c in zip(takers, migrants, self.evaluate(migrants, takers)):
            worst = int(np.argmax(b.f))
            if c[0] < b.f[worst]:
                b.x[worst], b.f[worst] = m[0], c[0]

    @staticmethod
    def migrant(b: Branch, leader: Branch) -> np.ndarray:
        """``b``'s best point with the free reals it shares with ``leader`` taken from the leader's
        best, as one row."""
        m = b.x[int(np.argmin(b.f))].copy()
        shared = np.intersect1d(b.free, leader.free)
        m[shared] = leader.x[int(np.argmin(leader.f)), shared]
        return m[None, :]

    def restart(self, b: Branch, scale: float = 0.1) -> None:
        """A converged branch redrawn around its best point (``scale`` of each free range), the best
        kept: the population of a narrow valley collapses before it reaches the bottom."""
        lo, hi = self.bounds[b.free, 0], self.bounds[b.free, 1]
        i = int(np.argmin(b.f))
        x = np.repeat(b.x[i:i + 1], b.x.shape[0], axis=0)
        x[1:, b.free] = np.clip(x[1:, b.free] + scale * (hi - lo) * self.rng.standard_normal((x.shape[0] - 1, lo.size)),
                                lo, hi)
        f = b.f.copy()
        f[0] = b.f[i]
        f[1:] = self.evaluate([x[1:]], [b])[0]
        b.x, b.f, b.stale = x, f, 0
        b.F, b.CR = self.rng.uniform(0.1, 1.0, x.shape[0]), self.rng.random(x.shape[0])

    def refine(self, finalists: list[Branch]) -> None:
        """From here on the objective itself: the finalists' populations re-evaluated on it."""
        self.final = finalists
        if self.counter.objective is self.objective:
            return
        self.counter.objective = self.objective
        for b, c in zip(finalists, self.evaluate([b.x for b in finalists], finalists)):
            b.f, b.stale = c, 0
        self.record()

    def settle(self, branches: list[Branch]) -> None:
        """Run ``branches`` to convergence, then restart them around their best points (``restart``)
        until a round improves none; each such round shrinks the radius tenfold, down to
        ``finest``, and is spent on the leader alone (the runner-up only sets the margin)."""
        self.converge(branches)
        self.restart_rounds(branches)

    def converge(self, branches: list[Branch]) -> None:
        """Run ``branches`` to convergence on the current fidelity, while the run may go on."""
        if self.stop == "converged":
            self.advance(branches, self.budget, until_converged=True)

    def restart_rounds(self, branches: list[Branch]) -> None:
        """``settle``'s rounds of restarts around the converged branches' best points."""
        scale, running = 0.1, branches
        for _ in range(self.options.restarts):
            before = [b.best for b in running]
            for b in running:
                if self.stop == "converged" and b.free.size and self.counter.evaluations + b.x.shape[0] <= self.budget:
                    self.restart(b, scale)
            if self.stop != "converged":
                break
            self.advance(running, self.budget, until_converged=True)
            if all(b.best >= c * (1 - self.options.tol) for b, c in zip(running, before)):
                scale /= 10
                running = [min(branches, key=lambda b: b.best)]
                if scale < self.options.finest:
                    break

    def revive(self, finalists: list[Branch]) -> Branch | None:
        """The winner's structure checked against every other one (raced or one decision away):
        each gets the winner's best reals where their free reals coincide, on the objective itself,
        one call. A structure left behind (its screen missed a narrow basin, an intermittent
        period the winner has since found) comes back when that point beats the winner: a
        finalist takes it in place of its worst point, any other structure joins the finalists
        with a population drawn around it (``restart``). Returns the structure to polish."""
        win = min(finalists, key=lambda b: b.best)
        shells = [b for b in self.branches.values() if b.key != win.key and b.free.size]
        unseen = {}                                        # neighbours never raced, from the winner's point
        for bits in self.neighbours(win.bits):
            key, free = self.describe(bits), self.free_reals(bits)
            if key not in self.branches and key not in unseen and free.size:
                unseen[key] = Branch(key, bits, free, win.x[win.f.argmin()][None, :].copy(), np.zeros(1), np.ones(1),
                                     np.ones(1))
        shells += unseen.values()
        if not shells or self.counter.evaluations + len(shells) > self.budget:
            return None
        migrants = [self.migrant(b, win) for b in shells]
        costs = [c[0] for c in self.evaluate(migrants, shells)]
        j = int(np.argmin(costs))
        if not costs[j] < win.best * (1 - self.options.tol):
            return None
        b = shells[j]
        if any(b is f for f in finalists):
            worst = int(np.argmax(b.f))
            b.x[worst], b.f[worst], b.stale = migrants[j][0], costs[j], 0
            return b
        size = self.size(b.free.size)
        if self.counter.evaluations + size > self.budget:
            return None
        b.x, b.f = np.repeat(migrants[j], size, axis=0), np.full(size, costs[j])
        b.F, b.CR = self.rng.uniform(0.1, 1.0, size), self.rng.random(size)
        self.branches[b.key] = b
        self.restart(b)
        finalists.append(b)
        return b

    def polish(self) -> None:
        """The two finalists on the objective itself, settled, and a structure left behind revived
        while one comes back."""
        finalists = self.finalists = self.survivors[:2]
        self.refine(finalists)
        self.migrate(sorted(finalists, key=lambda b: b.best))
        if self.options.settle_later and not self.options.recheck:
            self.converge(finalists)
            self.settled = False                        # the restarts and revivals wait for ``resume``
            return
        self.settle(finalists)
        if self.options.recheck:
            self.recheck(finalists)
        self.revive_and_settle(finalists)

    def revive_and_settle(self, finalists: list[Branch]) -> None:
        """Structures left behind revived (``revive``) and settled, one at a time, while one comes
        back (at most ``revivals`` times)."""
        for _ in range(self.options.revivals):
            if self.stop != "converged":
                break
            back = self.revive(finalists)
            if back is None:
                break
            self.settle([back])

    def solve(self) -> Result:
        snap = self.options.resume
        if snap is not None and not snap.paused:        # the final check of a run made without it
            self.restore(snap)
            if not self.settled:                        # converged only: the first pass's settling first
                self.restart_rounds(self.finalists)
                self.revive_and_settle(self.finalists)
                self.settled = True
            self.recheck(self.finalists)
            self.revive_and_settle(self.finalists)
            return self.result()
        if snap is None:
            self.init_population()
        else:
            self.restore(snap)
        pause = self.options.pause
        if pause is not None and snap is not None and pause <= self.rung:
            pause = None                                # already there: continue to the end
        gain = None
        while not self.converged():
            if pause is not None and self.rung >= pause:
                return self.paused(gain)
            before = min(b.best for b in self.branches.values())
            self.step()
            after = min(b.best for b in self.branches.values())
            gain = (before - after) / before if np.isfinite(before) and before > 0 else 1.0
        self.polish()
        return self.result()

    def paused(self, gain: float | None) -> Result:
        """The race stopped at ``pause``: its leader, costed on the objective itself (one evaluation,
        counted in the result but not in the state ``resume`` continues, so that the continued run
        is the run never paused), and the race's ``gain`` over its last rung in the snapshot."""
        snap = replace(self.snapshot(), gain=gain)
        lead = self.ranked()[0]
        x = lead.x[int(np.argmin(lead.f))].copy()
        cost = lead.best
        if self.cheap is not self.objective:
            cost = float(Counter(self.objective)(x[None, :], lead.bits[None, :])[0])
        r = self.make_result(x, lead.bits.copy(), cost, {"snapshot": snap, "raced": len(self.branches)})
        return replace(r, evaluations=r.evaluations + (self.cheap is not self.objective), stop="paused")

    def snapshot(self) -> Snapshot:
        """The run's state for ``resume``."""
        final = self.finalists
        race = None if final is not None else (tuple(b.key for b in self.survivors), self.rung, self.rung_generations,
                                               self.rung_spare, self.complete, self.stop)
        return Snapshot(tuple((b.key, b.bits.copy(), b.free.copy(), b.x.copy(), b.f.copy(), b.F.copy(), b.CR.copy(),
                               b.stale) for b in self.branches.values()),
                        tuple(b.key for b in final or ()), self.counter.evaluations, tuple(self.history),
                        self.rng.bit_generator.state, race, init=tuple(self.init),
                        settled=self.settled)

    def restore(self, snap: Snapshot) -> None:
        """The state of ``snap``: inside the race on the race's fidelity, or on the objective itself
        (where a run's polish leaves it)."""
        self.branches = {key: Branch(key, bits.copy(), free.copy(), x.copy(), f.copy(), F.copy(), CR.copy(), stale)
                         for key, bits, free, x, f, F, CR, stale in snap.branches}
        if snap.init:
            self.init = list(snap.init)              # its caller need not pose them again
        self.settled = snap.settled
        if snap.paused:
            keys, self.rung, self.rung_generations, self.rung_spare, self.complete, self.stop = snap.race
            self.survivors = [self.branches[k] for k in keys]
            self.final, self.finalists = [], None
            self.counter.objective = self.cheap
        else:
            self.finalists = self.final = [self.branches[k] for k in snap.finalists]
            self.counter.objective = self.objective
        self.counter.evaluations = snap.evaluations
        self.history = list(snap.history)
        self.rng.bit_generator.state = snap.rng

    def rank_of(self, cost: float, b: Branch) -> float:
        """``cost`` charged as ``rank`` charges branch ``b``'s."""
        return cost if self.penalized is None else float(self.penalized(cost, b.bits))

    def rank(self, b: Branch) -> float:
        """What the final choice compares: the branch's best cost, charged for its parameters when
        the problem says how (``penalized``)."""
        return b.best if self.penalized is None else float(self.penalized(b.best, b.bits))

    def result(self) -> Result:
        finalists = self.finalists
        finalists.sort(key=self.rank)
        win = finalists[0]
        i = int(np.argmin(win.f))
        margin = self.rank(finalists[1]) / max(self.rank(win), 1e-300) if len(finalists) > 1 else float("inf")
        extra = {"margin": margin, "structures": [(b.key, b.best) for b in finalists],
                 "raced": len(self.branches), "families": list(getattr(self, "checked", []))}
        if not self.options.recheck and (self.options.resume is None or self.options.resume.paused):
            extra["snapshot"] = self.snapshot()
        return self.make_result(win.x[i].copy(), win.bits.copy(), win.best, extra)


ENGINE = Engine("AHDE", AHDE, AHDEOptions)
