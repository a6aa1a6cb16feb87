"""Verification of the ARRs against the model's own simulation (``bgfdi check --verify``).

An ARR is derived symbolically from the bond graph; a slip anywhere in that chain (a sign, a
modulus on the wrong side, a dropped mode factor) gives a residual that does not vanish on the
healthy system, and nothing else would notice until a user's data raised false alarms. Here the
model is simulated in every mode combination from a few random consistent states under random
smooth inputs, and every ARR is evaluated on those exact signals by the residual machinery that
diagnosis uses (:func:`fdi.residuals.compile_residual`): a correct ARR vanishes to numerical
precision, a wrong one does not.

How (every scale from the model, no constant in seconds):

- time: the fastest time constant tau of the linearised state equations
  (:func:`bondgraph.timescales.time_scales`, over every mode) sets the sampling period (tau/10),
  the run's length (100 tau) and the inputs' angular frequencies (0.05/tau to 0.5/tau); where the
  states a scouting run visits are faster (a nonlinear law away from rest:
  :func:`bondgraph.timescales.visited_fastest`), the period follows them, up to 4x finer;
- inputs: each input is replaced by a seeded sum of three sinusoids around the mean of its
  nominal expression, with amplitudes following that expression's spread (half its mean at least);
- states: the first run of each mode starts from the model's initial state, the others from
  random states around those a scouting run visited (in simulation causality every storage
  state is free: any value is consistent);
- integration: LSODA, rtol 1e-10, an absolute tolerance of 1e-10 of each state's scale, a step
  of at most one sample. Where LSODA stalls (a velocity sticking under Coulomb friction, a tank
  emptying through a square-root law: the right-hand side switches at every step), the run is
  cut before the stall, and resampled more finely (at most a factor 1000^(1/k) for derivatives
  of order k) when too little is left. ROS2 was measured and not kept: at tau/200 it left
  violations of 1e-4 on correct ARRs, and its chatter while a velocity sticks is no motion an
  ARR with sign(v) describes;
- derivatives: Savitzky-Golay of polynomial order 7 over 9 samples (relative error about 1e-6 on
  the third derivative of the fastest mode), of the signals and of the stored quantities an
  ARR's exact form differentiates (a cubic there left the LC ladder's d2(C2 v2)/dt2 a quadratic
  fit's error, (w ts)^2: 1.3e-3 on correct ARRs); the filter's edges are dropped, and so are the
  samples within a filter's reach of a switching surface (a sign/abs/heaviside argument of any
  ARR crossing zero, or two arguments of a max/min crossing: no derivative across a kink is
  accurate; a thermostat's lift min(max(x, 0), 1) saturating at 1 failed a correct ARR when only
  each argument's sign was watched) and, for an ARR, those
  where one of its own kink arguments is below its round-off (its sign is unknown there);
- violation: max |r| over the samples kept, divided by the ARR's scale, the largest sum of the
  absolute values of its additive terms (:func:`terms`) over the same samples: unit-free, it
  compares the residual with what it sums.

An ARR passes in a mode when its violation stays at or below :data:`THRESHOLD` on every run.
One that fails is judged again on the same runs sampled REFINE and REFINE^2 times finer
(:func:`_refined`): a truncation error falls with the period, a wrong ARR's violation does not.
Measured (seeds 0 to 5, every model of models/ and tests/data/): correct ARRs at most 2.7e-6;
an ARR with one term dropped or mis-signed (242 variants) fails with that term's share of the
scale, median 0.7, 90 % above 4e-2, smallest 4.3e-4 (the back-EMF K w of dc_motor_clutch, a
5e-4 share of its voltage balance); only the CyCab's leak term, zero on the healthy model
(R4 = inf), can be dropped unnoticed, rightly. An ARR none of whose terms move in a mode (a part locked or at rest) is
not verified there, and says so; so is a mode the simulator refuses.

An RC node (tau = RC = 0.1 s): its AGARR, Kirchhoff's current law, vanishes on the simulated
model; the same relation with the resistor's law slipped (2R for R) fails by a third of its
terms' size, v/(2R) of i_in = C dv/dt + v/R at equilibrium; and a residual's terms are those of
its sum, a product with one sum distributed:

>>> import dataclasses
>>> from bondgraph.loader import load_model_text
>>> from fdi.scaph import derive_arrs
>>> m = load_model_text('''
... parameters: {C1: {value: 1.0e-3, unit: F}, R: {value: 100.0, unit: Ohm}}
... inputs: {i_in: {unit: A, expr: "0.01"}}
... elements: {src: {type: MSf, input: i_in}, cap: {type: C, parameter: C1}, res: {type: R, parameter: R}}
... junctions: {j: {type: "0"}}
... sensors: {v: {type: De, junction: j, unit: V}}
... bonds: {1: [src, j], 2: [j, cap], 3: [j, res]}
... ''')
>>> kcl = derive_arrs(m)[0]
>>> result = verify(m, [kcl], runs=1)
>>> result.ok, result.complete, result.checks[0].violation < THRESHOLD, round(result.settings.tau, 6)
(True, True, True, 0.1)
>>> slipped = dataclasses.replace(kcl, expr=kcl.expr.subs(m.symbols["R"], 2 * m.symbols["R"]))
>>> check = verify(m, [slipped], runs=1).checks[0]
>>> check.passed, round(check.violation, 1)
(False, 0.3)
>>> a2, k4, x, y = sp.symbols("a2 k4 x y")
>>> sorted(terms(-a2 * k4 * (x + y) + x * y), key=str)
[-a2*k4*x, -a2*k4*y, x*y]
"""
from __future__ import annotations

