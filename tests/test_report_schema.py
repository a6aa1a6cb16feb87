"""The report's JSON Schema (docs/report.schema.json) holds every report, is not vacuous, and its
key order is the one every front door prints. Validated by jsonschema, the reference validator
of the JSON Schema specification, not by bgfdi's own code."""
from __future__ import annotations

import copy
import json

import jsonschema
import pytest

from fdi.api import diagnose
from fdi.results import REPORT_KEYS

from .conftest import ROOT
from .test_golden import EXPECTED, laid_out

SCHEMA = json.loads((ROOT / "docs" / "report.schema.json").read_text(encoding="utf-8"))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)


def test_the_schema_is_a_valid_json_schema():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_every_recorded_report_is_valid(case):
    for door, text in EXPECTED[case].items():
        if door in ("cli", "demo", "fleet"):
            VALIDATOR.validate(json.loads(laid_out(text, door)))


def test_a_report_with_timings_is_valid_and_keeps_the_key_order():
    report = diagnose(ROOT / "models" / "cycab_steering.yaml", ROOT / "models/data/cycab/scenario3.csv").to_dict(
        timings=True)
    VALIDATOR.validate(report)
    assert [k for k in report if k != "timings"] == list(REPORT_KEYS) == SCHEMA["required"]


def test_a_report_missing_a_key_or_with_an_unknown_fault_type_is_refused():
    good = json.loads(laid_out(EXPECTED["cycab_scenario2"]["cli"], "cli"))
    missing = {k: v for k, v in good.items() if k != "window"}
    wrong = copy.deepcopy(good)
    wrong["diagnosis"]["faults"][0]["type"] = "sudden"
    lacking = copy.deepcopy(good)
    del lacking["diagnosis"]["faults"][1]["b"]           # an incipient fault without coefficients
    for bad in (missing, wrong, lacking):
        assert not VALIDATOR.is_valid(bad)


def test_fault_rows_have_one_shape_for_a_fleet():
    """One row per fault, the same keys on every row; a file without a fault still has its row.
    Scenario 2 of the paper: R4 abrupt and beta_theta2 incipient with its RUL (Table III)."""
    from fdi.results import ROW_KEYS, fault_rows
    reports = [{"file": case, **json.loads(laid_out(EXPECTED[case]["cli"], "cli"))}
               for case in ("cycab_nominal", "cycab_scenario2")]
    rows = fault_rows(reports)
    assert all(tuple(r) == ROW_KEYS for r in rows)
    assert [(r["file"], r["fault"], r["type"]) for r in rows] == [
        ("cycab_nominal", None, None), ("cycab_scenario2", "R4", "abrupt"),
        ("cycab_scenario2", "beta_theta2", "incipient")]
    assert rows[1]["rul"] is None and rows[2]["rul"] > 0 and rows[2]["model"] in (1, 2, 3, 4)


def test_fleet_lines_good_and_failed_hold_the_same_keys_and_are_valid():
    """Issue 25: every fleet line has ``file``, ``error`` and every report key; a failed line has
    its error and nulls, and nulls are refused where a file was diagnosed."""
    from fdi.app.fleet import line
    good = json.loads(laid_out(EXPECTED["cycab_scenario2"]["cli"], "cli"))
    ok, failed = line("a.csv", good), line("b.csv", error="b.csv: cannot read (No such file or directory)")
    assert list(ok) == list(failed) == ["file", "error", *REPORT_KEYS]
    VALIDATOR.validate(ok)
    VALIDATOR.validate(failed)
    assert not VALIDATOR.is_valid({**ok, "diagnosis": None})                 # a diagnosed file has its diagnosis
    assert not VALIDATOR.is_valid({**failed, "mode": {}})                    # a failed file has nothing else


def test_a_nominal_and_a_faulty_report_have_the_same_keys():
    """docs/cli.md: a key that does not apply is null, never missing (issue 25: nominal reports had
    6 keys, fault reports 10 to 13)."""
    from fdi.results import Diagnosis, Fault, Prognosis
    nominal = Diagnosis(model="m", mode={}).to_dict()
    faulty = Diagnosis(model="m", mode={"a1": 1}, faults=(Fault("R4", "abrupt", value=2.5e7, t0=32.0),),
                       prognosis=(Prognosis("R4", 1e9, 65.0, 23.0, 42.0, 22.0, 24.0),)).to_dict()
    assert list(nominal) == list(faulty) == SCHEMA["required"]
    VALIDATOR.validate(nominal)


