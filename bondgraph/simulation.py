"""Simulation in integral causality, with dependent storage, switching and time-varying faults.

The state is the energy variable of every storage element in integral causality (p of an I, q of
a C) plus the time integral of every sensor that measures a displacement or a momentum (so that a
modulated element such as F1(theta2) can use it). Storage elements that SCAP leaves in derivative
causality are *dependent*: their effort (or flow) is d/dt of an expression of the states, which
puts the state derivatives on both sides of the state equations. The equations are therefore
derived as ``A(x, t) x' = b(x, t)`` (linear in x', checked symbolically), and x' is obtained at
every step by a linear solve: the exact reduction to an ODE, never an approximation.

Structure follows the parameters: a resistor whose flow law is identically zero at the current
parameter values (a healthy leakage with R4 = inf) is an open circuit (a zero flow source) in
that *configuration*. When a fault makes it finite, causality is assigned again for the new
configuration and the state is carried over: states that exist in both keep their values, new
ones start from the values their variables had just before the switch (p = I f, q = C e).
Mode variables (controlled junctions) are inputs of the equations; the diagnostic hybrid bond graph
form (outputs x a) serves every mode with one causality.

The ODE is solved piece by piece between breakpoints (fault instants, switching instants): by
ROS2, a fixed-step L-stable Rosenbrock-W method, when the equations are discontinuous (Coulomb
friction, leakage: see ``simulate``), otherwise by scipy's LSODA; Radau, BDF or RK45 on request.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Mapping, Sequence

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from .causality import SIMULATION, assign
from .equations import relations, resolve
from .errors import CausalityError
from .model import LAW_VARIABLES, Element, Model, t


class SimulationError(Exception):
    """The model cannot be simulated as given (the message says why and what to change)."""


@dataclass
class System:
    """The reduced state equations of one configuration."""
    states: list[str]                 # storage elements in integral causality, then sensor integrals
    kinds: list[str]                  # 'storage' | 'sensor'
    open_resistors: frozenset[str]
    matrix: Callable                  # A(x, params...) -> (n, n)
    rhs: Callable                     # b(x, params...) -> (n,)
    explicit: Callable | None         # x' directly, when A is diagonal (no linear solve needed)
    outputs: Callable                 # (x, dx, params...) -> sensor true values, storage flows/efforts
    output_names: list[str]
    param_names: list[str]
    energy: Callable                  # (x, dx, params) -> energy variable of every storage element (for mapping)
    storage_names: list[str]
    discontinuous: bool               # sign/abs/heaviside in the equations (Coulomb friction, leakage)

    def derivative(self, t: float, x: np.ndarray, params: list[float]) -> np.ndarray:
        """x' from A(x) x' = b(x): divided out when A is diagonal, a linear solve otherwise."""
        if self.explicit is not None:
            return np.array(self.explicit(t, *x, *params))
        A = np.atleast_2d(np.asarray(self.matrix(t, *x, *params), dtype=float))
        return np.linalg.solve(A, np.asarray(self.rhs(t, *x, *params), dtype=float).reshape(-1))


def _specialise(model: Model, values: Mapping[str, float]) -> tuple[Model, frozenset[str]]:
    """Resistors whose flow law vanishes at these values become open circuits (Sf: 0)."""
    subs = {model.symbols[k]: (sp.oo if np.isinf(v) else sp.Float(v)) for k, v in values.items() if k in model.symbols}
    opened = set()
    elements = dict(model.elements)
    for e in model.elements.values():
        if e.kind != "R":
            continue
        law = e.laws.get("flow")
        if law is None and e.parameter is not None:
            law = LAW_VARIABLES["e"] / model.symbols[e.parameter]
        if law is not None and sp.simplify(law.xreplace(subs)) == 0:
            opened.add(e.name)
            elements[e.name] = Element(e.name, "Sf", value=sp.Integer(0), description=f"{e.name} open (infinite)")
    if not opened:
        return model, frozenset()
    return replace(model, elements=elements), frozenset(opened)


def build_system(model: Model, values: Mapping[str, float]) -> System:
    """Derive and lambdify the state equations of the configuration these parameter values imply."""
    return _build(*_specialise(model, values))


def _build(spec: Model, opened: frozenset[str]) -> System:
    """The state equations of one configuration (a model with its open resistors replaced)."""
    causality = assign(spec, SIMULATION)
    bad = [p for p in causality.problems if "dependent storage" not in p]
    if bad or causality.loops:
        raise CausalityError(bad + list(causality.loops))
    storage = [e for e in spec.elements.values() if e.kind in ("C", "I")]
    integral = [e for e in storage if causality.storage[e.name] == "integral"]
    integrals = [s for s in spec.sensors.values() if s.measures in ("displacement", "momentum")]
    X = {e.name: sp.Function(f"x_{e.name}", real=True)(t) for e in integral}
    X.update({s.name: sp.Function(f"x_{s.name}", real=True)(t) for s in integrals})
    known: dict[str, sp.Expr] = {}
    for e in spec.sources():
        if e.name in opened:
            known[e.name] = sp.Integer(0)
            continue
        if e.input:
            inp = spec.inputs[e.input]
            if inp.expr is None:
                raise SimulationError(f"input '{e.input}' has no expr: give inputs.{e.input}.expr (a function of t) "
                                      "to simulate")
            base = inp.expr
        else:
            base = e.value
        known[e.name] = spec.symbols[f"beta_{e.input or e.name}"] * base
    for s in spec.sensors.values():
        known[s.name] = sp.Integer(0)
    signals = {spec.symbols[s.name]: X[s.name] for s in integrals}
    for s in spec.sensors.values():
        if spec.symbols[s.name] not in signals:
            signals[spec.symbols[s.name]] = sp.Symbol(f"__signal_{s.name}")   # resolved below if used
    signals.update({spec.symbols[i]: spec.inputs[i].expr for i in spec.inputs if spec.inputs[i].expr is not None})
    rels = relations(spec, causality, known=known, states={e.name: X[e.name] for e in integral}, signals=signals)
    wanted = []
    for e in integral:
        (b,) = [x.id for x in spec.bonds if e.name in (x.source, x.target)]
        wanted.append(("e", b) if e.kind == "I" else ("f", b))
    for s in spec.sensors.values():
        wanted.append(("e", s.name) if s.kind == "De" else ("f", s.name))
    flows = []
    for e in storage:
        (b,) = [x.id for x in spec.bonds if e.name in (x.source, x.target)]
        flows.append(("f", b) if e.kind == "I" else ("e", b))
    try:
        values_ = resolve(rels, wanted + flows)
    except ValueError as exc:
        raise SimulationError(str(exc)) from None
    n_st = len(integral)
    derivs = [values_[w] for w in wanted[:n_st]]
    sensor_vals = {s.name: values_[w] for s, w in zip(spec.sensors.values(), wanted[n_st:])}
    for s in integrals:
        derivs.append(sensor_vals[s.name])
    states = [e.name for e in integral] + [s.name for s in integrals]
    xs = [X[n] for n in states]
    x_sym = [sp.Symbol(f"X{i}") for i in range(len(xs))]
    dx_sym = [sp.Symbol(f"dX{i}") for i in range(len(xs))]
    to_sym = {sp.Derivative(x, t): d for x, d in zip(xs, dx_sym)}
    to_sym2 = dict(zip(xs, x_sym))

    def plain(expr: sp.Expr) -> sp.Expr:
        expr = expr.xreplace(to_sym) if expr.has(sp.Derivative) else expr
        return expr.xreplace(to_sym2)
    residual = [plain(d) for d in derivs]
    F = [dx - r for dx, r in zip(dx_sym, residual)]
    A = sp.Matrix([[sp.diff(f, d) for d in dx_sym] for f in F])
    zero = {d: 0 for d in dx_sym}
    b = sp.Matrix([-f.xreplace(zero) for f in F])
    if any(entry.has(*dx_sym) for entry in A):
        raise SimulationError("the state equations are not linear in the state derivatives; "
                              "this dependent storage cannot be reduced")
    leftovers = [s for s in set().union(*(m.free_symbols for m in list(A) + list(b))) if s.name.startswith("__signal_")]
    if leftovers:
        raise SimulationError(f"a modulated element uses signal(s) {[s.name[9:] for s in leftovers]} that are not "
                              "displacements or momenta; measure them as such or use a parameter")
    params = sorted({s for s in set().union(*(m.free_symbols for m in list(A) + list(b))) if s not in x_sym
                     and s != t} | {spec.symbols[n] for n in spec.parameters} | {spec.symbols[m] for m in spec.modes}
                    | {spec.symbols[f"beta_{e.input or e.name}"] for e in spec.sources() if e.name not in opened},
                    key=lambda s: s.name)
    args = [t] + x_sym + params
    out_exprs = [plain(sensor_vals[s]) for s in spec.sensors] + [plain(values_[f]) for f in flows]
    storage_energy = []
    for e, f in zip(storage, flows):
        var = plain(values_[f])
        if e.parameter:
            storage_energy.append(spec.symbols[e.parameter] * var)
        else:
            law = e.laws.get("momentum" if e.kind == "I" else "displacement")
            if law is None:
                storage_energy.append(sp.nan)
            else:
                storage_energy.append(law.xreplace({LAW_VARIABLES["f" if e.kind == "I" else "e"]: var}))
    lam = lambda exprs, extra=(): sp.lambdify(args + list(extra), exprs, modules="numpy", cse=True)
    explicit = None
    if A.is_diagonal():
        explicit = sp.lambdify(args, [b[i] / A[i, i] for i in range(len(xs))], modules="math", cse=True)
    return System(states, ["storage"] * n_st + ["sensor"] * len(integrals), opened,
                  lam(A), lam(b), explicit, lam(out_exprs, dx_sym), list(spec.sensors) + [f"flow_{e.name}" for e in storage],
                  [p.name for p in params], lam(storage_energy, dx_sym), [e.name for e in storage],
                  any(m.has(sp.sign, sp.Abs, sp.Heaviside) for m in list(A) + list(b)))


@dataclass
class Trajectory:
    t: np.ndarray
    signals: dict[str, np.ndarray]         # true sensor values and inputs
    states: dict[str, np.ndarray]
    configurations: list[tuple[float, frozenset[str]]]


def simulate(model: Model, t_eval: np.ndarray, *, values: Callable[[float], Mapping[str, float]],
             breakpoints: Sequence[float] = (), initial: Mapping[str, float] | None = None,
             method: str = "auto", max_step: float | None = None, progress: Callable[[float], None] | None = None
             ) -> Trajectory:
    """Simulate on ``t_eval``. ``values(t)`` gives every parameter, efficiency factor and mode
    variable at time t (faults included); ``breakpoints`` are the instants where they jump.

    ``method``: a scipy ``solve_ivp`` method (LSODA, Radau, BDF for stiff problems; RK45), ``ros2``
    (fixed-step L-stable Rosenbrock-W, step <= ``max_step``, default 1 ms), or ``auto``: ros2 when the
    equations are discontinuous (Coulomb friction sign(v), leakage sqrt|dp|: error-controlled
    methods stall at the switching surface when a velocity sticks near zero, and a leak makes the
    problem stiff; a fixed step bounds the chatter to F_c/J * h, far below sensor resolution),
    LSODA otherwise."""
    initial = dict(initial or {})
    t_eval = np.asarray(t_eval, dtype=float)
    edges = sorted({float(t_eval[0]), float(t_eval[-1])} | {float(b) for b in breakpoints if t_eval[0] < b < t_eval[-1]})
    cache: dict[frozenset, System] = {}
    max_step = max_step or float(np.min(np.diff(t_eval))) if t_eval.size > 1 else None
    out_t, out_sig, out_states = [], {}, {}
    configs: list[tuple[float, frozenset[str]]] = []
    system: System | None = None
    x = None
    for a, b in zip(edges[:-1], edges[1:]):
        spec, opened = _specialise(model, values(0.5 * (a + b)))
        if opened not in cache:
            cache[opened] = _build(spec, opened)
        new = cache[opened]
        if system is None:
            x = _initial_state(new, initial, a, values(a))
        elif new is not system:
            x = _carry_over(system, new, x, a, values(a - 1e-9))
        if new is not system:
            configs.append((a, new.open_resistors))
        system = new
        mask = (t_eval >= a) & ((t_eval < b) | (b == edges[-1]))
        pts = t_eval[mask]

        last: list = [None, None]                       # the parameters of the last instant asked

        def param_vec(tt, sys_=system, last=last):
            if last[0] != tt:                           # integrators ask the same instant repeatedly
                v = values(tt)
                last[0], last[1] = tt, [v[p] for p in sys_.param_names]
            return last[1]

        def rhs(tt, xx, sys_=system):
            return sys_.derivative(tt, xx, param_vec(tt))
        how = method if method != "auto" else ("ros2" if system.discontinuous else "LSODA")
        if how == "ros2":
            sol = _ros2(rhs, a, b, x, pts, min(max_step or 1e-3, 1e-3))
            x = sol.end
        else:
            sol = solve_ivp(rhs, (a, b), x, method=how, t_eval=pts if pts.size else None,
                            max_step=max_step or np.inf, rtol=1e-6, atol=1e-9)
            if not sol.success:
                raise SimulationError(f"integration failed between {a:g} s and {b:g} s: {sol.message} "
                                      "(try method ros2)")
            x = sol.y[:, -1]
            if pts.size and sol.t[-1] < b:              # t_eval stopped short of the piece's end
                x = solve_ivp(rhs, (sol.t[-1], b), x, method=how, max_step=max_step or np.inf,
                              rtol=1e-6, atol=1e-9).y[:, -1]
        if pts.size:
            ys = sol.y
            for i, tt in enumerate(sol.t):
                p = param_vec(tt)
                dx = rhs(tt, ys[:, i])
                vals = np.asarray(system.outputs(tt, *ys[:, i], *p, *dx), dtype=float).reshape(-1)
                for name, v in zip(system.output_names, vals):
                    out_sig.setdefault(name, []).append(v)
                for name, v in zip(system.states, ys[:, i]):
                    out_states.setdefault(name, []).append(v)
            out_t.extend(sol.t)
        if progress:
            progress(b)
    n = len(out_t)
    sig = {k: np.asarray(v, dtype=float) for k, v in out_sig.items() if len(v) == n}
    for s in model.sensors.values():
        if s.measures in ("displacement", "momentum"):
            sig[s.name] = np.asarray(out_states.get(s.name, np.zeros(n)), dtype=float)
    return Trajectory(np.asarray(out_t), sig, {k: np.asarray(v) for k, v in out_states.items() if len(v) == n}, configs)


@dataclass
class _Solution:
    t: np.ndarray          # the output points reached
    y: np.ndarray          # states there, (n_states, points)
    end: np.ndarray        # the state at the end of the piece


def _ros2(rhs, a: float, b: float, x: np.ndarray, pts: np.ndarray, h_max: float, jac_every: int = 5) -> _Solution:
    """ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999): L-stable, order 2 with any Jacobian approximation
    (a W-method), so a finite-difference Jacobian is refreshed only every ``jac_every`` steps.
    Fixed step, landing exactly on every output point and on b.

        (I - g h J) k1 = f(x),   (I - g h J) k2 = f(x + h k1) - 2 k1,   x+ = x + h (3 k1 + k2) / 2,
        g = 1 + 1/sqrt(2)."""
    g = 1.0 + 1.0 / np.sqrt(2.0)
    marks = list(pts) + ([b] if not pts.size or pts[-1] < b else [])
    ts, ys = [], []
    tt, xx = a, np.asarray(x, dtype=float)
    n_state = xx.size
    eye = np.eye(n_state)
    count, lu = 0, None
    h_used = None
    for target in marks:
        span = target - tt
        if span > 0:
            n = max(1, int(np.ceil(span / h_max - 1e-9)))
            h = span / n
            for _ in range(n):
                f0 = rhs(tt, xx)
                if lu is None or count % jac_every == 0 or h != h_used:
                    jac = np.empty((n_state, n_state))
                    for j in range(n_state):
                        d = 1e-7 * max(1.0, abs(xx[j]))
                        xp = xx.copy()
                        xp[j] += d
                        jac[:, j] = (rhs(tt, xp) - f0) / d
                    if not np.all(np.isfinite(jac)):
                        jac = np.nan_to_num(jac, nan=0.0, posinf=0.0, neginf=0.0)
                    lu = np.linalg.inv(eye - g * h * jac)
                    h_used = h
                count += 1
                k1 = lu @ f0
                k2 = lu @ (rhs(tt + h, xx + h * k1) - 2.0 * k1)
                xx = xx + h * (1.5 * k1 + 0.5 * k2)
                tt += h
            tt = target
        if pts.size and target in pts:
            ts.append(target)
            ys.append(xx.copy())
    return _Solution(np.asarray(ts), np.asarray(ys).T if ys else np.zeros((n_state, 0)), xx)


def _initial_state(system: System, initial: Mapping[str, float], t0: float, vals: Mapping[str, float]) -> np.ndarray:
    """States from the initial values given by state name; values given for other sensor signals
    (a tank pressure, say) are met by solving for the storage states not given explicitly."""
    x = np.array([initial.get(n, 0.0) for n in system.states], dtype=float)
    targets = {k: v for k, v in initial.items() if k not in system.states and k in system.output_names}
    free = [i for i, (n, kind) in enumerate(zip(system.states, system.kinds)) if kind == "storage" and n not in initial]
    unknown = [k for k in initial if k not in system.states and k not in system.output_names]
    if unknown:
        raise SimulationError(f"initial value(s) for {', '.join(unknown)}: no state or sensor of that name")
    if not targets:
        return x
    if len(free) < len(targets):
        raise SimulationError(f"cannot meet initial values of {', '.join(targets)}: too few free storage states")
    from scipy.optimize import least_squares
    p = [vals[n] for n in system.param_names]
    idx = [system.output_names.index(k) for k in targets]
    want = np.array(list(targets.values()), dtype=float)

    def gap(z):
        xx = x.copy()
        xx[free] = z
        dx = system.derivative(t0, xx, p)
        out = np.asarray(system.outputs(t0, *xx, *p, *dx), dtype=float).reshape(-1)
        return (out[idx] - want) / np.maximum(1.0, np.abs(want))
    sol = least_squares(gap, x[free], xtol=1e-14, ftol=1e-14, gtol=1e-14)
    if np.max(np.abs(sol.fun)) > 1e-6:
        raise SimulationError(f"cannot meet the initial values of {', '.join(targets)}")
    x[free] = sol.x
    return x


def _carry_over(old: System, new: System, x: np.ndarray, t0: float, vals: Mapping[str, float]) -> np.ndarray:
    """Map the state across a configuration change (see module doc)."""
    p = [vals[n] for n in old.param_names]
    dx = old.derivative(t0, x, p)
    energy = dict(zip(old.storage_names, np.asarray(old.energy(t0, *x, *p, *dx), dtype=float).reshape(-1)))
    current = dict(zip(old.states, x))
    return np.array([current.get(n, energy.get(n, 0.0)) for n in new.states], dtype=float)
