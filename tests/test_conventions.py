"""The command line's conventions (issue 25): ``-`` for standard input wherever a file is read,
shipped files by name (a path wins), ``python -m fdi``, ``fdi.__version__``, ``bgfdi`` alone
prints help, one ``--plot`` convention (a folder), ``graph --format``, ``-q`` silences notes,
``monitor --json`` refused, and a pyproject that setuptools installs without deprecations.
Each expectation comes from outside the code under test: the files' own bytes, pyproject.toml
read with tomllib, a fake ``dot`` that records how it was called."""
from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fdi.app.cli import main

ROOT = Path(__file__).resolve().parent.parent
TANK = ROOT / "models" / "two_tank_valve.yaml"
CYCAB = ROOT / "models" / "cycab_steering.yaml"
SCENARIO = '{"T": 2, "fs": 10, "faults": []}\n'


def _feed(monkeypatch, data: bytes) -> None:
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BufferedReader(io.BytesIO(data)), encoding="utf-8"))


def _run(argv: list, capsys) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def _one_line(err: str, *words: str) -> None:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])


# ------------------------------------------------------------------ standard input and shipped names

def test_check_reads_the_model_from_standard_input(monkeypatch, capsys):
    _feed(monkeypatch, TANK.read_bytes())
    code, out, _ = _run(["check", "-", "--json"], capsys)
    assert code == 0
    report = json.loads(out)
    assert report["model"] == "two_tank_valve" and report["file"] == "standard input"


def test_tables_from_standard_input_equal_the_files(monkeypatch, capsys):
    code, expected, _ = _run(["tables", TANK, "--format", "csv"], capsys)
    _feed(monkeypatch, TANK.read_bytes())
    code2, got, _ = _run(["tables", "-", "--format", "csv"], capsys)
    assert code == code2 == 0 and got == expected and got.startswith("table,")


def test_a_bad_model_on_standard_input_is_named_so(monkeypatch, capsys):
    _feed(monkeypatch, b"x: [\n")
    code, _, err = _run(["check", "-"], capsys)
    assert code == 2
    _one_line(err, "standard input", "YAML")
    assert "bgfdi-stdin" not in err


def test_simulate_reads_the_scenario_from_standard_input(monkeypatch, capsys, tmp_path):
    _feed(monkeypatch, SCENARIO.encode())
    out = tmp_path / "s.csv"
    code, _, err = _run(["-q", "simulate", TANK, "-", "-o", out], capsys)
    assert code == 0, err
    lines = out.read_text().splitlines()
    assert lines[0] == "t,Qin,p1,p2" and len(lines) == 1 + 21            # T = 2 s at 10 Hz, both ends


def test_diagnose_reads_the_data_from_standard_input(monkeypatch, capsys, tmp_path):
    data = tmp_path / "s.csv"
    (tmp_path / "sc.json").write_text('{"T": 10, "fs": 10, "faults": []}')
    assert _run(["-q", "simulate", TANK, tmp_path / "sc.json", "-o", data], capsys)[0] == 0
    code, expected, _ = _run(["diagnose", TANK, data, "--json"], capsys)
    _feed(monkeypatch, data.read_bytes())
    code2, got, err = _run(["diagnose", TANK, "-", "--json"], capsys)
    assert code == code2 == 0, err
    assert json.loads(got) == json.loads(expected)


def test_two_inputs_cannot_both_be_standard_input(monkeypatch, capsys):
    _feed(monkeypatch, SCENARIO.encode())
    code, _, err = _run(["simulate", "-", "-", "-o", "x.csv"], capsys)
    assert code == 2
    _one_line(err, "standard input is already", "the model")


def test_a_shipped_model_by_name(capsys):
    code, out, _ = _run(["check", "cycab_steering", "--json"], capsys)
    assert code == 0
    report = json.loads(out)
    assert report["model"] == "cycab_steering" and Path(report["file"]).read_bytes() == CYCAB.read_bytes()


def test_shipped_data_and_scenarios_by_name(capsys, tmp_path):
    from fdi.app.sources import Sources
    import argparse
    args = argparse.Namespace(command="diagnose", model="cycab_steering", data=["scenario2", "nominal.csv"])
    Sources().resolve(args)
    assert [Path(p).read_bytes() for p in args.data] == [
        (ROOT / "models/data/cycab/scenario2.csv").read_bytes(), (ROOT / "models/data/cycab/nominal.csv").read_bytes()]
    args = argparse.Namespace(command="simulate", model="cycab_steering", scenario="cycab_scenario2")
    Sources().resolve(args)
    assert Path(args.scenario).read_bytes() == (ROOT / "models/scenarios/cycab_scenario2.json").read_bytes()
    args = argparse.Namespace(command="evaluate", model="two_tank_valve", scenarios=["suite_two_tank_valve"])
    Sources().resolve(args)
    assert sorted(p.name for p in Path(args.scenarios[0]).iterdir()) == sorted(
        p.name for p in (ROOT / "models/scenarios/suite_two_tank_valve").iterdir())


