"""The CSV reader's three paths read the same numbers and refuse the same files in the same words:
pandas' C parser (the ``pandas`` extra), numpy's parser for plain blocks, and the csv module with
Python's float for everything else. The reference is Python's own float() of each field's text."""
from __future__ import annotations

import re
import sys

import numpy as np
import pytest

from fdi.data import DataError, read_csv

HEADER = "t,u_in,theta1,theta2,p1,p2\n"


def _write(path, rows: list[str]) -> str:
    path.write_text(HEADER + "".join(r + "\n" for r in rows), encoding="utf-8")
    return str(path)


@pytest.fixture(params=["pandas", "numpy"])
def path_kind(request, monkeypatch):
    if request.param == "pandas":
        pytest.importorskip("pandas")
    else:
        monkeypatch.setitem(sys.modules, "pandas", None)      # import pandas fails: the plain-numpy path
    return request.param


def test_every_path_reads_python_floats(tmp_path, path_kind):
    rng = np.random.default_rng(5)
    values = rng.standard_normal((20_000, 5)) * 10.0 ** rng.integers(-300, 300, (20_000, 5))
    texts = [[f"{0.01 * i:.17g}"] + [repr(float(v)) for v in row] for i, row in enumerate(values)]
    got = read_csv(_write(tmp_path / "d.csv", [",".join(r) for r in texts]))
    for j, name in enumerate(HEADER.strip().split(",")):
        assert np.array_equal(got.columns[name], np.array([float(r[j]) for r in texts]))


@pytest.mark.parametrize("bad, words", [
    ("0.02,1,2,3,4", "rows do not all have 6 values: line 4 has 5 (cut short?); fix or remove it"),
    ("0.02,1,2,3,4,5,6", "rows do not all have 6 values: line 4 has 7"),
    ("0.02,1,,3,4,5", "row(s) with NaN, infinite or missing values, first at line 4"),
    ("0.02,1,x,3,4,5", "a value is not a number at line 4, column 'theta1'"),
    ("0.02,1,1e999,3,4,5", "row(s) with NaN, infinite or missing values, first at line 4"),
])
def test_every_path_refuses_in_the_same_words(tmp_path, path_kind, bad, words):
    rows = ["0,1,2,3,4,5", "0.01,1,2,3,4,5", bad, "0.03,1,2,3,4,5"]
    with pytest.raises(DataError, match=re.escape(words)):
        read_csv(_write(tmp_path / "d.csv", rows))


def test_a_number_only_python_reads_is_read_as_python_reads_it(tmp_path, path_kind):
    got = read_csv(_write(tmp_path / "d.csv", ["0,1_000,2,3,4,5", "0.01, 7 ,2,3,4,5", "0.02,1,2,3,4,5"]))
    assert got.columns["u_in"].tolist() == [1000.0, 7.0, 1.0]


@pytest.mark.parametrize("start, said", [(-1_000_000_005.0, "smallest -1000000005 s"),
                                         (1_000_000_005.0, "largest 1000000007 s")])
def test_time_stamps_beyond_a_billion_seconds_are_named_with_their_sign(tmp_path, path_kind, start, said):
    """Times of -1e9 s were refused as "beyond 1e+09 s (largest 1e+09)": rounded to read as within
    the bound, and "largest" of the most negative. The value is named whole, with its sign."""
    path = _write(tmp_path / "far.csv", [f"{start + k:.1f},1,2,3,4,5" for k in range(3)])
    with pytest.raises(DataError) as err:
        read_csv(path)
    assert "time values beyond +-1e+09 s" in str(err.value) and said in str(err.value)


def test_a_header_name_that_only_looks_like_the_models_is_named_with_its_character():
    """A trial's header wrote pressure A with a Cyrillic A: 'missing column pA; columns found: ...
    pА ...' printed two names that look the same. The message now names the character."""
    from bondgraph.loader import load_model
    from fdi.data import Measurements, check_against_model

    from .conftest import ROOT

    model = load_model(ROOT / "models" / "three_tank.yaml")      # columns t, q0, p1, q2
    cols = {c: np.zeros(3) for c in ("t", "q0", "\u04401", "q2")}   # p1 with a Cyrillic er
    with pytest.raises(DataError) as info:
        check_against_model(model, Measurements("x.csv", np.arange(3.0), cols))
    text = str(info.value)
    assert "'\u04401' looks like 'p1' ('\u0440' is U+0440 CYRILLIC SMALL LETTER ER): rename it in the header" in text


def test_a_comment_line_before_the_header_is_named_as_such(tmp_path, path_kind):
    """A trial's logger wrote '# recorded ...' first: 'no t column in the header (# recorded ...)'."""
    path = tmp_path / "d.csv"
    path.write_text("# recorded 2026-12-01 rig 3\n" + HEADER + "0,1,2,3,4,5\n", encoding="utf-8")
    with pytest.raises(DataError, match="the first line is a comment .*remove the comment lines"):
        read_csv(str(path))


def test_a_column_logged_far_coarser_than_its_declared_noise_is_noted():
    """A trial's pressure column rounded to three values (steps 520 times its declared noise) was
    calibrated into a threshold 90 times too large and diagnosed as a clogged port, with no word of
    the column. Both calibrate and diagnose read their runs through fdi.spikes.despiked, which now
    says so; a column quantised as its sensor declares is not noted."""
    from bondgraph.loader import load_model
    from fdi.data import Measurements
    from fdi.spikes import despiked

    from .conftest import ROOT

    model = load_model(ROOT / "models" / "three_tank.yaml")      # p1: noise 5 Pa; q2: 1e-8 m^3/s
    rng = np.random.default_rng(0)
    t = np.arange(2000) * 0.1
    p1 = 2.0e4 + 3.0e3 * np.sin(t / 10) + 5.0 * rng.standard_normal(t.size)
    cols = {"t": t, "q0": np.full(t.size, 1e-4), "p1": np.round(p1, -3), "q2": 1e-4 + 1e-8 * rng.standard_normal(t.size)}
    _, note = despiked(model, Measurements("x.csv", t, cols))
    assert note is not None and "p1 holds 7 distinct values in 2000 samples, in steps of 1000 Pa" in note
    assert "200 times its declared noise of 5 Pa" in note and "q2" not in note
    _, note = despiked(model, Measurements("x.csv", t, {**cols, "p1": p1}))
    assert note is None
