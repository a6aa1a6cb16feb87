"""Tables (issue 25): ``Diagnosis.residuals_frame()`` (one row per sample), ``faults_frame()``
(one row per fault), a fleet as one DataFrame and as Parquet, fleet JSON lines with every key.
Expectations are built by hand (a Diagnosis made of known arrays and faults) or read back with
pandas/pyarrow, not taken from an earlier run."""
from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from fdi.app.cli import main
from fdi.results import REPORT_KEYS, Diagnosis, Fault, Prognosis

from .conftest import CYCAB, DATA

pd = pytest.importorskip("pandas")


def _diagnosis() -> Diagnosis:
    t = np.arange(5) * 0.1
    residuals = np.array([[0.0, 0.5, 2.0, -3.0, np.nan], [1e-6, -2e-6, 3e-6, 0.0, 0.0]])
    return Diagnosis(model="m", mode={}, faults=(Fault("R4", "abrupt", value=2.5e7, t0=32.0),
                                                 Fault("beta", "incipient", model=2, eta=(), b=(-0.03,), t0=32.0)),
                     prognosis=(Prognosis("beta", 0.5, 65.3, 23.3, 42.0, 22.9, 23.8),),
                     t=t, residuals=residuals, thresholds=np.array([1.0, 2.5e-6]), names=("ARR1", "ARR2"),
                     units=("N*m", "m^3/s"))


def test_residuals_frame_has_one_row_per_sample():
    frame = _diagnosis().residuals_frame()
    assert list(frame.columns) == ["t", "ARR1", "ARR2", "ARR1_threshold", "ARR2_threshold", "ARR1_above", "ARR2_above"]
    assert frame["t"].tolist() == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    assert frame["ARR1"].tolist()[:4] == [0.0, 0.5, 2.0, -3.0] and np.isnan(frame["ARR1"].iloc[4])
    assert (frame["ARR2_threshold"] == 2.5e-6).all()
    assert frame["ARR1_above"].tolist() == [False, False, True, True, False]      # |r| > 1; NaN is not above
    assert frame["ARR2_above"].tolist() == [False, False, True, False, False]
    assert frame.attrs["units"] == {"t": "s", "ARR1": "N*m", "ARR2": "m^3/s"}


def test_faults_frame_has_one_row_per_fault():
    frame = _diagnosis().faults_frame()
    assert frame["fault"].tolist() == ["R4", "beta"] and frame["type"].tolist() == ["abrupt", "incipient"]
    assert frame.loc[0, "value"] == 2.5e7 and frame.loc[1, "b"] == [-0.03]
    assert frame.loc[1, "rul"] == 23.3 and frame.loc[1, "rul_low"] == 22.9 and pd.isna(frame.loc[0, "rul"])
    assert "file" not in frame.columns
    empty = Diagnosis(model="m", mode={}).faults_frame()
    assert len(empty) == 0 and list(empty.columns) == list(frame.columns)
    assert len(_diagnosis().to_frame()) == 2 and "file" in _diagnosis().to_frame().columns    # kept as it was


def test_without_pandas_one_line_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    for method in ("residuals_frame", "faults_frame", "to_frame"):
        with pytest.raises(ImportError, match=r"pip install 'bgfdi\[pandas\]'"):
            getattr(_diagnosis(), method)()


@pytest.fixture
def bad(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,x\n0,1\n0.1,2\n")
    return path


def test_fleet_lines_have_every_key_and_the_fleet_is_one_parquet_table(tmp_path, bad, capsys):
    pytest.importorskip("pyarrow")
    nominal = str(DATA / "nominal.csv")
    assert main(["diagnose", str(CYCAB), nominal, str(bad), "-q", "--workers", "1"]) == 2
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert [list(x) for x in lines] == [["file", "error", *REPORT_KEYS]] * 2
    assert lines[0]["error"] is None and lines[0]["detection"] is None          # the nominal run: no alarm
    assert "missing column(s)" in lines[1]["error"] and all(lines[1][k] is None for k in REPORT_KEYS)
    out = tmp_path / "fleet.parquet"
    assert main(["diagnose", str(CYCAB), nominal, str(bad), "-o", str(out), "-q", "--workers", "1"]) == 2
    table = pd.read_parquet(out)
    assert table["file"].tolist() == [nominal, str(bad)]
    assert table["error"].isna().tolist() == [True, False] and table["fault"].isna().all()


def test_parquet_without_pyarrow_is_refused_before_any_work(tmp_path, monkeypatch, capsys):
    from fdi.app import fleet
    monkeypatch.setattr(fleet, "have_parquet", lambda: False)
    out = tmp_path / "f.parquet"
    assert main(["diagnose", str(CYCAB), str(DATA / "nominal.csv"), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'bgfdi[parquet]'" in err[0] and not out.exists()


def test_a_fleet_of_reports_is_one_dataframe():
    from fdi.app.fleet import line, to_table
    lines = [line("a.csv", _diagnosis().to_dict()), line("b.csv", error="b.csv: cannot read")]
    table = to_table(lines)
    assert table["file"].tolist() == ["a.csv", "a.csv", "b.csv"]
    assert table["fault"].tolist()[:2] == ["R4", "beta"] and table["error"].tolist()[2] == "b.csv: cannot read"
