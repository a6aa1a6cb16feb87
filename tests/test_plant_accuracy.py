"""Diagnoses of runs of the independent CyCab reference plant (fdi/app/plant_cycab.py: the paper's
physics integrated with scipy, written apart from bgfdi's simulator and model file) whose truth the
paper's method alone misses; each truth is the run's design.

- An incremental-encoder gain beta_theta1 decaying as eq. (16) from 15 s moves ARR1 too little to
  fire it: the paper's structural exoneration leaves {R4}, which fits 30 times worse than noise;
  the sets a quiet residual could not have exonerated are tried and the truth wins.
- An absolute-encoder drift of eq. (19) from 20 s fires ARR2 at 25.8 s and ARR3 at 34 s: the
  re-decision fits the new candidate sets with onsets back before t_D, and beta_theta2 alone wins
  (fitted from t_D, {R4, R5, beta_theta2} won with beta_theta2 as eq. (17)).
"""
from __future__ import annotations

import math

import pytest

from fdi.api import Options, diagnose
from fdi.app import plant_cycab as pc
from fdi.app.plant_cycab import Event
from fdi.data import Measurements

from .conftest import CYCAB


def _run(events, seed, T=60.0):
    cols = pc.simulate(T, 100.0, events, seed=seed, theta2_0=-0.15)
    return Measurements("plant", cols["t"], cols)


def test_a_drift_that_cannot_fire_one_of_its_residuals_is_still_found():
    truth = Event("beta_theta1", "incipient", 15.0, model=1, b=(-0.05,))
    d = diagnose(CYCAB, _run([truth], seed=312), Options(workers=1))
    assert [f.name for f in d.faults] == ["beta_theta1"]
    (f,) = d.faults
    assert f.type == "incipient" and f.model == 1
    assert f.b[0] == pytest.approx(-0.05, rel=0.02)
    assert f.t0 == pytest.approx(15.0, abs=0.25)
    assert "nominal level" in d.note and d.isolation.weak == {"beta_theta1": ("ARR1",)}


@pytest.mark.slow
def test_a_drift_decided_again_when_its_second_residual_fires_keeps_its_early_onset():
    truth = Event("beta_theta2", "incipient", 20.0, model=4, b=(10.4, 0.002, -0.0045))
    d = diagnose(CYCAB, _run([truth], seed=328), Options(workers=1, failures={"beta_theta2": 0.5}))
    assert d.episodes and d.episodes[-1].coherence == (0, 1, 1)
    assert [f.name for f in d.faults] == ["beta_theta2"]
    (f,) = d.faults
    assert f.type == "incipient" and f.t0 < d.detection.time - 1.0      # before t_D = 25.8 s
    # the decision at 40.3 s (eq. 18 from 23.1 s: 13.9 s left, within Saxena's alpha-lambda at 0.2) is
    # refuted by the data after it (a lack of fit at 49.7 s) and decided again on the data from t_D:
    # eq. (19), the design's model, whose end of life has passed when that decision is given
    assert [e.cause for e in d.episodes] == ["coherence", "misfit"]
    assert f.model == 4
    eol = pc.end_of_life(truth, 0.5)                                      # 54.2 s, the plant's own profile
    (p,) = d.prognosis
    assert p.at > eol and p.rul == 0.0 and p.eol == pytest.approx(eol, abs=0.5)


def test_a_degradation_model_the_data_cannot_tell_apart_widens_the_rul_band():
    # eq. (17): 1/P = 1 + 0.03 (t - 32) reaches 0.5 at 32 + 100/3 s; eq. (16): P = exp(-0.02 (t - 32))
    # reaches it at 32 + ln 2 / 0.02 s; at 37 s the RULs are 28.333 and 29.657 s (by hand)
    from fdi.prognose import prognose
    fault = {"name": "beta", "model": 2, "b": [-0.03], "t0": 32.0,
             "other_models": [{"model": 1, "b": [-0.02], "t0": 32.0, "cost": 1.0}]}
    p = prognose(fault, 1.0, 0.5, tf=32.0, now=37.0)
    assert p["rul"] == pytest.approx(100 / 3 - 5, abs=1e-9)
    assert (p["rul_low"], p["rul_high"]) == pytest.approx((100 / 3 - 5, 50 * math.log(2) - 5), abs=1e-9)


def test_evaluate_tells_a_search_miss_from_data_that_do_not_prefer_the_design():
    """A leak R4 = 2.5e7 from 25 s on the plant: an answer equal to the design is 'data' (the
    design is not preferred over it), a wrong leak value (1e8) is 'search' (the design, which the
    data prefer by far, was missed)."""
    from fdi.app.evaluate import design_check
    from fdi.app.scenario import FaultEvent
    events = [FaultEvent("R4", "abrupt", 25.0, value=2.5e7)]
    meas = _run([Event("R4", "abrupt", 25.0, value=2.5e7)], seed=3, T=40.0)

    def report(value):
        return {"detection": {"time": 25.0}, "window": [25.0, 35.0],
                "diagnosis": {"faults": [{"name": "R4", "type": "abrupt", "value": value, "t0": 25.0}]}}
    same = design_check(str(CYCAB), meas, Options(workers=1), report(2.5e7), events)
    assert same["verdict"] == "data" and same["design_cost"] == pytest.approx(same["answer_cost"])
    wrong = design_check(str(CYCAB), meas, Options(workers=1), report(1e8), events)
    assert wrong["verdict"] == "search" and wrong["design_cost"] < wrong["answer_cost"]