import itertools

import math
import warnings
from dataclasses import dataclass, replace
from typing import Callable, Mapping, Sequence

import numpy as np
import sympy as sp

from bondgraph.errors import CausalityError
from bondgraph.measured import coefficient, measured_storage, offset
from bondgraph.model import Model, t
from bondgraph.simulation import SimulationError, Trajectory, simulate
from bondgraph.timescales import mode_combinations, time_scales, visited_fastest

from . import derivatives
from .scaph import ARR
from .residuals import Estimates, Residual, compile_residual, parameter_values

THRESHOLD = 1e-4         # relative violation above which an ARR fails
RUNS = 3                 # simulations per mode combination: the model's initial state and two random ones
STEPS_PER_TAU = 10       # samples per fastest time constant
FASTER = 1.25            # a visited state's time constant this much faster than at rest refines the sampling,
MAX_REFINE = 4.0         # ... by at most this factor (a run's samples grow as much)
TAUS = 100               # the run's length in fastest time constants
POLYORDER = 7            # Savitzky-Golay polynomial order of the signals' derivatives
SINUSOIDS = 3            # per input
FREQUENCIES = (0.05, 0.5)   # input angular frequencies, in units of 1/tau
RTOL = 1e-10             # LSODA's relative tolerance; absolute: RTOL times each state's scale
PRECISION = 1e-8         # relative precision of a simulated signal (a margin over RTOL), for the kinks
AMPLIFICATION = 1e3      # how much more round-off a resampled (cut) run may put into the derivatives
MIN_SAMPLES = 200        # a run cut before a stall keeps at least this many samples
REACH = (POLYORDER + 2) // 2 + 1   # samples a switch spoils on each side (a filter's half-width, and one)
BUDGET = 6               # right-hand-side evaluations per sample before LSODA counts as stalled
PACE = 3                 # evaluations per sample of a run that does not stall (measured: 1 to 1.5)
KINKS = (sp.sign, sp.Abs, sp.Heaviside, sp.Max, sp.Min)
REFINE = 4               # a failing ARR's runs sampled again this much finer, ...
REFINE_STEPS = 2         # ... at most this many times (16x): the same runs (inputs, initial states)
CONVERGES = 4.0          # a violation that falls at least this much as the period falls REFINE-fold is the sampling's


@dataclass(frozen=True)
class Check:
    """One ARR in one mode combination. ``violation`` is max |r| / scale over every run (NaN when
    not checked), ``residual`` the largest |r| (in the residual's unit), ``scale`` the largest sum
    of the absolute values of its terms; ``passed`` is None when it could not be checked (``note``
    says why)."""
    arr: str
    mode: tuple[tuple[str, int], ...]
    violation: float
    residual: float
    scale: float
    runs: int
    passed: bool | None
    note: str = ""

    @property
    def mode_text(self) -> str:
        """``a1=1,a2=0`` (``(no modes)`` for a model without modes)."""
        return _label(self.mode)


def _label(mode) -> str:
    """``a1=1,a2=0`` from a mapping or from pairs; ``(no modes)`` for a model without modes."""
    pairs = mode.items() if isinstance(mode, Mapping) else mode
    return ",".join(f"{k}={v}" for k, v in pairs) or "(no modes)"


@dataclass(frozen=True)
class Run:
    """A run that did not cover the whole length: cut before LSODA stalled (``end``, s) or left
    out (``end`` None, ``why``). ``index`` counts from 1 within its mode."""
    mode: tuple[tuple[str, int], ...]
    index: int
    end: float | None
    why: str = ""

    @property
    def mode_text(self) -> str:
        return _label(self.mode)


@dataclass(frozen=True)
class Settings:
    """How the model was simulated: its fastest time constant ``tau``, the sampling period ``ts``
    and the length ``duration`` of a run (s), the runs per mode, the threshold; the runs cut
    before LSODA stalled and those left out."""
    tau: float
    ts: float
    duration: float
    runs: int
    threshold: float
    cuts: tuple[Run, ...] = ()
    left_out: tuple[Run, ...] = ()


@dataclass(frozen=True)
class Verification:
    """Every ARR in every mode combination checked against the simulated model (``checks``, in
    mode order, ARRs in the order given); ``notes``: what kept a whole mode, or the model, from
    being verified; ``settings``: None when nothing could be simulated; ``zero``: (ARR, mode)
    pairs left out because the ARR is 0 there by its mode's indicator (a mode-only residual,
    :mod:`fdi.modewise`: nothing to verify; a trial's quarter car listed 9 such lines as "not
    verified: a part at rest")."""
    model: str
    seed: int
    checks: tuple[Check, ...]
    notes: tuple[str, ...]
    settings: Settings | None
    zero: tuple[tuple[str, str], ...] = ()

    @property
    def failures(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if c.passed is False)

    @property
    def unverified(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if c.passed is None)

    @property
    def ok(self) -> bool:
        """No ARR failed (some may be unverified: see ``complete``)."""
        return not self.failures

    @property
    def complete(self) -> bool:
        """Every ARR was checked in every mode combination."""
        return bool(self.checks) and not self.unverified


