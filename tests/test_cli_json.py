"""Issue 13: ``--json`` of check, tables, simulate and every bench, read back and checked against
facts that do not come from the JSON code (the paper's Fig. 2 and Tables I-II, the scenario file,
the CSV written, the text report)."""
from __future__ import annotations

import csv
import json
import re
import shutil

import pytest

from fdi.app.cli import main

from .conftest import CYCAB, MODELS
from .test_signatures import TABLE_I, TABLE_II


def _json(capsys, argv: list[str]) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


# ------------------------------------------------------------------ check

@pytest.fixture(scope="module")
def check_json():
    import contextlib
    import io
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["check", str(CYCAB), "--json", "-q"]) == 0
    return json.loads(out.getvalue())


def test_check_json_has_the_sensors_modes_and_residuals_of_the_paper(check_json):
    d = check_json
    assert d["model"] == "cycab_steering" and d["file"] == str(CYCAB)
    # two encoders (flow detectors: the angles are integrated flows) and the pressure difference
    assert [(s["name"], s["kind"], s["junction"]) for s in d["sensors"]] == [
        ("theta1", "Df", "J_13"), ("dp", "De", "J_01"), ("theta2", "Df", "J_15")]
    assert [(m["name"], m["nominal"]) for m in d["modes"]] == [("a1", 1), ("a2", 1)]
    # eqs. (5), (9), (13): one AGARR per sensor, at its junction, from SCAPH
    residuals = dict(d["residuals"])
    noise = residuals.pop("noise")      # one operating mode (a1, a2 change only by a fault): one prediction each
    assert noise["derivative_window"] == d["monitor"]["derivative_window"]
    assert {k: len(v) for k, v in noise["by_residual"].items()} == {"ARR1": 1, "ARR2": 1, "ARR3": 1}
    assert residuals == {"causality": "derivative", "from_structure": False, "msos": None, "notes": [],
                              "arrs": [{"name": "ARR1", "origin": "SCAPH", "sensor": "theta1", "junction": "J_13"},
                                       {"name": "ARR2", "origin": "SCAPH", "sensor": "dp", "junction": "J_01"},
                                       {"name": "ARR3", "origin": "SCAPH", "sensor": "theta2", "junction": "J_15"}]}
    assert {f["name"] for f in d["faults"]} >= set(TABLE_I) | set(TABLE_II)


def test_check_json_has_the_monitor_settings_of_the_file(check_json):
    m = check_json["monitor"]
    assert m["thresholds"] == {"ARR1": 1.0, "ARR2": 5.5e-6, "ARR3": 15.0}
    assert (m["waiting_time"], m["samples"], m["derivative_window"]) == (5.0, 1000, 0.25)
    assert m["faults"]["beta_theta2"] == {"bounds": [0.0, 1.5], "failure": 0.5}     # the encoder fails at 0.5


def test_check_json_gives_the_causality_of_fig_2(check_json):
    diag = check_json["diagnosis"]
    assert diag["ok"] and diag["problems"] == [] and diag["loops"] == [] and diag["modes_checked"] == 4
    # every storage element in derivative causality (the DHBG of Fig. 2)
    assert diag["storage"] == {"I_J1": "derivative", "I_J2": "derivative", "I_J3": "derivative"}
    # the leakage R4 in conductance causality: f19 = sign(dp) sqrt|dp| / R4, eq. (1)
    assert diag["resistors"]["R_R4"] == "conductance"
    # the strong bonds of the causal paths of eqs. (3), (4), (7), (12); sensors impose their variable
    assert {k: diag["strong"][k] for k in ("J_motor", "J_pump", "J_wheel", "sw_a1", "sw_a2", "J_13", "J_01", "J_15")} \
        == {"J_motor": 9, "J_pump": 14, "J_wheel": 26, "sw_a1": 3, "sw_a2": 13,
            "J_13": "theta1", "J_01": "dp", "J_15": "theta2"}
    bonds = {b["bond"]: b for b in diag["bonds"]}
    # inverted sensors: an encoder gives its flow to the junction, the pressure sensor its effort
    assert bonds["theta1"]["flow_to"] == "J_13" and bonds["dp"]["effort_to"] == "J_01"
    assert all(b["signal"] == isinstance(b["bond"], str) for b in diag["bonds"])
    # the strong bond of a 1 junction brings the flow into it; of a 0 junction the effort
    for j, bond in (("J_motor", 9), ("J_pump", 14), ("J_wheel", 26)):
        assert bonds[bond]["flow_to"] == j
    # simulation: integral causality but for the pump rotor, a dependent inertia
    assert check_json["simulation"]["storage"] == {"I_J1": "integral", "I_J2": "derivative", "I_J3": "integral"}


def test_check_json_says_what_the_text_report_says(check_json, capsys):
    assert main(["check", str(CYCAB)]) == 0
    text = capsys.readouterr().out
    strokes = dict(re.findall(r"^\s+(\w+)\s+\S+ -> \S+\s+stroke at (\S+)", text, re.M))
    assert strokes == {str(b["bond"]): b["effort_to"] for b in check_json["diagnosis"]["bonds"]}
    assert "residuals (derivative causality): ARR1 (SCAPH, theta1), ARR2 (SCAPH, dp), ARR3 (SCAPH, theta2)" in text


