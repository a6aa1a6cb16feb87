"""A domain no shipped model covers: the systemic circulation as a three-element Windkessel
(tests/data/windkessel.yaml: the heart's outflow into the aorta's characteristic impedance Zc, then
the arterial compliance C and the peripheral resistance Rp; aortic pressure measured, the inflow
known), data from tests/independent/windkessel.py (scipy, the two laws typed by hand). References:
the Windkessel's law by hand (Westerhof et al. 2009), nominal runs that raise no alarm, and designed
faults: vasoconstriction (Rp up 30 %) and a stiffening (C down 40 %), told apart by their fits
though the one residual reads both."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest
import sympy as sp

from fdi.api import Options, diagnose
from fdi.monitor import compiled

from .independent import by_hand, measurements, thresholds_fixture, windkessel

MODEL = str(Path(__file__).resolve().parent / "data" / "windkessel.yaml")
T0 = 60.0

_data = partial(measurements, windkessel.simulate)
thresholds = thresholds_fixture(MODEL, windkessel.simulate)


def test_the_residual_is_the_windkessel_law():
    """Q - C d(p - Zc Q)/dt - (p - Zc Q)/Rp: the compliance's pressure is the measured one less the
    characteristic impedance's drop."""
    (arr,) = compiled(MODEL).arrs
    expr, sym, sig = by_hand(arr.expr)
    t = sig["p"].args[0]
    Zc, C, Rp, Q, p = sym["Zc"], sym["C"], sym["Rp"], sig["Q"], sig["p"]
    pc = p - Zc * Q
    assert sp.simplify(expr - (Q - C * sp.diff(pc, t) - pc / Rp)) == 0


@pytest.mark.parametrize("which, factor, seed", [("Rp", 1.3, 4), ("C", 0.6, 5)])
def test_a_vasoconstriction_and_a_stiffening_are_found_and_sized(thresholds, which, factor, seed):
    report = diagnose(MODEL, _data(which, seed, t0=T0, factor=factor, which=which),
                      Options(workers=1, seed=0, thresholds=thresholds, max_set=1)).to_dict()
    assert T0 - 0.15 <= report["detection"]["time"] < T0 + 0.5      # half the 0.25 s derivative window, and a sample
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (which, "abrupt")
    assert found["value"] == pytest.approx(windkessel.NOMINAL[which] * factor, rel=0.02)
    assert found["t0"] == pytest.approx(T0, abs=0.1)
