"""Nothing a user sees changes when the house is rebuilt (issue 21): every front door of a
diagnosis (the CLI's JSON, the API with the model as a path, as YAML text and as a Model object,
a fleet, the streaming monitor's events, the demo) prints, character for character, what it
printed before the restructuring, on the four reference files of the paper's CyCab and a model
of each kind (tests/golden/cases.py). The expected texts were recorded once, before the change,
by tests/golden/make.py; a deliberate change of a report regenerates them in its own commit,
which says why."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from .conftest import ROOT
from .golden.cases import CASES, data_file, model_path
from .golden.doors import DOORS

EXPECTED = json.loads((ROOT / "tests" / "golden" / "expected.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("golden")


@pytest.mark.parametrize("case, door", [(c, d) for c in CASES for d in c.doors],
                         ids=[f"{c.name}-{d}" for c in CASES for d in c.doors])
def test_every_front_door_prints_what_it_printed_before(case, door, folder, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert DOORS[door](case, data_file(case, folder)) == EXPECTED[case.name][door]


def test_the_installed_command_prints_the_same_report():
    """The console script in a fresh process (its own imports and derivation) gives the same bytes."""
    (case,) = [c for c in CASES if c.name == "cycab_scenario2"]
    out = subprocess.run([sys.executable, "-m", "fdi.app.cli", "diagnose", model_path(case), str(ROOT / case.data),
                          "--json", "-q"], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out == EXPECTED[case.name]["cli"]
