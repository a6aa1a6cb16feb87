"""Simulators written apart from bgfdi (scipy, the physics typed by hand), and the steps every
domain test takes with them: their columns as measurements, thresholds calibrated on two nominal
runs and checked quiet on a third (as a module's fixture), and an ARR in the terms a hand
derivation is written in; and the exact solution of a linear system driven by tones, whose
parameters step once (the loudspeaker's and the hydrostatic transmission's simulators)."""
from __future__ import annotations

from typing import Callable

import numpy as np


def tones_steady(A: np.ndarray, B: np.ndarray, t: np.ndarray, tones, mean: float = 0.0) -> np.ndarray:
    """(states, t.size): the steady state of dx/dt = A x + B u for u = mean + sum a sin(2 pi f t) over
    ``tones`` ((a, f) pairs): the mean's equilibrium, plus per tone Im(X e^{j w t}) with
    X = (j w I - A)^-1 B a."""
    n = A.shape[0]
    out = np.repeat(np.linalg.solve(-A, B * mean)[:, None], t.size, axis=1) if mean else np.zeros((n, t.size))
    for a, f in tones:
        w = 2 * np.pi * f
        X = np.linalg.solve(1j * w * np.eye(n) - A, B * a)
        out += np.imag(X[:, None] * np.exp(1j * w * t)[None, :])
    return out


def piecewise_linear(t: np.ndarray, stretches, system: Callable, steady: Callable,
                     start: np.ndarray | None = None) -> np.ndarray:
    """(states, t.size): a linear system solved exactly, not integrated, sample to sample. Each
    stretch (first sample, one past its last, parameters) has ``system(parameters) -> (A, B)``;
    its state is ``steady(A, B, t)`` plus exp(A (t - a)) times the difference at its start, stepped
    by expm(A Ts). ``start``: the state at t[0] (None: the first stretch's steady state)."""
    from scipy.linalg import expm
    ts = float(t[1] - t[0])
    x = None
    state = start
    for a, b, params in stretches:
        if a >= b:
            continue
        A, B = system(params)
        x = np.empty((A.shape[0], t.size)) if x is None else x
        ss = steady(A, B, t[a:b])
        step = expm(A * ts)
        z = np.zeros(A.shape[0]) if state is None else state - ss[:, 0]     # the transient at the stretch's start
        for k in range(b - a):
            x[:, a + k] = ss[:, k] + z
            z = step @ z
        if b < t.size:                        # the state at the next stretch's first sample, these parameters'
            state = steady(A, B, t[b:b + 1])[:, 0] + z
    return x


def measurements(simulate: Callable[..., dict], name: str, seed: int, **kw):
    """``simulate(seed, **kw)``'s columns as :class:`fdi.data.Measurements` named ``name``."""
    from fdi.data import Measurements
    cols = simulate(seed, **kw)
    return Measurements(name, cols["t"], cols)


def found_alone(model: str, simulate: Callable[..., dict], which: str, factor: float, seed: int, t0: float,
                thresholds: dict) -> tuple[dict, dict]:
    """A run of ``simulate`` (seed ``seed``) with ``which`` times ``factor`` from ``t0``, diagnosed with
    ``thresholds``: the report and its one fault, asserted to be ``which``, abrupt (what each domain's
    designed abrupt faults are checked for before their size and date)."""
    from fdi.api import Options, diagnose
    report = diagnose(model, measurements(simulate, which, seed, t0=t0, factor=factor, which=which),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (which, "abrupt")
    return report, found


def thresholds(model: str, simulate: Callable[..., dict]) -> dict:
    """The model's thresholds calibrated on nominal runs 1 and 2 (seeds 1, 2), asserted quiet on a
    third (seed 3): no alarm on a run the calibration did not see."""
    from fdi.calibrate import calibrate, nominal_residuals
    cal = calibrate(model, [measurements(simulate, "nominal1", 1), measurements(simulate, "nominal2", 2)])
    held_out = nominal_residuals(model, measurements(simulate, "nominal3", 3))
    # NaN where no derivative is estimated (a stretch between switches shorter than the window)
    assert (np.nanmax(np.abs(held_out), axis=1) < np.asarray(cal.thresholds)).all()
    return dict(zip(cal.names, cal.thresholds))


def thresholds_fixture(model: str, simulate: Callable[..., dict]):
    """A module-scoped pytest fixture named ``thresholds``: :func:`thresholds` of ``model`` on
    ``simulate`` (``thresholds = thresholds_fixture(MODEL, cstr.simulate)`` in a test module)."""
    import pytest
    return pytest.fixture(scope="module", name="thresholds")(lambda: thresholds(model, simulate))


def by_hand(expr) -> tuple:
    """An ARR's expression as a hand derivation writes it: its sensor, input and source factors
    (``beta_*``) at 1; with its symbols by name and its signals (functions of t) by name."""
    import sympy as sp
    syms = {s.name: s for s in expr.free_symbols}
    plain = expr.subs({s: 1 for n, s in syms.items() if n.startswith("beta")})
    return plain, syms, {f.func.__name__: f for f in plain.atoms(sp.core.function.AppliedUndef)}


def laws_of(model: str) -> tuple[list, dict, dict]:
    """The model's residuals as :func:`by_hand` writes them, with every symbol and every signal
    (a function of t) among them by name: what a test of its laws by hand starts from."""
    import sympy as sp

    from fdi.monitor import compiled
    exprs = [by_hand(arr.expr)[0] for arr in compiled(model).arrs]
    sym = {x.name: x for e in exprs for x in e.free_symbols if isinstance(x, sp.Symbol)}
    sig = {f.func.__name__: f for e in exprs for f in e.atoms(sp.core.function.AppliedUndef)}
    return exprs, sym, sig