def terms(expr: sp.Expr) -> list[sp.Expr]:
    """The additive terms of ``expr``: sums split, and a product with exactly one sum among its
    factors distributed over it (``-a2*k4*(x + y)``: ``-a2*k4*x`` and ``-a2*k4*y``, the efforts
    a transformer carries into a junction's sum). A product of two sums, a power of a sum or a
    function of one stays whole: multiplying them out would split one physical contribution
    into pieces that cancel (and inflate the scale they are measured against)."""
    if isinstance(expr, sp.Add):
        return [u for a in expr.args for u in terms(a)]
    if isinstance(expr, sp.Mul):
        sums = [f for f in expr.args if isinstance(f, sp.Add)]
        if len(sums) == 1:
            rest = sp.Mul(*(f for f in expr.args if f is not sums[0]))
            return [u for a in sums[0].args for u in terms(rest * a)]
    return [expr]


@dataclass(frozen=True)
class _Compiled:
    """One ARR ready to evaluate: its residual(s), the sum of the absolute values of its terms,
    the arguments of its kinks."""
    arr: ARR
    forms: tuple[Residual, ...]      # the evaluated form, and the expanded one when they differ
    scale: Residual
    kinks: tuple[Residual, ...]


def _compile(model: Model, arr: ARR) -> _Compiled:
    """The residual machinery's own compilation (:func:`fdi.residuals.compile_residual`) of the
    ARR, of its scale and of its kinks' arguments. An ARR with an ``exact`` form (the rate of a
    stored quantity kept whole) is evaluated in both forms; its scale comes from the terms of
    the expanded one."""
    forms = [compile_residual(model, arr)]
    plain = replace(arr, exact=None)
    if arr.exact is not None:
        forms.append(compile_residual(model, plain))
    scale = compile_residual(model, replace(plain, expr=sp.Add(*(sp.Abs(u) for u in terms(arr.expr)))))
    args = set()
    for k in KINKS:          # a max's or min's switching surface is where two arguments are equal
        for e in arr.expr.atoms(k):
            args |= {a - b for a, b in itertools.combinations(e.args, 2)} if k in (sp.Max, sp.Min) else set(e.args)
    kinks = [compile_residual(model, replace(plain, expr=a)) for a in sorted(args, key=str)
             if a.has(t) and not a.is_number]
    return _Compiled(arr, tuple(forms), scale, tuple(kinks))


def _in_mode(model: Model, compiled: Sequence[_Compiled], mode: Mapping[str, int]) -> list[_Compiled]:
    """The ARRs with the mode's values written in before their terms are taken: a residual rebuilt
    mode by mode (``s*r_on + (1 - s)*r_off``, :mod:`fdi.modewise`) is one term per mode until then,
    and its violation would be measured against itself."""
    subs = {model.symbols[k]: sp.Integer(v) for k, v in mode.items() if k in model.symbols}
    out = []
    for c in compiled:
        a = c.arr
        if not subs or not (a.expr.free_symbols & set(subs)):
            out.append(c)
            continue
        fixed = replace(a, expr=a.expr.xreplace(subs), exact=None if a.exact is None else a.exact.xreplace(subs))
        out.append(_compile(model, fixed))
    return out


def _depth(r: Residual) -> int:
    """How many numerical differentiations of stored quantities are nested in a residual."""
    return 1 + max((_depth(inner) for _, inner in r.composites), default=0) if r.composites else 0


def _inputs(model: Model, rng: np.random.Generator, tau: float, grid: np.ndarray) -> dict[str, sp.Expr]:
    """A random sum of sinusoids for every input: mean and spread of its nominal expression over
    ``grid`` (1 when it has none), frequencies between FREQUENCIES / tau."""
    nominal = {s: sp.Float(v) for s, v in model.nominal_values().items() if math.isfinite(v)}
    out = {}
    for name, inp in model.inputs.items():
        centre, spread = 0.0, 1.0
        if inp.expr is not None:
            fn = sp.lambdify([t], inp.expr.xreplace(nominal), modules="numpy")
            with np.errstate(all="ignore"):
                u = np.asarray(fn(grid), dtype=float) * np.ones_like(grid)
            if np.all(np.isfinite(u)):
                centre = float(np.mean(u))
                spread = max(float(np.sqrt(2) * np.std(u)), 0.5 * abs(centre)) or 1.0
        weights = rng.uniform(0.2, 1.0, SINUSOIDS)
        amps = spread * weights / weights.sum()
        lo, hi = FREQUENCIES
        omegas = np.exp(rng.uniform(math.log(lo), math.log(hi), SINUSOIDS)) / tau
        phases = rng.uniform(0, 2 * math.pi, SINUSOIDS)
        out[name] = sp.Float(centre) + sp.Add(*(sp.Float(a) * sp.sin(sp.Float(w) * t + sp.Float(p))
                                                 for a, w, p in zip(amps, omegas, phases)))
    return out


