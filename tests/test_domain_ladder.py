"""A damped two-section LC ladder filter (tests/data/lc_ladder.yaml: electrical, two inductors
and two capacitors in a chain, a resistive load), data from tests/independent/lc_ladder.py
(scipy, Kirchhoff's laws typed by hand).

What this domain found and checks: with the inductor current and the output voltage measured,
both residuals are loop equations (KVL) whose derivatives reach the third of i1 (ARR1, through the
first capacitor's current) and the second of v2 (ARR2, through the second's): the rule's
derivative window (9 samples at 5 kHz) leaves them noise-dominated, and yet the output capacitor
losing half its capacitance is found, typed and sized. A load step is found and sized, with a
spurious companion (the xfail below)."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from fdi.api import Options, diagnose

from .independent import lc_ladder, measurements, thresholds_fixture

MODEL = Path(__file__).resolve().parent / "data" / "lc_ladder.yaml"
T0 = 1.0

_data = partial(measurements, lc_ladder.simulate)
thresholds = thresholds_fixture(str(MODEL), lc_ladder.simulate)


def test_the_residuals_are_the_ladders_loop_equations():
    """By hand (factors at 1), v1 = u - R1 i1 - L1 i1' (the first loop) and i2 = i1 - C1 v1' (the
    first node): ARR1 = v1 - L2 i2' - v2 (the second loop, i2 from the node: a third derivative of
    i1); ARR2 = v1 - L2 (C2 v2'' + v2'/RL) - v2 (the second loop, i2 from the output node)."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled

    from .independent import by_hand
    got = [by_hand(arr.expr) for arr in compiled(str(MODEL)).arrs]
    assert len(got) == 2
    sym = {k: v for g in got for k, v in g[1].items()}
    sig = {k: v for g in got for k, v in g[2].items()}
    R1, L1, C1, L2, C2, RL = (sym[n] for n in ("R1", "L1", "C1", "L2", "C2", "RL"))
    u, i1, v2 = sig["u"], sig["i1"], sig["v2"]
    v1 = u - R1 * i1 - L1 * sp.diff(i1, t)
    first = v1 - L2 * sp.diff(i1 - C1 * sp.diff(v1, t), t) - v2
    second = v1 - L2 * (C2 * sp.diff(v2, t, 2) + sp.diff(v2, t) / RL) - v2
    exprs = [g[0] for g in got]
    for want in (first, second):
        assert any(sp.simplify(e - want) == 0 or sp.simplify(e + want) == 0 for e in exprs)


def test_the_output_capacitor_losing_half_is_found_typed_and_sized(thresholds):
    report = diagnose(str(MODEL), _data("c2", 7, t0=T0, c2_fault=235e-6),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 0.01 <= report["detection"]["time"] < T0 + 0.05
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("C2", "abrupt")
    assert found["value"] == pytest.approx(235e-6, rel=0.03)
    assert found["t0"] == pytest.approx(T0, abs=0.01)


@pytest.mark.xfail(strict=False, reason=(
    "bgfdi: a load halved at 1 s (8 -> 4 Ohm) is found and sized (4.05), but with the output "
    "capacitor at 406 uF (for 470) beside it: C2 multiplies v2'', which the rule's 9-sample window "
    "leaves noisy (ARR2's threshold from nominal runs 1.56 V), and a smaller C2 shrinks that noise "
    "in the L1 cost: {C2, RL} costs 1434, the load alone 1506 (4.8 % more), and the information "
    "criterion takes the pair; at a 4 ms window C1 and C2 still move 4-5 % beside the load (the "
    "load's step is seen through the smoothing filter, its neighbours' terms through the "
    "derivatives': the filter remedy of the 2026-11-29 stop note). Since the coefficients' bounds are in "
    "units of the window it may pass at seed 0: that search misses the pair's fit (1434) and returns the "
    "load alone (1506); seeds 1-3 take the pair (measured on 2026-11-29)"))
def test_a_halved_load_is_the_load_alone(thresholds):
    report = diagnose(str(MODEL), _data("rl", 8, t0=T0, rl_fault=4.0),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("RL", "abrupt")
    assert found["value"] == pytest.approx(4.0, rel=0.03)
