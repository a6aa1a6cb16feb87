"""One estimator per candidate set (Sec. III-D), in one pool of processes per diagnosis.

Each estimator minimises the objective of :mod:`fdi.objective` for its candidate set with the
chosen engine (:mod:`optim`), seeded from the diagnosis seed and its index, so results do not
depend on the number of workers. :class:`Estimators` holds the compiled monitor and, with more
than one worker, one process pool for the whole diagnosis, which takes the rest of a batch once
that rest is predicted to take longer than :data:`POOL_WORTH_S` here (a short diagnosis runs in its
own process): each worker receives the monitor once (it derives the model once,
:mod:`fdi.monitor`) and each job only the window of data it fits.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np

import optim
from optim.core import fitness

from . import criterion, detect, encoding, hints, profiles
from .objective import Objective, Window, acted_on, linear_transform, window
from .results import Estimate

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

    from .monitor import Monitor

CHI2_95 = 3.841458820694124      # 95 % quantile of chi-square with one degree of freedom
POOL_WORTH_S = 0.5               # s of estimators left in a batch worth the pool (see Estimators._map)
"""With more than one worker, the pool takes the rest of a batch only once that rest is predicted to
take this long (wall) in this process: a pool costs its start, each job's data and each estimate's
state moved between processes, and the workers' empty caches. Measured on 2 cores: CyCab scenario
2 (estimators of 0.02-0.34 s, batches of at most 3) as a whole ``bgfdi diagnose`` 0.96-0.98 s with
one worker, 1.06-1.27 s when every batch went to the pool of two; the tutorial's capacitor ageing
(a first batch of four singletons, 0.38 s the first) keeps the pool for its first batch. Which
process fits a set never changes its result (each estimator's seed is its own)."""


@dataclass(frozen=True)
class Search:
    """The engine and its budget, the same for every estimator of a diagnosis."""
    engine: str
    pop: int
    generations: int


@dataclass(frozen=True)
class Job:
    """One estimator: a candidate set on a window, with its seed, the fits it starts from
    (``known``), the faults held at an earlier fit (``fixed``) and its onset interval."""
    win: Window
    candidate: tuple[str, ...]
    weights: np.ndarray
    search: Search
    seed: int
    known: tuple = ()
    fixed: tuple = ()
    onset: tuple[float, float] | None = None
    modes: tuple[tuple[str, float], ...] = ()      # mode variables the caller knows (Options.mode)
    recheck: bool = True                           # the engine's final check (where it has one)
    resume: object = None                          # the engine's state: the run continues from it
    pause: int | None = None                       # stop the race after this many rungs (``AHDEOptions.pause``)
    settle_later: bool = False                     # the finalists' restarts wait for the check (``AHDEOptions``)
    prognosed: tuple[str, ...] = ()                # faults with a failure value: their RUL band's other models


def fit(monitor: "Monitor", job: Job) -> Estimate:
    """Run one estimator: the engine on the candidate's objective, the best individual described
    as report entries (an intermittent fault that never switches inside the window is abrupt on the
    data seen), with each incipient fault's coefficient bands."""
    config, w = monitor.config, monitor.config.derivative_window
    win = job.win
    obj = Objective(monitor.model, monitor.residuals, win, job.candidate, np.asarray(job.weights), w,
                    fixed=list(job.fixed), onset=job.onset, config=config, modes=dict(job.modes))
    init = []
    if job.resume is None:                       # a continued run reads its starting points from its state
        init = [obj.encode(list(faults)) for faults in job.known]
        init += earlier_onsets(obj, init, job.seed)
    problem = optim.pose(obj, n_bits=encoding.N_BITS * len(obj.spaces), onehot=encoding.onehot_groups(obj.spaces),
                         init=init)
    extra = ({"recheck": job.recheck, "resume": job.resume, "pause": job.pause, "settle_later": job.settle_later}
             if has_recheck(job.search.engine) else {})
    r = optim.minimize(problem, engine=job.search.engine, pop=job.search.pop, generations=job.search.generations,
                       seed=job.seed, **extra)
    margin = r.extra.get("margin")
    real, bits, cost = obj.complete(r.real, r.bits), r.bits, r.cost
    faults = encoding.describe(obj.spaces, real[:-1], bits)
    end = win.t0 + (win.crop.stop - win.crop.start) * win.ts
    plausible: dict[str, list[dict]] = {}
    for i, f in enumerate(faults):
        seeds = [m for known in job.known for k in known if k.get("name") == f["name"]
                 for m in k.get("other_models") or ()]
        if f["type"] == "incipient" and job.recheck and f["name"] in job.prognosed:
            # the final fit of a fault with a prognosis: another degradation model the criterion
            # prefers takes its place (the polish found what the search left), the plausible ones stay
            others = other_models(obj, real, bits, cost, i, job.seed, r.extra.get("families", ()), seeds)
            better = min((o for o in others if o["criterion_difference"] < 0), default=None,
                         key=lambda o: o["criterion_difference"])
            if better is not None:
                real, bits, cost = better["real"], better["bits"], better["cost"]
                faults = encoding.describe(obj.spaces, real[:-1], bits)
                f = faults[i]
                others = other_models(obj, real, bits, cost, i, job.seed, (), seeds + [_entry(o) for o in others])
            if others:
                plausible[f["name"]] = [_entry(o, coefficient_band(obj, o["real"], o["bits"], o["cost"], i, job.seed),
                                               _of(onset_profile(obj, o["real"], o["bits"], o["cost"], job.seed), i))
                                        for o in others]
    for i, f in enumerate(faults):
        f["t0"] = float(real[-1])
        if f["type"] == "incipient" and job.recheck:
            # the first pass of a two-phase run (recheck off) leaves the band to the sets its check
            # continues, those that may win: a band of a set that loses by twice the cost, or to a
            # subset, is never read (scenario 2: 1 842 of 31 213 evaluations)
            f["b_band"], f["t0_band"] = coefficient_band(obj, real, bits, cost, i, job.seed)
            if f["name"] in job.prognosed:
                f["onset_profile"] = _of(onset_profile(obj, real, bits, cost, job.seed), i)
            if f["name"] in plausible:
                f["other_models"] = plausible[f["name"]]
        elif f["type"] == "intermittent" and f["t0"] + f["period"] / 2 >= end:
            faults[i] = {"name": f["name"], "type": "abrupt", "value": f["value"], "t0": f["t0"]}
    return Estimate(tuple(job.candidate), cost, float(fitness(cost)), tuple(float(fitness(c)) for c in r.history),
                    None if margin is None or not np.isfinite(margin) else float(margin),
                    tuple(faults), r.evaluations, r.wall_s, r.objective_s, resume=r.extra.get("snapshot"))


EARLIER = (2.0, 5.0, 10.0)   # s: a known drift re-expressed as one that started this much earlier


def earlier_onsets(obj: Objective, init: list, seed: int = 0) -> list:
    """Starting points for a search whose onset may go back before its window: each known fit with
    an incipient fault re-expressed (:func:`fdi.hints.translate`, same degradation model) as a
    drift that started ``EARLIER`` seconds before, with the profile it has over the window. A
    drift fitted from t_D compensates a late onset with a steeper start; the earlier onset lies
    along a narrow valley of the cost that a search from the late fit seldom follows (measured: an
    eq. (18) encoder drift from 25 s detected at 35.3 s: refitted from 32.2 s at cost 281, the
    design costs 229, and {R4, R5, beta_theta2} won at 236)."""
    lo = obj.bounds()[-1, 0]
    if not lo < obj.win.t0 - obj.win.ts:
        return []
    t = obj.win.t[obj.win.crop]
    out = []
    for real, bits in init:
        kinds = encoding.structure(obj.spaces, bits)
        if not any(kind == "incipient" for kind, _ in kinds):
            continue
        for back in EARLIER:
            onset = float(real[-1]) - back
            if onset < lo:
                break
            moved = hints.translate(obj.spaces, real[:-1], bits, bits, t, float(real[-1]), seed, t0_to=onset)
            out.append((np.append(np.where(np.isnan(moved), real[:-1], moved), onset), bits))
    return out


def has_recheck(engine: str) -> bool:
    """Whether the engine named ``engine`` has a final check that can be left out (``recheck``)."""
    return "recheck" in optim.ENGINES[engine].options.names()


def plausible_limit(obj: Objective, cost: float) -> float:
    """The cost within which a point is as plausible as the best (``cost``) at 95 %: with Laplace
    residuals of common scale, 2 ln L ratio = 2 N_eff ln(C / C*) against chi2_1(0.95)."""
    win = obj.win
    n_eff = criterion.effective_samples(win.crop.stop - win.crop.start, len(obj.residuals), win.ts, obj.window_s)
    return cost * float(np.exp(CHI2_95 / (2 * n_eff)))


def coefficient_band(obj: Objective, real: np.ndarray, bits: np.ndarray, cost: float, index: int,
                     seed: int = 0) -> tuple[list[list[float]], list[float]]:
    """95 % profile-likelihood intervals of each degradation coefficient of fault ``index`` and of
    the onset, from the final fit alone (no re-identification): the ranges, over the points whose
    cost is within the likelihood-ratio limit, of each coefficient and of t0. Returns (b_band,
    t0_band).

    With Laplace-distributed weighted residuals of common scale (the L1 cost of eq. 24 is then their
    negative log-likelihood), profiling the scale out gives 2 ln L ratio = 2 N_eff ln(C / C*), so
    a point is plausible when C <= C* exp(chi2_1(0.95) / (2 N_eff)); N_eff counts independent
    samples (residual samples over the derivative window in samples). The coefficients and the
    onset are correlated (a later onset with a faster rate fits a drift almost as well): intervals
    with the others held at the fit (conditional) were far too narrow, the true RUL outside the
    band in 12 of 24 checkpoints of the plant suite. The region is sampled on a Latin hypercube
    (``BAND_SAMPLES``) in a box three times the conditional intervals, widened where plausible
    points reach its edge."""
    limit = plausible_limit(obj, cost)
    model = encoding.describe(obj.spaces, real[:-1], bits)[index]["model"]
    bounds = obj.bounds()
    coords = [encoding.N_REAL * index + slot for slot in encoding.COEFF_SLOTS[model]] + [real.size - 1]
    lo, hi = bounds[coords, 0], bounds[coords, 1]
    near = np.array([[_crossing(obj, real, bits, j, bounds[j, side] - real[j], limit) for side in (0, 1)]
                     for j in coords])
    centre = real[coords]
    reach = np.maximum(np.abs(near - centre[:, None]), 1e-9 * np.maximum(1.0, np.abs(centre))[:, None])
    box = np.column_stack([np.maximum(lo, centre - 3 * reach[:, 0]), np.minimum(hi, centre + 3 * reach[:, 1])])
    rng = np.random.default_rng(seed)
    points = [np.vstack([np.where(np.arange(len(coords)) == k, near[k, s], centre) for k in range(len(coords))
                         for s in (0, 1)] + [centre])]
    for _ in range(BAND_ROUNDS):
        strata = (np.argsort(rng.random((BAND_SAMPLES, len(coords))), axis=0)
                  + rng.random((BAND_SAMPLES, len(coords)))) / BAND_SAMPLES
        x = box[:, 0] + strata * (box[:, 1] - box[:, 0])
        rows = np.tile(real, (BAND_SAMPLES, 1))
        rows[:, coords] = x
        ok = obj(rows, np.tile(bits, (BAND_SAMPLES, 1))) <= limit
        points.append(x[ok])
        got = np.vstack(points)
        width = box[:, 1] - box[:, 0]
        grow_lo = (got.min(axis=0) <= box[:, 0] + 0.1 * width) & (box[:, 0] > lo)
        grow_hi = (got.max(axis=0) >= box[:, 1] - 0.1 * width) & (box[:, 1] < hi)
        if not (grow_lo.any() or grow_hi.any()):
            break
        box[:, 0] = np.where(grow_lo, np.maximum(lo, box[:, 0] - width), box[:, 0])
        box[:, 1] = np.where(grow_hi, np.minimum(hi, box[:, 1] + width), box[:, 1])
    got = np.vstack(points)
    rows = np.tile(real, (got.shape[0], 1))
    rows[:, coords] = got
    b = encoding.decode(obj.spaces, rows[:, :-1], np.tile(bits, (got.shape[0], 1)))[index].b
    b_band = [[float(b[:, slot - 2].min()), float(b[:, slot - 2].max())] for slot in encoding.COEFF_SLOTS[model]]
    return b_band, [float(got[:, -1].min()), float(got[:, -1].max())]


MODEL_ODDS = 2.0 * float(np.log(20.0))   # Schwarz's criterion within this of the fit's: posterior odds above 1/20
MODEL_ROUNDS = 12    # rounds of the local search that polishes each other degradation model
MODEL_DRAWS = 64     # points per round (one objective call)
MODEL_FINEST = 0.005  # the search stops below this share of each range (the simplex after it starts with 2 % steps)
MODEL_ONSETS = (0.0, 2.0, 8.0)   # s before the fit's onset where each other model's search may start


def other_models(obj: Objective, real: np.ndarray, bits: np.ndarray, cost: float, index: int,
                 seed: int = 0, families=(), seeds: list[dict] = ()) -> list[dict]:
    """The other degradation models (16)-(19) of incipient fault ``index`` that the window cannot
    tell from the fit's: each re-expressed from the fitted profile (:func:`fdi.hints.translate`),
    and from the engine's best point of that structure where its final check settled one
    (``families``: bits, reals, cost) and from the plausible models an earlier fit of the fault
    found (``seeds``: a refit on more data starts where the shorter window left each model),
    brought to its basin by a shrinking Gaussian search over its coefficients and the onset on the
    race's fidelity (``Objective.coarse``; stopped once its step is below ``MODEL_FINEST`` of each
    range), polished on the objective itself by a simplex when within reach, and kept when
    Schwarz's criterion (:func:`fdi.criterion.information`) is within ``MODEL_ODDS`` of the fit's:
    posterior odds of at least 1 to 20 against it (BIC approximates twice the log Bayes factor).
    Returns, per plausible model, {model, b, t0, cost} (the report's entry, :func:`_entry`) with
    its ``criterion_difference`` to the fit and its ``real``/``bits`` row; for the prognosis' band
    (and the fit's place, when the criterion prefers one): the band's corners from one model's
    coefficient intervals assume that model, and two models that fit a window equally can fail far
    apart (measured on the plant: an R5 drift of eq. (19) from 20 s,
    refitted at 50 % of its life, costs 109.03; eq. (17) from 23.5 s 109.88, RUL 13.8 s for a true
    20.3 s, band 13.1-14.5 s)."""
    win = obj.win
    n_eff = criterion.effective_samples(win.crop.stop - win.crop.start, len(obj.residuals), win.ts, obj.window_s)
    entries = encoding.describe(obj.spaces, real[:-1], bits)
    mine = criterion.information(cost, entries, n_eff)
    model = int(entries[index]["model"])
    bounds = obj.bounds()
    t = win.t[win.crop]
    rng = np.random.default_rng(seed + 7)
    out = []
    for other in profiles.MODELS:
        if other == model:
            continue
        to = np.array(bits, dtype=bool).copy()
        to[encoding.N_BITS * index + 3], to[encoding.N_BITS * index + 4] = (other - 1) // 2, (other - 1) % 2
        starts = []
        for back in MODEL_ONSETS:          # a second-order drift leaves with zero slope: it may start earlier
            onset = float(np.clip(real[-1] - back, *bounds[-1]))
            moved = hints.translate(obj.spaces, real[:-1], bits, to, t, onset, seed)
            starts.append(np.append(np.where(np.isnan(moved), real[:-1], moved), onset))
        starts += [np.asarray(x, dtype=float) for b, x, _ in families
                   if np.array_equal(np.asarray(b, dtype=bool), to) and np.asarray(x).shape == real.shape]
        for known in seeds:
            if int(known["model"]) == other:
                x = starts[0].copy()
                part, _ = encoding.encode([obj.spaces[index]], [{"type": "incipient", "model": other, "b": known["b"]}])
                cols = [encoding.N_REAL * index + slot for slot in encoding.COEFF_SLOTS[other]]
                x[cols] = part[encoding.COEFF_SLOTS[other]]
                x[-1] = known["t0"]
                starts.append(np.clip(x, bounds[:, 0], bounds[:, 1]))
        starts = np.unique(np.array(starts), axis=0)
        c = obj.coarse(starts, np.tile(to, (len(starts), 1)))
        k = int(np.nanargmin(np.where(np.isfinite(c), c, np.inf)))
        x, best = starts[k], float(c[k])
        coords = [encoding.N_REAL * index + slot for slot in encoding.COEFF_SLOTS[other]] + [real.size - 1]
        width = bounds[coords, 1] - bounds[coords, 0]
        scale = 0.1
        for _ in range(MODEL_ROUNDS):
            if scale < MODEL_FINEST:
                break
            rows = np.tile(x, (MODEL_DRAWS, 1))
            rows[:, coords] += rng.normal(0.0, 1.0, (MODEL_DRAWS, len(coords))) * scale * width
            rows[:, coords] = np.clip(rows[:, coords], bounds[coords, 0], bounds[coords, 1])
            c = obj.coarse(rows, np.tile(to, (MODEL_DRAWS, 1)))
            k = int(np.nanargmin(np.where(np.isfinite(c), c, np.inf)))
            if c[k] < best:
                best, x = float(c[k]), rows[k]
            else:
                scale /= 4
        if not np.isfinite(best):
            continue
        best = float(obj(x[None, :], to[None, :])[0])      # the search's fidelity was the race's: the cost itself
        if not np.isfinite(best):
            continue
        if best <= MODEL_POLISH * cost:       # within reach: a simplex follows the narrow valley down
            x, best = _simplex(obj, x, to, coords, bounds, best)
        entry = encoding.describe(obj.spaces, x[:-1], to)[index]
        others = [e for j, e in enumerate(entries) if j != index] + [entry]
        difference = criterion.information(best, others, n_eff) - mine
        if difference <= MODEL_ODDS:
            out.append({"model": other, "b": [float(v) for v in entry["b"]], "t0": float(x[-1]), "cost": best,
                        "criterion_difference": difference, "real": x.copy(), "bits": to})
    return out


def onset_profile(obj: Objective, real: np.ndarray, bits: np.ndarray, cost: float, seed: int = 0) -> list[dict]:
    """The plausible fits along the onset: the fit re-expressed (:func:`fdi.hints.translate`, same
    degradation models) as drifts that started ``ONSET_STEPS`` seconds earlier or later, kept where
    the cost is within the likelihood-ratio limit of :func:`coefficient_band`. Returns, per kept
    point, {t0, b (each fault's coefficients, None for a fault without), cost}.

    Why: a second-order drift leaves its nominal value with zero slope, so an onset seconds
    earlier with a gentler rate fits a short window almost as well; that valley is long and curved,
    and the box of :func:`coefficient_band` (sampled around the fit) does not follow it. Measured on
    the plant: an eq. (18) pressure drift from 20 s (b3 = -8, b4 = -1.1) refitted 3 s after
    detection, eq. (18) at its best from 21.28 s with b3 = -30.2 (RUL 9.5 s for a true 7.3 s);
    re-expressed from 20.28, 19.28, 18.28 and 15.28 s it costs 36.76, 37.28, 37.83, 38.31 within
    the limit 38.62 (RULs 8.2, 7.0, 6.5, 5.6 s); the first-order models (16), (17) leave the
    limit at once (41.8 at 0.5 s earlier)."""
    win = obj.win
    limit = plausible_limit(obj, cost)
    lo, hi = obj.bounds()[-1]
    t = win.t[win.crop]
    onsets = [float(real[-1]) + step for step in ONSET_STEPS if lo <= float(real[-1]) + step <= hi]
    if not onsets:
        return []
    rows = []
    for onset in onsets:
        moved = hints.translate(obj.spaces, real[:-1], bits, bits, t, float(real[-1]), seed, t0_to=onset)
        rows.append(np.append(np.where(np.isnan(moved), real[:-1], moved), onset))
    rows = np.array(rows)
    c = obj(rows, np.tile(bits, (len(rows), 1)))
    out = []
    for x, ck in zip(rows, c):
        if np.isfinite(ck) and ck <= limit:
            entries = encoding.describe(obj.spaces, x[:-1], bits)
            out.append({"t0": float(x[-1]), "b": [None if e.get("b") is None else [float(v) for v in e["b"]]
                                                   for e in entries], "cost": float(ck)})
    return out


ONSET_STEPS = (-16.0, -8.0, -4.0, -2.0, -1.0, -0.5, 0.5, 1.0, 2.0)   # s from the fit's onset (:func:`onset_profile`)


def _entry(fit: dict, band: tuple[list, list] | None = None, profile: list[dict] | None = None) -> dict:
    """The report's entry of one of :func:`other_models`' fits: model, b, t0, cost, and with
    ``band`` (:func:`coefficient_band` of that model at its own best) its ``b_band`` and
    ``t0_band``: the prognosis' band holds each plausible model's own 95 % region, not only its
    best point (measured on the plant: an eq. (18) pressure drift from 20 s refitted at 50 % of
    its life, 3 s after detection: the fit eq. (16), eq. (18) plausible at 36.64 from 21.3 s with
    b3 = -30; the design, eq. (18) with b3 = -8 from 20 s, costs 36.83, inside that model's region
    and outside the fit's; the band 11.5-28.0 s missed the true 7.3 s)."""
    out = {k: fit[k] for k in ("model", "b", "t0", "cost")}
    if band is not None:
        out["b_band"], out["t0_band"] = band
    if profile:
        out["onset_profile"] = profile
    return out


def _of(profile: list[dict], index: int) -> list[dict]:
    """:func:`onset_profile`'s points with fault ``index``'s coefficients only (the report's entry)."""
    return [dict(p, b=p["b"][index]) for p in profile]


MODEL_POLISH = 1.25  # another model's best within this factor of the fit's cost is polished by a simplex (plausible: ~1.05)


def _simplex(obj: Objective, x: np.ndarray, bits: np.ndarray, coords: list[int], bounds: np.ndarray,
             best: float) -> tuple[np.ndarray, float]:
    """Nelder-Mead (``optim.simplex``: scipy's, without importing scipy.optimize) over the reals
    ``coords`` of ``x`` within their bounds, one row per call: the coefficients of a second-order
    drift and its onset trade off along a curved valley that a random search crosses but does not follow."""
    from optim.simplex import nelder_mead
    lo, hi = bounds[coords, 0], bounds[coords, 1]
    scale = np.where(hi > lo, hi - lo, 1.0)

    def f(u: np.ndarray) -> float:
        row = x.copy()
        row[coords] = np.clip(lo + u * scale, lo, hi)
        c = float(obj(row[None, :], bits[None, :])[0])
        return c if np.isfinite(c) else 1e300
    u0 = (x[coords] - lo) / scale
    r = nelder_mead(f, u0, maxfev=60 * len(coords), xatol=1e-6, fatol=1e-9 * best,
                    initial_simplex=np.vstack([u0] + [u0 + 0.02 * np.eye(len(coords))[k] for k in range(len(coords))]))
    if r.fun < best:
        out = x.copy()
        out[coords] = np.clip(lo + r.x * scale, lo, hi)
        return out, float(r.fun)
    return x, best


BAND_SAMPLES = 128   # points per round of the profile-likelihood sampling (one objective call)
BAND_ROUNDS = 4      # rounds at most: the box grows where plausible points reach its edge


def _crossing(obj: Objective, real: np.ndarray, bits: np.ndarray, j: int, span: float, limit: float) -> float:
    """Where the cost along real j (towards real[j] + span) first exceeds ``limit``: a geometric
    grid then a linear one between the last point inside and the first outside (two calls)."""
    steps = span * np.concatenate([[0.0], np.logspace(-5, 0, 31)])
    for _ in range(2):
        rows = np.tile(real, (steps.size, 1))
        rows[:, j] += steps
        c = obj(rows, np.tile(bits, (steps.size, 1)))
        outside = np.flatnonzero(~(c <= limit))
        if outside.size == 0:
            return float(real[j] + steps[-1])
        k = int(outside[0])
        if k == 0:
            return float(real[j])
        steps = np.linspace(steps[k - 1], steps[k], 17)
    return float(real[j] + steps[0])


_worker: "Monitor | None" = None


def _install(monitor: "Monitor") -> None:
    """A worker's initializer: the monitor, unpickled (derived) once per worker process."""
    global _worker
    _worker = monitor


def _fit_in_worker(job: Job) -> Estimate:
    return fit(_worker, job)


class Estimators:
    """The estimators of one diagnosis: the monitor, the search, and with ``workers`` > 1 one
    process pool, opened when first needed and closed with the diagnosis (``with`` block)."""

    def __init__(self, monitor: "Monitor", search: Search, workers: int = 1, memo: dict | None = None,
                 modes: dict[str, float] | None = None, prognosed=()) -> None:
        self.monitor, self.search, self.workers, self.memo = monitor, search, workers, memo
        self.prognosed = tuple(sorted(prognosed))
        self.modes = tuple(sorted((modes or {}).items()))
        self._pool: ProcessPoolExecutor | None = None
        self._spent, self._fitted = 0.0, 0  # wall seconds and number of the estimators run in this process
        # final checks put off (``run``'s ``defer``), by the engine's state they continue from:
        # that state, not the Estimate, is kept by ``dataclasses.replace``
        self._pending: dict[int, tuple[Estimate, Job, tuple]] = {}
        # every answer of this diagnosis by its question (:meth:`_question`): a later decision that
        # fits a set on the same window with the same bounds gets the earlier fit
        self._answers: dict[str, Estimate] = {}

    def __enter__(self) -> "Estimators":
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def _map(self, jobs: list[Job]) -> list[Estimate]:
        """The jobs' estimates, in order. With more than one worker, the jobs left of a batch go to
        the pool once they are predicted (this diagnosis's mean estimator so far, times their number)
        to take longer than POOL_WORTH_S in this process; until then, and for a batch of one, they
        run here (so a batch's first job always does, before the pool is open). Once open, the pool
        (of ``workers`` processes) takes every later batch of two or more whole."""
        out: list[Estimate] = []
        while jobs:
            if self.workers > 1 and len(jobs) > 1 and (
                    self._pool is not None or self._fitted and self._spent / self._fitted * len(jobs) > POOL_WORTH_S):
                if self._pool is None:
                    from concurrent.futures import ProcessPoolExecutor     # (20 ms of imports a short run skips)
                    self._pool = ProcessPoolExecutor(self.workers, initializer=_install, initargs=(self.monitor,))
                return out + list(self._pool.map(_fit_in_worker, jobs))
            start = time.perf_counter()
            out.append(fit(self.monitor, jobs[0]))
            self._spent, self._fitted = self._spent + time.perf_counter() - start, self._fitted + 1
            jobs = jobs[1:]
        return out

    def run(self, t: np.ndarray, raw: Mapping[str, np.ndarray], t0: float, samples: int,
            candidates: list[tuple[str, ...]], weights: np.ndarray, seed: int, progress: Callable | None = None,
            fixed: list[list[dict]] | None = None, onsets: list[tuple[float, float] | None] | None = None,
            known: list[list[dict]] | None = None,
            defer: Callable[[int, Estimate], bool] | None = None) -> list[Estimate]:
        """One estimator per candidate set (seed + 1000 * index each) on the N ``samples`` from
        ``t0``, smaller sets first: a set starts from the fits of the sets it contains, its other
        faults as no-ops (the engine searches around them; results do not depend on ``workers``).
        With an engine that has a final check (AHDE's ``recheck``), every set is first fitted
        without it, and the sets within ``RECHECK_REACH`` of the best cost are continued with it
        from where their first pass stopped (``Estimate.resume``): the check costs as much as the
        race, and only the sets that may win need it.

        Per candidate set, optionally: ``fixed`` faults held at an earlier fit (each with its
        onset), the ``onsets`` interval its own onset is searched in, and ``known`` fits to start
        from. With a ``memo`` (the streaming monitor's, across decisions on a growing stream), a
        job whose settings and data window are unchanged is not run again. A set whose faults are
        :func:`separable` also starts from each of its faults fitted alone (fitted first, not returned).

        ``defer(i, estimate)`` (two-phase runs only): True puts off the final check of set ``i``,
        given its first pass, to :meth:`settle`: a caller that will refit the set and keep the
        better fit (:func:`refit_early_onsets`) checks only the fit it keeps. Until then the set
        competes on its first pass (its cost before the check, never lower than after it)."""
        fixed = fixed or [[] for _ in candidates]
        onsets = onsets or [None for _ in candidates]
        known = known or [[] for _ in candidates]
        asked = len(candidates)
        asked_sets = {tuple(c) for c in candidates}
        alone: dict[tuple[str, ...], int] = {}      # each fault alone, once, with the settings of its first set
        for i, c in enumerate(candidates):
            if separable(self.monitor, tuple(c)):
                for name in c:
                    if (name,) not in asked_sets:
                        alone.setdefault((name,), i)
        parts = [(i, c) for c, i in alone.items()]
        candidates = list(candidates) + [c for _, c in parts]
        fixed, onsets = list(fixed) + [fixed[i] for i, _ in parts], list(onsets) + [onsets[i] for i, _ in parts]
        known = list(known) + [[] for _ in parts]
        win = window(t, raw, t0, samples, self.monitor.config.derivative_window)
        two_phase = has_recheck(self.search.engine) and len(candidates) > 1
        n_eff = criterion.effective_samples(win.crop.stop - win.crop.start, len(self.monitor.residuals), win.ts,
                                            self.monitor.config.derivative_window)
        done: dict[int, Estimate] = {}
        jobs: dict[int, Job] = {}
        for size in sorted({len(c) for c in candidates}):
            wave = [i for i, c in enumerate(candidates) if len(c) == size]
            for i in wave:
                jobs[i] = Job(win, tuple(candidates[i]), np.asarray(weights), self.search, seed + 1000 * i,
                              tuple(known[i]) + tuple(list(r.faults) for j, r in done.items()
                                                      if set(r.candidate) < set(candidates[i]) and fixed[j] == fixed[i]
                                                      and not r.raced_out),
                              tuple(fixed[i]), onsets[i], self.modes, recheck=not two_phase,
                              settle_later=two_phase and size == 1, prognosed=self.prognosed)
            if two_phase and size > 1 and any(i < asked for i in wave):   # single faults seed every set: settled
                done.update(self._race(wave, jobs, fixed, asked, t, t0, samples, done, candidates, n_eff))
            else:
                done.update(zip(wave, self._run([jobs[i] for i in wave], t, t0, samples)))
            if progress:
                progress(len(done), len(candidates))
        if two_phase:                    # the final check only where it can change the decision
            best = min((r.cost for r in done.values() if np.isfinite(r.cost)), default=np.inf)
            score = {i: criterion.information(r.cost, list(r.faults), n_eff) for i, r in done.items()}
            # a set a subset of which the criterion already prefers adds a fault that explains nothing:
            # its check would re-polish the subset's families beside a no-op
            again = [i for i in sorted(done) if done[i].cost <= best * (1 + RECHECK_REACH) and not done[i].raced_out
                     and not any(set(candidates[j]) < set(candidates[i]) and fixed[j] == fixed[i]
                                 and score[j] <= score[i] for j in done)]
            again = [i for i in again if i < asked]
            checks = {i: replace(jobs[i], recheck=True, settle_later=False, resume=done[i].resume) for i in again}
            later = [i for i in again if defer is not None and done[i].resume is not None and defer(i, done[i])]
            where = (t, t0, samples)
            for i in later:
                self._pending[id(done[i].resume)] = (done[i], checks[i], where)
            again = [i for i in again if i not in later]
            done.update(zip(again, self._run([checks[i] for i in again], t, t0, samples)))
        return [done[i] for i in range(asked)]

    def settle(self, estimates: list[Estimate]) -> list[Estimate]:
        """``estimates`` with every final check :meth:`run` put off (``defer``) run now, from the
        state the first pass left: the fit, cost, evaluations and times the check would have given
        in ``run``, plus any work a caller added to the estimate (evaluations, time, and history
        entries before the first pass's). A snapshot met twice is checked once. Checks put off for
        estimates not among ``estimates`` (fits a refit replaced) are dropped."""
        out = list(estimates)
        todo: dict[int, list[int]] = {}                  # snapshot -> the places that hold it
        for k, e in enumerate(out):
            if e.resume is not None and id(e.resume) in self._pending:
                todo.setdefault(id(e.resume), []).append(k)
        groups: dict[int, list[int]] = {}                # one batch per run that put checks off
        for key in todo:
            groups.setdefault(id(self._pending[key][2]), []).append(key)
        for keys in groups.values():
            t, t0, samples = self._pending[keys[0]][2]
            got = self._run([self._pending[key][1] for key in keys], t, t0, samples)
            for key, checked in zip(keys, got):
                first = self._pending[key][0]
                for k in todo[key]:
                    e = out[k]
                    n = len(first.history)
                    before = tuple(e.history[:-n]) if n and tuple(e.history[-n:]) == tuple(first.history) else ()
                    out[k] = replace(checked, evaluations=checked.evaluations + e.evaluations - first.evaluations,
                                     history=before + tuple(checked.history),
                                     wall_s=checked.wall_s + e.wall_s - first.wall_s,
                                     objective_s=checked.objective_s + e.objective_s - first.objective_s)
        self._pending.clear()
        return out

    def _race(self, wave: list[int], jobs: dict[int, Job], fixed: list, asked: int, t: np.ndarray, t0: float,
              samples: int, done: dict[int, Estimate], candidates: list, n_eff: float) -> dict[int, Estimate]:
        """The candidate sets of one size (two faults or more) raced like the engine's structures:
        each runs its screen and first rung, and after each of the rungs ``SET_RUNGS``
        (``Job.pause``) a set stops there when its leader costs more than ``1 + SET_REACH`` times
        the best set of its wave (the same faults held) and its race gained less than ``SET_STALL``
        over its last rung, or when its race gained less than that with its leader no better than
        the fit of one of its subsets (within ``SUBSET_GAIN``), which the information criterion
        prefers (:func:`_preferred_subset`; a set alone in its size races for this rule alone); the
        others continue exactly where they stopped (the run never paused).
        On the objective itself every set's cost is on one scale: the same window, weights and
        residuals. Sets that only seed larger ones (a separable set's faults alone, past ``asked``)
        are never stopped; a stopped set seeds no larger one (``run``)."""
        out: dict[int, Estimate] = {}
        state: dict[int, Estimate] = {}
        live = list(wave)
        for rung in SET_RUNGS + (None,):
            got = self._run([replace(jobs[i], pause=rung, resume=state[i].resume if i in state else None)
                             for i in live], t, t0, samples)
            for i, r in zip(live, got):
                if i in state:
                    r = replace(r, wall_s=r.wall_s + state[i].wall_s, objective_s=r.objective_s + state[i].objective_s)
                state[i] = r
            going = [i for i in live if state[i].resume is not None and state[i].resume.paused]
            out.update({i: state[i] for i in live if i not in going})   # their race ended (or the last rung)
            live = []
            for i in going:
                lead = min(state[j].cost for j in wave if fixed[j] == fixed[i])
                snap = state[i].resume
                stalled = i < asked and snap.gain is not None and snap.gain < SET_STALL
                if stalled and state[i].cost > lead * (1 + SET_REACH):
                    out[i] = replace(state[i], raced_out=True)   # behind and stalled: its leader is its fit
                elif stalled and (sub := _preferred_subset(state[i], i, done, candidates, fixed, n_eff)) is not None:
                    out[i] = replace(state[i], raced_out=True, outdone_by=tuple(candidates[sub]))
                else:
                    live.append(i)
            if not live:
                break
        return {i: out[i] for i in wave}           # in index order: larger sets start from these in order

    def _run(self, jobs: list[Job], t: np.ndarray, t0: float, samples: int) -> list[Estimate]:
        """The estimates of ``jobs``, from the memo where it has them, or from this diagnosis'
        earlier answer to the same question (:meth:`_question`; none of its work counted again:
        evaluations and times 0). A question asked twice in ``jobs`` is fitted once."""
        keys = [self._key(job, t, t0, samples) for job in jobs] if self.memo is not None else [None] * len(jobs)
        asked = [self._question(job, t, t0, samples) for job in jobs]
        todo: list[Job] = []
        first: dict[str, int] = {}                       # a question fitted in this call: its job in todo
        for job, key, q in zip(jobs, keys, asked):
            if (key is None or key not in self.memo) and q not in self._answers and q not in first:
                first[q] = len(todo)
                todo.append(job)
        got = self._map(todo)
        out = []
        for job, key, q in zip(jobs, keys, asked):
            if key is not None and key in self.memo:
                r = self.memo[key]
            elif q in self._answers:
                r = replace(self._answers[q], evaluations=0, wall_s=0.0, objective_s=0.0)
            else:
                r = got[first[q]]
                if todo[first[q]] is not job:             # the same question twice in this call
                    r = replace(r, evaluations=0, wall_s=0.0, objective_s=0.0)
            if key is not None:
                self.memo[key] = r
            self._answers.setdefault(q, r)
            out.append(r)
        return out

    def _question(self, job: Job, t: np.ndarray, t0: float, samples: int) -> str:
        """What an estimator answers: :meth:`_key` without the seed and the fits it starts from
        (``known``: the engine's starting points and those of the other degradation models'
        search), and with the run it continues (its snapshot, held by the answer kept for the
        question that made it: its id is not reused while the diagnosis runs). Every run of one
        Estimators reads the same record (``raw``), so the window's place says which samples.
        A later decision on the window of an earlier one asks again for sets that decision
        fitted (the tutorial's re-decision: a fifth of its evaluations to find the same fit of
        {C1}); the earlier fit answers it, without a second search from it."""
        return json.dumps([*self._window(t, t0, samples), list(job.candidate), list(map(float, job.weights)), repr(job.search),
                           job.fixed, job.onset, job.modes, job.recheck, job.pause, job.settle_later, job.prognosed,
                           None if job.resume is None else id(job.resume)], default=float, sort_keys=True)

    def _key(self, job: Job, t: np.ndarray, t0: float, samples: int) -> str:
        """What an estimator's result depends on: the model and settings, the job, and the samples
        of its window (the stream's record grows; its window's last sample is where it ends)."""
        return json.dumps([self.monitor.key, repr(self.monitor.config), *self._window(t, t0, samples),
                           list(job.candidate),
                           list(map(float, job.weights)), repr(job.search), job.seed, job.known, job.fixed,
                           job.onset, job.modes, job.recheck, job.pause, job.settle_later, job.prognosed],
                          default=float, sort_keys=True)

    def _window(self, t: np.ndarray, t0: float, samples: int) -> tuple[float, int, int]:
        """Where a job's window is in the record: its start, its samples and the index one past its
        last sample read (the filter's margin after it)."""
        i0 = int(np.searchsorted(t, t0 - 1e-9))
        margin = int(np.ceil(self.monitor.config.derivative_window / float(t[1] - t[0])))
        return t0, samples, min(t.size, i0 + samples + margin)


def _preferred_subset(r: Estimate, i: int, done: dict[int, Estimate], candidates: list, fixed: list,
                      n_eff: float) -> int | None:
    """The best fitted subset of set ``i`` (its faults held alike, not itself raced out) when ``r``,
    the set's paused race leader, costs no less than that subset's fit but for ``SUBSET_GAIN`` and
    the information criterion prefers the subset; else None. A set starts from its subsets' fits,
    its other faults as no-ops: a race that stalled there has found nothing the extra faults
    explain. (The criterion alone also stopped sets that explained a little: a pair 0.65 % below its
    single fault's abrupt fit at t_D, whose refit with an earlier onset found the true drift.)"""
    subs = [(d.cost, j) for j, d in done.items()
            if set(candidates[j]) < set(candidates[i]) and fixed[j] == fixed[i] and not d.raced_out
            and np.isfinite(d.cost)]
    if not subs:
        return None
    cost, j = min(subs)
    if not r.cost >= cost * (1 - SUBSET_GAIN):
        return None
    preferred = criterion.information(cost, list(done[j].faults), n_eff) <= criterion.information(
        r.cost, list(r.faults), n_eff)
    return j if preferred else None


def separable(monitor: "Monitor", candidate: tuple[str, ...]) -> bool:
    """Whether a set of several faults is fitted from its faults fitted alone (:meth:`Estimators.run`):
    its faults touch pairwise disjoint residuals (no residual reads the parameters or the
    corrected signal of two of them), so that its cost is a sum of one part per fault (the onset
    is shared), and some fault's magnitude is searched. The set's best fit may leave some faults
    as no-ops: a solved magnitude reaches one by itself (delta = 0), a searched one is a point the
    joint search over every fault's structures rarely reaches.
    Measured on a chain of 100 tanks (`bgfdi bench chain`: tank 50's capacitance 20 % low from
    100 s): the pressure jump lit the two neighbours' residuals through the derivative filter's
    transient; the set of three was fitted at 6840-7900 on three seeds, worse than no fault at all
    (6537; the design: 5422), and a 1.4 % change of tank 49 was the diagnosis. Started from each
    fault fitted alone (tank 50: 5398 in 4674 evaluations): 5376, tank 50 at 7.93e-6 for 8e-6, the
    neighbours changed by 0.4 % (fitting the transient)."""
    if len(candidate) < 2:
        return False
    seen: set[int] = set()
    searched = False
    for name in candidate:
        mine = acted_on(monitor.model, monitor.residuals, name)
        if mine & seen:
            return False
        seen |= mine
        searched = searched or linear_transform(monitor.model, monitor.residuals, name, sorted(mine)) is None
    return searched


RECHECK_REACH = 1.0  # the engine's final check reruns the candidate sets within twice the best cost: the
                    # information criterion never prefers a set that fits twice as badly (scenario 2: 2 of 5
                    # sets rechecked, 17 000 -> 3 000 evaluations of the check)
SET_RUNGS = (1, 2)  # the candidate sets of one size (>= 2 faults) race each other after these rungs: one
SET_REACH = 5.0     # whose leader costs over 6x the wave's best and whose race gained under 5 % in its last
SET_STALL = 0.05    # rung stops. Measured (traces of the plant suite and the domain tests, each set's race
                    # run to its end): a set that went on to win was 4.3x behind after its first rung
                    # (gaining 86 %) and 4.4x behind and stalled after its second; at 4x without the stall
                    # rule the CSTR's true set {catalyst} stopped. Single faults are never raced: their fits
                    # seed every larger set and the later refits (the CSTR's stopped {holdup} moved the
                    # catalyst's rate 8-11 % on 3 of 8 seeds, 1 of 8 without). Scenario 2: {R4, R5} and
                    # {R5, beta_theta2} stop
SUBSET_GAIN = 1e-3  # a set whose race stalled within 0.1 % of its best subset's cost (and not preferred by the
                    # criterion) stops: scenario 2's {R4, R5, beta_theta2}, 0.01 % below {R4, beta_theta2}
REFIT_REACH = 2.5   # a refit with an earlier onset lowered a biased drift's cost 4-fold (581 -> 133, best 308)


def evidence_onsets(monitor: "Monitor", r: np.ndarray, t: np.ndarray, thresholds: np.ndarray, t_d: float,
                    start: float, late: float | None = None) -> tuple[float, float]:
    """The onsets the residuals ``r`` (residuals x samples, from ``start``, the settling time, on)
    allow (:func:`fdi.hints.onset_interval`): never earlier than the first departure of a residual
    from its noise band minus its look-ahead (nesting depth of its derivative filters x half the
    derivative window), never later than t_D (``late``: where the confirming excursion began, when
    t_D's crossings were a switch's transient, :func:`fdi.pipeline.switch_excursion`) plus that
    look-ahead."""
    w = monitor.config.derivative_window
    look = np.array([hints.nesting_depth(res) * w / 2 for res in monitor.residuals])
    return hints.onset_interval(np.asarray(r).reshape(len(monitor.residuals), -1), t, thresholds, t_d, start, look,
                                late)


def within(results: list[Estimate], i: int) -> list[list[dict]]:
    """Starting points for refitting set ``i`` from the sets that contain it and fit better: each
    such fit with the other faults left out. A set and its superset race apart, and the smaller
    one's search may miss a basin the larger one found with its extra faults bending around it
    (measured on the plant: an eq. (18) encoder drift from 25 s; {beta_theta2} alone fitted at 278
    for a design of 229 while {R4, R5, beta_theta2} reached 231 with beta_theta2 near the design,
    R4 a leak growing from nothing and R5 at 1.005, and won)."""
    names = set(results[i].candidate)
    return [[f for f in e.faults if f["name"] in names] for e in results
            if set(e.candidate) > names and e.cost < results[i].cost and e.faults]


def refit_early_onsets(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], t_d: float, samples: int,
                       candidates: list, results: list[Estimate], weights: np.ndarray, seed: int,
                       onsets: tuple[float, float], earliest: float | None = None,
                       seeds: list[list[list[dict]]] | None = None, pinned: bool = True,
                       quiet: tuple | None = None) -> list[Estimate]:
    """Estimators fitted with their onset at t_D, the earliest the first search allows, refitted from
    their fit (and the structures one decision away: an abrupt fault may be a drift seen late) with
    the onset free over ``onsets``, the interval the evidence allows (:func:`evidence_onsets`); the
    better fit is kept. A slow drift crosses its threshold well after it starts, and fitted from
    t_D on, its rate comes out biased while spurious extra faults absorb the rest (measured: a
    beta_theta2 drift from 20 s, detected at 22.5 s: b2 -0.042 for -0.03, and {R4, R5, beta_theta2}
    won; refitted: b2 -0.0298, onset 19.98 s, and beta_theta2 alone wins). Only fits within
    REFIT_REACH of the best cost are refitted, and only these: a wider onset range for every fit
    makes an intermittent fault's phase far harder to find. Searched back to the start of the data,
    an intermittent encoder fault of period 0.7 s was fitted as an eq. (19) drift from 12 s before
    any residual fired. A fit with an incipient fault is the exception (``earliest``: the start of
    the trusted data): a drift starts from its nominal value, a second-order one with zero slope, so
    its residuals leave their noise band seconds after its onset and the evidence bounds nothing
    (measured: an eq. (18) drift of beta_theta2 from 25 s left the band at 32.4 s; bounded there, its
    fit took a spurious R4 and an end of life already past; from the start of the data, onset
    25.0 s and b within 1 %). Each refit also starts from the better fits of the sets containing
    it (:func:`within`) and from ``seeds`` (per set: fits to start from, a re-decision's earlier
    diagnosis: its onset may lie outside the first search's interval, where that search clipped it).
    A set seeded with a drift is refitted from ``earliest`` at once, as a drift fitted at first is.
    ``pinned``: a drift whose refitted onset stays at the evidence's bound is refitted once more from
    ``earliest`` (a re-decision, whose sets are seeded with the earlier diagnosis, passes False).
    ``quiet`` (thresholds, the detector's rule): a refit the quiet data before t_D contradict
    (:func:`contradicted`) is not kept.
    A first pass whose final check was put off (``Estimators.run``'s ``defer``: steps dated at t_D,
    :func:`steps_at_window_start`) enters here unchecked: it is compared, and refitted from, as its first
    pass left it, and checked at the end only if it is kept (``Estimators.settle``)."""
    ts = float(t[1] - t[0])
    best = min(e.cost for e in results)
    redo = [i for i, e in enumerate(results) if e.faults and at_window_start(e.faults, t_d, ts)
            and e.cost <= REFIT_REACH * best and not e.raced_out]     # a set raced out is no candidate
    seeds = seeds or [[] for _ in candidates]
    growing = lambda e: earliest is not None and any(f["type"] == "incipient" for f in e.faults)
    seeded = lambda i: earliest is not None and any(f["type"] == "incipient" for s in seeds[i] for f in s)
    spans = [(min(earliest, onsets[0]), onsets[1]) if growing(results[i]) or seeded(i) else tuple(onsets)
             for i in redo]
    redo = [i for i, s in zip(redo, spans) if s[0] < t_d - ts]
    spans = [s for s in spans if s[0] < t_d - ts]
    if not redo:
        return est.settle(results)
    # a drift found by the refit of an abrupt fit with its onset pinned at the evidence's bound:
    # refitted from the start of the trusted data, as a drift fitted at first is (measured: the
    # tutorial's capacitor ageing from 5 s refitted as eq. (17) from the bound, 8.04 s, at 1696
    # while the design costs 1675)
    out = _refit(est, t, raw, t_d, samples, candidates, list(results), weights, seed + 15485863, redo, spans, seeds,
                 quiet)
    again = [i for i in redo if pinned and earliest is not None and growing(out[i]) and onsets[0] > earliest + ts
             and min(f["t0"] for f in out[i].faults) <= onsets[0] + 1.5 * ts]
    if again:
        out = _refit(est, t, raw, t_d, samples, candidates, out, weights, seed + 32452843, again,
                     [(earliest, onsets[1])] * len(again), seeds, quiet)
    return est.settle(out)


