"""An electro-mechano-acoustic chain no shipped model joins: a closed-box loudspeaker (Thiele-Small:
the voice coil, a GY of force factor Bl, the cone on its suspension, a TF of the cone's area into the
box's air, which leaks): tests/data/closed_box_speaker.yaml, data from tests/independent/speaker.py
(the four state equations solved exactly: linear, driven by two tones). References: the three laws
by hand, nominal runs that raise no alarm, and designed faults in each domain: the voice coil
heated (Re x 1.3), the box leaking (Ral x 0.01), the suspension fatigued (Cms x 3) and the
microphone reading 10 % and 20 % low, each found alone and sized.

The microphone at 20 % low is the case that taught something (2026-11-30): it fires the voice-coil
balance ARR1 and the box balance ARR3 and leaves the cone's ARR2 just under its threshold, so
exoneration leaves one candidate, the leak {Ral}, whose signature is exactly [1 0 1]; the best leak
(an intermittent one at the 76 Hz resonance's period) left the residuals 17 times their nominal
level, and was the diagnosis. A fit that far from the noise means a quiet residual exonerated the
true fault: the smallest sets covering the coherence vector are identified too
(:func:`fdi.pipeline.widen`), and {beta_p} fits to the noise."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest
import sympy as sp

from fdi.api import Options, diagnose

from .independent import found_alone, laws_of, measurements, speaker, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "closed_box_speaker.yaml")
T0 = 1.0

_data = partial(measurements, speaker.simulate)
thresholds = thresholds_fixture(MODEL, speaker.simulate)


def test_the_residuals_are_the_coil_the_cone_and_the_box_by_hand():
    (e1, e2, e3), sym, sig = laws_of(MODEL)
    i, v, p, u = sig["i"], sig["v"], sig["p"], sig["u"]
    t = i.args[0]
    Re, Le, Bl, Mms, Rms, Cms, Sd, Cab, Ral = (sym[n] for n in ("Re", "Le", "Bl", "Mms", "Rms", "Cms", "Sd", "Cab",
                                                                 "Ral"))
    box_flow = Cab * sp.diff(p, t) + p / Ral                  # the air the cone pushes into the box, Sd v
    hand = [u - Re * i - Le * sp.diff(i, t) - Bl * box_flow / Sd,     # the coil's voltages, v read from the box
            v - Cms * (Bl * sp.diff(i, t) - Mms * sp.diff(v, t, 2) - Rms * sp.diff(v, t) - Sd * sp.diff(p, t)),
            Sd * v - box_flow]                                          # the box's flows
    for expr, want in zip((e1, e2, e3), hand):       # the cone's forces, differentiated once (x unknown)
        assert sp.simplify(expr.doit() - want) == 0


@pytest.mark.parametrize("which, factor, seed, rel", [("Re", 1.3, 23, 0.01), ("Ral", 0.01, 24, 0.02),
                                                      ("beta_p", 0.9, 26, 0.01), ("Cms", 3.0, 21, 0.15)])
def test_a_fault_in_each_domain_is_found_and_sized(thresholds, which, factor, seed, rel):
    """Cms within 15 %: it enters ARR2 only, through the cone's second derivative (calibrate: the
    smallest change of Cms these runs detect is 87 %, of Re 4 %); measured +8.4 % at x 3 and +5.8 %
    at x 2 (the Savitzky-Golay derivatives are not each other's derivatives at 110 Hz)."""
    report, found = found_alone(MODEL, speaker.simulate, which, factor, seed, T0, thresholds)
    assert T0 - 0.003 <= report["detection"]["time"] < T0 + 0.05     # half the 5 ms window before
    assert found["value"] == pytest.approx(speaker.NOMINAL.get(which, 1.0) * factor, rel=rel)


def test_a_microphone_exonerated_by_a_quiet_residual_is_found_when_the_exact_sets_fit_badly(thresholds):
    report = diagnose(MODEL, _data("mic", 25, t0=T0, factor=0.8, which="beta_p"),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert report["detection"]["final_coherence"] == [1, 0, 1]        # ARR2 quiet: beta_p's signature is [1 1 1]
    assert ["Ral"] in report["candidates"] and ["beta_p"] in report["candidates"]
    assert report["exoneration_relaxed"] is True and "nominal level" in report["note"]
    costs = {tuple(e["candidate"]): e["cost"] for e in report["estimators"]}
    assert costs[("Ral",)] > 10 * costs[("beta_p",)]                 # the exact set explains nothing
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("beta_p", "abrupt")
    assert found["value"] == pytest.approx(0.8, rel=0.01)


def test_the_text_report_says_why_exoneration_was_relaxed(thresholds):
    """The CLI's line names the reason: the exact sets' lack of fit here (the note's words), no
    matching set where none equals the coherence vector (that note left out)."""
    from fdi.app.report import to_text
    report = diagnose(MODEL, _data("mic", 25, t0=T0, factor=0.8, which="beta_p"),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert "as the sets that equal it left the residuals far above their nominal level" in to_text(report, "m", "d")
    assert "as no fault set's signature equals it" in to_text({**report, "note": None}, "m", "d")
