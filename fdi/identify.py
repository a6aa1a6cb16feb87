"""Fault identification: one estimator per candidate set, the fault-mode estimator, in parallel.

An estimator's decision vector is the paper's (``fdi.encoding``: per fault zeta, eta, magnitudes,
period, coefficients). Its cost is eq. (24)'s sum of |G_l| over the N samples from tD, with each
residual divided by its threshold: the paper sums residuals of different units (N*m, m^3/s), which
would leave the m^3/s residual with no weight at all; dividing by the thresholds makes the sum
dimensionless and gives each residual the weight the detector gives it (``weights="none"`` is
the paper's sum as printed). The fitness reported is 1/(cost + eps).

Profiles start at tD (abrupt and intermittent faults begin when they are detected, Sec. III-D);
an incipient fault is taken to start at tD too, from its nominal value, as the paper does when
an abrupt or intermittent fault is detected with it (its data window starts at t0 = tD). When an
incipient fault is alone, detection lags its onset and the identified coefficients describe its
growth from tD on: the prognosis still runs from the identified profile, and the report says so.

Residuals that no fault of the candidate enters are evaluated once, not per individual; a sensor
whose beta is a decision is corrected and differentiated per individual ((pop, samples) arrays).
Each estimator is seeded from the diagnosis seed and its index, so results do not depend on the
number of worker processes.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from typing import Mapping

import numpy as np

from bondgraph.errors import ModelError
from bondgraph.loader import load_model
from bondgraph.model import Model
from optim import ENGINES, bde
from optim.core import fitness

from . import encoding
from .arrs import ARR, select_arrs
from .encoding import FaultSpace
from .residuals import Residual, compile_residuals, corrected_signals, derivative_orders, parameter_values

DEFAULT_BOUNDS = {"sensor": (0.05, 1.5), "source": (0.05, 1.5), "group": (0.1, 10.0)}


@lru_cache(maxsize=4)
def compiled(path: str) -> tuple[Model, tuple[ARR, ...], tuple[Residual, ...]]:
    """Model, AGARRs and residuals, derived once per process."""
    model = load_model(path)
    arrs = tuple(select_arrs(model).arrs)
    return model, arrs, tuple(compile_residuals(model, list(arrs)))


def fault_space(model: Model, name: str, span: float | None = None) -> FaultSpace:
    """The search space of a candidate fault; ``span`` (s), the data window, caps the intermittent
    period: a period longer than the window is indistinguishable from an abrupt fault."""
    f = model.faults[name]
    if f.kind in ("sensor", "source"):
        nominal, bounds = 1.0, f.bounds or DEFAULT_BOUNDS[f.kind]
    elif len(f.targets) > 1:
        nominal, bounds = 1.0, f.bounds or DEFAULT_BOUNDS["group"]
    else:
        nominal = model.parameters[f.targets[0]].value
        if f.bounds is None:
            if not np.isfinite(nominal):
                raise ModelError("nominal value is infinite: give bounds: [low, high] to identify this fault",
                                 file=model.path, where=f"faults.{name}")
            bounds = (nominal / 100.0, nominal * 100.0) if nominal > 0 else (nominal * 100.0, nominal / 100.0)
        else:
            bounds = f.bounds
    period = (0.5, span) if span else encoding.DEFAULT_PERIOD
    return FaultSpace.make(name, nominal, tuple(bounds), period=period)


@dataclass
class Window:
    """The data an estimator sees: a segment around [t0, t0 + N ts) with margins for the filter."""
    t: np.ndarray
    raw: dict[str, np.ndarray]
    ts: float
    t0: float
    crop: slice


def window(t: np.ndarray, raw: Mapping[str, np.ndarray], t0: float, samples: int, margin: float) -> Window:
    ts = float(t[1] - t[0])
    i0 = int(np.searchsorted(t, t0 - 1e-9))
    m = int(np.ceil(margin / ts))
    a, b = max(0, i0 - m), min(t.size, i0 + samples + m)
    n = min(samples, t.size - i0)
    return Window(t[a:b], {k: np.asarray(v)[a:b] for k, v in raw.items()}, ts, float(t[i0]), slice(i0 - a, i0 - a + n))


class Objective:
    """cost(real, bits) of one candidate set on one data window (vectorised over the population)."""

    def __init__(self, model: Model, residuals: tuple[Residual, ...], win: Window, candidate: tuple[str, ...],
                 weights: np.ndarray, window_s: float) -> None:
        self.model, self.residuals, self.win, self.candidate = model, residuals, win, candidate
        span = (win.crop.stop - win.crop.start) * win.ts
        self.spaces = [fault_space(model, f, span) for f in candidate]
        self.weights = weights
        self.window_s = window_s
        self.nominal = parameter_values(model)
        self.orders = derivative_orders(list(residuals))
        touched = set()
        for f in candidate:
            touched |= set(model.faults[f].symbols)
        self.varying_signals = {model.faults[f].targets[0] for f in candidate if model.faults[f].kind in ("sensor", "source")}
        self.active = [i for i, r in enumerate(residuals)
                       if touched & r.parameter_names() or self.varying_signals & {s for s, _ in r.signal_orders()}]
        base = corrected_signals(model, win.raw, win.ts, self.orders, None, window_s)
        self.base_signals = base
        c = win.crop
        self.constant = sum(weights[i] * np.abs(np.asarray(residuals[i](base, self.nominal, win.ts, window_s))[..., c]).sum()
                            for i in range(len(residuals)) if i not in self.active)

    def bounds(self) -> np.ndarray:
        """The encoding's bounds plus the fault onset, last: the symmetric derivative filter makes a
        residual cross up to half a window *before* the fault starts, so the onset is searched in
        [t_D, t_D + window]."""
        onset = [[self.win.t0, self.win.t0 + self.window_s]]
        return np.vstack([encoding.bounds(self.spaces), onset])

    def onset(self, real: np.ndarray) -> np.ndarray:
        return np.atleast_2d(real)[:, -1]

    def profiles(self, real: np.ndarray, bits: np.ndarray) -> list[np.ndarray]:
        real = np.atleast_2d(real)
        return encoding.profiles(self.spaces, encoding.decode(self.spaces, real[:, :-1], bits), self.win.t,
                                 self.onset(real))

    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        ps = self.profiles(real, bits)
        values = dict(self.nominal)
        betas: dict[str, np.ndarray] = {}
        invalid = np.zeros(real.shape[0], dtype=bool)
        for name, p in zip(self.candidate, ps):
            f = self.model.faults[name]
            invalid |= np.isnan(p).any(axis=1)
            if f.kind in ("sensor", "source"):
                bad = ~(np.isfinite(p) & (p > 0)).all(axis=1)    # a profile past its pole, or through zero
                invalid |= bad
                betas[f.targets[0]] = np.where(bad[:, None], 1.0, p)
            elif len(f.targets) == 1:
                values[f.targets[0]] = p
            else:
                for target in f.targets:
                    values[target] = self.nominal[target] * p
        signals = dict(self.base_signals)
        if betas:
            signals.update(corrected_signals(self.model, self.win.raw, self.win.ts,
                                             {k: self.orders[k] for k in betas if k in self.orders}, betas,
                                             self.window_s, edges="mirror"))
        c = self.win.crop
        total = np.full(real.shape[0], float(self.constant))
        with np.errstate(all="ignore"):
            for i in self.active:
                r = np.asarray(self.residuals[i](signals, values, self.win.ts, self.window_s), dtype=float)
                r = np.broadcast_to(r, (real.shape[0], r.shape[-1]))
                total += self.weights[i] * np.abs(r[:, c]).sum(axis=1)
        return np.where(np.isfinite(total) & ~invalid, total, np.inf)

    def structure(self, bits: np.ndarray):
        return encoding.structure(self.spaces, bits)


@dataclass
class EstimatorResult:
    candidate: tuple[str, ...]
    cost: float
    fitness: float
    history: list[float]               # best fitness per generation
    margin: float | None
    faults: list[dict]
    evaluations: int
    wall_s: float
    objective_s: float = 0.0


def _run_estimator(job: tuple) -> EstimatorResult:
    path, t, raw, t0, samples, candidate, weights, settings, seed = job
    model, _, residuals = compiled(path)
    win = window(t, raw, t0, samples, model.derivative_window)
    obj = Objective(model, residuals, win, tuple(candidate), np.asarray(weights), model.derivative_window)
    engine = ENGINES[settings["engine"]]
    r = engine(obj, obj.bounds(), encoding.N_BITS * len(obj.spaces), pop=settings["pop"],
               generations=settings["generations"], seed=seed, onehot=encoding.onehot_groups(obj.spaces),
               structure=obj.structure)
    margin = r.extra.get("margin")
    faults = encoding.describe(obj.spaces, r.real[:-1], r.bits)
    for f in faults:
        f["t0"] = float(r.real[-1])
    return EstimatorResult(tuple(candidate), r.cost, float(fitness(r.cost)), [float(fitness(c)) for c in r.history],
                           None if margin is None or not np.isfinite(margin) else float(margin),
                           faults, r.evaluations, r.wall_s, r.objective_s)


def run_estimators(path: str, t: np.ndarray, raw: Mapping[str, np.ndarray], t0: float, samples: int,
                   candidates: list[tuple[str, ...]], weights: np.ndarray, settings: dict, seed: int,
                   workers: int = 1, progress=None) -> list[EstimatorResult]:
    """One estimator per candidate set (seed + index each), in ``workers`` processes."""
    jobs = [(path, t, dict(raw), t0, samples, c, weights, settings, seed + 1000 * i) for i, c in enumerate(candidates)]
    out: list[EstimatorResult] = []
    if workers <= 1 or len(jobs) <= 1:
        for j in jobs:
            out.append(_run_estimator(j))
            if progress:
                progress(len(out), len(jobs))
        return out
    with ProcessPoolExecutor(min(workers, len(jobs))) as pool:
        for r in pool.map(_run_estimator, jobs):
            out.append(r)
            if progress:
                progress(len(out), len(jobs))
    return out


def estimate_mode(model: Model, residuals: tuple[Residual, ...], win: Window, weights: np.ndarray,
                  seed: int, variables: list[str] | None = None) -> tuple[dict[str, int], float]:
    """The fault-mode estimator: BDE over the suspected mode variables (Sec. III-C: the MCSM names
    them; the others keep their current values), same cost as eq. (24)."""
    names = list(variables or model.modes)
    nominal = parameter_values(model)
    signals = corrected_signals(model, win.raw, win.ts, derivative_orders(list(residuals)), None, model.derivative_window)
    c = win.crop
    current = {m: int(model.modes[m].nominal) for m in model.modes}

    def cost(real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        values = dict(nominal)
        for j, n in enumerate(names):
            values[n] = bits[:, j:j + 1].astype(float)
        total = np.zeros(bits.shape[0])
        for i, r in enumerate(residuals):
            out = np.broadcast_to(np.asarray(r(signals, values, win.ts, model.derivative_window), dtype=float),
                                  (bits.shape[0], win.t.size))
            total += weights[i] * np.abs(out[:, c]).sum(axis=1)
        return total
    r = bde.minimize(cost, len(names), pop=max(8, 4 * len(names)), generations=20, seed=seed)
    # a mode variable the data cannot see (a2 once a burnt driver has stopped the motor) is put back:
    # one fault mode at a time, as the paper assumes, unless the data need more (cost within 1 %)
    best = r.bits.copy()
    best_cost = float(r.cost)
    for j in range(len(names)):
        if best[j] != bool(model.modes[names[j]].nominal):
            trial = best.copy()
            trial[j] = bool(model.modes[names[j]].nominal)
            trial_cost = float(cost(np.zeros((1, 0)), trial[None, :])[0])
            if trial_cost <= 1.01 * best_cost:
                best, best_cost = trial, min(best_cost, trial_cost)
    current.update({n: int(b) for n, b in zip(names, best)})
    return current, best_cost


def benchmark_problem(name: str, seed: int):
    """The scenario-2 identification (beta_theta2 & R4 on the shipped reference data) for the bench."""
    from .resources import reference_data, shipped_model
    from .data import read_csv, signals_from_data
    from .synthetic import Problem
    if name != "scenario2":
        raise ValueError(f"unknown problem '{name}' (synthetic, synthetic-all, a synthetic case, or scenario2)")
    path = str(shipped_model("cycab_steering"))
    model, arrs, residuals = compiled(path)
    data = read_csv(reference_data("scenario2.csv"))
    raw = signals_from_data(model, data)
    win = window(data.t, raw, 32.0, model.samples, model.derivative_window)
    weights = 1.0 / np.array([model.thresholds[a.name] for a in arrs])
    obj = Objective(model, residuals, win, ("R4", "beta_theta2"), weights, model.derivative_window)
    truth = [{"type": "abrupt", "value": 2.5221e7}, {"type": "incipient", "model": 2, "b": [-0.03]}]
    t_win = win.t[win.crop]
    fixed_onset = lambda real, bits: obj(np.hstack([real, np.full((real.shape[0], 1), 32.0)]), bits)
    return Problem("scenario2", obj.spaces, truth, t_win, win.t0, fixed_onset, "scenario-2 identification, beta_theta2 & R4")