def evidence_start(monitor: "Monitor", r: np.ndarray, t: np.ndarray, thresholds: np.ndarray, start: float) -> float:
    """Where the evidence begins (:func:`fdi.hints.evidence`: the earliest departure from its noise
    band of a residual that crossed its threshold at or after ``start``): :func:`evidence_onsets`'
    lower end without the filters' look-ahead; inf when no residual crossed."""
    found = hints.evidence(np.asarray(r).reshape(len(monitor.residuals), -1), t, thresholds, start)
    return min((began for _, _, began in found), default=np.inf)


def at_window_start(faults, t_d: float, ts: float) -> bool:
    """Whether a fit's onset sits at t_D, the earliest its window lets the search date it (within
    a sample and a half)."""
    return min((f.get("t0", np.inf) for f in faults), default=np.inf) <= t_d + 1.5 * ts


def steps_at_window_start(fit: Estimate, t_d: float, ts: float) -> bool:
    """Whether a fit is all steps, dated at t_D (:func:`at_window_start`): one that
    :func:`refit_early_onsets` refits with the onset free, so that a first pass's final check can
    wait for the fit that is kept (``Estimators.run``'s ``defer``), and whose onsets
    :func:`date_onsets` dates from the evidence. A step seen late is usually a drift or an earlier
    step: the tutorial's capacitor ageing, first fitted as a step at t_D (cost 2 029), refitted as
    eq. (16) from 5 s (1 674); its check (4 700 evaluations, a second on 5 000-sample rows) was
    never read. Fits with a drift or an intermittent fault keep their check: it settles each
    family at its bottom (a second-order drift's narrow basin), and a drift's refit starts from
    the degradation models it found (``other_models``)."""
    return bool(fit.faults) and all(f["type"] == "abrupt" for f in fit.faults) \
        and at_window_start(fit.faults, t_d, ts)