def test_a_file_wins_over_a_shipped_name(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("cycab_steering").write_bytes(TANK.read_bytes())      # a file named like the shipped model
    code, out, _ = _run(["check", "cycab_steering", "--json"], capsys)
    assert code == 0 and json.loads(out)["model"] == "two_tank_valve"


def test_an_unknown_name_lists_the_shipped_models(capsys):
    code, _, err = _run(["check", "cycab_steerin"], capsys)
    assert code == 2
    _one_line(err, "cycab_steerin", "no such file", "cycab_steering", "three_tank")


# ------------------------------------------------------------------ the program

def test_python_m_fdi_and_the_version():
    tomllib = pytest.importorskip("tomllib")

    import fdi
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert fdi.__version__ == version
    done = subprocess.run([sys.executable, "-m", "fdi", "--version"], capture_output=True, text=True, timeout=60,
                          cwd=ROOT)
    assert done.returncode == 0 and done.stdout.strip() == f"bgfdi {version}"


def test_bgfdi_alone_prints_the_help(capsys):
    code, out, err = _run([], capsys)
    assert code == 0 and out.startswith("usage: bgfdi") and "diagnose" in out and err == ""


# ------------------------------------------------------------------ outputs

def test_plot_is_a_folder_in_simulate(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    (tmp_path / "sc.json").write_text(SCENARIO)
    code, out, err = _run(["simulate", TANK, tmp_path / "sc.json", "-o", tmp_path / "s.csv", "--plot",
                           tmp_path / "plots"], capsys)
    assert code == 0, err
    png = tmp_path / "plots" / "signals.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"plot: {png}" in out


def test_plot_names_a_folder_not_a_file(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    (tmp_path / "sc.json").write_text(SCENARIO)
    (tmp_path / "p.png").write_text("")
    for argv in (["simulate", TANK, tmp_path / "sc.json", "-o", tmp_path / "s.csv"],
                 ["evaluate", TANK, tmp_path / "sc.json"], ["diagnose", TANK, tmp_path / "s.csv"]):
        code, _, err = _run(argv + ["--plot", tmp_path / "p.png"], capsys)
        assert code == 2
        _one_line(err, "--plot", "is a file; name a folder")


def test_a_fleet_refuses_plot_rather_than_ignoring_it(capsys, tmp_path):
    code, out, err = _run(["diagnose", TANK, tmp_path / "a.csv", tmp_path / "b.csv", "--plot", tmp_path / "p"], capsys)
    assert code == 2 and out == ""
    _one_line(err, "--plot", "fleet")


def test_quiet_silences_every_note(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    (tmp_path / "sc.json").write_text(SCENARIO)
    code, out, err = _run(["simulate", "-q", TANK, tmp_path / "sc.json", "-o", tmp_path / "s.csv", "--plot",
                           tmp_path / "plots"], capsys)
    assert code == 0 and out == "" and err == ""
    assert (tmp_path / "plots" / "signals.png").is_file()


def test_monitor_refuses_json_and_plot(capsys, tmp_path):
    for option in (["--json"], ["--plot", tmp_path / "p"]):
        code, out, err = _run(["monitor", TANK, "-"] + option, capsys)
        assert code == 2 and out == ""
        _one_line(err, option[0], "monitor")


def test_graph_formats_without_dot(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    for argv in (["-o", tmp_path / "g.png"], ["--format", "svg"], ["--format", "pdf", "-o", tmp_path / "g.pdf"]):
        code, out, err = _run(["graph", TANK] + argv, capsys)
        assert code == 2 and out == ""
        _one_line(err, "Graphviz", "dot", "install")
    assert not (tmp_path / "g.png").exists()
    code, _, err = _run(["graph", TANK, "--format", "dot", "-o", tmp_path / "g.png"], capsys)
    assert code == 2 and not (tmp_path / "g.png").exists()
    _one_line(err, "--format dot", "g.png")
    assert _run(["graph", TANK, "-o", tmp_path / "g.gv"], capsys)[0] == 0
    assert (tmp_path / "g.gv").read_text().startswith("digraph")


def test_graph_renders_with_dot_when_present(capsys, tmp_path, monkeypatch):
    """A stand-in ``dot`` on PATH records its arguments and input and answers with fixed bytes."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "dot"
    fake.write_text(f"#!/bin/sh\necho \"$@\" > {tmp_path}/args\ncat > {tmp_path}/input\nprintf 'PNGBYTES'\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}")
    code, _, err = _run(["graph", TANK, "-o", tmp_path / "g.png"], capsys)
    assert code == 0, err
    assert (tmp_path / "g.png").read_bytes() == b"PNGBYTES"
    assert (tmp_path / "args").read_text().split() == ["-Tpng"]
    assert (tmp_path / "input").read_text().startswith("digraph")


def test_pyproject_has_no_deprecated_licence_metadata():
    """setuptools >= 77 warns about licence classifiers and a license table (PEP 639)."""
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert project["project"]["license"] == "BSD-3-Clause"
    assert not any(c.startswith("License ::") for c in project["project"]["classifiers"])
    assert (ROOT / project["project"]["license-files"][0]).is_file()
    floor = [r for r in project["build-system"]["requires"] if r.startswith("setuptools")][0]
    assert tuple(int(x) for x in floor.split(">=")[1].split(".")) >= (77,)


def test_the_eta_of_evaluate_weighs_each_scenario_by_its_samples(tmp_path, monkeypatch):
    """Two scenarios, 101 and 1001 samples (T fs + 1): after the short one the bar is 101/1102
    done, so the ETA is elapsed x 1001/101, not elapsed x 1 as a uniform rate per scenario says."""
    from fdi.app import cli, evaluate
    from fdi.app.progress import Progress
    (tmp_path / "a.json").write_text('{"T": 10, "fs": 10, "faults": []}')
    (tmp_path / "b.json").write_text('{"T": 100, "fs": 10, "faults": []}')
    now = [0.0]
    seen = []

    class Clocked(Progress):
        def __init__(self, total, label, unit="", **kw):
            super().__init__(total, label, unit, clock=lambda: now[0], tty=False)
            seen.append(self)

    def fake(model, path, options):
        now[0] += 1.0                       # each scenario "takes" 1 s of the fake clock
        return path.name

    monkeypatch.setattr(cli, "Progress", Clocked)
    monkeypatch.setattr(evaluate, "evaluate_scenario", fake)
    etas = []
    original = Clocked.advance

    def advance(self, n=1.0):
        original(self, n)
        etas.append((self.done, self.total, self.eta()))
    monkeypatch.setattr(Clocked, "advance", advance)
    files = [tmp_path / "a.json", tmp_path / "b.json"]
    assert cli._evaluate_files(str(TANK), files, None) == ["a.json", "b.json"]
    assert etas[0][:2] == (101.0, 1102.0) and etas[0][2] == pytest.approx(1001 / 101)


def test_slow_marker_is_registered_and_ci_runs_everything():
    tomllib = pytest.importorskip("tomllib")
    markers = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["markers"]
    assert any(m.startswith("slow:") for m in markers)
    ci = (ROOT / ".ci" / "run").read_text()
    assert "python -m pytest -q -n auto\n" in ci and "not slow" not in ci
    readme = (ROOT / "README.md").read_text()
    assert "python -m pytest -q -n auto  # the tests" in readme and '-m "not slow"' in readme


def test_an_unreadable_standard_input_is_one_line(capsys):
    """Under pytest, standard input cannot be read (its capture refuses): one line, exit 2."""
    code, _, err = _run(["check", "-"], capsys)
    assert code == 2
    _one_line(err, "-:", "standard input")


def test_a_plot_folder_whose_figure_is_the_output_is_refused(capsys, tmp_path):
    (tmp_path / "sc.json").write_text(SCENARIO)
    code, _, err = _run(["simulate", TANK, tmp_path / "sc.json", "-o", tmp_path / "signals.png", "--plot", tmp_path],
                        capsys)
    assert code == 2 and not (tmp_path / "signals.png").exists()
    _one_line(err, "--plot", "signals.png", "-o")


def test_standard_input_is_bounded_and_named_in_a_fleets_lines(monkeypatch, capsys, tmp_path):
    _feed(monkeypatch, b"a" * (2 << 20))
    code, _, err = _run(["check", "-"], capsys)
    assert code == 2
    _one_line(err, "standard input", "larger than 1 MB")
    _feed(monkeypatch, b"t,x\n0,1\n0.1,2\n")
    code, out, err = _run(["diagnose", TANK, tmp_path / "missing.csv", "-", "-q"], capsys)
    lines = [json.loads(x) for x in out.splitlines()]
    assert code == 2 and [x["file"] for x in lines] == [str(tmp_path / "missing.csv"), "standard input"]
    assert lines[1]["error"].startswith("standard input: missing column(s)") and "bgfdi-stdin" not in out + err


def test_binary_standard_input_is_refused_at_its_first_block(monkeypatch, capsys):
    """`head -c 1G /dev/zero | bgfdi diagnose MODEL -` copied the whole gigabyte to a temporary file
    before its first line was read: a NUL byte in the first block is refused at once."""
    class Endless:                          # /dev/zero: a read after the first fails the test
        reads = 0

        def read(self, n):
            Endless.reads += 1
            assert Endless.reads == 1, "read on past the first block"
            return b"\0" * n
    monkeypatch.setattr("sys.stdin", type("In", (), {"buffer": Endless(), "closed": False})())
    code, _, err = _run(["diagnose", TANK, "-"], capsys)
    assert code == 2
    _one_line(err, "standard input", "NUL byte at offset 0")


def test_gzip_and_utf16_standard_input_are_still_read(monkeypatch, capsys, tmp_path):
    """Their NUL bytes are the encodings' (the data reader decodes both): not refused as binary."""
    import gzip
    text = "t,Qin,p1,p2\n" + "".join(f"{0.1 * k:.1f},0,3000,2000\n" for k in range(5))
    for raw in (gzip.compress(text.encode()), text.encode("utf-16")):
        _feed(monkeypatch, raw)
        code, _, err = _run(["diagnose", TANK, "-", "-q"], capsys)
        assert "NUL byte" not in err
