"""Generated chains (benchmarks): compact derivation and state equations mean the same as the flat forms."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import bondgraph.equations as equations
from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.chains import chain_yaml
from bondgraph.equations import ParameterProduct
from bondgraph.loader import load_model_text
from fdi.arrs import derive_arrs


@pytest.fixture(scope="module")
def chain():
    return load_model_text(chain_yaml(120), "chain_120")


def test_grouped_products_flatten_to_the_plain_arr(chain, monkeypatch):
    grouped = derive_arrs(chain, assign(chain, DIAGNOSIS))[0].expr
    assert grouped.has(ParameterProduct)
    monkeypatch.setattr(equations, "PRODUCT_LIMIT", 10 ** 9)      # never group: sympy's flat products
    flat = derive_arrs(chain, assign(chain, DIAGNOSIS))[0].expr
    assert not flat.has(ParameterProduct)
    assert grouped.doit() == flat


def test_grouped_products_are_positive_and_lambdify(chain):
    expr = derive_arrs(chain, assign(chain, DIAGNOSIS))[0].expr
    product = next(iter(expr.atoms(ParameterProduct)))
    assert product.is_positive and product.is_commutative
    values = {s: 1.0 + 0.01 * i for i, s in enumerate(sorted(product.free_symbols, key=str))}
    fn = sp.lambdify(list(values), product, "math")
    assert fn(*values.values()) == pytest.approx(float(product.doit().xreplace(values)), rel=1e-12)
    assert np.isfinite(fn(*values.values()))


def test_chain_state_equations_simulate_and_bench_rejects_bad_sizes(capsys):
    from bondgraph.simulation import build_system
    from fdi.app.cli import main

    model = load_model_text(chain_yaml(40), "chain_40")
    values = {s.name: v for s, v in model.nominal_values().items()}
    system = build_system(model, values)
    assert system.states == ["I1"] and system.discontinuous        # nine inertias, one independent
    p = [values[n] for n in system.param_names]
    assert np.isfinite(system.derivative(0.3, np.array([0.01]), p)).all()
    assert main(["bench", "derive", "--sizes", "10,x"]) == 2
    assert "--sizes" in capsys.readouterr().err


def test_chain_state_equation_is_the_hand_derived_one():
    """One independent inertia: with N_i the product of the moduli before stage i (f_i = N_i f_1),
    power balance gives p' = (u - sum N_i R_i(N_i f_1)) / (1 + sum_{i>1} J_i N_i^2 / J_1),
    f_1 = p / J_1, R_i(f) = b_i f + c_i sign(f)."""
    from bondgraph.simulation import build_system

    stages = 12
    model = load_model_text(chain_yaml(4 * stages), "chain_48")
    values = {s.name: v for s, v in model.nominal_values().items()}
    system = build_system(model, values)
    p = [values[n] for n in system.param_names]
    for tt, x in ((0.3, 0.01), (1.7, -0.4), (2.2, 3.0)):
        f1 = x / values["J1"]
        ratio, drive, inertia = 1.0, values["beta_u"] * np.sin(tt), 1.0
        for i in range(1, stages + 1):
            f = ratio * f1
            drive -= ratio * (values[f"b{i}"] * f + values[f"c{i}"] * np.sign(f))
            if i > 1:
                inertia += values[f"J{i}"] * ratio ** 2 / values["J1"]
            ratio *= values.get(f"n{i}", 1.0)
        assert system.derivative(tt, np.array([x]), p)[0] == pytest.approx(drive / inertia, rel=1e-12)


def test_tank_chain_state_equations_are_the_mass_balances():
    """Tanks in series (tank_chain_yaml): tank i's volume q_i changes by the flow in minus the
    flow out, dq_i/dt = Q_(i-1) - Q_i, with p_i = q_i/CT_i, Q_i = (p_i - p_(i+1))/Rv_i, the
    outlet Q_n = p_n/Rv_n and the pump Q_0 = 1e-5 (1 + 0.3 sin(0.01 t)) m^3/s."""
    from bondgraph.chains import tank_chain_yaml
    from bondgraph.simulation import build_system

    n = 6
    model = load_model_text(tank_chain_yaml(n), "tank_chain_6")
    assert len(model.sensors) == n and len(model.faults) == 3 * n + 1
    values = {s.name: v for s, v in model.nominal_values().items()}
    system = build_system(model, values)
    assert system.states == [f"tank{i}" for i in range(1, n + 1)]
    p_args = [values[k] for k in system.param_names]
    rng = np.random.default_rng(5)
    for tt in (0.0, 37.0, 410.0):
        q = rng.uniform(0.5e-3, 5e-3, n)
        p = q / np.array([values[f"CT{i}"] for i in range(1, n + 1)])
        flows = [1e-5 * (1 + 0.3 * np.sin(0.01 * tt))]
        flows += [(p[i] - p[i + 1]) / values[f"Rv{i + 1}"] for i in range(n - 1)] + [p[-1] / values[f"Rv{n}"]]
        expected = [flows[i] - flows[i + 1] for i in range(n)]
        assert system.derivative(tt, q, p_args) == pytest.approx(expected, rel=1e-9, abs=1e-20)