def date_onsets(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], t_d: float, samples: int,
                winner: Estimate, weights: np.ndarray, seed: int, onsets: tuple[float, float],
                evidence: float, earliest: float) -> Estimate:
    """The winner's steps dated where the evidence says they began before t_D. The identification
    window starts at t_D, so a step that began before it changes nothing the cost reads but the
    filter's margin: its onset, searched back over the evidence (``onsets``,
    :func:`refit_early_onsets`), stays wherever the search left it. When every fault of the winner
    is abrupt, one of them dated at or before t_D, and the ``evidence`` (:func:`evidence_start`: a
    residual left its noise band) begins more than a derivative window before t_D (a step the
    persistence rule confirmed late), the winner's set is fitted again from its fit on a window that
    starts a derivative window before ``onsets[0]`` (the same N samples after t_D), and all its
    faults are taken from that fit when their types are kept: the decision, and the cost it was made
    on, stay the first window's; the dates and values come from the longer one (the evaluations
    add up). Measured: a spring sagging from 8.00 s (quarter car) left the band at 8.0 s and was
    confirmed at 8.381 s (t_D): dated 8.36 s, now 8.007 s (12 166 N/m for 12 000; 12 075 before);
    the two tanks' outlet clogged at 200 s, confirmed 33 s later: dated 233.5 s, now 199.9-200.0 s."""
    ts = float(t[1] - t[0])
    w = est.monitor.config.derivative_window
    if not steps_at_window_start(winner, t_d, ts) or not evidence < t_d - w:
        return winner
    start = max(onsets[0] - w, earliest)
    i0, i1 = (int(np.searchsorted(t, x - 1e-9)) for x in (start, t_d))
    (r,) = est.run(t, raw, start, samples + (i1 - i0), [tuple(winner.candidate)], weights, seed + 7919, None, None,
                   [(start, onsets[1])], [[list(winner.faults)]])
    if sorted((f["name"], f["type"]) for f in r.faults) != sorted((f["name"], f["type"]) for f in winner.faults):
        return winner
    return replace(winner, faults=r.faults, evaluations=winner.evaluations + r.evaluations)