class _Stalled(Exception):
    """LSODA spent its budget of evaluations (a discontinuous model sticking on a switching
    surface, a tank emptying through a square-root law); ``at``: where its crawl began."""

    def __init__(self, at: float):
        super().__init__(f"LSODA stalls at t = {at:.3g} s")
        self.at = at


def _lsoda(model: Model, grid: np.ndarray, vals: Mapping[str, float], initial: Mapping[str, float],
           atol) -> Trajectory:
    """LSODA with tight tolerances and a budget of BUDGET evaluations per sample. A stalled run
    reports the instant it was at after PACE evaluations per sample (a run at the usual pace
    would have ended by then: it had begun to crawl there)."""
    left, onset = [BUDGET * len(grid)], [None]
    latest = [float(grid[0])]
    first = [True]

    def values(tt):
        if first[0]:                # the simulator's first call asks the run's middle (its configuration)
            first[0] = False
            return vals
        left[0] -= 1
        latest[0] = float(tt)
        if onset[0] is None and left[0] <= (BUDGET - PACE) * len(grid):
            onset[0] = latest[0]
        if left[0] < 0:
            raise _Stalled(onset[0] if onset[0] is not None else latest[0])
        return vals
    return simulate(model, grid, values=values, initial=initial, method="LSODA", tolerances=(RTOL, atol),
                    autonomous=False)


def _integrate(model: Model, grid: np.ndarray, vals: Mapping[str, float], initial: Mapping[str, float],
               atol, finest: float) -> Trajectory:
    """One run on ``grid`` by LSODA, or a shorter one: where LSODA stalls at t_s (a
    velocity sticking under Coulomb friction, a tank emptying through a square-root law: the
    ODE's right-hand side switches at every step), the run is cut before t_s, at the same
    sampling period if half of it remains, else resampled at a period down to ``finest`` to keep
    MIN_SAMPLES. SimulationError when neither succeeds."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return _lsoda(model, grid, vals, initial, atol)
        except _Stalled as exc:
            stall = exc.at
        ts = float(grid[1] - grid[0])
        if stall - 2 * ts >= 0.5 * grid[-1]:
            cut = grid[grid <= stall - 2 * ts]
        else:
            period = max(finest, 0.9 * stall / (len(grid) - 1))
            cut = np.arange(int(0.9 * stall / period) + 1) * period
        if len(cut) < MIN_SAMPLES:
            raise SimulationError(f"LSODA stalls at t = {stall:.3g} s, on a switching surface (sticking friction, "
                                  "an emptied tank), too early to keep a run")
        try:
            return _lsoda(model, cut, vals, initial, atol)
        except _Stalled as exc:
            raise SimulationError(f"LSODA stalls at t = {exc.at:.3g} s, on a switching surface (sticking friction, "
                                  "an emptied tank), too early to keep a run") from None


def _raw(traj: Trajectory, model: Model, inputs: Mapping[str, sp.Expr]) -> dict[str, np.ndarray]:
    """The signals the residuals read: every sensor's true value (a displacement or momentum
    sensor's integral, a sensor of several columns its own value), every input."""
    raw = {s: np.asarray(traj.signals[s], dtype=float) for s in model.sensors}
    for name, expr in inputs.items():
        fn = sp.lambdify([t], expr, modules="numpy")
        raw[name] = np.asarray(fn(traj.t), dtype=float) * np.ones_like(traj.t)
    return raw


def _derivatives(raw: Mapping[str, np.ndarray], orders: Mapping[str, int], ts: float) -> dict[str, list[np.ndarray]]:
    """Every signal and its derivatives: Savitzky-Golay of order POLYORDER over POLYORDER + 2 samples
    (with the samples themselves, which stored quantities are formed from)."""
    return {name: Estimates(derivatives.estimate(raw[name], ts, max(order, 1), (POLYORDER + 2) * ts,
                                                 polyorder=POLYORDER), raw[name])
            for name, order in orders.items()}


