"""Residuals: the AGARRs lambdified for numpy and evaluated on sampled data.

A residual is called with the *corrected* signals: each measurement divided by its sensor's
efficiency factor profile beta(t), each input multiplied by its source's, and then
differentiated numerically (:mod:`fdi.derivatives`). Correcting before differentiating is what
makes a time-varying beta(t) (intermittent, incipient) exact: d/dt(theta1/beta) includes the
beta'(t) terms, and the jumps of an intermittent sensor fault cancel when the profile is right.
Every argument may be a scalar or an array broadcastable to (population, samples).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np
import sympy as sp

from bondgraph.model import Model, t

from . import derivatives
from .arrs import ARR


@dataclass(frozen=True)
class Residual:
    name: str
    sensor: str
    func: Callable[..., np.ndarray]
    signals: tuple[tuple[str, int], ...]     # (signal, derivative order), in argument order
    symbols: tuple[str, ...]                 # parameters, remaining efficiency factors, modes
    expr: sp.Expr                            # the numeric form that was lambdified

    def __call__(self, signals: Mapping[str, list[np.ndarray]], values: Mapping[str, object]) -> np.ndarray:
        args = [signals[s][k] for s, k in self.signals] + [values[n] for n in self.symbols]
        out = self.func(*args)
        return np.asarray(out, dtype=float)


def numeric_form(model: Model, expr: sp.Expr) -> sp.Expr:
    """Sensor and input efficiency factors set to 1: the caller passes corrected signals."""
    ones = {model.beta_symbol(s): sp.Integer(1) for s in model.sensors}
    ones.update({model.beta_symbol(e.input): sp.Integer(1) for e in model.sources() if e.input})
    return expr.xreplace(ones)


def compile_residual(model: Model, arr: ARR) -> Residual:
    """Lambdify one AGARR: signal derivatives become plain array arguments."""
    expr = numeric_form(model, arr.expr)
    names = list(model.sensors) + list(model.inputs)
    replace: dict[sp.Expr, sp.Symbol] = {}
    used: list[tuple[str, int]] = []
    for d in sorted(expr.atoms(sp.Derivative), key=str):
        fn = d.expr
        if not (isinstance(fn, sp.core.function.AppliedUndef) and fn.args == (t,)):
            raise ValueError(f"{arr.name}: cannot evaluate the derivative {d} numerically")
        order = sum(c for v, c in d.variable_count if v == t)
        replace[d] = sp.Symbol(f"{fn.func.__name__}__d{order}", real=True)
        used.append((fn.func.__name__, order))
    for fn in expr.atoms(sp.core.function.AppliedUndef):
        if fn.func.__name__ in names:
            replace[fn] = sp.Symbol(f"{fn.func.__name__}__d0", real=True)
            used.append((fn.func.__name__, 0))
    # replace derivatives first so that theta1(t) inside Derivative(theta1(t), t) is not touched
    numeric = expr.xreplace({k: v for k, v in replace.items() if isinstance(k, sp.Derivative)})
    numeric = numeric.xreplace({k: v for k, v in replace.items() if not isinstance(k, sp.Derivative)})
    used = sorted(set(used))
    signal_syms = [sp.Symbol(f"{s}__d{k}", real=True) for s, k in used]
    others = sorted((s for s in numeric.free_symbols if s not in set(signal_syms)), key=lambda s: s.name)
    if arr.states:
        raise ValueError(f"{arr.name} integrates states (mixed causality); bgfdi evaluates residuals in "
                         "derivative causality on data: use the derivative-causality residual set")
    # dummify: a parameter may be named like a numpy function (exp, sign) without shadowing it
    func = sp.lambdify(signal_syms + others, numeric, modules="numpy", cse=True, dummify=True)
    return Residual(arr.name, arr.sensor, func, tuple(used), tuple(s.name for s in others), expr)


def compile_residuals(model: Model, arrs: list[ARR]) -> list[Residual]:
    return [compile_residual(model, a) for a in arrs]


def derivative_orders(residuals: list[Residual]) -> dict[str, int]:
    """The highest derivative of each signal that any residual needs."""
    orders: dict[str, int] = {}
    for r in residuals:
        for s, k in r.signals:
            orders[s] = max(orders.get(s, 0), k)
    return orders


def corrected_signals(model: Model, raw: Mapping[str, np.ndarray], ts: float, orders: Mapping[str, int],
                      betas: Mapping[str, object] | None = None,
                      window: float = derivatives.DEFAULT_WINDOW, edges: str = "interp") -> dict[str, list[np.ndarray]]:
    """Each signal (sensor measurement / beta, or beta * input) and its derivatives."""
    betas = betas or {}
    out: dict[str, list[np.ndarray]] = {}
    for name, order in orders.items():
        x = np.asarray(raw[name], dtype=float)
        beta = betas.get(name)
        if beta is not None:
            x = x / beta if name in model.sensors else x * beta
        out[name] = derivatives.estimate(x, ts, order, window, edges=edges)
    return out


def parameter_values(model: Model, overrides: Mapping[str, object] | None = None) -> dict[str, object]:
    """Nominal parameter, efficiency factor and mode values by name, with overrides applied."""
    values: dict[str, object] = {s.name: v for s, v in model.nominal_values().items()}
    values.update(overrides or {})
    return values


def evaluate(model: Model, residuals: list[Residual], raw: Mapping[str, np.ndarray], ts: float, *,
             values: Mapping[str, object] | None = None, betas: Mapping[str, object] | None = None,
             window: float = derivatives.DEFAULT_WINDOW) -> np.ndarray:
    """Residuals on data: array of shape (n_residuals, ..., samples)."""
    sig = corrected_signals(model, raw, ts, derivative_orders(residuals), betas, window)
    vals = parameter_values(model, values)
    outs = [r(sig, vals) for r in residuals]
    shape = np.broadcast_shapes(*[o.shape for o in outs], *[np.shape(v[0]) for v in sig.values()])
    return np.stack([np.broadcast_to(o, shape) for o in outs])