def contradicted(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], fit: Estimate, t_d: float,
                 thresholds: np.ndarray, rule: tuple[float, float] = (0.0, 0.0)) -> bool:
    """Whether ``fit``'s faults, begun at their onset before t_D, would have confirmed an alarm on the
    data before t_D by the detector's own rule (``rule``, :func:`fdi.detect.confirmed`, as
    :func:`step_onset_band` asks): then the detector would have fired earlier, and the quiet data
    contradict the fit, however well it explains the window after t_D, which is all its cost reads.
    The effect is the fit's residuals minus the nominal ones on the same data (to first order), up
    to two derivative windows before t_D (the filters' look-ahead), over at most
    :data:`STEP_LOOKBACK` samples after the onset. A user trial: a stuck ABS outlet was refitted as
    an outlet clogging and an air-filled caliper drifting from the first trusted sample, 5 s before
    the detection; that fit put ARR1 above its threshold on 23 % of the quiet samples before it."""
    onsets = {f.get("t0") for f in fit.faults}
    if not fit.faults or len(onsets) != 1 or None in onsets:
        return False
    w = est.monitor.config.derivative_window
    t0 = float(onsets.pop())
    start, stop = max(t0, float(t[0]) + w), t_d - 2 * w
    stop = min(stop, start + STEP_LOOKBACK * float(t[1] - t[0]))
    if stop - start <= 2 * w:
        return False
    return bool(_would_alarm(est, t, raw, fit, thresholds, rule, start, stop, (t0, t_d))([t0])[0])