def test_an_alternative_with_a_lower_criterion_reads_as_a_tie():
    """Schwarz's criterion within 2 is no preference (fdi.decide.NO_PREFERENCE) and the smaller set
    wins: an alternative 1.6 lower is printed with its sign and why it did not win (it read
    'criterion +-1.60': a two-compartment pharmacokinetic model's clearance drift beside a pump
    fault, written for the review)."""
    from fdi.app.report import to_text
    fault = {"name": "a", "type": "abrupt", "value": 2.0, "t0": 1.0}
    report = {"detection": {"time": 1.0, "alarm": 1.0, "coherence": [1, 0], "decision_time": 2.0,
                            "final_coherence": [1, 0]},
              "mode": {}, "candidates": [["a"], ["a", "b"]], "diagnosis": {"faults": [fault]},
              "alternatives": [{"candidate": ["a", "b"], "cost": 10.0, "criterion": -1.6,
                                "faults": [fault, {"name": "b", "type": "abrupt", "value": 1.02, "t0": 1.0}]},
                               {"candidate": ["b"], "cost": 11.0, "criterion": 1.5, "faults": []}]}
    text = to_text(report, "m", "d")
    assert "(criterion -1.60: lower, but within 2 is a tie and the smaller set wins; cost 10)" in text
    assert "(criterion +1.50; cost 11)" in text and "+-" not in text


def test_a_failure_value_the_fit_never_reaches_is_said_in_the_text_report():
    """A drift fitted away from its failure value (eq. (16), b1 < 0, from a nominal 1.0 to a failure
    value of 2.0: P = exp(b1 tau) never reaches it; the end of life is infinite by the definition
    EOL = inf{t: P(t) reached the failure value} of fdi.prognose) whose RUL band's other models do
    reach it: the text report says so (it raised TypeError formatting the null RUL), with the band."""
    import math

    from fdi.app.report import to_text
    from fdi.prognose import prognose
    p = prognose({"name": "R1", "type": "incipient", "model": 1, "b": [-0.01], "t0": 10.0}, 1.0, 2.0, 20.0, 30.0)
    assert math.isinf(p["eol"])
    for eol, rul in ((p["eol"], p["rul"]), (None, None)):                # as computed, and as JSON gives it
        entry = {**p, "eol": eol, "rul": rul, "rul_low": 0.48, "rul_high": 996.6}
        detection = {"time": 20.0, "alarm": 20.0, "coherence": [1], "decision_time": 30.0, "final_coherence": [1]}
        text = to_text({"detection": detection, "diagnosis": {"faults": []}, "prognosis": [entry]}, "m", "d.csv")
        assert "R1 does not reach its failure value 2 on the fitted degradation" in text
        assert "0.48 to 996.60 s" in text
    # with the fit and the nominal value: why (b1 < 0 takes P = exp(b1 tau) down from 1.0, away from 2)
    fault = {"name": "R1", "type": "incipient", "model": 1, "eta": [0, 0], "b": [-0.01], "t0": 10.0}
    text = to_text({"detection": detection, "diagnosis": {"faults": [fault]}, "prognosis": [p]}, "m", "d.csv",
                   nominals={"R1": 1.0})
    assert ("R1 does not reach its failure value 2 on the fitted degradation: the fitted drift moves it away from "
            "that value (down from 1, eq. (16), b = -0.01)") in text
    # a review's cases, each EOL = inf by fdi.prognose: eq. (16) never crosses 0; eq. (17) from 1 with b2 = 0.1
    # rises through its pole (1/P = 1 - 0.1 tau) and never comes back up to 0.5 from below; a negative start
    for model, b, start, failure, says in ((1, -0.1, 1.0, 0.0, "keeps it on its nominal value's side of 0 (1)"),
                                           (1, -0.1, 1.0, -0.5, "keeps it on its nominal value's side of 0 (1)"),
                                           (1, 0.1, -2.0, -1.0, "moves it away from that value (down from -2"),
                                           (2, 0.1, 1.0, 0.5, "moves it away from that value (up from 1, eq. (17)")):
        q = prognose({"name": "R1", "type": "incipient", "model": model, "b": [b], "t0": 10.0}, start, failure,
                     10.0, 30.0)
        assert math.isinf(q["eol"]), (model, b, start, failure)
        f = {**fault, "model": model, "b": [b]}
        text = to_text({"detection": detection, "diagnosis": {"faults": [f]}, "prognosis": [q]}, "m", "d.csv",
                       nominals={"R1": start})
        assert says in text, text


