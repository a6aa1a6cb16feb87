"""Nothing a user sees changes when the house is rebuilt (issue 21): every front door of a
diagnosis (the CLI's JSON, the API with the model as a path, as YAML text and as a Model object,
a fleet, the streaming monitor's events, the demo) prints what it
printed before the restructuring (every key, string and flag; every real to round-off, 1e-9 of
its value, since a matrix product need not sum in the same order on every CPU), on the four reference files of the paper's CyCab and a model
of each kind (tests/golden/cases.py; the API given the model as text or as an object on two of
them: past reading the model it is the API given its path). The expected texts were recorded once, before the change,
by tests/golden/make.py; a deliberate change of a report regenerates them in its own commit,
which says why.

One change was made on purpose in issue 21: a report has every top-level key, always, in one
order, null where the diagnosis did not reach it (a nominal report had 6 keys, a fault report
10-13). :func:`laid_out` applies exactly that change to the recorded text and nothing else, so the
comparison stays character for character.

One more in issue 25: the monitor identifies in a worker, and its decision and prognosis events
say how long that took (``identification_s``, wall-clock seconds: never the same twice).
:func:`timed` checks that key on those events, a real >= 0, and takes it out of the output before
the comparison; any other new or changed key still fails it."""
from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from .conftest import ROOT
from .golden.cases import CASES, data_file, model_path
from .golden.doors import DOORS

EXPECTED = json.loads((ROOT / "tests" / "golden" / "expected.json").read_text(encoding="utf-8"))

# The report's keys in the order of docs/report.schema.json
KEYS = ("detection", "mode", "candidates", "estimators", "diagnosis", "prognosis", "note", "weakly_detectable",
        "pruned", "suspected_mode_changes", "mode_estimate", "mode_costs", "mode_fault_cost", "exoneration_relaxed",
        "alternatives", "winner", "episodes", "window", "insignificant")


def _report(old: dict, lead: str | None = None) -> dict:
    head = {lead: old[lead]} if lead else {}
    rest = {k: v for k, v in old.items() if k != lead}
    assert set(rest) <= set(KEYS), set(rest) - set(KEYS)
    return {**head, **{k: rest.get(k) for k in KEYS}}


def laid_out(text: str, door: str) -> str:
    """A recorded output with its report(s) in the layout of issue 21 (every key, in order)."""
    if door == "monitor":
        events = [json.loads(line) for line in text.splitlines()]
        return "".join(json.dumps(_report(e, "event") if e["event"] == "summary" else e, default=float) + "\n"
                       for e in events)
    old = json.loads(text)
    report = _report({k: v for k, v in old.items() if k != "error"} if door == "fleet" else old,
                     "file" if door == "fleet" else None)
    if door == "fleet":                       # issue 25: every fleet line has ``error`` (null), after ``file``
        report = {"file": report["file"], "error": old.get("error"), **{k: v for k, v in report.items() if k != "file"}}
    return json.dumps(report, indent=1, default=float) + "\n"


SLOW_CASES = {"boost_rL"}       # 2 to 37 s a door (--durations): left out by -m "not slow"


TIMED = ("decision", "prognosis")      # the events of an identification (issue 25)


def timed(text: str, door: str) -> str:
    """The monitor's output without the ``identification_s`` of its decision and prognosis events
    (checked there: a real >= 0), in the CLI's layout; any other door's output as it is."""
    if door != "monitor":
        return text
    out = []
    for line in text.splitlines():
        e = json.loads(line)
        if e["event"] in TIMED:
            seconds = e.pop("identification_s")
            assert isinstance(seconds, float) and seconds >= 0, (e["event"], seconds)
        out.append(json.dumps(e, default=float) + "\n")
    return "".join(out)


RTOL = 1e-9     # round-off: a matrix product need not sum in the same order on every CPU and BLAS


def close(got, want, where: str = "") -> None:
    """``got`` equals ``want`` in every key, string, integer and flag, and every real to round-off
    (RTOL of its value): what a user reads is the same, whatever order the machine's BLAS sums in."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and list(got) == list(want), (where, got, want)
        for k in want:
            close(got[k], want[k], f"{where}.{k}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), (where, got, want)
        for i, (g, w) in enumerate(zip(got, want)):
            close(g, w, f"{where}[{i}]")
    elif isinstance(want, float) and not isinstance(want, bool):
        assert isinstance(got, (int, float)) and not isinstance(got, bool), (where, got, want)
        assert got == pytest.approx(want, rel=RTOL, abs=1e-300, nan_ok=True), (where, got, want)
    else:
        assert type(got) is type(want) and got == want, (where, got, want)


def same_text(got: str, want: str) -> None:
    """A report (JSON) or the monitor's events (JSON lines) as :func:`close` compares them; the
    layout (keys' order, indentation, line ends) character for character."""
    def parse(text):
        try:
            return [json.loads(text)]
        except json.JSONDecodeError:
            return [json.loads(line) for line in text.splitlines()]
    g, w = parse(got), parse(want)
    close(g, w)
    strip = lambda text: re.sub(r"-?\d[\d.eE+-]*", "0", text)      # the layout around the numbers
    assert strip(got) == strip(want)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("golden")


@pytest.mark.parametrize("case, door", [pytest.param(c, d, marks=[pytest.mark.slow] if c.name in SLOW_CASES else [])
                                         for c in CASES for d in c.doors],
                         ids=[f"{c.name}-{d}" for c in CASES for d in c.doors])
def test_every_front_door_prints_what_it_printed_before(case, door, folder, monkeypatch):
    monkeypatch.chdir(ROOT)
    same_text(timed(DOORS[door](case, data_file(case, folder)), door), laid_out(EXPECTED[case.name][door], door))


@pytest.mark.slow
def test_the_installed_command_prints_the_same_report():
    """The console script in a fresh process (its own imports and derivation) gives the same bytes."""
    (case,) = [c for c in CASES if c.name == "cycab_scenario2"]
    out = subprocess.run([sys.executable, "-m", "fdi.app.cli", "diagnose", model_path(case), str(ROOT / case.data),
                          "--json", "-q"], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    same_text(out, laid_out(EXPECTED[case.name]["cli"], "cli"))
