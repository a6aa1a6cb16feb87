"""Long chains (issue 24): a residual deeper than Python's default recursion limit is derived and
equals the one written by hand; a tank chain with one capacitance fault is diagnosed on data from
an independent simulator (tests/independent/tank_chain.py). Speed is in ``bgfdi bench chain``."""
from __future__ import annotations

import json
import random

import numpy as np
import pytest
import sympy as sp

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.chains import chain_yaml, fault_chain_yaml
from bondgraph.deep import free_symbols, has_any, run_deep
from bondgraph.loader import load_model_text
from fdi.api import Options, diagnose
from fdi.app.cli import main
from fdi.arrs import select_arrs
from fdi.data import Measurements
from fdi.scaph import derive_arrs

from .independent import tank_chain
from .independent.faults import Fault


def _hand_drivetrain_residual(values: dict, stages: int, u: float, w: float, dw: float) -> float:
    """The drivetrain chain's residual written out stage by stage (no expression, no recursion):
    the torque left at stage i+1 is the torque left at stage i through transformer i
    (e1 = n e2: divided by n_i) minus what stage i+1 takes, D = J f' + b f + c sign(f), with the
    speed of stage i the measured speed divided by the moduli after it (f2 = n f1)."""
    f, df = w / values["beta_w"], dw / values["beta_w"]
    speeds = [(f, df)]
    for i in range(stages - 1, 0, -1):              # stage i from stage i+1 through transformer i
        f, df = f / values[f"n{i}"], df / values[f"n{i}"]
        speeds.append((f, df))
    speeds.reverse()                                 # speeds[i-1]: stage i

    def demand(i: int) -> float:
        f, df = speeds[i - 1]
        return values[f"J{i}"] * df + values[f"b{i}"] * f + values[f"c{i}"] * np.sign(f)
    left = values["beta_u"] * u - demand(1)
    for i in range(2, stages + 1):
        left = left / values[f"n{i - 1}"] - demand(i)
    return left


def _evaluate(expr, symbols: dict, signals: dict, rates: dict) -> float:
    """``expr`` in floats, node by node from the leaves (each shared node once, no recursion):
    sums, products, powers, sign, grouped products, signals ``name(t)`` and their first derivatives."""
    done: dict[int, float] = {}
    stack = [(expr, False)]
    while stack:
        node, ready = stack.pop()
        if id(node) in done:
            continue
        if isinstance(node, sp.Derivative):
            done[id(node)] = rates[node.expr.func.__name__]
        elif isinstance(node, sp.core.function.AppliedUndef):
            done[id(node)] = signals[node.func.__name__]
        elif node.is_Symbol:
            done[id(node)] = symbols[node]
        elif node.is_Number:
            done[id(node)] = float(node)
        elif not ready:
            stack.append((node, True))
            stack.extend((a, False) for a in node.args)
        else:
            args = [done[id(a)] for a in node.args]
            if node.is_Add:
                done[id(node)] = sum(args)
            elif node.is_Mul:
                done[id(node)] = float(np.prod(args))
            elif node.is_Pow:
                done[id(node)] = args[0] ** args[1]
            elif isinstance(node, sp.sign):
                done[id(node)] = float(np.sign(args[0]))
            elif isinstance(node, sp.UnevaluatedExpr):
                done[id(node)] = args[0]
            else:
                raise AssertionError(f"unexpected node {type(node).__name__}")
    return done[id(expr)]