def test_the_fault_mode_estimators_line_says_when_it_is_not_the_diagnosis():
    """Two user trials read the fault-mode estimator's line as a mode fault found: a thermostat
    "th=0 fan=1 (a mode fault: fitness ...)" where a sensor offset won, and a brake supply's modes
    "g=0 a=commanded r=1", exactly as the data command them."""
    from fdi.app.report import to_text
    detection = {"time": 20.0, "alarm": 20.0, "coherence": [1, 0], "decision_time": 30.0, "final_coherence": [1, 1]}
    offset = {"name": "Te_offset", "type": "abrupt", "value": 3.0, "t0": 20.0}
    lost = {"detection": detection, "suspected_mode_changes": ["stat_closed"], "mode": {"th": 1, "fan": 1},
            "mode_estimate": {"th": 0, "fan": 1}, "mode_fault_cost": 5.9e4, "diagnosis": {"faults": [offset]}}
    assert "(a mode fault: fitness 1.695e-05, no parameter; not the diagnosis: the faults below fit better)" in \
        to_text(lost, "m", "d.csv")
    held = {"detection": detection, "suspected_mode_changes": ["g", "a"], "mode": {"g": 0, "a": 0, "r": 1},
            "mode_estimate": {"g": 0, "a": "commanded", "r": 1}, "mode_fault_cost": None,
            "diagnosis": {"faults": [offset]}}
    assert "fault-mode estimator: g=0 a=commanded r=1 (the modes the data give: no mode fault)" in \
        to_text(held, "m", "d.csv")
    nothing = {**lost, "diagnosis": {"faults": []}}                 # nothing kept: no "faults below" to point at
    assert "(a mode fault: fitness 1.695e-05, no parameter; not kept)" in to_text(nothing, "m", "d.csv")


def test_a_mode_change_the_model_declares_no_fault_for_says_so():
    """A water heater's draw (an autonomous mode, tap, on the condition qm - 0.01 > 0; no fault
    declared on it) with the flow logged in L/min: the fault-mode estimator's tap = 0 won, and the
    diagnosis read "tap: fault mode (tap = 0)" as if the model named such a fault (a user trial)."""
    from fdi.app.report import to_text
    detection = {"time": 20.0, "alarm": 20.0, "coherence": [1, 0], "decision_time": 30.0, "final_coherence": [1, 0]}
    report = {"detection": detection, "mode": {"s": 0, "tap": 0},
              "diagnosis": {"faults": [{"name": "tap", "type": "mode", "value": 0, "t0": 20.0}]}}
    declared = {"relay_off": "s"}                       # the model's one mode fault, on another variable
    text = to_text(report, "m", "d.csv", declared, autonomous={"tap"})
    assert "tap: fault mode (tap = 0)" in text
    assert "(not one of the model's faults: the data fit tap = 0 better than the mode its condition gives" in text
    relay = {**report, "diagnosis": {"faults": [{"name": "relay_off", "type": "mode", "value": 0, "t0": 20.0}]}}
    assert "not one of the model's faults" not in to_text(relay, "m", "d.csv", declared, autonomous={"tap"})
    s = {**report, "diagnosis": {"faults": [{"name": "s", "type": "mode", "value": 1, "t0": 20.0}]}}
    assert "better than its command: a switch that did not follow it" in to_text(s, "m", "d.csv", declared,
                                                                                autonomous={"tap"})