def _would_alarm(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], fit: Estimate, thresholds: np.ndarray,
                 rule: tuple[float, float], start: float, stop: float,
                 bounds: tuple[float, float]) -> Callable[[list[float]], np.ndarray]:
    """A test of onsets, its window set up once: per onset, whether ``fit``'s faults, begun there,
    would have confirmed an alarm by the detector's rule (``rule``: its persistence and span,
    :func:`fdi.detect.confirmed`) on the data from ``start`` to ``stop``; their effect on each
    residual is the fit's residuals minus the nominal ones on the same data (to first order).
    ``bounds``: the onset's range for the encoding."""
    w = est.monitor.config.derivative_window
    ts = float(t[1] - t[0])
    i0, i1 = int(np.searchsorted(t, start - 1e-9)), int(np.searchsorted(t, stop - 1e-9))
    win = window(t, raw, start, i1 - i0, w)
    thresholds = np.asarray(thresholds, dtype=float).reshape(-1)
    obj = Objective(est.monitor.model, est.monitor.residuals, win, tuple(fit.candidate), 1.0 / thresholds, w,
                    onset=bounds, config=est.monitor.config, modes=dict(est.modes))
    real, bits = obj.encode(list(fit.faults))
    persistence, span = rule
    n = detect.evidence_samples(span, ts)

    def alarms(onsets: list[float]) -> np.ndarray:
        rows = np.tile(real, (len(onsets) + 1, 1))
        rows[:, -1] = [np.inf] + list(onsets)            # the first: never begun (the nominal residuals)
        b = np.tile(bits, (rows.shape[0], 1))
        out = np.zeros(len(onsets), dtype=bool)
        with np.errstate(all="ignore"):
            ps = encoding.profiles(obj.spaces, encoding.decode(obj.spaces, rows[:, :-1], b), obj.win.t, rows[:, -1])
            values, signals, _ = obj.inputs(ps)
            for i in obj.active:
                r = obj.residual_values(obj.residuals[i], signals, values, rows.shape[0])
                z = detect.evidence(r[1:] - r[0], np.full(len(onsets), thresholds[i]), ts)
                out |= detect.confirmed(z, n, persistence).any(axis=1)
        return out
    return alarms


