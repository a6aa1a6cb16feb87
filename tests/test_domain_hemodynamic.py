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


def test_calibrate_finds_a_window_shorter_than_the_rules_where_the_heart_beats_faster(tmp_path):
    """Without the file's window, the rule's is half of Rp C = 1.5 s, and the heartbeat (1.25 Hz and
    its harmonic) is smoothed by it: `calibrate --window auto` tries windows below the rule's too
    and picks one (0.375 s), where every fault is detected from a smaller change than at the rule's."""
    from fdi.calibrate import calibrate
    from fdi.window_choice import chosen
    text = Path(MODEL).read_text(encoding="utf-8")
    model = tmp_path / "windkessel_rule.yaml"
    model.write_text(text[:text.index("\ndiagnosis:")] + "\n", encoding="utf-8")
    runs = [_data("nominal1", 1), _data("nominal2", 2)]
    scores = calibrate(str(model), runs, window="auto").window_scores
    rule, pick = scores[0], chosen(scores)
    assert rule.window == pytest.approx(0.75, rel=0.01) and pick.window < rule.window / 1.5
    assert all(pick.detectable[f] < rule.detectable[f] for f in rule.detectable)
