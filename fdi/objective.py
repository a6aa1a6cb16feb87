"""The identification objective (eq. 24) of one candidate set on one data window.

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

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from bondgraph.errors import ModelError
from bondgraph.model import Model

from . import criterion, derivatives, encoding, hints, kernels, profiles, scales
from .config import MonitorConfig
from .data import commanded
from .encoding import FaultSpace
from .residuals import (Estimates, Residual, corrected_signals, corrects_signal, derivative_orders,
                        parameter_values, samples_of, switch_gaps)

ROWS = 256             # individuals per objective block (bounds memory on wide screening calls)
WINDOW_VALUES = 1 << 18  # ... and at most this many individual-samples per block: a 10 kHz window of 5 000
                         # samples took 256 rows x 5 000 at once, 20 MB per temporary (peak 460 MB; 203 MB so)
BLOCK = 32768          # samples x individuals per block of a residual that filters a stored quantity (about 128 kB
                       # per temporary; each block pays a filter call: the tutorial's RC, 5 000 samples, 6 rows a block)
KERNEL_BLOCK = 8192    # ... and of one that does not (64 kB per temporary: the CyCab's ARR3 in blocks of 8 rows x 1 000
                       # samples 24 ns a value, in one block of 30 rows 53 ns, measured)
PHASES = 16           # onsets proposed per period found in the residuals (fdi.hints)
SPIKE_OFFSETS = (-1, 0, 1, 2, 3)   # samples from a spike's peak where its step is proposed (Objective.spikes)
SPIKE_LEVELS = 16     # values proposed at each of them, evenly over the fault's range (its decades when logarithmic)
DEFAULT_BOUNDS = {"sensor": (0.05, 1.5), "source": (0.05, 1.5), "group": (0.1, 10.0)}


def nominal(model: Model, name: str) -> float:
    """The nominal value of fault ``name``'s decision: 1 for an efficiency factor or a group of
    parameters (a common factor), else its parameter's value (possibly infinite: a healthy leak)."""
    f = model.faults[name]
    if f.effect == "bias":
        return 0.0
    if f.kind in ("sensor", "source") or len(f.targets) > 1:
        return 1.0
    return float(model.parameters[f.targets[0]].value)


def fault_space(model: Model, name: str, span: float | None = None,
                config: MonitorConfig | None = None, min_period: float | None = None,
                window: float | None = None) -> FaultSpace:
    """The search space of a candidate fault: the bounds the monitor settings give, else a factor
    of 100 around a parameter's nominal value (0.05-1.5 for an efficiency factor, 0.1-10 for a
    group's common factor). ``span`` (s), the data window, caps the intermittent period: a period
    longer than the window is indistinguishable from an abrupt fault; ``min_period`` (s) is the
    shortest (:func:`fdi.scales.min_period`: two derivative windows; without it, the default of
    :data:`fdi.encoding.DEFAULT_PERIOD`). ``window`` (s), the identification window N ts, sets the
    degradation coefficients' bounds (:func:`fdi.encoding.coefficient_bounds`; without it, the
    CyCab's 10 s)."""
    f = model.faults[name]
    value, given = nominal(model, name), config.bounds(name) if config else None
    if given is not None:
        if not all(np.isfinite(given)):
            raise ModelError(f"bounds {list(given)} are not finite: the identification searches between them",
                             file=model.path, where=f"faults.{name}.bounds")
        bounds = given
    elif f.effect == "bias":
        raise ModelError("a bias fault needs bounds: [low, high], the offsets to search, in the unit of "
                         f"{f.kind} '{f.targets[0]}'", file=model.path, where=f"faults.{name}")
    elif f.kind in ("sensor", "source"):
        bounds = DEFAULT_BOUNDS[f.kind]
    elif len(f.targets) > 1:
        bounds = DEFAULT_BOUNDS["group"]
    elif not np.isfinite(value):
        raise ModelError("nominal value is infinite: give bounds: [low, high] to identify this fault",
                         file=model.path, where=f"faults.{name}")
    else:
        bounds = (value / 100.0, value * 100.0) if value > 0 else (value * 100.0, value / 100.0)
    low = encoding.DEFAULT_PERIOD[0] if min_period is None else min_period
    period = (min(low, span), span) if span else (low, max(encoding.DEFAULT_PERIOD[1], 2 * low))
    coefficients = encoding.coefficient_bounds(window) if window else tuple(encoding.DEFAULT_COEFF_BOUNDS)
    return FaultSpace.make(name, value, tuple(bounds), period=period, coefficients=coefficients)


LINEAR = {"identity": (lambda v: v, lambda u: u),
          "reciprocal": (lambda v: 1.0 / np.asarray(v, dtype=float), lambda u: 1.0 / np.asarray(u, dtype=float))}


def _holds(residual: Residual, names: set[str]) -> bool:
    """Whether a stored quantity ``residual`` differentiates (at any depth) reads one of ``names``."""
    return any(names & set(inner.symbols) or _holds(inner, names) for _, inner in residual.composites)


def acted_on(model: Model, residuals: tuple[Residual, ...], name: str) -> set[int]:
    """The residuals fault ``name`` acts on: those reading one of its parameters, or the signal its
    sensor or source fault corrects."""
    f = model.faults[name]
    symbols = set(f.symbols)
    signal = f.targets[0] if corrects_signal(model, f) else None
    return {i for i, r in enumerate(residuals)
            if symbols & r.parameter_names() or (signal is not None and signal in {s for s, _ in r.signal_orders()})}