def step_onset_band(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], fit: Estimate,
                    thresholds: np.ndarray, earliest: float, rule: tuple[float, float] = (0.0, 0.0)) -> Estimate:
    """``fit`` with the onset band of its steps (each fault's ``t0_band``: [earliest onset the data
    allow, onset]) where the data before the onset do not tell when they began. The identification
    window starts at t_D, so a step that began earlier changes nothing its cost reads: a fault that
    shows only when the plant is excited (a clutch's damper, read through the slip's acceleration,
    doubled at 20 s while the clutch stayed engaged, seen at the re-engagement at 28.5 s: a user
    trial) was dated 28.48 s with nothing said.

    The rule is the detector's: had the fit's faults begun at an earlier sample, each residual
    would have read their effect from there on, the fit's residual minus the nominal one on the
    same data (to first order), their step's own transient included; where that effect would have
    confirmed an alarm by the detector's own rule (``rule``: its persistence and span,
    :func:`fdi.detect.confirmed`), the detector would have fired before t_D, so they began later. Onsets are tried back from the fit's, two derivative windows
    doubling each time, down to ``earliest`` (the first trusted sample; at most
    :data:`STEP_LOOKBACK` samples are looked at: where all of those allow it, the band reaches
    ``earliest``, the data before them unread), then between the last allowed and the first
    refused; the band reaches the earliest onset allowed with every one tried after it. (The fit's cost is no
    guide here: a damper read through noisy derivatives makes its residual noisier as it grows, so
    on quiet data the true value costs more than the nominal one.) Only fits all of whose faults
    are steps (one onset); the band is given where it reaches more than two derivative windows
    before the onset."""
    if not fit.faults or any(f["type"] != "abrupt" or f.get("t0") is None for f in fit.faults):
        return fit
    w = est.monitor.config.derivative_window
    ts = float(t[1] - t[0])
    t0 = float(min(f["t0"] for f in fit.faults))
    start = max(float(earliest), float(t[0]) + w, t0 - STEP_LOOKBACK * ts)
    if t0 - start <= 2 * w:
        return fit
    refused = _would_alarm(est, t, raw, fit, thresholds, rule, start, t0, (start, t0))  # would it have fired before t0

    tries = _earlier(t0, w, start)
    no = refused(tries)
    first = int(np.argmax(no)) if no.any() else len(tries)
    low = tries[first - 1] if first else t0
    if first == len(tries):                               # every onset looked at allowed: the unread data too
        low = min(low, max(float(earliest), float(t[0]) + w))
    else:                                                 # refine between the last allowed and the first refused
        between = list(np.linspace(low, tries[first], 10)[1:-1])
        for onset, bad in zip(between, refused(between)):
            if bad:
                break
            low = float(onset)
    if low > t0 - 2 * w:
        return fit
    return replace(fit, faults=tuple({**f, "t0_band": [float(low), float(f["t0"])]} for f in fit.faults))