def test_a_residual_deeper_than_the_recursion_limit_is_the_hand_derived_one():
    """1 800 elements (450 stages): sympy's walks of this residual nest deeper than the default
    recursion limit of 1 000 frames (the CLI refused it before: RecursionError)."""
    size, stages = 1800, 450
    model = load_model_text(chain_yaml(size), f"chain_{size}")

    arr = run_deep(lambda: derive_arrs(model, assign(model, DIAGNOSIS))[0])

    def residual_at(point):
        values = {model.symbols[k]: v for k, v in point["values"].items()}
        return _evaluate(arr.expr, values, {"u": point["u"], "w": point["w"]}, {"w": point["dw"]})
    rng = random.Random(3)
    for _ in range(2):
        values = {s.name: v for s, v in model.nominal_values().items()}
        values.update({k: v * rng.uniform(0.8, 1.2) for k, v in values.items()})
        values.update(beta_u=rng.uniform(0.9, 1.1), beta_w=rng.uniform(0.9, 1.1))
        point = {"values": values, "u": rng.uniform(-1, 1), "w": rng.uniform(0.1, 1), "dw": rng.uniform(-1, 1)}
        got = residual_at(point)
        want = _hand_drivetrain_residual(values, stages, point["u"], point["w"], point["dw"])
        assert got == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_check_of_a_deep_chain_prints_its_residual(tmp_path, capsys):
    path = tmp_path / "chain.yaml"
    path.write_text(chain_yaml(1800))
    assert main(["check", str(path), "--json", "-q"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [a["sensor"] for a in report["residuals"]["arrs"]] == ["w"]


def test_walks_of_shared_expressions_agree_with_sympy():
    """bondgraph.deep walks each shared subexpression once; the answers are sympy's."""
    model = load_model_text(chain_yaml(120), "chain_120")
    expr = derive_arrs(model, assign(model, DIAGNOSIS))[0].expr
    assert free_symbols(expr) == expr.free_symbols
    x = sp.Symbol("x")
    for e in (expr, expr + sp.zoo, sp.Integral(x, (x, 0, 1)) + x):
        assert has_any(e, (sp.zoo, sp.nan, sp.oo)) == e.has(sp.zoo, sp.nan, sp.oo)
        assert free_symbols(e) == e.free_symbols


def test_a_derivation_runs_with_the_collector_paused_and_restores_it():
    """run_deep pauses Python's cyclic collector while the derivation runs (gc.isenabled seen from
    inside) and restores it as it was: on after a value and after an error, off if it was off."""
    import gc

    assert gc.isenabled()
    assert run_deep(gc.isenabled) is False and gc.isenabled()

    def fails():
        raise ValueError("inside")
    with pytest.raises(ValueError, match="inside"):
        run_deep(fails)
    assert gc.isenabled()
    gc.disable()
    try:
        assert run_deep(gc.isenabled) is False and not gc.isenabled()
    finally:
        gc.enable()


def test_a_fault_chain_residual_is_its_tank_mass_balance():
    """ARR i of fault_chain_yaml: q_{i-1} - CT_i dp_i/dt - (p_i - p_{i+1})/Rv_i (Samantaray &
    Ould Bouamama ch. 5), with the measurements divided by their beta."""
    n = 6
    model = load_model_text(fault_chain_yaml(n), f"fault_chain_{n}")
    arrs = {a.sensor: a.expr for a in select_arrs(model).arrs}
    assert sorted(arrs) == sorted(f"p{i}" for i in range(1, n + 1))
    sig = {f.func.__name__: f for e in arrs.values() for f in e.atoms(sp.core.function.AppliedUndef)}
    tt = sig["p1"].args[0]
    s = model.symbols
    p = {i: sig[f"p{i}"] / s[f"beta_p{i}"] for i in range(1, n + 1)}
    p[n + 1] = 0
    q = {0: s["beta_q0"] * sig["q0"]}
    q.update({i: (p[i] - p[i + 1]) / s[f"Rv{i}"] for i in range(1, n + 1)})
    for i in range(1, n + 1):
        hand = q[i - 1] - s[f"CT{i}"] * sp.diff(p[i], tt) - q[i]
        assert sp.simplify(arrs[f"p{i}"] - hand) == 0


def test_a_tank_chain_capacitance_fault_is_isolated_and_identified():
    """50 tanks, tank 25's capacitance 1e-5 -> 8e-6 m^3/Pa from 100 s, simulated independently:
    the pressure jumps by 25 % (the stored volume is continuous) and the jump also lights the two
    neighbours' residuals (the derivative filter's transient). The set of three, started from
    each fault fitted alone (fdi.estimators.separable), gives tank 25 its design and the
    neighbours at most a 1 % change (before: a neighbour alone was the diagnosis, tank 25 dropped)."""
    n, middle, value = 50, 25, 0.8e-5
    cols = tank_chain.simulate(n, (Fault(f"CT{middle}", "abrupt", 100.0, value),), T=300.0, seed=0)
    report = diagnose(fault_chain_yaml(n), Measurements("tanks", cols["t"], cols),
                      Options(workers=1, seed=0)).to_dict()
    assert 90.0 <= report["detection"]["time"] <= 100.0          # the derivative window sees the jump early
    faults = {f["name"]: f for f in report["diagnosis"]["faults"]}
    assert faults[f"fT{middle}"]["type"] == "abrupt"
    assert faults[f"fT{middle}"]["value"] == pytest.approx(value, rel=0.05)
    assert faults[f"fT{middle}"]["t0"] == pytest.approx(100.0, abs=1.0)
    assert all(abs(f["value"] / 1e-5 - 1) < 0.01 for name, f in faults.items() if name != f"fT{middle}")


def test_the_independent_tank_chain_rests_at_the_hand_equilibrium():
    """Without a fault and with the pump at its mean, each tank stays at p_i = (n - i + 1) Rv q0."""
    cols = tank_chain.simulate(4, (), T=20.0, seed=0)
    for i in range(1, 5):
        assert abs(np.mean(cols[f"p{i}"][:3]) - (4 - i + 1) * tank_chain.RV * tank_chain.Q_MEAN) < 1.0
