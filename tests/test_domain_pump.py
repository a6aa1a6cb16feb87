"""A chain of three domains no shipped model joins: a DC motor (electrical), its rotor and a
positive-displacement pump (mechanical, a GY then a TF), filling an accumulator drained through a
valve (hydraulic): tests/data/motor_pump_tank.yaml, data from tests/independent/pump.py (scipy, the
three state equations typed by hand). References: the three laws by hand, nominal runs that raise
no alarm, and designed faults in each domain: the outlet valve clogged (Ro x 2), worn bearings
(b x 20) and a pressure transducer reading 10 % low, each found alone and sized."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest
import sympy as sp

from fdi.api import Options, diagnose

from .independent import laws_of, measurements, pump, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "motor_pump_tank.yaml")
T0 = 20.0

_data = partial(measurements, pump.simulate)
thresholds = thresholds_fixture(MODEL, pump.simulate)


def test_the_residuals_are_the_armature_the_rotor_and_the_accumulator_by_hand():
    (e1, e2, e3), sym, sig = laws_of(MODEL)
    i, w, p, u = sig["i"], sig["w"], sig["p"], sig["u"]
    t = i.args[0]
    Ra, La, K, J, b, D, C, Ro = (sym[n] for n in ("Ra", "La", "K", "J", "b", "D", "C", "Ro"))
    hand = [u - Ra * i - La * sp.diff(i, t) - K * w,            # the armature loop
            K * i - J * sp.diff(w, t) - b * w - D * p,          # the rotor's torques
            D * w - C * sp.diff(p, t) - p / Ro]                 # the accumulator's flows
    for expr, want in zip((e1, e2, e3), hand):
        assert sp.simplify(expr.doit() - want) == 0


@pytest.mark.parametrize("which, factor, seed", [("Ro", 2.0, 4), ("b", 20.0, 5), ("beta_p", 0.9, 7)])
def test_a_fault_in_each_domain_is_found_and_sized(thresholds, which, factor, seed):
    report = diagnose(MODEL, _data(which, seed, t0=T0, factor=factor, which=which),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 0.06 <= report["detection"]["time"] < T0 + 1.0      # half the 0.113 s window before
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (which, "abrupt")
    assert found["value"] == pytest.approx(pump.NOMINAL.get(which, 1.0) * factor, rel=0.01)
    assert found["t0"] == pytest.approx(T0, abs=0.06)