_LINEAR: dict[tuple, str | None] = {}   # linear_transform's answers, by what they depend on (_linear_key)
LINEAR_KEPT = 4096


def linear_transform(model: Model, residuals: tuple[Residual, ...], name: str, active: list[int]) -> str | None:
    """How fault ``name``'s magnitude enters the residuals it touches, when affinely: through its
    value (``identity``) or its inverse (``reciprocal``: a resistance in a flow law, R4's leak
    sqrt|dp|/R4). None for sensor and source faults (they act on the signals before the
    derivatives), stored quantities, or any other dependence, or when no residual is ``active``.
    Answered once per fault and residuals it touches (sympy's derivatives; a compiled model carries
    the answers: :func:`linear_transforms`)."""
    if not active:
        return None
    key = _linear_key(model, residuals, name)
    if key not in _LINEAR:
        if len(_LINEAR) >= LINEAR_KEPT:
            _LINEAR.clear()
        _LINEAR[key] = _transform(model, residuals, name)
    return _LINEAR[key]


def linear_transforms(model: Model, residuals: tuple[Residual, ...]) -> dict[tuple, str | None]:
    """:func:`linear_transform`'s answers for every fault of the model, by what each depends on
    (:func:`_linear_key`: the fault's kind, targets and their values, and the exact expressions of
    the residuals it touches, as text), so any copy of the same residuals finds them: one read back
    from the disk cache, or received by a worker."""
    every = list(range(len(residuals)))
    for name in model.faults:
        linear_transform(model, residuals, name, every)
    return {key: _LINEAR[key] for key in (_linear_key(model, residuals, name) for name in model.faults)}


def _touched(model: Model, residuals: tuple[Residual, ...], name: str) -> list[Residual]:
    symbols = set(model.faults[name].symbols)
    return [r for r in residuals if symbols & r.parameter_names()]


def _linear_key(model: Model, residuals: tuple[Residual, ...], name: str) -> tuple:
    f = model.faults[name]
    values = tuple(float(model.parameters[t].value) if t in model.parameters else None for t in f.targets)
    return (f.kind, tuple(f.targets), values, tuple(r.key for r in _touched(model, residuals, name)))


def _transform(model: Model, residuals: tuple[Residual, ...], name: str) -> str | None:
    f = model.faults[name]
    if f.kind not in ("parametric",):
        return None
    touched = _touched(model, residuals, name)
    if not touched or any(r.composites for r in touched):
        return None
    import sympy as sp
    u = sp.Symbol("__u", positive=True)
    for kind in ("identity", "reciprocal"):
        if len(f.targets) > 1 and kind != "identity":
            break
        if kind == "identity" and len(f.targets) == 1 and not np.isfinite(model.parameters[f.targets[0]].value):
            continue
        if len(f.targets) == 1:
            sub = {f.targets[0]: u if kind == "identity" else 1 / u}
        else:
            sub = {t: model.parameters[t].value * u for t in f.targets}
        exprs = [r.expr.xreplace({x: sub[x.name] for x in r.expr.free_symbols if x.name in sub}) for r in touched]
        if all(u in e.free_symbols and sp.diff(e, u, 2) == 0 for e in exprs):
            return kind
    return None



def seen_profile(transform: str, nominal: float, value: float, seen: np.ndarray) -> np.ndarray:
    """A two-level profile, ``nominal`` before a step and ``value`` after it, blended in u =
    h(value) (``transform``, :data:`LINEAR`) by ``seen``, the step as the filter sees it
    (:func:`fdi.derivatives.step_seen`): exactly the two values where ``seen`` is 0 or 1."""
    to_u, from_u = LINEAR[transform]
    u0 = to_u(nominal)
    seen = np.asarray(seen, dtype=float)
    out = np.where(seen == 1.0, value, nominal)
    mid = (seen != 0.0) & (seen != 1.0)        # the blend where the filter's window holds a step (NaN too)
    with np.errstate(all="ignore"):
        out[mid] = from_u(u0 + (to_u(value) - u0) * seen[mid])
    return out


def seen_step_profile(t: np.ndarray, onsets: np.ndarray, transform: str, nominal: float, value: float,
                      window: float | None, ts: float) -> np.ndarray:
    """(onsets, t.size): a two-level profile stepping from ``nominal`` to ``value`` at each onset as
    the smoothing filter (:data:`fdi.derivatives.STEP_ORDER`) sees it: :func:`seen_profile` of
    :func:`fdi.derivatives.step_seen`, formed as the sharp step's two levels where the filter's
    window lies wholly before or after the onset and the blend on the 2 h samples around it only
    (:func:`fdi.derivatives.step_blends`: 2.6-4.0 -> 0.26 ms for 100 onsets on a 1 050-sample
    window, the same bits). The order-0 filter sees a step alike wherever it falls between two
    samples, so the blend's 2 h values are one vector per fault (:func:`_blend`, mapped by
    seen_profile elementwise, hence the same bits), placed by slices for a few onsets (an
    objective call of one row spent 120 us here, now 20)."""
    onsets = np.atleast_1d(np.asarray(onsets, dtype=float))
    out = np.where(t[None, :] >= onsets[:, None], value, nominal)
    nw = t.size
    if derivatives.STEP_ORDER != 0:
        blends = derivatives.step_blends(t, onsets, derivatives.STEP_ORDER, window, ts)
        if blends is not None:
            at, seen, valid = blends
            out[derivatives.blend_rows(valid), at[valid]] = seen_profile(transform, nominal, value, seen[valid])
        return out
    blend = _blend(transform, float(nominal), float(value), window, float(ts))
    h = blend.size // 2
    if not onsets.size or nw < 2 * h + 1:
        return out
    if onsets.size > FEW_ONSETS:
        at, _, valid = derivatives.step_blends(t, onsets, derivatives.STEP_ORDER, window, ts)
        out[derivatives.blend_rows(valid), at[valid]] = np.broadcast_to(blend, at.shape)[valid]
        return out
    for r, q in enumerate(np.searchsorted(t, onsets, side="left").tolist()):
        lo, hi = max(q - h, h), min(q + h, nw - h)        # step_blends' valid places: inside, h from each end
        if q < nw and lo < hi:
            out[r, lo:hi] = blend[lo - q + h:hi - q + h]
    return out


