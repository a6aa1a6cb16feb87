"""Two acoustic cavities linked by a neck, the second vented through a port (tests/data/helmholtz.yaml:
lumped acoustics, pressure as effort and volume velocity as flow, a loudspeaker as the flow source;
a domain no shipped model covers), data from tests/independent/helmholtz.py (scipy, the physics
typed by hand).

Designed truths at 1 s, one at a time: the port blocked (its resistance doubled), the neck
obstructed (tripled), microphone 2 reading 10 % low."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from fdi.api import Options, diagnose

from .independent import by_hand, helmholtz, measurements, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "helmholtz.yaml")
T0 = 1.0

_data = partial(measurements, helmholtz.simulate)    # (name, seed, **the simulator's keywords)
thresholds = thresholds_fixture(MODEL, helmholtz.simulate)    # two nominal runs; a third asserted quiet


def test_the_residuals_are_the_volume_balance_and_the_neck_s_momentum():
    """By hand (factors at 1): Q - C1 p1' - C2 p2' - p2/Rp (the two cavities' volume balance), and
    p1 - p2 - Rn f - In f' with the neck's flow f = Q - C1 p1' (its momentum), up to their signs."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled
    hand = {}
    for arr in compiled(MODEL).arrs:
        expr, syms, fn = by_hand(arr.expr)
        hand[arr.name] = expr, syms, fn
    (e1, s1, fn), (e2, s2, _) = hand["ARR1"], hand["ARR2"]
    s = {**s1, **s2}
    C1, C2, In, Rn, Rp = (s[n] for n in ("C1", "C2", "In", "Rn", "Rp"))
    Q, p1, p2 = fn["Q"], fn["p1"], fn["p2"]
    f = Q - C1 * sp.diff(p1, t)
    balance = Q - C1 * sp.diff(p1, t) - C2 * sp.diff(p2, t) - p2 / Rp
    momentum = p1 - p2 - Rn * f - In * sp.diff(f, t)
    for got, want in ((e1, balance), (e2, momentum)):
        assert sp.simplify(got - want) == 0 or sp.simplify(got + want) == 0


@pytest.mark.parametrize("fault, keywords, name, value", [
    ("port", {"rp": 7.0e6}, "port", 7.0e6),
    ("neck", {"rn": 4.2e5}, "neck", 4.2e5),
    ("microphone", {"g2": 0.9}, "beta_p2", 0.9),
])
def test_each_fault_is_found_and_sized(thresholds, fault, keywords, name, value):
    report = diagnose(MODEL, _data(fault, 4, t0=T0, **keywords),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 0.01 <= report["detection"]["time"] < T0 + 0.05   # the derivative window is centred
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (name, "abrupt")
    assert found["value"] == pytest.approx(value, rel=0.01)
    assert found["t0"] == pytest.approx(T0, abs=0.01)