def _floors(raw: Mapping[str, np.ndarray], orders: Mapping[str, int], ts: float) -> dict[tuple[str, int], float]:
    """The round-off of every signal's derivatives: PRECISION times the signal's largest value,
    through the filter's gain (the sum of its coefficients' magnitudes over ts^k)."""
    n = POLYORDER + 2
    out = {}
    for name, order in orders.items():
        k = max(order, 1)
        gains = np.abs(derivatives.kernels(n, POLYORDER, k, 1.0, n // 2)).sum(axis=0)
        size = float(np.max(np.abs(raw[name]), initial=0.0))
        out.update({(name, j): PRECISION * size * float(gains[j]) / ts ** j for j in range(k + 1)})
    return out


def _orders(compiled: Sequence[_Compiled]) -> dict[str, int]:
    """The highest derivative of each signal that any form, term or kink reads."""
    orders: dict[str, int] = {}
    for c in compiled:
        for r in (*c.forms, c.scale, *c.kinks):
            for s, k in r.signal_orders():
                orders[s] = max(orders.get(s, 0), k)
    return orders


def _call(r: Residual, sig, vals, ts: float, n: int) -> np.ndarray:
    """A residual (or term, or kink argument) on every sample; stored quantities differentiated as
    the signals are (order POLYORDER over POLYORDER + 2 samples). A cubic over 5 samples was used
    until 2026-11: exact to (w ts)^4 on a first derivative, but its second derivative is the
    quadratic fit's, (w ts)^2: the LC ladder's d2(C2 v2)/dt2 left 7e-4 on correct ARRs."""
    with np.errstate(all="ignore"):
        return np.broadcast_to(np.asarray(r(sig, vals, ts, (POLYORDER + 2) * ts, polyorder=POLYORDER),
                                          dtype=float), (n,))


@dataclass(frozen=True)
class _Kink:
    """A kink argument on one run: where it is below its own round-off (its sign unknown: the
    ARR that holds it cannot be judged there), and where it crosses zero (a switching surface:
    the signals' derivatives are not smooth there, for every ARR)."""
    flat: np.ndarray
    crossing: np.ndarray


def _roundoff(r: Residual, value: np.ndarray, sig, vals, ts: float, n: int,
              floors: Mapping[tuple[str, int], float]) -> np.ndarray:
    """The round-off of a residual (or term sum, or kink argument) whose value is ``value``: that
    of each signal derivative it reads (``floors``), carried through it."""
    out = np.zeros(n)
    for s, j in set(r.signal_orders()):
        bumped = {**sig, s: [x + floors[(s, j)] if i == j else x for i, x in enumerate(sig[s])]}
        out = out + np.abs(_call(r, bumped, vals, ts, n) - value)
    return out


def _kink(k: Residual, sig, vals, ts: float, n: int, floors: Mapping[tuple[str, int], float]) -> _Kink:
    """Where a kink argument is below its round-off, and where it crosses zero: a change of sign
    with the argument above its round-off on at least one side (round-off flipping about an
    argument that is zero is none)."""
    a = _call(k, sig, vals, ts, n)
    flat = ~np.isfinite(a) | (np.abs(a) <= 10 * _roundoff(k, a, sig, vals, ts, n, floors))
    crossing = np.zeros(n, dtype=bool)
    crossing[1:] = (np.sign(a[1:]) != np.sign(a[:-1])) & ~(flat[1:] & flat[:-1])
    return _Kink(flat, crossing)


def _dilate(mask: np.ndarray, reach: int) -> np.ndarray:
    """``mask`` widened by ``reach`` samples on both sides."""
    out = mask.copy()
    for i in np.flatnonzero(mask):
        out[max(0, i - reach):i + reach + 1] = True
    return out


def _kept(c: _Compiled, kinks: Mapping[int, _Kink], crossings: np.ndarray, n: int) -> np.ndarray:
    """The samples to judge an ARR on: away from the run's ends (the filters' edges), from every
    switching surface any ARR sees (``crossings``, already widened), and from the samples where
    one of its own kink arguments has no known sign; each by a filter's reach."""
    depth = max(_depth(r) for r in (*c.forms, c.scale, *c.kinks))
    edge = (POLYORDER + 2) * (1 + depth) + 2
    keep = np.zeros(n, dtype=bool)
    keep[edge:n - edge] = True
    keep &= ~crossings
    for k in c.kinks:
        keep &= ~_dilate(kinks[id(k)].flat, REACH * (1 + _depth(k)))
    return keep


def _evaluate_run(compiled: Sequence[_Compiled], sig, vals, ts: float, n: int,
                  floors: Mapping[tuple[str, int], float]) -> dict[str, tuple[float, float, int]]:
    """For every ARR on one run: max |r|, its scale (max over samples of the sum of |terms|) and
    the number of samples judged."""
    kinks = {id(k): _kink(k, sig, vals, ts, n, floors) for c in compiled for k in c.kinks}
    depth = max((_depth(r) for c in compiled for r in (*c.forms, c.scale, *c.kinks)), default=0)
    crossings = _dilate(np.logical_or.reduce([k.crossing for k in kinks.values()] + [np.zeros(n, dtype=bool)]),
                        REACH * (1 + depth))
    out = {}
    for c in compiled:
        keep = _kept(c, kinks, crossings, n)
        if not keep.any():
            out[c.arr.name] = (0.0, 0.0, 0)
            continue
        r = max(float(np.max(np.abs(_call(f, sig, vals, ts, n)[keep]))) for f in c.forms)
        scale = _call(c.scale, sig, vals, ts, n)
        size = float(np.max(scale[keep]))
        if size <= 10 * float(np.max(_roundoff(c.scale, scale, sig, vals, ts, n, floors)[keep])):
            size = 0.0                          # every term at round-off: nothing it relates moves
        out[c.arr.name] = (r, size, int(keep.sum()))
    return out


def verify(model: Model, arrs: Sequence[ARR] | None = None, *, seed: int = 0,
           modes: Sequence[Mapping[str, int]] | None = None, runs: int = RUNS,
           threshold: float = THRESHOLD, progress: Callable[[str], None] | None = None) -> Verification:
    """Check every ARR (default: :func:`fdi.arrs.select_arrs`) in every mode combination
    (default: :func:`bondgraph.timescales.mode_combinations`, nominal first) on ``runs`` seeded
    simulations each. ``progress`` is called with each mode's label before it is simulated."""
    if arrs is None:
        from .arrs import select_arrs
        arrs = select_arrs(model).arrs
    arrs = list(arrs)
    modes = [dict(m) for m in (modes if modes is not None else mode_combinations(model))]
    compiled: list[_Compiled] = []
    skipped: dict[str, str] = {}
    for a in arrs:
        try:
            compiled.append(_compile(model, a))
        except ValueError as exc:
            skipped[a.name] = str(exc).splitlines()[0]
    notes: list[str] = []               # what keeps a whole mode (or the model) from being verified
    scales = time_scales(model, modes)
    if not scales.known:
        reason = ("the simulator cannot linearise it for its time constants: " + "; ".join(scales.notes)
                  if scales.notes else "it has no time constant to set the simulation's step (no storage in "
                  "integral causality, or only integrators)")
        row = "the simulator cannot linearise the model (the note says why)" if scales.notes else reason  # once, in the note
        return Verification(model.name, seed, tuple(_unchecked(a.name, m, row) for m in modes for a in arrs),
                            tuple(notes) + (f"not verified in any mode: {reason}",), None)
    tau = scales.fastest
    ts = tau / STEPS_PER_TAU
    grid = np.arange(TAUS * STEPS_PER_TAU + 1) * ts
    orders = _orders(compiled)
    highest = max([max((k for _, k in r.signal_orders()), default=0) + _depth(r)
                   for c in compiled for r in c.forms] + [1])
    finest = ts / AMPLIFICATION ** (1 / highest)
    rng = np.random.default_rng(seed)
    pool: dict[str, np.ndarray] | None = None
    own: dict[tuple, set[str]] = {}      # the states each mode's own scouting run has (a mode that switches an
                                         # element out has no state of it: a drawn value for it was refused)
    checks: list[Check] = []
    cuts: list[Run] = []
    left_out: list[Run] = []
    if len(modes) > 1:
        # the states every mode visits: a state one mode leaves at rest (a converter's output
        # capacitor while the switch conducts) is drawn from where another mode takes it
        visited: dict[str, list[np.ndarray]] = {}
        for mode in modes:
            try:
                for name, v in _Runner(model, mode, grid, tau, finest, rng).scout(runs).items():
                    visited.setdefault(name, []).append(v)
                    own.setdefault(tuple(mode.items()), set()).add(name)
            except (SimulationError, CausalityError, ValueError, ArithmeticError, np.linalg.LinAlgError):
                continue
        pool = {name: np.concatenate(vs) for name, vs in visited.items()} or None
    else:
        try:
            pool = _Runner(model, modes[0], grid, tau, finest, rng).scout(runs)
        except (SimulationError, CausalityError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            pool = None              # (the mode's own run below says why)
    if pool is not None:
        # sampled at the fastest rate the runs visit, not only the linearisation's at rest (a hardening
        # spring k q + k3 q^3 at 3 cm: twice as stiff, its ARR failed by 1.8e-4 of its terms at rest's step)
        seen = visited_fastest(model, modes, pool)
        if seen < tau / FASTER:
            ts = max(seen, tau / MAX_REFINE) / STEPS_PER_TAU
            grid = np.arange(int(round(TAUS * tau / ts)) + 1) * ts      # the same span, finer
            finest = ts / AMPLIFICATION ** (1 / highest)
    zero: dict[str, set[str]] = {}     # per mode label: the ARRs identically 0 there
    for mode in modes:
        label = _label(mode)
        subs = {model.symbols[k]: sp.Integer(v) for k, v in mode.items() if k in model.symbols}
        zero[label] = {a.name for a in arrs if a.expr.xreplace(subs) == 0}
        if progress:
            progress(label)
        try:
            runner = _Runner(model, mode, grid, tau, finest, rng)
            if pool is None:
                pool = runner.scout(runs)
            states = own.get(tuple(mode.items()))
            seen_pool = pool if states is None else {k: v for k, v in pool.items() if k in states}
            state = rng.bit_generator.state          # the runs' draws: a refinement repeats the same runs
            in_mode = _in_mode(model, compiled, mode)
            found, done = runner.judge(in_mode, orders, seen_pool, runs)
        except (SimulationError, CausalityError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            why = _reason(exc)
            notes.append(f"not verified in mode {label}: {why}")
            checks += [_unchecked(a.name, mode, why) for a in arrs if a.name not in zero[label]]
            continue
        for k, outcome in enumerate(done):
            if isinstance(outcome, str):
                left_out.append(Run(tuple(mode.items()), k + 1, None, outcome))
            elif outcome < grid[-1]:
                cuts.append(Run(tuple(mode.items()), k + 1, outcome))
        failing = [c for c in in_mode if _fails(*found[c.arr.name][:3], threshold)]
        refined = _refined(model, mode, grid, tau, finest, state, failing, orders, seen_pool, runs, found,
                           threshold) if failing else {}
        for a in arrs:
            if a.name in zero[label]:
                continue
            checks.append(_unchecked(a.name, mode, skipped[a.name]) if a.name in skipped
                          else refined.get(a.name) or _check(a.name, mode, *found[a.name], threshold))
    settings = Settings(tau, ts, float(grid[-1]), runs, threshold, tuple(cuts), tuple(left_out))
    left = tuple((a.name, label) for label, names in zero.items() for a in arrs if a.name in names)
    return Verification(model.name, seed, tuple(checks), tuple(notes), settings, left)


def _check(arr: str, mode: Mapping[str, int], r: float, scale: float, judged: int, used: int,
           threshold: float) -> Check:
    """The verdict on one ARR in one mode from its worst run (``used``: the runs where its terms
    moved)."""
    if not judged:
        return Check(arr, tuple(mode.items()), math.nan, r, scale, 0, None,
                     "no sample away from the switching surfaces of its sign/abs arguments on any run "
                     "(a part at rest, stuck or locked in this mode)")
    if not (math.isfinite(r) and math.isfinite(scale)):
        return Check(arr, tuple(mode.items()), math.inf, r, scale, used, False, "not finite on the simulated signals")
    if not scale > 0:
        return Check(arr, tuple(mode.items()), math.nan, r, scale, 0, None,
                     "every term is zero on every run in this mode (a part at rest, stuck or locked: nothing "
                     "it relates moves)")
    return Check(arr, tuple(mode.items()), r / scale, r, scale, used, r / scale <= threshold)


def _fails(r: float, scale: float, judged: int, threshold: float) -> bool:
    """A finite violation above the threshold, on samples where the ARR's terms moved."""
    return bool(judged) and math.isfinite(r) and math.isfinite(scale) and scale > 0 and r / scale > threshold


def _refined(model: Model, mode: Mapping[str, int], grid: np.ndarray, tau: float, finest: float, state: dict,
             failing: Sequence[_Compiled], orders: Mapping[str, int], pool: Mapping[str, np.ndarray], runs: int,
             found: Mapping[str, tuple[float, float, int, int]], threshold: float) -> dict[str, Check]:
    """The verdicts on ARRs that failed in ``mode``, from the same runs (the random draws from
    ``state`` again) sampled REFINE, then REFINE^2 times finer. A derivative estimated where the
    signals turn faster than the samples follow (a brake's tanh(w/w0) with a small w0 locking a
    wheel: a real pole that rings not, so :func:`bondgraph.timescales.visited_fastest` does not
    refine for it) is a truncation error: it falls as the period does; a wrong ARR's violation is
    a missing term's share and stays. An ARR whose violation falls to the threshold passes (the
    note says at which sampling); one that falls by CONVERGES per step but not to the threshold
    is not verified (the note says how far it fell); one whose violation stays fails, as it did.

    Measured on tests/data/unverified/abs_modulator.yaml (w0 = 0.5 rad/s): the wheel balance's
    violations 0.156, 0.0143, 4.8e-4, 0.125 in its four modes at tau/10; 0.0174, 5.7e-5, 5.5e-8,
    0.0136 at 4x finer; 4.7e-5, 8.5e-8, 4.1e-10, 2.1e-5 at 16x."""
    ts = float(grid[1] - grid[0])
    first = {c.arr.name: found[c.arr.name] for c in failing}
    last = dict(first)
    pending = list(failing)
    out: dict[str, Check] = {}
    factor = 1
    for _ in range(REFINE_STEPS):
        factor *= REFINE
        fine = np.arange((len(grid) - 1) * factor + 1) * (ts / factor)
        rng = np.random.default_rng()
        rng.bit_generator.state = state
        try:
            got, _ = _Runner(model, mode, fine, tau, finest / factor, rng).judge(pending, orders, pool, runs)
        except (SimulationError, CausalityError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            break
        still = []
        for c in pending:
            name = c.arr.name
            r, scale, judged, used = got[name]
            before = last[name][0] / last[name][1]
            if not (judged and math.isfinite(r) and math.isfinite(scale) and scale > 0):
                continue                             # (the coarse verdict stands)
            v, last[name] = r / scale, got[name]
            if v <= threshold:
                out[name] = Check(name, tuple(mode.items()), v, r, scale, used, True,
                                  f"at {factor}x finer sampling ({ts / factor:.3g} s); at {ts:.3g} s "
                                  f"{first[name][0] / first[name][1]:.2e}, which fell as the period did: the "
                                  f"signals turn faster there than the coarser samples follow")
            elif v * CONVERGES <= before:
                still.append(c)                      # (else not the sampling's: the coarse FAIL stands)
        pending = still
        if not pending:
            break
    for c in pending:
        name = c.arr.name
        r, scale, _, used = last[name]
        out[name] = Check(name, tuple(mode.items()), math.nan, r, scale, used, None,
                          f"its violation fell from {first[name][0] / first[name][1]:.2e} at {ts:.3g} s to "
                          f"{r / scale:.2e} at {ts / factor:.3g} s sampling (a truncation error falls so, a wrong "
                          f"ARR's violation stays): the signals turn faster than the sampling follows; verify again "
                          f"with a smoother law, or judge the residual on data")
    return out


def _unchecked(arr: str, mode: Mapping[str, int], why: str) -> Check:
    return Check(arr, tuple(mode.items()), math.nan, math.nan, math.nan, 0, None, why)


class _Runner:
    """The runs of one mode combination: the model with its inputs replaced, the parameters and
    mode values held fixed, LSODA's absolute tolerance per state."""

    def __init__(self, model: Model, mode: Mapping[str, int], grid: np.ndarray, tau: float, finest: float,
                 rng: np.random.Generator):
        self.model, self.mode, self.grid, self.tau, self.finest, self.rng = model, mode, grid, tau, finest, rng
        self.vals = {k: float(v) for k, v in model.nominal_by_name().items()}
        self.vals.update({k: float(v) for k, v in mode.items()})
        self.atol: object = 1e-9

    def simulate(self, inputs: Mapping[str, sp.Expr], initial: Mapping[str, float]) -> Trajectory:
        m = replace(self.model, inputs={k: replace(i, expr=inputs[k]) for k, i in self.model.inputs.items()})
        return _integrate(m, self.grid, self.vals, initial, self.atol, self.finest)

    def scout(self, tries: int) -> dict[str, np.ndarray]:
        """The states a run from the model's initial state visits (default absolute tolerance):
        where the random initial states are drawn, and each state's scale. Up to ``tries`` draws
        of the inputs (a run from rest under a weak input may stick at once)."""
        for k in range(tries):
            try:
                traj = self.simulate(_inputs(self.model, self.rng, self.tau, self.grid), self.model.initial)
            except SimulationError:
                if k == tries - 1:
                    raise
                continue
            return {name: np.asarray(v, dtype=float) for name, v in traj.states.items()}
        raise SimulationError("no scouting run")

    def judge(self, compiled: Sequence[_Compiled], orders: Mapping[str, int], pool: Mapping[str, np.ndarray],
              runs: int) -> tuple[dict[str, tuple[float, float, int, int]], list[float | str]]:
        """For every ARR, its run of largest violation (max |r|, scale, samples judged) and the
        number of runs that judged it; for every run, the instant it ended (cut runs end early)
        or why it was left out. SimulationError when no run could be simulated."""
        scale = {k: max(float(np.max(np.abs(v))), float(np.ptp(v))) for k, v in pool.items()}
        self.atol = np.array([RTOL * (scale[k] or 1.0) for k in pool]) if pool else RTOL
        values = parameter_values(self.model, self.mode)
        worst: dict[str, tuple[float, float, int, int]] = {c.arr.name: (0.0, 0.0, 0, 0) for c in compiled}
        done: list[float | str] = []
        for k in range(runs):
            inputs = _inputs(self.model, self.rng, self.tau, self.grid)
            if k == 0:
                initial = dict(self.model.initial)
            else:
                i = int(self.rng.integers(len(next(iter(pool.values()))))) if pool else 0
                # (i % len(v): a state's pool may be shorter than the first, a momentum read on a
                # switched junction's sensor: an IndexError traceback in a user trial)
                initial = {s: float(v[i % len(v)] * math.exp(0.3 * self.rng.standard_normal())
                                    + 0.5 * np.ptp(v) * self.rng.standard_normal()) for s, v in pool.items()}
                for element, readings in measured_storage(self.model).items():
                    if element in initial and all(s in initial for s in readings):   # sensors read its state
                        initial[element] = (sum(coefficient(self.model, a) * initial[s] for s, a in readings.items())
                                            + offset(self.model, element, readings))
            try:
                traj = self.simulate(inputs, initial)
                raw = _raw(traj, self.model, inputs)
                if not all(np.all(np.isfinite(x)) for x in raw.values()):
                    raise SimulationError("the simulated signals leave the floats (an unstable or singular mode)")
            except (SimulationError, CausalityError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                done.append(_reason(exc))
                continue
            done.append(float(traj.t[-1]))
            ts = float(traj.t[1] - traj.t[0])
            sig = _derivatives(raw, orders, ts)
            found = _evaluate_run(compiled, sig, values, ts, len(traj.t), _floors(raw, orders, ts))
            for c in compiled:
                r, s, judged = found[c.arr.name]
                old = worst[c.arr.name]
                used = old[3] + (judged > 0 and s > 0)
                worst[c.arr.name] = (r, s, judged, used) if _rank(r, s, judged) > _rank(*old[:3]) else (*old[:3], used)
        if all(isinstance(d, str) for d in done):
            raise SimulationError(str(done[0]).removeprefix("the simulation failed: "))
        return worst, done


def _rank(r: float, scale: float, judged: int) -> tuple[int, float]:
    """Which run judges an ARR worst: one that leaves the floats, then the largest violation
    among runs where its terms move, then a run where they do not, then one with nothing judged."""
    if not judged:
        return (-1, 0.0)
    if not (math.isfinite(r) and math.isfinite(scale)):
        return (2, math.inf)
    return (1, r / scale) if scale > 0 else (0, 0.0)


def _reason(exc: BaseException) -> str:
    if isinstance(exc, CausalityError):
        return "the simulator refuses the model: " + "; ".join(exc.problems)
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return f"the simulation failed: {text}"