def drift_onset_band(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], t_d: float, samples: int,
                     fit: Estimate, weights: np.ndarray, earliest: float) -> Estimate:
    """``fit`` with the bands of its drifts reaching back along the onset-rate valley where the data
    allow it. The bands of a drift's coefficients and onset (:func:`coefficient_band`) are sampled
    in a box around the fit; but a slow drift leaves its residuals' noise band long after it starts,
    and on a short window its onset and rate trade off along a long curved valley the box does not
    follow (a user trial: a bearing's friction drifting as eq. (16), b = 0.02/s from 25 s, detected
    at 52 s, fitted b = 0.0324 from 36.05 s, with bands [0.0315, 0.0388] and [36.05, 38.87]: both
    excluding the truth, said with confidence). Where a drift's onset band starts more than a
    derivative window after the first trusted sample, the fit is re-expressed as drifts that started
    earlier (:func:`fdi.hints.translate`, the same degradation models; onsets two derivative
    windows back, doubling, down to ``earliest``) and costed on the fit's own window: the onset band
    reaches back to the earliest of a run of them within the likelihood-ratio limit
    (:func:`plausible_limit`), and each coefficient's band takes in theirs. Only fits with one
    drift or more, all of one onset."""
    drifts = [k for k, f in enumerate(fit.faults) if f["type"] == "incipient" and f.get("t0_band")]
    if not drifts:
        return fit
    w = est.monitor.config.derivative_window
    t0 = float(fit.faults[drifts[0]]["t0"])
    bound = min(float(fit.faults[k]["t0_band"][0]) for k in drifts)
    if bound - float(earliest) <= w:                   # the band already reaches the first trusted sample
        return fit
    win = window(t, raw, t_d, samples, w)
    obj = Objective(est.monitor.model, est.monitor.residuals, win, tuple(fit.candidate), np.asarray(weights), w,
                    onset=(float(earliest), t0), config=est.monitor.config, modes=dict(est.modes))
    real, bits = obj.encode([dict(f) for f in fit.faults])
    real[-1] = t0
    base = float(obj(real[None, :], bits[None, :])[0])
    if not np.isfinite(base):
        return fit
    onsets = _earlier(t0, w, float(earliest))
    times = win.t[win.crop]
    limit = plausible_limit(obj, base)

    def moved(onset: float) -> np.ndarray:
        x = hints.translate(obj.spaces, real[:-1], bits, bits, times, t0, 0, t0_to=onset)
        return np.append(np.where(np.isnan(x), real[:-1], x), onset)

    kept = []
    for part in (onsets[:1], onsets[1:]):      # the nearest alone first: where it is refused, nothing more is translated
        rows = [moved(onset) for onset in part]
        if not rows:
            break
        cost = obj(np.array(rows), np.tile(bits, (len(rows), 1)))
        plausible = np.isfinite(cost) & (cost <= limit)
        run = len(rows) if plausible.all() else int(np.argmin(plausible))     # the run of plausible ones
        kept += rows[:run]
        if run < len(rows):
            break
    if not kept:
        return fit
    out = [dict(f) for f in fit.faults]
    low = float(kept[-1][-1])
    described = [encoding.describe(obj.spaces, x[:-1], bits) for x in kept]
    for k in drifts:
        entries = [d[k] for d in described]
        out[k]["t0_band"] = [min(low, float(out[k]["t0_band"][0])), float(out[k]["t0_band"][1])]
        if out[k].get("b_band") is not None:
            out[k]["b_band"] = [[min([lo] + [float(e["b"][j]) for e in entries]), max([hi] + [float(e["b"][j]) for e in entries])]
                                for j, (lo, hi) in enumerate(out[k]["b_band"])]
    return replace(fit, faults=tuple(out))


