"""A mode's command column read as 0/1: values in between or beyond are named (designed truth:
the rule is "1 from 0.5 up, 0 below", docs/model-format.md)."""
from __future__ import annotations

import numpy as np

from bondgraph.loader import load_model
from fdi.data import Measurements, signals_from_data
from fdi.pipeline import commands_read

from .conftest import ROOT

MODEL = load_model(ROOT / "models" / "two_tank_commanded.yaml")


def _record(v_cmd: np.ndarray) -> Measurements:
    t = np.arange(v_cmd.size) * 0.1
    cols = {"t": t, "Qin": np.full(t.size, 1e-4), "p1": np.full(t.size, 3e3), "p2": np.full(t.size, 2e3), "v_cmd": v_cmd}
    return Measurements("run.csv", t, cols)


def test_a_command_of_zeros_and_ones_says_nothing():
    assert commands_read(MODEL, _record(np.r_[np.ones(5), np.zeros(5)])) is None


def test_a_command_in_another_scale_is_named_with_how_it_is_read():
    meas = _record(np.r_[np.zeros(3), np.full(4, 2.0), np.full(3, 0.4)])
    note = commands_read(MODEL, meas)
    assert note.startswith("column v_cmd (mode v) holds values other than 0 and 1 (7 sample(s); at 0.3 s the first: 2)")
    assert signals_from_data(MODEL, meas)["v"].tolist() == [0, 0, 0, 1, 1, 1, 1, 0, 0, 0]     # 2 -> 1, 0.4 -> 0


def test_the_note_survives_a_fault_mode_that_explains_the_data():
    """The two-tank valve stuck open (the golden record) with its command logged as 2 for open: read
    as 1, the same diagnosis, a fault mode that explains the data; its note ("the fault mode explains
    the data ...") replaced the report's, and the column's went unsaid (a user trial's valve logged
    as -1 for open)."""
    from fdi.api import Options, diagnose
    from fdi.data import read_csv
    meas = read_csv(ROOT / "tests" / "golden" / "tank_stuck_open.csv.gz")
    cols = {**meas.columns, "v_cmd": 2.0 * np.asarray(meas.columns["v_cmd"])}
    r = diagnose(str(ROOT / "models" / "two_tank_commanded.yaml"), Measurements("run.csv", meas.t, cols),
                 Options(workers=1, seed=0)).to_dict()
    assert [f["name"] for f in r["diagnosis"]["faults"]] == ["v_open"] and r["estimators"] == []
    assert "column v_cmd (mode v) holds values other than 0 and 1" in r["note"]
    assert "the fault mode explains the data" in r["note"]
