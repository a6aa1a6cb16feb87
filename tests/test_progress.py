"""Issue 13: -q/-v through the ``bgfdi`` logger, and progress on a terminal (tqdm or the plain
bar) or in a log (every 10 % or 30 s, not every tick)."""
from __future__ import annotations

import io
import json
import re

import pytest

from fdi.app import progress as P
from fdi.app.cli import main

from .conftest import CYCAB


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def normal():
    P.configure(P.NORMAL)
    yield
    P.configure(P.NORMAL)


def test_off_a_terminal_a_line_per_ten_percent_not_per_tick(normal, capsys):
    clock = Clock()
    with P.Progress(200, "simulating", "s", tty=False, clock=clock) as bar:
        for k in range(1, 201):              # 200 ticks, half a second each: 100 s in all
            clock.now += 0.5
            bar(k)
    lines = capsys.readouterr().err.splitlines()
    assert [int(re.match(r"simulating: (\d+) %", x).group(1)) for x in lines] == list(range(10, 101, 10))
    assert lines[0] == "simulating: 10 % (20 of 200 s), 10 s elapsed, ETA 1 min 30 s"
    assert lines[-1] == "simulating: 100 % (200 of 200 s), 1 min 40 s elapsed"


def test_off_a_terminal_a_slow_task_says_something_every_30_s(normal, capsys):
    clock = Clock()
    bar = P.Progress(1000, "estimators", tty=False, clock=clock)
    for k in range(1, 21):                   # 20 ticks of 10 s: 2 % of the work in 200 s
        clock.now += 10.0
        bar.advance()
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 6 and all("ETA" in x for x in lines)          # at 30, 60, ... 180 s
    assert lines[0].startswith("estimators: 0 % (3 of 1000), 30 s elapsed, ETA 2 h 46 min")


def test_a_short_task_off_a_terminal_logs_nothing(normal, capsys):
    clock = Clock()
    with P.Progress(10, "x", tty=False, clock=clock) as bar:
        for k in range(1, 11):
            clock.now += 0.1
            bar(k)
    assert capsys.readouterr().err == ""


def test_the_plain_bar_on_a_terminal_has_the_same_numbers():
    clock = Clock()
    stream = io.StringIO()
    with P.Progress(4, "diagnosed", "files", stream=stream, tty=True, use_tqdm=False, clock=clock) as bar:
        for k in range(1, 5):
            clock.now += 3.0
            bar.advance()
    text = stream.getvalue()
    assert text.startswith("\r") and text.endswith("\n")
    frames = [f.removesuffix("\033[K") for f in text.strip().split("\r")]
    assert frames[-1] == "#" * 30 + " diagnosed: 100 % (4 of 4 files), 12 s elapsed"


def test_tqdm_on_a_terminal():
    pytest.importorskip("tqdm")
    stream = io.StringIO()
    with P.Progress(60.0, "simulating", "s", stream=stream, tty=True) as bar:
        assert bar.kind == "tqdm"
        for t in range(1, 61):
            bar(float(t))
    assert "simulating: 100%" in stream.getvalue() and "60/60 s" in stream.getvalue()


def test_without_tqdm_the_plain_bar(monkeypatch):
    monkeypatch.setattr(P, "_tqdm", lambda: None)
    assert P.Progress(1, "x", stream=io.StringIO(), tty=True).kind == "bar"


def test_quiet_means_no_progress(capsys):
    P.configure(P.QUIET)
    try:
        clock = Clock()
        bar = P.Progress(10, "x", tty=False, clock=clock)
        assert bar.kind == "off"
        clock.now = 100.0
        bar(10)
        assert P.Progress(10, "x", stream=io.StringIO(), tty=True).kind == "off"
    finally:
        P.configure(P.NORMAL)
    assert capsys.readouterr().err == ""


def test_steps_count_from_the_start_of_the_task(normal, capsys):
    clock = Clock()
    with P.Steps("estimators", tty=False, clock=clock) as tick:
        clock.now = 50.0                    # the first estimator takes 50 s
        tick(1, 2)
        clock.now = 100.0
        tick(2, 2)
    assert capsys.readouterr().err.splitlines() == ["estimators: 50 % (1 of 2), 50 s elapsed, ETA 50 s",
                                                    "estimators: 100 % (2 of 2), 1 min 40 s elapsed"]


# ------------------------------------------------------------------ -q and -v on the command line

def test_quiet_silences_notes_but_not_errors(tmp_path, capsys):
    scenario = tmp_path / "s.json"
    scenario.write_text(json.dumps({"seed": 1, "T": 1, "fs": 100}))
    assert main(["simulate", str(CYCAB), str(scenario), "-o", "-"]) == 0
    assert capsys.readouterr().err.startswith("wrote standard output: 101 samples")
    for argv in (["-q", "simulate", str(CYCAB), str(scenario), "-o", "-"],
                 ["simulate", str(CYCAB), str(scenario), "-o", "-", "--quiet"]):
        assert main(argv) == 0
        out, err = capsys.readouterr()
        assert err == "" and out.startswith("t,u_in,")
    assert main(["simulate", "-q", str(CYCAB), str(tmp_path / "none.json"), "-o", "-"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("bgfdi: error: ") and "none.json" in err


def test_verbose_adds_stage_timings(capsys):
    assert main(["check", str(CYCAB), "-v"]) == 0
    err = capsys.readouterr().err.splitlines()
    cache = [line for line in err if "compiled model of" in line]          # where the compiled model came from
    assert all("(cache off)" in line or "read from" not in line for line in cache)    # the tests run it off
    stages = [re.match(r"\[ *[\d.]+ s\] (.+): [\d.]+ s$", line).group(1) for line in err if line not in cache]
    assert stages == ["load", "diagnostic causality (SCAPH)", "residual selection (derivative causality)",
                      "noise predicted by mode", "time scales"]
    assert main(["-v", "tables", str(CYCAB), "--json"]) == 0
    assert "signature matrices (4 mode(s))" in capsys.readouterr().err


def test_quiet_and_verbose_together_are_refused(capsys):
    assert main(["check", str(CYCAB), "-q", "-v"]) == 2
    assert main(["-q", "check", str(CYCAB), "-v"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and all(line.startswith("bgfdi: error: ") for line in err)
    assert "-q and -v: give one of them" in err[1]


def test_every_command_takes_q_and_v():
    from fdi.app.cli import build_parser
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name, parser in sub.choices.items():
        flags = {s for a in parser._actions for s in a.option_strings}
        assert {"-q", "--quiet", "-v", "--verbose"} <= flags, name