STEP_LOOKBACK = 200_000    # samples before a step's onset its band looks back over at most (step_onset_band)


def _earlier(t0: float, w: float, lowest: float) -> list[float]:
    """Onsets before ``t0`` that the bands try: two derivative windows ``w`` back, doubling, then
    ``lowest`` (the earliest that may be tried).

    >>> _earlier(10.0, 0.5, 2.5)
    [9.0, 8.0, 6.0, 2.5]
    """
    return [t0 - 2 * w * 2 ** k for k in range(64) if t0 - 2 * w * 2 ** k > lowest] + [lowest]


def _refit(est: Estimators, t: np.ndarray, raw: Mapping[str, np.ndarray], t_d: float, samples: int,
           candidates: list, out: list[Estimate], weights: np.ndarray, seed: int, redo: list[int],
           spans: list[tuple[float, float]], seeds: list[list[list[dict]]],
           quiet: tuple | None = None) -> list[Estimate]:
    """Sets ``redo`` refitted over ``spans`` from their fits (the better fits of the sets containing
    them, and their ``seeds``); each keeps the better of its two fits (evaluations and histories
    added), a refit the quiet data before t_D contradict excepted (``quiet``: the thresholds and
    the detector's rule, :func:`contradicted`)."""
    refits = est.run(t, raw, t_d, samples, [candidates[i] for i in redo], weights, seed, None, None,
                     spans, [[list(out[i].faults)] + within(out, i) + list(seeds[i]) for i in redo])
    for i, r in zip(redo, refits):
        if r.cost < out[i].cost and not (quiet is not None and contradicted(est, t, raw, r, t_d, *quiet)):
            out[i] = replace(r, evaluations=r.evaluations + out[i].evaluations, history=out[i].history + r.history)
    return out