def test_a_degradation_model_graded_on_its_refit_carries_the_refit_s_check():
    """The grade of an incipient fault's model is made on its refit at 90 % of life: when that grade
    fails, the scenario's refit_check is the check made on the refit's data (not the decision's), and
    the totals' line names its verdict. An eq. (19) design refitted as eq. (18), and as eq. (19)."""
    from bondgraph.loader import load_model
    from fdi.app.evaluate import Score, format_scores, regrade, summary
    from fdi.app.scenario import FaultEvent
    model = load_model(CYCAB)
    events = [FaultEvent("beta_dp", "incipient", 15.0, model=4, b=(10.0, 0.002, -0.0034), failure=0.5)]
    report = {"detection": {"time": 27.5}, "window": [27.5, 32.5],
              "diagnosis": {"faults": [{"name": "beta_dp", "type": "incipient", "model": 3, "b": [-45.0, -1.4],
                                        "t0": 18.7}]}}
    check = {"design_cost": 332.5, "answer_cost": 333.3, "criterion_difference": 4.3, "verdict": "data"}
    for refit_model, typed in ((3, False), (4, True)):
        s = Score("dp_incipient19", ["beta_dp"], ["beta_dp"], 27.5, 12.5, False, True, False)
        b = [-95.6, -2.0] if refit_model == 3 else [20.0, 0.0042, -0.0067]
        s.rul = [{"fault": "beta_dp", "fraction": 0.9, "t": 54.4, "true_rul": 4.4, "rul": 4.1, "error": -0.07,
                  "alpha_ok": True, "rul_low": 2.6, "rul_high": 5.7, "covered": True, "ra": None, "onset": 15.0,
                  "eol": 58.8, "model": refit_model, "b": b, "refit_t0": 19.7,
                  "refit_check": check if refit_model != 4 else None}]
        regrade(s, events, report, {}, 0.9, model)
        assert s.typed is typed and s.typed_at_decision is False
        assert s.refit_check == (None if typed else check)
    other = Score("other", ["R4"], ["R5"], 1.0, 0.1, False, False, False, design_check={**check, "verdict": "search"})
    assert "missed by the search" in format_scores([other], summary([other]))
    s.typed, s.refit_check = False, check
    assert "the data do not prefer the design" in format_scores([s], summary([s]))
    assert summary([s])["wrong"] == ["dp_incipient19"]


def test_the_rul_band_holds_each_plausible_fit_along_the_onset_and_each_other_models_region():
    # eq. (17) 1/P = 1 - b2 (t - t0) reaches 0.5 when b2 (t - t0) = -1: the fit (-0.03 from 32 s) at
    # 32 + 100/3 s; a plausible fit along the onset (-0.025 from 30 s) at 70 s; eq. (16) P = exp(b1 (t - t0))
    # reaches it at t0 + ln 2 / -b1: the other model's region b1 in [-0.021, -0.019] from 31-33 s spans
    # 31 + ln 2 / 0.021 to 33 + ln 2 / 0.019 s (by hand); RULs at 37 s
    from fdi.prognose import prognose
    fault = {"name": "beta", "model": 2, "b": [-0.03], "t0": 32.0,
             "onset_profile": [{"t0": 30.0, "b": [-0.025], "cost": 1.0}],
             "other_models": [{"model": 1, "b": [-0.02], "t0": 32.0, "cost": 1.0,
                               "b_band": [[-0.021, -0.019]], "t0_band": [31.0, 33.0]}]}
    p = prognose(fault, 1.0, 0.5, tf=32.0, now=37.0)
    assert p["rul"] == pytest.approx(100 / 3 - 5, abs=1e-9)
    assert p["rul_low"] == pytest.approx(31 + math.log(2) / 0.021 - 37, abs=1e-9)
    assert p["rul_high"] == pytest.approx(70.0 - 37.0, abs=1e-9)             # the onset profile's point
    del fault["onset_profile"]
    assert prognose(fault, 1.0, 0.5, tf=32.0, now=37.0)["rul_high"] == pytest.approx(
        33 + math.log(2) / 0.019 - 37, abs=1e-9)                               # the other model's region


@pytest.mark.slow
@pytest.mark.xfail(strict=False, reason=(
    "the search's miss on some machines (2026-11-29, AMD EPYC without AVX-512, numpy 2.4.6: fresh CI of "
    "main red): beta_dp typed abrupt 0.906 (cost 114) and R5 added (99.5) where the design costs 36; "
    "passes where the search's last bits take it to eq. (18) from 21.3 s (the stop note of 2026-11-29)"))
def test_a_second_order_drift_refitted_seconds_after_detection_has_its_true_rul_in_the_band():
    """An eq. (18) pressure-sensor drift from 20 s (b3 = -8, b4 = -1.1; beta_dp fails at 0.5, at
    34.7 s on the plant's own profile), its prognosis refreshed at 50 % of its life, 3 s after
    detection: the fit is a first-order model and eq. (18) is plausible from 21.3 s with b3 = -30
    (RUL 9.5 s for a true 7.3 s); the band reaches the truth through that model's plausible fits
    with earlier onsets (the band was 11.5-28.0 s)."""
    from fdi.monitor import compiled
    from fdi.pipeline import refresh_prognosis
    truth = Event("beta_dp", "incipient", 20.0, model=3, b=(-8.0, -1.1))
    eol = pc.end_of_life(truth, 0.5)
    at = 20.0 + 0.5 * (eol - 20.0)
    meas = _run([truth], seed=327, T=45.0)
    k = int((meas.t <= at).sum())
    prefix = Measurements("plant", meas.t[:k], {c: v[:k] for c, v in meas.columns.items()})
    o = Options(workers=1, failures={"beta_dp": 0.5})
    d = diagnose(CYCAB, prefix, o)
    assert [f.name for f in d.faults] == ["beta_dp"] and d.faults[0].type == "incipient"
    _, (p,) = refresh_prognosis(compiled(CYCAB), prefix, d, o)
    assert p.rul_low <= eol - p.at <= p.rul_high