FEW_ONSETS = 48      # seen_step_profile places up to this many blends by slices, numpy's indexing beyond
                     # (measured on 1 050 samples: 20 onsets 116 vs 168 us, 100: 483 vs 408)
_BLENDS: dict[tuple, np.ndarray] = {}


def _blend(transform: str, nominal: float, value: float, window: float | None, ts: float) -> np.ndarray:
    """:func:`seen_profile` of :func:`fdi.derivatives.smoothed_step`: a step from ``nominal`` to
    ``value`` on the 2 h samples around it, kept by its arguments."""
    key = (transform, nominal, value, window, ts)
    got = _BLENDS.get(key)
    if got is None:
        if len(_BLENDS) >= LINEAR_KEPT:
            _BLENDS.clear()
        with np.errstate(all="ignore"):
            got = _BLENDS[key] = seen_profile(transform, nominal, value, derivatives.smoothed_step(window, ts))
    return got


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


def window_gaps(model: Model, residuals, win: Window, signals: Mapping, window_s: float) -> np.ndarray:
    """The samples of ``win`` the data leave without a residual: a signal NaN there (within half a
    derivative window of a commanded or autonomous switch, :func:`fdi.residuals.mode_breaks`, the
    filters do not straddle it), or a stored quantity's rate's wider trim at a switch. They count
    for no hypothesis, in the estimators as in the fault-mode estimator."""
    gaps = np.zeros(win.t.size, dtype=bool)
    for series in signals.values():
        for x in series:
            gaps |= np.isnan(np.asarray(x, dtype=float)).reshape(-1, win.t.size).any(axis=0)
    designed = switch_gaps(model, residuals, win.raw, win.t.size, window_s, win.ts)
    if designed is not None:
        gaps |= designed
    return gaps