def test_check_json_of_a_model_without_scaph(capsys):
    d = _json(capsys, ["check", str(MODELS / "two_mass_spring_damper.yaml"), "--json"])
    assert not d["diagnosis"]["ok"] and d["residuals"]["from_structure"] and d["residuals"]["msos"] > 0
    assert d["residuals"]["arrs"] and all(a["origin"] == "MSO" for a in d["residuals"]["arrs"])


# ------------------------------------------------------------------ tables

def test_tables_json_is_tables_i_and_ii(capsys):
    d = _json(capsys, ["tables", str(CYCAB), "--json"])
    fsm = {tuple(sorted(f["mode"].items())): f for f in d["fsm"]}
    nominal = fsm[(("a1", 1), ("a2", 1))]
    assert nominal["columns"] == ["ARR1", "ARR2", "ARR3"]
    assert {r["fault"]: tuple(r["structural"]) for r in nominal["rows"]} == TABLE_I
    assert {r["mode_change"]: (tuple(r["signature"]), r["Db"], r["Ib"]) for r in d["mcsm"]["rows"]} == TABLE_II
    assert [a["name"] for a in d["arrs"]] == ["ARR1", "ARR2", "ARR3"] and len(d["fsm"]) == 4
    assert main(["tables", str(CYCAB), "--format", "json"]) == 0
    assert json.loads(capsys.readouterr().out) == d                      # --json is --format json


