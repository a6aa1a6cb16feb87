"""Fleets (issue 13): several files in one run, one JSON line each, in worker processes."""
from __future__ import annotations

import json

from fdi.app.cli import main

from .conftest import CYCAB, DATA

FILES = [str(DATA / f"{n}.csv") for n in ("nominal", "scenario1", "scenario2", "scenario3")]


def test_four_reference_files_in_two_jobs_give_their_single_reports(capsys, tmp_path):
    assert main(["diagnose", str(CYCAB), *FILES, "--jobs", "2", "--fail-on-fault"]) == 3    # faults found
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [line.pop("file") for line in lines] == FILES
    assert [line.pop("error") for line in lines] == [None] * len(FILES)      # every line has every key
    for path, line in zip(FILES, lines):
        assert main(["diagnose", str(CYCAB), path, "--json", "--workers", "1"]) == 0
        assert json.loads(capsys.readouterr().out) == line
    assert main(["diagnose", str(CYCAB), FILES[0], "--fail-on-fault", "--workers", "1"]) == 0   # nothing found


def test_a_bad_file_in_a_batch_is_its_own_line(capsys, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n0,1\n0.1,2\n")
    assert main(["diagnose", str(CYCAB), FILES[0], str(bad)]) == 2
    captured = capsys.readouterr()
    first, second = (json.loads(line) for line in captured.out.splitlines())
    assert first["detection"] is None and "missing column(s)" in second["error"]
    assert captured.err.count("bgfdi: error:") == 1