class Objective:
    """cost(real, bits) of one candidate set on one data window (vectorised over the population)."""

    def __init__(self, model: Model, residuals: tuple[Residual, ...], win: Window, candidate: tuple[str, ...],
                 weights: np.ndarray, window_s: float, fixed: list[dict] = (),
                 onset: tuple[float, float] | None = None, config: MonitorConfig | None = None,
                 modes: Mapping[str, float] | None = None) -> None:
        """``config``: the monitor settings (the faults' search bounds); ``fixed``: faults already identified (report entries with ``t0``), held at their fit
        with their own onset while ``candidate`` is searched (a second fault after a first decision);
        ``onset``: where the candidate's onset is searched (default: the window's first
        ``window_s`` seconds)."""
        self.model, self.residuals, self.win, self.candidate = model, residuals, win, candidate
        span = (win.crop.stop - win.crop.start) * win.ts
        self.config = config
        self.min_period = scales.min_period(window_s, win.ts)
        # the identification window the degradation coefficients' bounds are expressed in: the
        # configured N samples (not this window's, shorter at the data's end: the same bounds for
        # every window of a run)
        self.window = config.samples * win.ts if config is not None else None
        self.spaces = [fault_space(model, f, span, config, self.min_period, self.window) for f in candidate]
        self.weights = weights
        self.window_s = window_s
        self.onset_bounds = onset
        self.fixed = list(fixed)
        self.nominal = parameter_values(model)
        self.nominal.update({m: v[None, :] for m, v in commanded(model, win.raw).items()})
        self.nominal.update(modes or {})          # mode variables the caller knows (Options.mode)
        fixed_betas, fixed_biases = self._fix(span)
        self.fixed_betas, self.fixed_biases = fixed_betas, fixed_biases
        self.orders = derivative_orders(list(residuals))
        self.varying_signals = {model.faults[f].targets[0] for f in candidate if corrects_signal(model, model.faults[f])}
        self.active = sorted(set().union(*(acted_on(model, residuals, f) for f in candidate)))
        self.linear = {f: h for f in candidate if (h := linear_transform(model, residuals, f, self.active))}
        self.enters = {j: {i: bool(set(model.faults[f].symbols) & residuals[i].parameter_names()) for i in self.active}
                       for j, f in enumerate(candidate)}
        self.base_signals = corrected_signals(model, win.raw, win.ts, self.orders, fixed_betas or None, window_s,
                                              biases=fixed_biases or None)
        self.gaps = window_gaps(model, residuals, win, self.base_signals, window_s)
        self._constant: dict[int, float] = {}
        self._rates: dict = {}
        self._blocks: dict = {}
        self._phase_onsets: dict = {}   # propose's onsets per (period, phase): every structure with that fault
                                        # intermittent asks for the same (scenario 2: 1 632 -> 704 computed)
        self.composites = any(r.composites for r in residuals)
        # the screening fidelity: every stride-th sample, a sixth of the derivative window apart, so that
        # the filtered residuals barely change between the samples left out
        self.stride = max(1, int(round(window_s / win.ts)) // 6)

    def _fix(self, span: float) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Fold the fixed faults into the base values (parameter profiles) and return their sensor
        and source profiles (efficiency factors, and offsets of bias faults), all (1, window samples)."""
        betas: dict[str, np.ndarray] = {}
        biases: dict[str, np.ndarray] = {}
        for f in self.fixed:
            space = fault_space(self.model, f["name"], span, self.config, self.min_period, self.window)
            real, bits = encoding.encode([space], [f])
            (p,) = encoding.profiles([space], encoding.decode([space], real[None, :], bits[None, :]), self.win.t,
                                     f.get("t0", self.win.t0))
            fault = self.model.faults[f["name"]]
            if fault.effect == "bias":
                biases[fault.targets[0]] = p
            elif corrects_signal(self.model, fault):
                betas[fault.targets[0]] = p
            elif fault.kind == "source":             # a fixed-value source: beta_<name> is a parameter
                self.nominal[fault.symbols[0]] = p
            elif len(fault.targets) == 1:
                self.nominal[fault.targets[0]] = self._held_step(f, p)
            else:
                for target in fault.targets:
                    self.nominal[target] = self.nominal[target] * p
        return betas, biases

    def _held_step(self, f: dict, p: np.ndarray) -> np.ndarray:
        """A held abrupt fault's profile ``p`` as the filtered residuals see its step
        (:func:`seen_profile`), when its magnitude enters them affinely; else ``p``."""
        name = f["name"]
        fault = self.model.faults[name]
        if f.get("type") != "abrupt" or fault.kind != "parametric" or len(fault.targets) != 1:
            return p
        transform = linear_transform(self.model, self.residuals, name,
                                     sorted(acted_on(self.model, self.residuals, name)))
        if transform is None:
            return p
        return seen_step_profile(self.win.t, f.get("t0", self.win.t0), transform, nominal(self.model, name),
                                 float(f["value"]), self.window_s, self.win.ts)

    def constant(self, stride: int = 1) -> float:
        """The weighted cost of the residuals no candidate fault touches (the same for everyone)."""
        if stride not in self._constant:
            c = self.crop(stride)
            self._constant[stride] = float(sum(
                self.weights[i] * np.nansum(np.abs(np.asarray(self.residuals[i](self.base_signals, self.nominal,
                                                                                self.win.ts, self.window_s))[..., c]))
                for i in range(len(self.residuals)) if i not in self.active))
        return self._constant[stride]

    def crop(self, stride: int = 1) -> slice:
        return slice(self.win.crop.start, self.win.crop.stop, stride)

    def bounds(self) -> np.ndarray:
        """The encoding's bounds plus the fault onset, last: the symmetric derivative filter makes a
        residual cross up to half a window *before* the fault starts, so the onset is searched in
        [t_D, t_D + window]."""
        onset = [list(self.onset_bounds or (self.win.t0, self.win.t0 + self.window_s))]
        return np.vstack([encoding.bounds(self.spaces), onset])

    def onset(self, real: np.ndarray) -> np.ndarray:
        return np.atleast_2d(real)[:, -1]

    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        return self.evaluate(real, bits)[0]

    def coarse(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        """The cost on every ``stride``-th sample, times ``stride``: what the engine screens and races
        structures with (the residuals are filtered over a window six strides wide, so the ranking
        holds); the finalists are then refined on every sample."""
        return self.evaluate(real, bits, self.stride)[0]

    def complete(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        """One individual with the magnitudes the objective solves (``linear``) written in."""
        return self.evaluate(np.atleast_2d(real), np.atleast_2d(bits))[1][0]

    def evaluate(self, real: np.ndarray, bits: np.ndarray, stride: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Costs of a population (on every ``stride``-th sample, scaled by ``stride``), and the
        population with its solved magnitudes.

        A fault in ``linear`` (its magnitude enters every residual affinely through u = h(value))
        that is abrupt or intermittent has a two-level profile, so each residual is
        r = r0 + delta * G with G the response to a unit step of u where the fault is active: its
        magnitude is solved per individual (weighted least squares, then iteratively reweighted
        towards the L1 cost of eq. 24) instead of searched."""
        real, bits = np.atleast_2d(real), np.atleast_2d(bits)
        rows = max(1, min(ROWS, WINDOW_VALUES // self.win.t.size))
        if real.shape[0] > rows:
            parts = [self.evaluate(real[i:i + rows], bits[i:i + rows], stride) for i in range(0, real.shape[0], rows)]
            return np.concatenate([c for c, _ in parts]), np.vstack([r for _, r in parts])
        with np.errstate(all="ignore"):      # an individual whose signals overflow costs inf, silently
            self._rates, self._blocks = {}, {}  # stored quantities' rates (and row blocks) shared within this evaluation
            try:
                return self._evaluate(real, bits, stride)
            finally:
                self._rates, self._blocks = {}, {}

    def _evaluate(self, real: np.ndarray, bits: np.ndarray, stride: int) -> tuple[np.ndarray, np.ndarray]:
        fast = self.fused()
        if fast is not None:                     # the compiled path: one call for the population (fdi.fused)
            return fast.evaluate(real, bits, stride)
        real, solve, ps, steps = self.prepare(real, bits)
        values, signals, invalid = self.inputs(ps, stride=stride)
        n = real.shape[0]
        total = np.full(n, self.constant(stride))
        plain = [i for i in self.active if not any(self.enters[j][i] for j in solve)]
        for i in plain:
            total += self.weights[i] * np.abs(self.residual_values(self.residuals[i], signals, values, n, stride)).sum(axis=1)
        joint = [i for i in self.active if i not in plain]
        deltas = {}
        if joint:
            base = {i: self.residual_values(self.residuals[i], signals, values, n, stride) for i in joint}
            gains = {}
            for j in solve:          # a parametric fault: the signals stay, its parameters step
                stepped = self.inputs([steps[j] if k == j else p for k, p in enumerate(ps)], signals)
                gains[j] = {i: self.residual_values(self.residuals[i], stepped[1], stepped[0], n, stride) - base[i]
                            for i in joint if self.enters[j][i]}
            deltas = self.solve_magnitudes(base, gains, solve)
            for i in joint:
                r = base[i] + sum(deltas[j][:, None] * g[i] for j, g in gains.items() if i in g)
                total += self.weights[i] * np.abs(r).sum(axis=1)
        return self.finish(real, solve, deltas, total, invalid, stride)

    def prepare(self, real: np.ndarray, bits: np.ndarray) -> tuple[np.ndarray, dict, list, dict]:
        """A copy of ``real``, the individuals whose linear faults' magnitudes are solved (per fault
        index: abrupt or intermittent), every fault's profile (a solved fault's at its nominal value)
        and the solved faults' unit-step profiles."""
        real = real.copy()
        decoded = encoding.decode(self.spaces, real[:, :-1], bits)
        solve = {}
        for j, (space, d) in enumerate(zip(self.spaces, decoded)):
            if space.name in self.linear:
                rows = d.kind < 2
                if rows.any():
                    to_u, from_u = LINEAR[self.linear[space.name]]
                    unit = from_u(to_u(space.nominal) + 1.0)
                    d.value_ab, d.value_int = np.where(rows, unit, d.value_ab), np.where(rows, unit, d.value_int)
                    solve[j] = rows
        ps = encoding.profiles(self.spaces, decoded, self.win.t, self.onset(real))
        steps = {j: ps[j] for j in solve}
        for j, rows in solve.items():            # a step and a square wave as the filtered residuals see them
            abrupt, wave = rows & (decoded[j].kind == 0), rows & (decoded[j].kind == 1)
            if abrupt.any() or wave.any():
                steps[j] = np.array(steps[j], dtype=float)
            if abrupt.any():
                steps[j][abrupt] = self.seen_steps(j, real[abrupt, -1])
            if wave.any():
                steps[j][wave] = self.seen_steps(j, real[wave, -1], decoded[j].period[wave])
        for j, rows in solve.items():
            ps[j] = np.where(rows[:, None], self.spaces[j].nominal, ps[j])
        return real, solve, ps, steps

    def finish(self, real: np.ndarray, solve: dict, deltas: dict, total: np.ndarray, invalid: np.ndarray,
               stride: int) -> tuple[np.ndarray, np.ndarray]:
        """The costs (``stride`` times the weighted sums; inf where not finite or invalid) and the
        population with each solved magnitude written in (``deltas``: u - u_nominal per fault)."""
        for j, delta in deltas.items():
            space = self.spaces[j]
            to_u, from_u = LINEAR[self.linear[space.name]]
            v = from_u(to_u(space.nominal) + delta)
            real[:, encoding.N_REAL * j] = np.where(solve[j], np.log10(v) if space.log else v,
                                                    real[:, encoding.N_REAL * j])
        return np.where(np.isfinite(total) & ~invalid, stride * total, np.inf), real

    def fused(self):
        """The compiled path of this objective (:class:`fdi.fused.Fused`), or None: numba off or
        not installed, or a residual the tapes do not cover (kept per objective)."""
        if kernels.jit() is None:
            return None
        if not hasattr(self, "_fused"):
            from .fused import Fused
            self._fused = Fused.make(self)
        return self._fused

    def solve_magnitudes(self, base: dict, gains: dict, solve: dict) -> dict[int, np.ndarray]:
        """delta (u - u_nominal) per linear fault and individual, within the fault's bounds, that
        minimises eq. (24)'s weighted L1 cost: for one fault, given the others, sum_i w_i |r_i + delta g_i|
        is smallest at the weighted median of -r_i / g_i with weights w_i |g_i| (exact, and clipped to
        the bounds, since the cost is convex in delta); several faults take turns (three passes).
        Least squares reweighted twice towards L1, as before, was pulled by the filter's spikes at a
        step that is a sample off: a load brake 0.05 -> 0.15 N m s came out 0.001 (the bound) at the
        true onset, costing more than no fault at all (a torsional shaft, tests/test_domain_shaft.py)."""
        n = next(iter(base.values())).shape[0]
        deltas = {j: np.zeros(n) for j in gains}
        for _ in range(3 if len(gains) > 1 else 1):
            for j, g in gains.items():
                rows = solve[j]                 # the individuals whose fault j is abrupt or intermittent
                rest = [base[i][rows] + sum(deltas[k][rows, None] * gk[i][rows] for k, gk in gains.items()
                                            if k != j and i in gk) for i in g]
                gj = [g[i][rows] for i in g]
                delta = weighted_median(np.hstack([-r / np.where(x != 0, x, 1.0) for r, x in zip(rest, gj)]),
                                        np.hstack([np.where((x != 0) & np.isfinite(r) & np.isfinite(x),
                                                            self.weights[i] * np.abs(x), 0.0)
                                                   for r, x, i in zip(rest, gj, g)]))
                lo, hi = self.delta_bounds(j)
                deltas[j] = np.zeros(n)
                deltas[j][rows] = np.clip(delta, lo, hi)
        return deltas

    def seen_steps(self, j: int, onsets: np.ndarray, periods: np.ndarray | None = None) -> np.ndarray:
        """(onsets, window samples): linear fault j's unit step (one unit of u = h(value) from its
        nominal value) at each onset through the smoothing filter (:data:`fdi.derivatives.STEP_ORDER`,
        :func:`seen_profile`): the nominal value and the unit value exactly where the filter's
        window lies wholly before or after the onset, a blend of the two within half a window.
        With ``periods``, eq. (15)'s square wave from each onset (on for the first half of each
        period), each of its edges seen so."""
        space = self.spaces[j]
        t = self.win.t
        transform, unit = self.linear[space.name], self.unit_value(j)
        if periods is None:
            return seen_step_profile(t, onsets, transform, space.nominal, unit, self.window_s, self.win.ts)
        fast = kernels.jit() if derivatives.STEP_ORDER == 0 and kernels.cheap() and np.size(onsets) else None
        if fast is not None and hasattr(fast, "square_seen"):     # the three steps below in one compiled pass
            n = derivatives.window_samples(self.window_s, self.win.ts, derivatives.DEFAULT_ORDER)
            got = fast.square_seen(t, float(t[-1]), np.asarray(onsets, dtype=float), np.asarray(periods, dtype=float),
                                   derivatives.smoothed_step(self.window_s, self.win.ts), n // 2, t.size >= n,
                                   {"identity": 0, "reciprocal": 1}[transform], float(space.nominal), unit)
            if got is not None:
                return got
        edges, signs = profiles.intermittent_edges(float(t[-1]), onsets, periods)
        seen = derivatives.edges_seen(t, edges, signs, derivatives.STEP_ORDER, self.window_s, self.win.ts)
        return seen_profile(transform, space.nominal, unit, seen)

    def unit_value(self, j: int) -> float:
        """Linear fault j's value one unit of u = h(value) from its nominal value: its unit step
        (the value :meth:`prepare` gives a solved fault's profile)."""
        space = self.spaces[j]
        to_u, from_u = LINEAR[self.linear[space.name]]
        return float(from_u(to_u(space.nominal) + 1.0))

    def delta_bounds(self, j: int) -> tuple[float, float]:
        space = self.spaces[j]
        to_u, _ = LINEAR[self.linear[space.name]]
        ends = sorted(to_u(np.asarray(space.bounds, dtype=float)) - to_u(space.nominal))
        return ends[0], ends[1]

    def inputs(self, ps: list[np.ndarray], signals: dict | None = None,
               stride: int = 1) -> tuple[dict, dict, np.ndarray]:
        """Parameter values, (corrected) signals and the invalid individuals for the profiles ``ps``;
        ``signals`` given when only parameters changed (the sensor corrections are then known).
        Corrected signals are filtered on the samples of ``crop(stride)`` only, unless a residual
        differentiates a stored quantity (which reads them over the whole window)."""
        values, betas, biases, invalid = self.corrections(ps)
        if signals is not None:
            return values, signals, invalid
        signals = dict(self.base_signals)
        if betas or biases:
            changed = set(betas) | set(biases)
            signals.update(corrected_signals(self.model, self.win.raw, self.win.ts,
                                             {k: self.orders[k] for k in changed if k in self.orders},
                                             {**self.fixed_betas, **betas}, self.window_s, edges="mirror",
                                             biases={**self.fixed_biases, **biases},
                                             at=None if self.composites else self.crop(stride)))
        return values, signals, invalid

    def corrections(self, ps: list[np.ndarray]) -> tuple[dict, dict, dict, np.ndarray]:
        """Parameter values, the sensors' and sources' efficiency factors and offsets per
        individual, and the invalid individuals, for the profiles ``ps`` (:meth:`inputs` without
        the filtering)."""
        n = ps[0].shape[0] if ps else 1
        values = dict(self.nominal)
        betas: dict[str, np.ndarray] = {}
        biases: dict[str, np.ndarray] = {}
        invalid = np.zeros(n, dtype=bool)
        for name, p, space in zip(self.candidate, ps, self.spaces):
            f = self.model.faults[name]
            invalid |= np.isnan(p).any(axis=1)
            lo, hi = space.bounds           # a sensor's or source's correction stays within its search bounds:
            # gains drifting to 1e-50 and 1e+50 together scaled every signal of a homogeneous ARR to zero
            if f.effect == "bias":
                bad = ~(np.isfinite(p) & (p >= lo) & (p <= hi)).all(axis=1)
                invalid |= bad
                biases[f.targets[0]] = np.where(bad[:, None], 0.0, p)
            elif f.kind in ("sensor", "source"):
                bad = ~(np.isfinite(p) & (p > 0) & (p >= lo) & (p <= hi)).all(axis=1)   # past a pole, through zero
                invalid |= bad
                if corrects_signal(self.model, f):
                    betas[f.targets[0]] = np.where(bad[:, None], 1.0, p)
                else:                               # a fixed-value source: beta_<name> is a kernel parameter
                    values[f.symbols[0]] = np.where(bad[:, None], 1.0, p)
            elif len(f.targets) == 1:
                values[f.targets[0]] = p
            else:
                for target in f.targets:
                    values[target] = self.nominal[target] * p
        return values, betas, biases, invalid

    def residual_values(self, residual: Residual, signals: dict, values: dict, n: int, stride: int = 1) -> np.ndarray:
        """(n, window samples): the kernel run on blocks of rows whose temporaries stay in the cache
        (measured on the CyCab's ARR3: 25 us per individual in blocks of 16, 94 us in one block of 300)."""
        crop = self.crop(stride)
        m = len(range(crop.start, crop.stop, stride))
        step = max(1, (BLOCK if residual.composites else KERNEL_BLOCK) // m)
        out = np.empty((n, m))
        if not residual.composites and n > step:
            # the kernel's arguments cut once, then sliced by rows per block (slicing every signal and
            # value per block took a third of a 100-row call)
            args = [np.asarray(a) for a in residual.arguments(signals, values, crop)]
            rowwise = [a.ndim == 2 and a.shape[0] == n for a in args]
            for a in range(0, n, step):
                rows = slice(a, min(n, a + step))
                out[rows] = residual.func(*[x[rows] if r else x for x, r in zip(args, rowwise)])
            if self.gaps.any():
                out[:, self.gaps[crop]] = 0.0
            return out
        def block(x, rows: slice):
            """x's rows of this block, one view per array and block within an evaluation: a stored
            quantity's rate, filtered from the very same views, is then shared by every residual and
            every unit step that reads it (the tutorial's RC: ARR2 and ARR3 share d(C1 v)/dt)."""
            if not (np.ndim(x) == 2 and x.shape[0] == n):
                return x
            held = self._blocks.get((id(x), rows.start))
            if held is None or held[0] is not x:        # the entry holds x: its id is not reused meanwhile
                held = self._blocks[(id(x), rows.start)] = (x, x[rows])
            return held[1]
        for a in range(0, n, step):
            rows = slice(a, min(n, a + step))
            part = signals if n <= step else {k: Estimates([block(x, rows) for x in v], block(samples_of(v), rows),
                                                           getattr(v, "breaks", None), getattr(v, "settle", 0))
                                     for k, v in signals.items()}
            vals = values if n <= step else {k: block(v, rows) for k, v in values.items()}
            out[rows] = residual(part, vals, self.win.ts, self.window_s, crop, rates=self._rates)
        if self.gaps.any():
            out[:, self.gaps[crop]] = 0.0
        return out

    def magnitudes(self) -> list[np.ndarray]:
        """Per candidate fault, the weighted magnitude of the residuals it enters at the nominal
        hypothesis (the fixed faults held) on the window's samples (``crop()``), summed; zeros for
        a fault no active residual reads. Computed once."""
        if getattr(self, "_magnitudes", None) is None:
            c = self.crop()
            mags = {}
            for i in self.active:
                x = np.asarray(self.residuals[i](self.base_signals, self.nominal, self.win.ts, self.window_s))
                x = np.abs(np.broadcast_to(x, x.shape[:-1] + (self.win.t.size,)).reshape(-1, self.win.t.size)[0, c])
                mags[i] = self.weights[i] * np.where(np.isfinite(x), x, 0.0)
            out = []
            for space in self.spaces:
                mine = self._entered(space.name)
                out.append(sum((mags[i] for i in mine), np.zeros(c.stop - c.start)))
            self._magnitudes = out
        return self._magnitudes

    def _entered(self, name: str) -> list[int]:
        """The active residuals fault ``name`` enters (a parameter read, or its signal)."""
        f = self.model.faults[name]
        return [i for i in self.active if set(f.symbols) & self.residuals[i].parameter_names()
                or f.targets[0] in {s for s, _ in self.residuals[i].signal_orders()}]

    def seeds(self) -> list[list[tuple[float, float]]]:
        """Per candidate fault, the (period, phase) pairs the data suggest (:mod:`fdi.hints`): square
        waves in the weighted magnitude of the residuals it enters (:meth:`magnitudes`), from the
        window's first sample; computed once."""
        if getattr(self, "_seeds", None) is None:
            self._seeds = [hints.periods(x, self.win.ts, *space.period) if self._entered(space.name) else []
                           for space, x in zip(self.spaces, self.magnitudes())]
        return self._seeds

    def spikes(self) -> list[list[float]]:
        """Per candidate fault, the onsets the data suggest for its step where the objective must
        search its value and a residual differentiates a stored quantity that holds its parameter
        (:attr:`fdi.residuals.Residual.composites`: an orifice's flow inside the supply pressure
        whose rate the balance reads). Such a step shows as a spike of the residual at the onset
        (the rate of a jump), and only the right value at the right onset, within a few samples,
        takes it away: a basin a Latin hypercube over the value's decades and the onset interval
        hits a few times in a hundred draws (the orifice's {Kv}: missed on 2 of 8 seeds). The onsets
        are the samples around the peak of the weighted magnitude (:meth:`magnitudes`) within the
        onset interval, :data:`SPIKE_OFFSETS` samples from it; [] for the other faults."""
        if getattr(self, "_spikes", None) is None:
            lo, hi = self.bounds()[-1]
            t = self.win.t[self.crop()]
            inside = (t >= lo) & (t <= hi)
            out = []
            for space, x in zip(self.spaces, self.magnitudes()):
                f = self.model.faults[space.name]
                stored = f.kind == "parametric" and space.name not in self.linear and any(
                    _holds(self.residuals[i], set(f.targets)) for i in self._entered(space.name))
                if not stored or not inside.any() or not np.any(x[inside] > 0):
                    out.append([])
                    continue
                peak = int(np.flatnonzero(inside)[np.argmax(x[inside])])
                out.append(sorted({float(np.clip(t[0] + (peak + k) * self.win.ts, lo, hi)) for k in SPIKE_OFFSETS}))
            self._spikes = out
        return self._spikes

    def translate(self, real: np.ndarray, bits_from: np.ndarray, bits_to: np.ndarray) -> np.ndarray:
        """The engine's ``translate`` hook: ``real``'s fault profiles re-expressed in the structure
        of ``bits_to`` (:func:`fdi.hints.translate`), the onset kept; NaN where nothing changes."""
        real = np.asarray(real, dtype=float)
        out = hints.translate(self.spaces, real[:-1], bits_from, bits_to, self.win.t[self.crop()], float(real[-1]))
        return np.append(out, np.nan)

    def propose(self, bits: np.ndarray) -> np.ndarray:
        """Points the data suggest for the structure of ``bits`` (the engine's ``propose`` hook): its
        intermittent faults at the periods found in the residuals (:meth:`seeds`), each with its
        onset where its square wave switches on within the onset interval; its abrupt faults whose
        step the residuals see as a spike at the spike (:meth:`spikes`), at values spread over their
        range; NaN elsewhere."""
        lo, hi = self.bounds()[-1]
        at = self._phase_onsets

        def onsets(T: float, phase: float) -> list[float]:
            # the phase's own switch first, then PHASES evenly over the period: the phase of |r| is
            # biased by the spikes a gain's switching leaves at both edges (measured: 70 ms on 0.7 s)
            if (T, phase) not in at:
                at[T, phase] = [hints.aligned_onsets(T, phase + k * T / PHASES, self.win.t0, lo, hi, limit=1)[0]
                                for k in range(PHASES)]
            return at[T, phase]
        rows = hints.intermittent_rows(self.spaces, bits, self.seeds(), onsets, levels=3)
        return np.vstack([rows, hints.step_rows(self.spaces, bits, self.spikes(), SPIKE_LEVELS)])

    def structure(self, bits: np.ndarray):
        return encoding.structure(self.spaces, bits)

    def penalized(self, cost: float, bits: np.ndarray) -> float:
        """The cost Schwarz's criterion charges the structure of ``bits`` (the engine's ``penalized``
        hook; :func:`fdi.criterion.penalized`, the criterion the diagnosis chooses candidate sets
        with): the engine chooses among one set's structures as the diagnosis chooses among sets.
        On cost alone a two-parameter intermittent fault that fits 0.06 % better beat the abrupt
        truth (a torsional shaft's load brake, 0.05 -> 0.15 N m s at 20 s)."""
        faults = [{"type": kind, "b": [0.0] * len(encoding.COEFF_SLOTS[model]) if model else []}
                  for kind, model in encoding.structure(self.spaces, bits)]
        n_eff = criterion.effective_samples(self.win.crop.stop - self.win.crop.start, len(self.residuals),
                                            self.win.ts, self.window_s)
        return criterion.penalized(cost, criterion.parameters(faults), n_eff)

    def family(self, bits: np.ndarray):
        return encoding.family(self.spaces, bits)

    def encode(self, faults: list[dict]) -> tuple[np.ndarray, np.ndarray]:
        """A known fit of some of this candidate's faults (report entries with ``t0``) as one
        individual: the faults it names as fitted, the others as no-ops (abrupt at their nominal
        value, or the bound nearest to it)."""
        by_name = {f["name"]: f for f in faults}
        rows = [by_name.get(s.name) or {"type": "abrupt", "value": float(np.clip(s.nominal, *s.bounds))}
                for s in self.spaces]
        real, bits = encoding.encode(self.spaces, rows)
        bounds = self.bounds()
        onset = faults[0].get("t0", self.win.t0) if faults else self.win.t0
        return np.clip(np.append(real, onset), bounds[:, 0], bounds[:, 1]), bits

    def free(self, bits: np.ndarray) -> np.ndarray:
        """The reals a structure leaves to the search: its faults' (``encoding.free``) but the
        magnitudes the objective solves, and the onset."""
        mask = encoding.free(self.spaces, bits)
        for j, (kind, _) in enumerate(encoding.structure(self.spaces, bits)):
            if self.spaces[j].name in self.linear and kind != "incipient":
                mask[encoding.N_REAL * j] = False
        return np.append(mask, True)


def weighted_median(points: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Per row, the point where the weights' cumulative sum, in the order of the points, first
    reaches half their total: the minimiser of sum_k weights_k |x - points_k| (0 where every weight
    is zero).

    >>> weighted_median(np.array([[3.0, 1.0, 2.0, 10.0]]), np.array([[1.0, 1.0, 1.0, 0.5]])).tolist()
    [2.0]
    """
    fast = kernels.jit()
    if fast is not None and points.size:       # the same sums in one compiled pass (fdi.kernels)
        return fast.weighted_median(np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(weights, dtype=float))
    points = np.where(weights > 0, points, 0.0)
    n, m = points.shape
    order = (np.argsort(points, axis=1) + (np.arange(n) * m)[:, None]).ravel()    # flat indices, row by row
    cum = np.cumsum(weights.ravel()[order].reshape(n, m), axis=1)
    total = cum[:, -1]
    k = np.minimum((cum < 0.5 * total[:, None]).sum(axis=1), m - 1)
    return np.where(total > 0, points.ravel()[order.reshape(n, m)[np.arange(n), k]], 0.0)