def test_tables_json_and_another_format_is_refused(capsys):
    assert main(["tables", str(CYCAB), "--json", "--format", "csv"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == "bgfdi: error: --json: contradicts --format csv; give one of them\n"


# ------------------------------------------------------------------ simulate

SCENARIO = {"seed": 5, "T": 3, "fs": 100, "faults": [{"target": "R4", "type": "abrupt", "t0": 1.5, "value": 2.5e7}]}


def test_simulate_json_describes_the_csv_it_wrote(tmp_path, capsys):
    scenario = tmp_path / "s.json"
    scenario.write_text(json.dumps(SCENARIO))
    data = tmp_path / "s.csv"
    d = _json(capsys, ["simulate", str(CYCAB), str(scenario), "-o", str(data), "--json", "--seed", "9"])
    with open(data, newline="") as fh:
        rows = list(csv.reader(fh))
    assert d["columns"] == rows[0] == ["t", "u_in", "theta1", "theta2", "p1", "p2"]
    assert d["samples"] == len(rows) - 1 == SCENARIO["T"] * SCENARIO["fs"] + 1
    assert d["t_start"] == float(rows[1][0]) == 0.0 and d["t_end"] == float(rows[-1][0]) == 3.0
    assert d["sampling_time"] == pytest.approx(0.01) and d["seed"] == 9 and d["method"] == "auto"
    assert d["output"] == str(data) and d["scenario"] == str(scenario) and d["plot"] is None
    fault = d["faults"][0]
    assert {k: fault[k] for k in ("target", "type", "t0", "value")} == SCENARIO["faults"][0]


def test_simulate_json_with_the_csv_on_standard_output_is_refused(tmp_path, capsys):
    scenario = tmp_path / "s.json"
    scenario.write_text(json.dumps(SCENARIO))
    assert main(["simulate", str(CYCAB), str(scenario), "-o", "-", "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("bgfdi: error: --json: standard output carries the CSV") and err.count("\n") == 1


# ------------------------------------------------------------------ bench

def _seconds(x) -> bool:
    return isinstance(x, float) and x >= 0.0


def test_bench_derive_json(capsys, monkeypatch):
    import fdi.app.bench as bench
    import fdi.app.resources as resources
    monkeypatch.setattr(resources, "shipped_models", lambda: [CYCAB])
    monkeypatch.setattr(bench, "TANK_SIZES", (3,))       # the 100-tank chain took 8 of this test's 15 s
    d = _json(capsys, ["bench", "derive", "--sizes", "5", "--json"])
    assert d["benchmark"] == "derive"
    cycab, chain = d["cases"]
    assert set(cycab) == set(chain) == {"case", "chain", "elements", "arrs", "arrs_s", "state_equations_s"}
    assert cycab["case"] == "cycab_steering" and cycab["arrs"] == 3 and not cycab["chain"]
    assert cycab["elements"] == 17 + 9                        # elements and junctions of the YAML
    assert cycab["state_equations_s"] is None and _seconds(cycab["arrs_s"])
    assert chain["case"] == "chain N=5" and chain["chain"] and _seconds(chain["state_equations_s"])
    assert d["mso"]["case"] == "cycab_steering" and d["mso"]["msos"] > 0 and _seconds(d["mso"]["search_s"])
    (tanks,) = d["tank_chains"]     # three tanks: the pump's fault, each tank's, valve's and sensor's
    assert (tanks["tanks"], tanks["faults"]) == (3, 1 + 3 * 3) and _seconds(tanks["tables_s"])
    assert tanks["arrs"] >= 3                                 # at least each tank's mass balance


def test_bench_simulate_json(capsys):
    d = _json(capsys, ["bench", "simulate", "--json"])
    assert d["benchmark"] == "simulate" and d["scenario"] == "cycab_scenario2.json" and d["duration"] == 60.0
    assert set(d["stages_cpu_s"]) == {"build", "integrate", "outputs", "sampling"}
    assert sum(d["stages_cpu_s"].values()) == pytest.approx(d["total_cpu_s"])
    # the independent plant timed in the same run (a stored figure was printed before): a 60 s run
    # takes it about a second, never nothing, never the whole minute
    assert 0.01 < d["reference_cpu_s"] < 60 and d["reference_cpu_s"] != 2.3


def test_bench_diagnose_json(capsys, monkeypatch):
    from functools import partial

    import fdi.app.bench as bench
    # one timed process, none to fill the caches first, and one probe of the compiled kernels: the
    # fields are tested, not the timing
    monkeypatch.setattr(bench, "process_costs", partial(bench.process_costs, repeat=1, fill=False))
    monkeypatch.setattr(bench, "jit_costs", partial(bench.jit_costs, probes=1))
    # one compiled path's start-up is probed (numba's import alone took 7 of this test's 43 s): the
    # fields are the same for every path
    import fdi.kernels as kernels
    monkeypatch.setattr(kernels, "available", lambda paths=kernels.available(): paths[:1])
    d = _json(capsys, ["bench", "diagnose", "--workers", "1", "--json"])
    assert d["benchmark"] == "diagnose" and (d["pop"], d["generations"], d["workers"]) == (100, 150, 1)
    # scenario 2's five candidate sets (README): {beta_theta2}, {R4, R5}, and the three pairs/triple with both
    assert d["estimators"] == 5 and d["evaluations"] > 5 * 100
    assert {"load", "residuals", "isolation", "identification"} <= set(d["stages_s"])
    assert all(_seconds(d[k]) for k in ("total_s", "estimator_s", "objective_s", "cpu_s"))
    assert d["kernels"] in ("c", "numba", "numpy")       # fdi.kernels: C or numba where the machine has them
    for name in ("full", "coarse"):                       # one objective call on 1 and on 100 rows
        c = d["objective"][name]
        assert c["call_100_s"] > c["call_1_s"] > 0 and c["per_row_s"] > 0
        assert abs(c["overhead_s"] + c["per_row_s"] - c["call_1_s"]) < 1e-12
    p = d["process"]                                      # a whole bgfdi diagnose process, as a user runs it
    assert p["runs"] == 1 and p["cache"] is True and _seconds(p["wall_s"]) and _seconds(p["cpu_s"])   # the session's own cache
    for path, j in (d["jit"] or {}).items():             # a fresh process loads the kept kernels of each path
        assert path in ("c", "numba")
        assert _seconds(j["import_s"]) and j["first_call_s"] > 0 and j["second_call_s"] > 0 and j["path"] == path


def test_bench_accuracy_json(capsys, monkeypatch, tmp_path):
    import fdi.app.resources as resources
    suite = tmp_path / "suite_two_tank_valve"
    suite.mkdir()
    shutil.copy(MODELS / "scenarios" / "suite_two_tank_valve" / "nominal.json", suite / "nominal.json")
    monkeypatch.setattr(resources, "scenarios_dir", lambda: tmp_path)
    d = _json(capsys, ["bench", "accuracy", "--workers", "1", "--json"])
    assert d["benchmark"] == "accuracy" and len(d["suites"]) == 1
    s = d["suites"][0]
    assert (s["suite"], s["model"]) == ("suite_two_tank_valve", "two_tank_valve")
    assert (s["summary"]["scenarios"], s["summary"]["nominal"], s["summary"]["false_alarms"]) == (1, 1, 0)
    assert s["scenarios"][0]["name"] == "nominal" and s["scenarios"][0]["found"] == []
    assert s["scenarios"][0]["detection"] is None


def test_check_json_gives_each_transformer_s_laws_as_fig_2_draws_it(check_json):
    """Fig. 2's TF k1 takes the motor's input current to the arm (e1 = k1 e2, f2 = k1 f1 from its first
    bond to its second, docs/model-format.md); the gyrator k2 crosses effort and flow."""
    ports = {p["name"]: p for p in check_json["two_ports"]}
    assert set(ports) == {"TF_k1", "GY_k2", "TF_k3", "TF_k4", "TF_k5", "TF_A", "MTF_F1", "MTF_F2"}
    assert ports["TF_k1"] == {"name": "TF_k1", "kind": "TF", "from": "MSf_uin", "to": "sw_a1",
                              "laws": ["e[1] = k1*e[2]", "f[2] = k1*f[1]"]}
    assert ports["GY_k2"]["laws"] == ["e[5] = k2*f[6]", "e[6] = k2*f[5]"]
    assert ports["TF_A"]["laws"] == ["e[21] = (1/A)*e[22]", "f[22] = (1/A)*f[21]"]
