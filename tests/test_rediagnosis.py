"""Re-diagnosis as evidence arrives (issue 10): the three ways a one-shot decision at t_D + T_wt
was wrong on CyCab runs, each a shipped scenario whose design is the truth.

- a slow incipient drift of beta_theta1 lights ARR2 first (one-shot answer: an R4 fault) and ARR1
  only at 49 s;
- an abrupt R4 leak with a slow beta_theta2 drift: ARR3 fires 17 s after the decision (one-shot
  answer: R4 alone, its value 12 % off);
- a second fault (beta_theta2 abrupt at 35 s) 20 s after the first (R4 at 15 s).
"""
from __future__ import annotations

import pytest

from bondgraph.loader import load_model
from fdi.data import Measurements
from fdi.api import Options, diagnose
from fdi.app.resources import scenarios_dir
from fdi.app.scenario import load_scenario, run

from .conftest import CYCAB

REPORTS: dict = {}


def report(name: str, **options) -> dict:
    key = (name, tuple(sorted(options.items())))
    if key not in REPORTS:
        model = load_model(CYCAB)
        columns = run(model, load_scenario(scenarios_dir() / f"cycab_{name}.json", model))
        meas = Measurements(name, columns["t"], {k: v for k, v in columns.items()})
        REPORTS[key] = diagnose(CYCAB, meas, Options(workers=2, seed=0, **options)).to_dict()
    return REPORTS[key]


def _fault(r, name):
    return next(f for f in r["diagnosis"]["faults"] if f["name"] == name)


@pytest.mark.slow
def test_a_late_residual_overturns_a_wrong_first_decision():
    # ARR1 touches its threshold once, at 49.2 s, for 0.04 s at 1.01 times it (3e-4 threshold-seconds):
    # with the paper's first-crossing rule (persistence 0) that touch is latched and decided again ...
    r = report("late_drift", persistence=0.0)
    assert r["detection"]["final_coherence"] == [0, 1, 0] and r["estimators"][0]["candidate"] == ["R4"]
    (episode,) = r["episodes"]
    assert episode["coherence"] == [1, 1, 0] and episode["time"] > 40
    assert r["winner"] == ["beta_theta1"]
    b1 = _fault(r, "beta_theta1")
    assert b1["type"] == "incipient" and b1["model"] == 1 and b1["b"][0] == pytest.approx(-0.05, rel=0.05)


def test_a_touch_of_a_threshold_is_not_latched():
    # ... while the default persistence (a quarter derivative window, 0.0625 threshold-seconds within a
    # span of four windows) asks for two hundred times that evidence: ARR1 never joins
    r = report("late_drift")
    assert r["detection"]["final_coherence"] == [0, 1, 0] and not r["episodes"]


@pytest.mark.slow
def test_a_slow_drift_seen_late_is_identified_with_the_leak():
    r = report("slow_drift")
    assert r["detection"]["final_coherence"] == [0, 1, 0]
    assert [e["coherence"] for e in r["episodes"]] == [[0, 1, 1]]
    assert sorted(r["winner"]) == ["R4", "beta_theta2"]
    r4, b2 = _fault(r, "R4"), _fault(r, "beta_theta2")
    assert r4["type"] == "abrupt" and r4["value"] == pytest.approx(2.5e7, rel=0.02)
    assert b2["type"] == "incipient" and b2["model"] == 2 and b2["b"][0] == pytest.approx(-0.008, rel=0.05)
    (p,) = r["prognosis"]
    # designed: 1/beta = 1 + 0.008 (t - 20) reaches 1/0.5 at t = 145 s
    assert p["eol"] == pytest.approx(145.0, rel=0.05)


@pytest.mark.slow
def test_a_second_fault_after_the_first_decision_is_found():
    r = report("second_fault")
    r4 = _fault(r, "R4")
    assert r4["type"] == "abrupt" and r4["value"] == pytest.approx(2.5e7, rel=0.02) and r4["t0"] < 16
    # Table I: R4 lights ARR2, beta_theta2 ARR2 and ARR3 (ARR1's spike as the leak opens, 0.1 s, is not
    # latched: fdi.detect's persistence)
    assert r["episodes"] and r["episodes"][-1]["coherence"] == [0, 1, 1]
    b2 = _fault(r, "beta_theta2")
    assert b2["type"] == "abrupt" and b2["value"] == pytest.approx(0.8, rel=0.02)
    assert b2["t0"] == pytest.approx(35.0, abs=0.3)          # its own onset, not the first fault's
    # {R4, beta_theta2} contains the known R4: fitted keeping R4 at its fit and afresh, and the
    # episode's estimators say which is which (a user trial read the two as a duplicate)
    twice = [e for e in r["episodes"][-1]["estimators"] if sorted(e["candidate"]) == ["R4", "beta_theta2"]]
    assert sorted(e["held"] or [] for e in twice) == [[], ["R4"]]


def test_a_later_decision_that_no_set_matches_tries_the_covering_sets_beside_the_known_one(monkeypatch):
    """A later coherence vector no candidate set matches exactly (a piezoelectric stack's capacitance
    drift lit a second residual its signature did not give it; the decision again crashed on no
    candidate): as at the first decision, the smallest sets covering it are fitted, with the known
    set refitted beside them, and the criterion chooses; with nothing to try, the diagnosis stands."""
    from types import SimpleNamespace

    import numpy as np

    from fdi import episodes
    from fdi.results import Estimate
    known = [{"name": "C0", "type": "incipient", "model": 1, "b": [-0.1], "t0": 0.5}]
    fits = {("n",): 40.0, ("C0",): 10.0}
    asked = []

    class Est:
        faults = {n: SimpleNamespace(effect="gain") for n in ("n", "C0")}      # (no stuck sensor among them)
        monitor = SimpleNamespace(config=SimpleNamespace(derivative_window=0.01), residuals=[0, 1, 2, 3],
                                  model=SimpleNamespace(faults=faults))

        def run(self, t, raw, start, span, candidates, *rest):
            asked.append(list(candidates))
            return [Estimate(c, fits[c], 1 / fits[c], (), None, ({**known[0], "name": c[0]},), 1, 0.0) for c in candidates]

    t = np.arange(0.0, 2.0, 1e-3)
    meas = SimpleNamespace(t=t, ts=1e-3)
    det = SimpleNamespace(time=0.8)
    monkeypatch.setattr(episodes, "candidate_sets", lambda fsm, coherence, exoneration, size: [])
    monkeypatch.setattr(episodes, "relaxed_sets", lambda fsm, coherence, size: [("n",)])
    o = SimpleNamespace(exoneration=True, max_set=3, seed=0)
    e = episodes.redecide(Est(), meas, {}, det, np.ones(4), o, None, known, 1.2, 1.3, (1, 0, 0, 1), 100, 1)
    assert asked == [[("n",), ("C0",)]] and e.winner == ("C0",) and len(e.estimates) == 2
    monkeypatch.setattr(episodes, "relaxed_sets", lambda fsm, coherence, size: [])
    o.exoneration = False                         # nothing to try: the known diagnosis stands, nothing fitted
    e = episodes.redecide(Est(), meas, {}, det, np.ones(4), o, None, known, 1.2, 1.3, (1, 0, 0, 1), 100, 2)
    assert len(asked) == 1 and e.winner == ("C0",) and e.faults == tuple(known) and e.estimates == ()
