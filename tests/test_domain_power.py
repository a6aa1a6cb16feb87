"""A mains transformer feeding an R-L load (tests/data/transformer.yaml: an ideal TF between two
1-junctions, 50 Hz AC, time constant 2.5 ms; a domain no shipped model covers), data from
tests/independent/transformer.py (scipy, Kirchhoff's laws typed by hand, apart from bgfdi).

Designed truths: the load resistance steps 2.0 -> 1.4 Ohm at 1.2 s (it enters the effort balance
only); shorted turns take the ratio 10 -> 9.5 at 1.2 s (both relations)."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from fdi.api import Options, diagnose
from fdi.data import Measurements

from .independent import by_hand, measurements, thresholds_fixture, transformer

MODEL = str(Path(__file__).resolve().parent / "data" / "transformer.yaml")
T0 = 1.2

_data = partial(measurements, transformer.simulate)    # (name, seed, **the simulator's keywords)
thresholds = thresholds_fixture(MODEL, transformer.simulate)    # two nominal runs; a third asserted quiet


def test_the_residuals_are_the_ratio_and_the_effort_balance():
    """By hand (sensor factors at 1): i2 - N i1 from the TF, and (V - R1 i1)/N - N R2 i1 - N L2 i1'
    (the secondary current written as N i1); each up to its sign and a factor."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled
    arrs = compiled(MODEL).arrs
    hands = []
    for arr in arrs:
        expr, syms, fn = by_hand(arr.expr)
        N, R1, R2, L2 = (sp.Symbol(n, positive=True) for n in ("N", "R1", "R2", "L2"))
        expr = expr.subs({syms[n]: s for n, s in zip(("N", "R1", "R2", "L2"), (N, R1, R2, L2)) if n in syms})
        i1 = fn["i1"]
        candidates = [fn["i2"] - N * i1 if "i2" in fn else None,
                      (fn["V"] - R1 * i1) / N - N * R2 * i1 - N * L2 * sp.Derivative(i1, t) if "V" in fn else None]
        hands.append(any(h is not None and sp.simplify(sp.cancel(expr / h)).is_number for h in candidates))
    assert len(arrs) == 2 and all(hands)


@pytest.mark.parametrize("fault, truth, kw", [("R2", 1.4, {"r2": 1.4}), ("N", 9.5, {"n": 9.5})])
def test_a_load_step_and_shorted_turns_are_isolated_and_sized(thresholds, fault, truth, kw):
    report = diagnose(MODEL, _data(f"{fault}_step", 4, t0=T0, **kw),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert report["detection"]["time"] == pytest.approx(T0, abs=0.005)    # a centred filter: half a window early at most
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault, "abrupt")
    assert found["value"] == pytest.approx(truth, rel=0.01)


def test_a_load_step_with_a_sensor_reading_low_is_two_faults_found_and_sized(thresholds):
    """Designed truth, two faults at once: the load steps 2.0 -> 1.4 Ohm at 1.2 s and from then the
    secondary current's sensor reads 10 % low (its column scaled here, after the independent
    simulation). Ten candidate sets explain the alarm; sets that miss a true fault may stop early
    in their race (``raced_out``), and one that holds both only as outdone by the designed pair
    (its extra faults explain nothing), and the answer is the designed pair."""
    import numpy as np
    cols = transformer.simulate(7, t0=T0, r2=1.4)
    cols["i2"] = np.where(cols["t"] >= T0, 0.9 * cols["i2"], cols["i2"])
    report = diagnose(MODEL, Measurements("load_and_sensor", cols["t"], cols),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    found = {f["name"]: f for f in report["diagnosis"]["faults"]}
    assert set(found) == {"R2", "beta_i2"} and all(f["type"] == "abrupt" for f in found.values())
    assert found["R2"]["value"] == pytest.approx(1.4, rel=0.01)
    assert found["beta_i2"]["value"] == pytest.approx(0.9, rel=0.01)
    raced = {tuple(e["candidate"]): e["outdone_by"] for e in report["estimators"] if e["raced_out"]}
    assert raced and all(sorted(by or ()) == ["R2", "beta_i2"] for c, by in raced.items() if {"R2", "beta_i2"} <= set(c))
