"""Trust (issue 23): no planted file is read, no input is lost or damaged, inputs that cannot be
meant are refused in one line, and every input is read within bounded memory and time.

Each test builds its designed truth by hand: a planted file whose model would answer otherwise,
an output path that *is* an input, a header written twice, and so on."""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

from fdi.api import diagnose

from .conftest import MODELS

TANK = (MODELS / "two_tank_valve.yaml").read_text(encoding="utf-8")
QUIET = TANK.replace("thresholds: {ARR1: 1.0e-4, ARR2: 1.0e-4, ARR3: 1.5e-4}",
                     "thresholds: {ARR1: 1.0e3, ARR2: 1.0e3, ARR3: 1.0e3}")
LOUD = TANK.replace("thresholds: {ARR1: 1.0e-4, ARR2: 1.0e-4, ARR3: 1.5e-4}",
                    "thresholds: {ARR1: 1.0e-12, ARR2: 1.0e-12, ARR3: 1.0e-12}")


def tank_data() -> dict:
    """Constant pressures far from the tanks' equilibrium: every residual is about 1e-4 m^3/s."""
    t = np.arange(0, 200, 0.1)
    return {"t": t, "Qin": 1e-4 * (1 + 0.5 * np.sin(0.01 * t)), "p1": np.full_like(t, 5000.0),
            "p2": np.full_like(t, 2000.0)}


# ------------------------------------------------------------------ 1. no temporary file is trusted

def test_the_api_reads_no_planted_file_and_follows_no_planted_link(tmp_path, monkeypatch):
    """Earlier versions wrote YAML text to <tmp>/bgfdi-model-<sha256[:16]>.yaml and reused it when
    it existed. A file planted there (thresholds of 1e-12: everything detected) and a .tmp link to
    a victim file are both ignored: the text's own thresholds (1e3: nothing crosses) decide, the
    victim is untouched and nothing is written in the temporary folder."""
    shared = tmp_path / "shared"
    shared.mkdir()
    monkeypatch.setenv("TMPDIR", str(shared))
    monkeypatch.setattr(tempfile, "tempdir", str(shared))
    digest = hashlib.sha256(QUIET.encode("utf-8")).hexdigest()[:16]
    planted = shared / f"bgfdi-model-{digest}.yaml"
    planted.write_text(LOUD, encoding="utf-8")
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n", encoding="utf-8")
    os.symlink(victim, shared / f"bgfdi-model-{digest}.tmp")
    before = sorted(p.name for p in shared.iterdir())
    d = diagnose(QUIET, tank_data(), workers=1)
    assert d.detection is None                                    # the text's thresholds, not the planted file's
    assert victim.read_text(encoding="utf-8") == "precious\n"
    assert planted.read_text(encoding="utf-8") == LOUD
    assert sorted(p.name for p in shared.iterdir()) == before     # nothing written there


# ------------------------------------------------------------------ 2. never lose or damage a file

def _cli(argv: list[str], capsys) -> tuple[int, str]:
    from fdi.app.cli import main
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


def _one_line(err: str, *words: str) -> None:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])


@pytest.mark.parametrize("how", ["same", "dot", "link", "hardlink"])
def test_an_output_that_is_an_input_is_refused_and_the_input_kept(tmp_path, capsys, how):
    """``simulate M sc.json -o sc.json`` (also as ./sc.json, a link to it, a hard link): exit 2,
    one line, the scenario byte for byte as it was."""
    scenario = tmp_path / "sc.json"
    text = '{"T": 1, "fs": 100}\n'
    scenario.write_text(text, encoding="utf-8")
    out = {"same": scenario, "dot": tmp_path / "." / "sc.json", "link": tmp_path / "l.json",
           "hardlink": tmp_path / "h.json"}[how]
    if how == "link":
        out.symlink_to(scenario)
    if how == "hardlink":
        os.link(scenario, out)
    code, err = _cli(["simulate", MODELS / "cycab_steering.yaml", scenario, "-o", out], capsys)
    assert code == 2
    _one_line(err, "-o:", "is the input", "name another file")
    assert scenario.read_text(encoding="utf-8") == text


@pytest.mark.parametrize("argv", [
    ["diagnose", "{model}", "{data}", "-o", "{data}"],
    ["calibrate", "{model}", "{data}", "-o", "{model}"],
    ["monitor", "{model}", "{data}", "-o", "{data}"],
    ["tables", "{model}", "-o", "{model}"],
    ["evaluate", "{model}", "{suite}", "-o", "{suite}/s.json"],
    ["simulate", "{model}", "{suite}/s.json", "-o", "{suite}/s.json"],     # (--plot is a folder: tests/test_conventions.py)
])
def test_no_command_writes_over_what_it_reads(tmp_path, capsys, argv):
    model = tmp_path / "m.yaml"
    model.write_text(TANK, encoding="utf-8")
    data = tmp_path / "d.csv"
    data.write_text("t,Qin,p1,p2\n0,1e-4,0,0\n0.1,1e-4,0,0\n", encoding="utf-8")
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "s.json").write_text('{"T": 1, "fs": 10}\n', encoding="utf-8")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    args = [a.format(model=model, data=data, suite=suite) for a in argv]
    if "--plot" in args:
        pytest.importorskip("matplotlib")
    code, err = _cli(args, capsys)
    assert code == 2
    _one_line(err, "is the input")
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before


@pytest.mark.skipif(not hasattr(os, "lchown") or os.geteuid() != 0, reason="needs a link owned by another user")
def test_a_link_planted_by_another_user_in_a_sticky_folder_is_not_followed(tmp_path, capsys):
    """A world-writable sticky folder (as /tmp) with out.csv -> victim, the link owned by uid 4242:
    -o out.csv is refused before the work and write_atomic refuses it too; the victim is intact.
    A link of our own there is still followed (the link kept, its target replaced)."""
    from fdi.atomic import OutputError, write_atomic
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o1777)
    os.chown(shared, 4343, 4343)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n", encoding="utf-8")
    link = shared / "out.txt"
    link.symlink_to(victim)
    os.lchown(link, 4242, 4242)
    code, err = _cli(["tables", MODELS / "two_tank_valve.yaml", "-o", link], capsys)
    assert code == 2
    _one_line(err, "-o:", "owned by another user", "uid 4242")
    with pytest.raises(OutputError, match="not followed"):
        write_atomic(link, "x\n")
    assert victim.read_text(encoding="utf-8") == "precious\n" and link.is_symlink()
    os.lchown(link, os.geteuid(), os.getegid())                  # our own link: followed, kept
    write_atomic(link, "new\n")
    assert link.is_symlink() and victim.read_text(encoding="utf-8") == "new\n"


def test_a_link_another_user_owns_in_a_sticky_folder_is_not_followed_as_any_user(tmp_path, capsys, monkeypatch):
    """The same refusal without root (CI): a sticky, world-writable folder of our own with
    out.txt -> victim, and the link's owner, as the process sees it (lstat), uid 4242 — neither us
    nor the folder's owner, as a link another user planted in /tmp. -o is refused before the work,
    write_atomic refuses too, the victim is intact; seen as ours again, the link is followed."""
    from fdi.atomic import OutputError, write_atomic
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o1777)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n", encoding="utf-8")
    link = shared / "out.txt"
    link.symlink_to(victim)
    real_lstat = os.lstat
    stranger = 4242 if os.geteuid() != 4242 else 4243

    def lstat(path, *args, **kw):
        st = real_lstat(path, *args, **kw)
        if os.fspath(path) == os.fspath(link):             # the link, as planted by uid 4242
            fields = list(st[:10])
            fields[4] = stranger
            return os.stat_result(fields)
        return st
    monkeypatch.setattr(os, "lstat", lstat)
    code, err = _cli(["tables", MODELS / "two_tank_valve.yaml", "-o", link], capsys)
    assert code == 2
    _one_line(err, "-o:", "owned by another user", f"uid {stranger}")
    with pytest.raises(OutputError, match="not followed"):
        write_atomic(link, "x\n")
    assert victim.read_text(encoding="utf-8") == "precious\n" and link.is_symlink()
    monkeypatch.setattr(os, "lstat", real_lstat)                 # our own link: followed, kept
    write_atomic(link, "new\n")
    assert link.is_symlink() and victim.read_text(encoding="utf-8") == "new\n"


@pytest.fixture
def interactive_sigint():
    """SIGINT raising KeyboardInterrupt, as it does in a terminal: a test run started in the
    background (``pytest &``, nohup) inherits SIGINT ignored, and Python keeps it so."""
    import signal
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


@pytest.mark.parametrize("signum", ["SIGTERM", "SIGINT"])
def test_a_signal_during_a_write_leaves_the_old_file_and_no_partial_one(tmp_path, signum, interactive_sigint):
    """The signal arrives after half the pieces were written: the target keeps its old content,
    no hidden temporary file stays in the folder, and the signal ends the write (Terminated for
    SIGTERM, KeyboardInterrupt for SIGINT)."""
    import signal

    from fdi.atomic import Terminated, write_atomic
    target = tmp_path / "report.csv"
    target.write_text("old\n", encoding="utf-8")
    before = signal.getsignal(signal.SIGTERM)

    def pieces():
        for i in range(10):
            if i == 5:
                os.kill(os.getpid(), getattr(signal, signum))
            yield f"row {i}\n"
    with pytest.raises(Terminated if signum == "SIGTERM" else KeyboardInterrupt):
        write_atomic(target, pieces())
    assert target.read_text(encoding="utf-8") == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["report.csv"]
    assert signal.getsignal(signal.SIGTERM) == before               # the handler set back


@pytest.mark.parametrize("signum, code", [("SIGTERM", 143), ("SIGHUP", 129), ("SIGINT", 130)])
def test_a_signal_during_simulate_s_output_ends_the_command_and_keeps_the_old_file(tmp_path, capsys, monkeypatch,
                                                                                  signum, code, interactive_sigint):
    """``bgfdi simulate M sc.json -o out.csv`` signalled after the header and a block of rows
    went into the temporary file: exit 128 + the signal, one line, the old out.csv byte for byte,
    no .part left (the signal is sent from inside the CSV's pieces, so it lands mid-write)."""
    import signal

    from fdi.app import cli
    if not hasattr(signal, signum):
        pytest.skip(f"no {signum}")
    scenario = tmp_path / "sc.json"
    scenario.write_text('{"seed": 1, "T": 5, "fs": 100}', encoding="utf-8")
    out = tmp_path / "out.csv"
    out.write_text("old\n", encoding="utf-8")
    real = cli.write_atomic

    def signalled(path, content):
        def pieces():
            for i, piece in enumerate([content] if isinstance(content, (str, bytes)) else content):
                if i == 1:
                    os.kill(os.getpid(), getattr(signal, signum))
                yield piece
        return real(path, pieces())
    monkeypatch.setattr(cli, "write_atomic", signalled)
    rc, err = _cli(["simulate", MODELS / "two_tank_valve.yaml", scenario, "-o", out], capsys)
    assert rc == code
    assert "Traceback" not in err and ("interrupted" in err if signum == "SIGINT" else
                                       f"terminated by signal {getattr(signal, signum).value}" in err), err
    assert out.read_text(encoding="utf-8") == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "sc.json"]


def test_a_plot_folder_that_cannot_be_written_is_refused_before_the_work(tmp_path, capsys):
    """--plot into a folder where nothing can be created: refused at once, one line, exit 2 (for
    the superuser too: /proc takes no folder, whatever the permission bits say)."""
    pytest.importorskip("matplotlib")
    if os.geteuid() == 0:
        where = "/proc/bgfdi-plots"
    else:
        locked = tmp_path / "locked"
        locked.mkdir()
        os.chmod(locked, 0o555)
        where = str(locked / "plots")
    data = MODELS / "data" / "cycab" / "nominal.csv"
    code, err = _cli(["diagnose", MODELS / "cycab_steering.yaml", data, "--plot", where], capsys)
    assert code == 2
    _one_line(err, "--plot:", "cannot create folder")


# ------------------------------------------------------------------ 3. inputs that cannot be meant

CYCAB_HEADER = "t,u_in,theta1,theta2,p1,p2"


def _short_cycab(header: str) -> str:
    rows = (MODELS / "data" / "cycab" / "nominal.csv").read_text(encoding="utf-8").splitlines()[1:301]
    return header + "\n" + "\n".join(rows) + "\n"


@pytest.mark.parametrize("header, words", [
    ("t,u_in,theta1,theta2,p1,p1", ["column 'p1' appears twice", "columns 5 and 6"]),
    ("t,u_in,theta1,theta2,p1,p2,p1", ["column 'p1' appears twice"]),
    ("t,u_in,theta1,theta2,p1,p2,\u00b5,\u03bc", ["'\u00b5' (column 7) and '\u03bc' (column 8)", "NFKC"]),
])
@pytest.mark.parametrize("command", ["diagnose", "monitor"])
def test_a_header_naming_a_column_twice_is_refused(tmp_path, capsys, header, words, command):
    """The later column no longer wins silently (a dict keeps the last): the file is refused."""
    data = tmp_path / "d.csv"
    body = _short_cycab(CYCAB_HEADER).split("\n", 1)[1]
    extra = header.count(",") - CYCAB_HEADER.count(",")
    data.write_text(header + "\n" + "".join(r + ",0" * extra + "\n" for r in body.splitlines()), encoding="utf-8")
    code, err = _cli([command, MODELS / "cycab_steering.yaml", data, "--workers", "1"], capsys)
    assert code == 2
    _one_line(err, "d.csv", *words)


class FrameLike:
    """What the API reads of a pandas DataFrame: column names (repeatable) and a matrix of cells."""

    def __init__(self, names: list, cells: list[list]):
        self.columns = names
        self._m = np.array(cells, dtype=object)

    def to_numpy(self, dtype=None):
        return self._m.astype(dtype) if dtype is not None else self._m


def test_dataframes_with_a_repeated_column_or_cells_that_are_no_numbers_are_refused():
    from fdi.api import measurements
    from fdi.data import DataError
    with pytest.raises(DataError, match="column 'p' appears twice"):
        measurements(FrameLike(["t", "p", "p"], [[0.0, 1.0, 2.0], [0.1, 1.0, 2.0]]))
    with pytest.raises(DataError, match="a value is no number"):
        measurements(FrameLike(["t", "p"], [[0.0, "high"], [0.1, 1.0]]))
    with pytest.raises(DataError, match="a value is no number"):
        measurements(FrameLike(["t", "p"], [[0.0, [1, 2]], [0.1, None]]))
    with pytest.raises(DataError, match="appears twice"):
        measurements({"t": [0.0, 0.1], 1: [1.0, 2.0], "1": [3.0, 4.0]})
    with pytest.raises(DataError, match="not arrays of numbers"):
        measurements({"t": [0.0, 0.1], "p": ["a", "b"]})


def test_notebook_data_that_would_be_read_wrong_is_refused():
    """Three ways the API used to read data silently wrong: complex samples (cast to float with
    only a warning: the imaginary parts dropped), a (5, 2) matrix beside 10 times (flattened: its
    rows read as 10 later samples), and CSV text given as a file name (its line ends in the error
    line). Each is one line naming what to give; a column vector (n, 1) is still one column."""
    from fdi.api import measurements
    from fdi.data import DataError
    t = np.arange(10) * 0.1
    with pytest.raises(DataError, match="column 'p' holds complex numbers; give real values"):
        measurements({"t": t, "p": t + 1j})
    with pytest.raises(DataError, match="column 'p' holds complex numbers"):
        measurements(np.zeros(3, dtype=[("t", float), ("p", complex)]))
    with pytest.raises(DataError, match="a value is no number"):                 # object cells: no cast at all
        measurements(FrameLike(["t", "p"], [[0.0, 1 + 1j], [0.1, 2.0]]))
    with pytest.raises(DataError, match=r"column 'p' is an array of shape \(5, 2\), not one value per sample"):
        measurements({"t": t, "p": np.ones((5, 2))})
    with pytest.raises(DataError) as err:
        measurements("t,p\n0,1\n0.1,2\n")
    assert "\n" not in str(err.value) and "text with line ends, not a file name" in str(err.value)
    column = measurements({"t": t, "p": (2 * t).reshape(-1, 1)})
    assert np.array_equal(column.columns["p"], 2 * t)


def test_model_text_given_as_a_path_is_one_line():
    """load_model("name: x\n...") printed the YAML text as the file's name, across lines (a user
    trial); now one line saying what to give. The text itself still loads with load_model_text."""
    from bondgraph.errors import ModelError
    from bondgraph.loader import load_model, load_model_text
    text = (Path(__file__).parent / "data" / "rc_two_sensors.yaml").read_text(encoding="utf-8")
    with pytest.raises(ModelError) as err:
        load_model(text)
    assert "\n" not in str(err.value) and "text with line ends, not a file name" in str(err.value)
    assert load_model_text(text).sensors


def test_arrays_name_a_bad_sample_by_its_position_not_a_file_line(tmp_path):
    """A NaN at index 6 of a dict of arrays was said to be "first at line 8" (a file's numbering: the
    header, then rows from 1; a user trial); arrays have no lines. Now it is its position from 0, and
    a file of the same numbers still gives its line."""
    from fdi.api import measurements
    from fdi.data import DataError, read_csv
    t, p = np.arange(10) * 0.1, np.ones(10)
    p[6] = np.nan
    with pytest.raises(DataError, match=r"^data: 1 row\(s\) with NaN, infinite or missing values, first at position 6;"):
        measurements({"t": t, "p": p})
    stuck = t.copy()
    stuck[7] = stuck[6]
    with pytest.raises(DataError, match=r"^data: time does not increase at position 7 \(t = 0.6 s\)"):
        measurements({"t": stuck, "p": np.ones(10)})
    path = tmp_path / "run.csv"
    path.write_text("t,p\n" + "".join(f"{a:g},{b}\n" for a, b in zip(t, p)), encoding="utf-8")
    with pytest.raises(DataError, match=r"first at line 8;"):
        read_csv(path)


@pytest.mark.parametrize("name, text, words", [
    ("s.json", '{"T": 2, "fs": 100, "T": 3}', ["duplicate key 'T'"]),
    ("s.json", '{"T": 2, "fs": 100, "faults": [{"target": "R4", "type": "abrupt", "t0": 1, "t0": 1.5, '
               '"value": 1e7}]}', ["duplicate key 't0'"]),
    ("s.yaml", "T: 2\nfs: 100\nT: 3\n", ["duplicate key 'T' at line 3 (first at line 1)"]),
    ("s.yaml", "T: 2\nfs: 100\nnoise: {p1: 1, p1: 2}\n", ["duplicate key 'p1' at line 3"]),
])
def test_a_scenario_key_given_twice_is_refused(tmp_path, capsys, name, text, words):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    code, err = _cli(["simulate", MODELS / "cycab_steering.yaml", path, "-o", tmp_path / "o.csv"], capsys)
    assert code == 2
    _one_line(err, name, *words, "give each key once")
    assert not (tmp_path / "o.csv").exists()


def test_a_yaml_merge_may_still_be_overridden():
    """``<<: *base`` then an own key is YAML's override, not a duplicate."""
    from fdi.app.scenario import _UniqueKeyLoader
    import yaml
    doc = yaml.load("base: &b {T: 1, fs: 10}\nrun:\n  <<: *b\n  T: 2\n", Loader=_UniqueKeyLoader)
    assert doc["run"] == {"T": 2, "fs": 10}


@pytest.mark.parametrize("old, new, words", [
    # a parameter micro sign (U+00B5) beside a Greek mu (U+03BC): NFKC reads both as U+03BC
    ("  Cd:  {value", "  \u00b5: {value: 1.0, unit: Pa}\n  \u03bc: {value: 2.0, unit: Pa}\n  Cd:  {value",
     ["'\u03bc' and '\u00b5' (a parameter)", "NFKC"]),
    # a ligature fi (U+FB01) in one name, plain fi in another
    ("  Cd:  {value", "  \ufb01x: {value: 1.0, unit: Pa}\n  fix: {value: 2.0, unit: Pa}\n  Cd:  {value",
     ["'fix' and '\ufb01x' (a parameter)"]),
    ("columns: [t, Qin, p1, p2]", "columns: [t, Qin, p1, p2, p1]", ["data.columns", "'p1' is listed twice"]),
    ("p2: {type: De, junction: J2, column: p2", "p2: {type: De, junction: J2, column: p1",
     ["sensors.p2.column", "reads column 'p1' as sensor 'p1' does"]),
    # a sensor on the time column: its "pressure" would be the seconds since the start
    ("p2: {type: De, junction: J2, column: p2", "p2: {type: De, junction: J2, column: t",
     ["sensors.p2.column", "reads column 't', the time (s)"]),
])
def test_names_that_cannot_be_told_apart_are_refused_at_load(old, new, words):
    from bondgraph.errors import ModelError
    from bondgraph.loader import load_model_text
    assert old in TANK
    with pytest.raises(ModelError) as err:
        load_model_text(TANK.replace(old, new, 1), "m.yaml")
    for w in words:
        assert w in str(err.value), str(err.value)


def test_one_name_in_another_unicode_form_is_still_the_same_parameter():
    """R12 renamed to the micro sign and used in an expression: the expression's parser reads
    U+03BC, which is that parameter (it was 'undefined symbol')."""
    from bondgraph.loader import load_model_text
    text = TANK.replace("R12", "\u00b5").replace('effort: "rho*g*q/A1"', 'effort: "rho*g*q/A1 + 0*\u00b5"')
    model = load_model_text(text, "m.yaml")
    assert "\u00b5" in model.parameters and model.parameters["\u00b5"].value == 1.0e7


def test_calibrating_on_constant_data_is_refused_with_the_reason(tmp_path, capsys):
    run = tmp_path / "flat.csv"
    run.write_text("t,Qin,p1,p2\n" + "".join(f"{i / 10:.1f},0,0,0\n" for i in range(600)), encoding="utf-8")
    code, err = _cli(["calibrate", MODELS / "two_tank_valve.yaml", run], capsys)
    assert code == 2
    _one_line(err, "flat.csv", "every column is constant", "no threshold can be learnt")


def test_calibrating_on_a_run_whose_noisy_sensors_are_frozen_is_refused(tmp_path, capsys):
    """A trial's run with both thermometers frozen (a stuck sensor: a fault) was taken as nominal
    and raised the thresholds 40-75 %; the model gives p1 and p2 noise, so a constant reading is no
    nominal run."""
    run = tmp_path / "frozen.csv"
    run.write_text("t,Qin,p1,p2\n" + "".join(f"{i / 10:.1f},{1e-4 * (1 + i % 7)},2000,1000\n" for i in range(600)),
                   encoding="utf-8")
    code, err = _cli(["calibrate", MODELS / "two_tank_valve.yaml", run], capsys)
    assert code == 2
    _one_line(err, "frozen.csv", "p1, p2 never change", "stuck")


def test_calibrating_on_a_record_stamped_in_hours_is_refused_at_once_with_the_unit_asked(tmp_path, capsys):
    """The model samples every 0.1 s with a 5 s window (51 samples); a record stamped in hours
    (0.1 s = 2.8e-5 h) spans 1.8e5 samples of it per window: calibrate filtered a window many times the
    record's length for minutes before saying no residual had a sample. Refused like diagnose does,
    and the unit is asked."""
    run = tmp_path / "hours.csv"
    run.write_text("t,Qin,p1,p2\n" + "".join(f"{i * 0.1 / 3600!r},{1e-4 * (1 + i % 7)},{2000 + i % 5},{1000 + i % 3}\n"
                                              for i in range(600)), encoding="utf-8")
    code, err = _cli(["calibrate", MODELS / "two_tank_valve.yaml", run], capsys)
    assert code == 2
    _one_line(err, "hours.csv", "600 samples are too few", "1/3600 of the model file's data.sampling_time",
              "h or min for s")


# ------------------------------------------------------------------ 4. bounded memory and time

@pytest.mark.parametrize("shape, window", [((5000,), 0.4001), ((3, 4000), 0.1001), ((2, 2, 3000), 0.0501)])
def test_the_derivative_filter_in_blocks_gives_the_same_numbers(monkeypatch, shape, window):
    """Blocks of a few windows (FIR_BLOCK made tiny: hundreds of blocks) give the numbers of
    one product over all the windows to 1e-12 of the largest value, every order and both edge
    rules, for one signal, a population and a population of populations; and on a cubic (which
    the cubic fit reproduces exactly) the analytic derivatives."""
    from fdi import derivatives
    x = np.random.default_rng(7).standard_normal(shape).cumsum(axis=-1) + 1e3
    t = np.arange(shape[-1]) * 1e-4
    cubic = 1e3 + 2 * t - 5 * t ** 2 + 7 * t ** 3
    exact = [cubic, 2 - 10 * t + 21 * t ** 2, -10 + 42 * t, 42 + 0 * t]
    for edges in ("interp", "mirror"):
        monkeypatch.setattr(derivatives, "FIR_BLOCK", 1 << 40)
        whole = derivatives.estimate(x, 1e-4, 3, window=window, polyorder=3, edges=edges)
        monkeypatch.setattr(derivatives, "FIR_BLOCK", 5000)
        ours = derivatives.estimate(x, 1e-4, 3, window=window, polyorder=3, edges=edges)
        for k in range(4):
            assert np.max(np.abs(ours[k] - whole[k])) <= 1e-12 * np.abs(whole[k]).max(), (edges, k)
    fitted = derivatives.estimate(cubic, 1e-4, 3, window=window, polyorder=3)
    for k, tol in enumerate((1e-8, 1e-7, 1e-7, 1e-3)):                   # round-off grows with the order
        assert np.max(np.abs(fitted[k] - exact[k])) <= tol * np.abs(exact[k]).max(), k


def test_the_derivative_filter_memory_grows_with_the_samples_not_the_window():
    """100 000 samples and a window of 2001: all windows at once would copy 1.6 GB; in blocks the
    peak of numpy's allocations stays under 64 MB (the signal, its padding, four derivatives of
    0.8 MB each and one block of at most 16 MB)."""
    import tracemalloc

    from fdi import derivatives
    t = np.arange(100_000) * 1e-4
    x = np.sin(3.0 * t) + 0.1 * t ** 3
    tracemalloc.start()
    try:
        v = derivatives.estimate(x, 1e-4, 3, window=0.2, polyorder=3)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 64 << 20, peak / 2 ** 20
    inner = slice(2000, -2000)
    assert np.max(np.abs(v[1][inner] - (3 * np.cos(3 * t) + 0.3 * t ** 2)[inner])) < 1e-3   # d/dt, analytic


def test_residuals_in_blocks_are_the_hand_derived_residual_and_the_same_numbers(monkeypatch):
    """The two-tank ARR1 = Qin - (A1/(rho g)) dp1/dt - v (p1 - p2)/R12 (the model file's own
    derivation, docs) on p1 rising at 2 Pa/s, p2 = 1000 Pa, Qin = 1e-4: the value by hand at every
    trusted sample; evaluated 500 samples at a time it is the same array, bit for bit."""
    from fdi import residuals as R
    from fdi.monitor import Monitor
    from fdi.data import checked, signals_from_data
    m = Monitor(TANK)
    t = np.arange(3000) * 0.1
    cols = {"t": t, "Qin": np.full_like(t, 1e-4), "p1": 5000 + 2.0 * t, "p2": np.full_like(t, 1000.0)}
    data = checked("x", list(cols), np.column_stack(list(cols.values())))
    raw = signals_from_data(m.model, data)
    monkeypatch.setattr(R, "EVAL_BLOCK", 1 << 30)
    whole = R.evaluate(m.model, list(m.residuals), raw, 0.1, window=5.0)
    monkeypatch.setattr(R, "EVAL_BLOCK", 500)
    blocked = R.evaluate(m.model, list(m.residuals), raw, 0.1, window=5.0)
    assert np.array_equal(whole, blocked)
    arr1 = 1e-4 - 0.0154 / (1000 * 9.81) * 2.0 - (cols["p1"] - 1000.0) / 1.0e7
    i = m.names.index("ARR1")
    assert np.allclose(blocked[i][50:-50], arr1[50:-50], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("source", ["file", "stream"])
def test_a_line_without_end_is_refused_after_one_mebibyte(tmp_path, capsys, monkeypatch, source):
    """/dev/zero as data (a file or standard input): one line, exit 2, after reading 1 MiB, not
    after exhausting the memory."""
    import io
    import sys
    import time
    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    model = MODELS / "cycab_steering.yaml"
    start = time.perf_counter()
    if source == "file":
        code, err = _cli(["diagnose", model, "/dev/zero"], capsys)
    else:
        with open("/dev/zero", "rb") as raw:
            monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(raw, encoding="utf-8"))
            code, err = _cli(["monitor", model, "-"], capsys)
    assert code == 2 and time.perf_counter() - start < 5
    _one_line(err, "line 1 is longer than 1,048,576 characters")


@pytest.mark.parametrize("stream, words", [
    ("zero", ["standard input", "line 1 is longer than 1,048,576 characters"]),
    ("t,a,b\n0,1,2\n0.01,1,2\n", ["standard input", "missing column(s)", "columns found: t, a, b"]),
])
def test_monitor_prints_no_event_before_the_header_is_checked(capsys, monkeypatch, stream, words):
    """``monitor M - < /dev/zero`` and a stream for another model: one line, exit 2, and nothing on
    standard output (the start event used to go out before the header was read)."""
    import io
    import sys
    if stream == "zero" and not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    from fdi.app.cli import main
    raw = open("/dev/zero", "rb") if stream == "zero" else io.BytesIO(stream.encode("ascii"))
    with raw:
        monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(raw, encoding="utf-8"))
        code = main(["monitor", str(MODELS / "cycab_steering.yaml"), "-"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    _one_line(err, *words)


def test_monitor_s_start_event_comes_with_the_header_before_any_row(capsys, monkeypatch):
    """A stream that has sent its header and nothing more: the start event is out already (the
    monitor does not wait for the first block of rows to say it has started)."""
    import sys
    import threading
    from fdi.app.cli import main
    read, write = os.pipe()
    header = (MODELS / "data" / "cycab" / "nominal.csv").read_text(encoding="utf-8").splitlines()[0]
    os.write(write, (header + "\n").encode("ascii"))
    monkeypatch.setattr(sys, "stdin", open(read, "r", encoding="utf-8", newline=""))
    seen = threading.Event()
    real_print = print

    def spy(*args, **kw):
        real_print(*args, **kw)
        if args and '"event": "start"' in str(args[0]):
            seen.set()
    monkeypatch.setattr("builtins.print", spy)
    result = {}
    runner = threading.Thread(target=lambda: result.update(code=main(["monitor", str(MODELS / "cycab_steering.yaml"), "-"])))
    runner.start()
    try:
        assert seen.wait(30), "no start event while the stream waits for rows"
    finally:
        os.close(write)                                    # the stream ends: header only, too few samples
        runner.join(30)
    assert result.get("code") == 2


def test_a_long_row_and_a_wide_header_are_refused(tmp_path, capsys):
    from fdi.data import MAX_COLUMNS, MAX_LINE
    model = MODELS / "cycab_steering.yaml"
    row = tmp_path / "row.csv"
    row.write_text(CYCAB_HEADER + "\n0," + "1," * (MAX_LINE // 2) + "1\n", encoding="utf-8")
    code, err = _cli(["diagnose", model, row], capsys)
    assert code == 2
    _one_line(err, "row.csv", "line 2 is longer")
    wide = tmp_path / "wide.csv"
    wide.write_text("t," + ",".join(f"c{i}" for i in range(MAX_COLUMNS)) + "\n", encoding="utf-8")
    code, err = _cli(["diagnose", model, wide], capsys)
    assert code == 2
    _one_line(err, "wide.csv", f"{MAX_COLUMNS + 1:,} columns")


def test_a_model_whose_residual_nests_too_deep_is_one_line(tmp_path, capsys, monkeypatch):
    """A drivetrain chain of 200 stages (800 elements): its one residual runs the whole chain.
    ``check`` derives on a deep-stack thread (bondgraph.deep.run_deep, 250 000 frames; the walks
    over shared subexpressions do not recurse), so it is checked (a 10 000-element chain too);
    should Python's limit still be reached, one line naming the model and what to change, exit 2,
    no traceback (the limit is forced here: no model in reach of a test exhausts 250 000 frames)."""
    from bondgraph.chains import chain_yaml
    from fdi.app import cli
    model = tmp_path / "chain.yaml"
    model.write_text(chain_yaml(800), encoding="utf-8")
    code, err = _cli(["check", model], capsys)
    assert code == 0, err

    def too_deep(fn, *args, **kwargs):
        raise RecursionError("maximum recursion depth exceeded")
    monkeypatch.setattr(cli, "run_deep", too_deep)
    code, err = _cli(["check", model], capsys)
    assert code == 2
    _one_line(err, "chain.yaml", "nest deeper than Python follows", "measure more signals")


def test_a_local_cluster_has_no_more_workers_than_files(monkeypatch):
    """--scheduler local --jobs 16 for 2 files starts 2 workers (the cluster is faked: what is
    asked of dask is the point, not dask starting)."""
    distributed = pytest.importorskip("distributed")
    from fdi.app import fleet
    asked = {}

    class FakeCluster:
        def __init__(self, n_workers, **kw):
            asked["n"] = n_workers

        def close(self):
            pass

    class FakeClient:
        def __init__(self, cluster, **kw):
            pass

        def close(self):
            pass
    monkeypatch.setattr(distributed, "LocalCluster", FakeCluster)
    monkeypatch.setattr(distributed, "Client", FakeClient)
    with fleet.Cluster("local", 16, files=2):
        pass
    assert asked["n"] == 2
    with fleet.Cluster("local", 1, files=5):
        pass
    assert asked["n"] == 1


def test_local_processes_are_no_more_than_files(monkeypatch):
    """--jobs 16 for 2 files (no scheduler): the process pool is asked for 2 workers, not 16 (the
    pool is faked and runs the jobs here: what is asked of it is the point); the reports are the
    two files' own, in order."""
    import concurrent.futures as cf

    from fdi.app.fleet import diagnose_many
    asked = []

    class FakePool:
        def __init__(self, max_workers=None, initializer=None, initargs=(), **kw):
            asked.append(max_workers)
            if initializer is not None:          # a worker's set-up, here where the jobs run
                initializer(*initargs)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def submit(self, fn, *args):
            future = cf.Future()
            future.set_result(fn(*args))
            return future
    monkeypatch.setattr(cf, "ProcessPoolExecutor", FakePool)
    with tempfile.TemporaryDirectory() as d:
        data = tank_data()
        paths = []
        for name in ("a.csv", "b.csv"):
            path = os.path.join(d, name)
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(",".join(data) + "\n")
                for row in zip(*data.values()):
                    fh.write(",".join(repr(float(v)) for v in row) + "\n")
            paths.append(path)
        reports = diagnose_many(QUIET, paths, jobs=16)          # thresholds 1e3: nothing to identify, fast
    assert asked == [2]
    assert [r["file"] for r in reports] == paths


# ------------------------------------------------------------------ 5. the tracebacks left

MU_TANK = TANK.replace("R12", "\u00b5")          # a model whose names need more than ASCII


def test_standard_output_on_a_full_disk_is_one_line(capsys, monkeypatch):
    """/dev/full takes no byte (ENOSPC on every write): one line, exit 2, no traceback."""
    import sys
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    with open("/dev/full", "w", encoding="utf-8") as full:
        monkeypatch.setattr(sys, "stdout", full)
        code, err = _cli(["tables", MODELS / "two_tank_valve.yaml"], capsys)
        assert code == 2
        _one_line(err, "standard output: cannot write", "No space left on device")


def test_monitor_s_first_event_on_a_full_disk_blames_standard_output_not_the_data(tmp_path, capsys, monkeypatch):
    """The start event goes out from inside the reader (once the header is checked): its failed
    write was reported as the data file's ('d.csv: cannot read (No space left on device)')."""
    import sys
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    data = tmp_path / "d.csv"
    data.write_text(_short_cycab(CYCAB_HEADER), encoding="utf-8")
    with open("/dev/full", "w", encoding="utf-8") as full:
        monkeypatch.setattr(sys, "stdout", full)
        code, err = _cli(["monitor", MODELS / "cycab_steering.yaml", data, "--workers", "1"], capsys)
        assert code == 2
        _one_line(err, "standard output: cannot write", "No space left on device")
        assert "d.csv" not in err


def test_an_ascii_standard_output_with_a_non_ascii_model_is_one_line(tmp_path, capsys, monkeypatch):
    """PYTHONIOENCODING=ascii (or an ASCII locale) and a parameter named µ: one line saying how to
    get UTF-8, exit 2; with -o the file is written in UTF-8 and the command succeeds."""
    import io
    import sys
    model = tmp_path / "mu.yaml"
    model.write_text(MU_TANK, encoding="utf-8")
    monkeypatch.setattr(sys, "stdout", io.TextIOWrapper(io.BytesIO(), encoding="ascii"))
    code, err = _cli(["tables", model], capsys)
    assert code == 2
    _one_line(err, "encoding ascii", "PYTHONIOENCODING=utf-8", "-o")
    code, err = _cli(["tables", model, "-o", tmp_path / "t.txt"], capsys)
    assert code == 0 and "\u00b5" in (tmp_path / "t.txt").read_text(encoding="utf-8")


def test_monitor_with_standard_input_closed_is_one_line(capsys, monkeypatch):
    import sys
    monkeypatch.setattr(sys, "stdin", None)                 # what Python gives for `bgfdi monitor M - <&-`
    code, err = _cli(["monitor", MODELS / "cycab_steering.yaml", "-", "--workers", "1"], capsys)
    assert code == 2
    _one_line(err, "standard input is closed")


def test_a_fifo_in_a_suite_folder_is_skipped_not_waited_for(tmp_path, capsys):
    """evaluate on a folder whose only *.json is a FIFO with no writer: it is skipped with a line
    (reading it would wait forever), then 'no scenario files', exit 2, at once."""
    import signal
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs")
    suite = tmp_path / "suite"
    suite.mkdir()
    os.mkfifo(suite / "x.json")

    def hang(signum, frame):
        raise TimeoutError("evaluate waited on the FIFO")
    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(10)
    try:
        code, err = _cli(["evaluate", MODELS / "cycab_steering.yaml", suite], capsys)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 2 and "x.json: not a regular file" in lines[0] and "no scenario files" in lines[1], err


def _within(seconds: int, run):
    """``run()``, failing with TimeoutError if it is still waiting after ``seconds`` (SIGALRM)."""
    import signal

    def hang(signum, frame):
        raise TimeoutError("waited on a FIFO")
    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        return run()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("role", ["scenario", "data", "model"])
def test_a_fifo_with_no_writer_is_refused_not_waited_for(tmp_path, capsys, role):
    """A named FIFO nothing writes into, given as the scenario, the data or the model: one line
    naming it, exit 2, at once (opening it to read used to wait for a writer forever)."""
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs")
    fifo = tmp_path / "input"
    os.mkfifo(fifo)
    model = MODELS / "cycab_steering.yaml"
    argv = {"scenario": ["simulate", model, fifo, "-o", tmp_path / "out.csv"],
            "data": ["diagnose", model, fifo], "model": ["check", fifo]}[role]
    code, err = _within(10, lambda: _cli(argv, capsys))
    assert code == 2
    _one_line(err, str(fifo), "give the model as a regular file" if role == "model" else "nothing writes into")
    assert not (tmp_path / "out.csv").exists()


def test_a_fifo_whose_writer_has_already_left_is_read_whole(tmp_path, capsys):
    """A writer that opens the FIFO, writes the whole scenario and leaves before bgfdi reads it
    (a quick writer started first): the scenario is read through the descriptor that found the
    writer, not by opening the FIFO again (that would wait for a second writer), and simulated:
    the CSV has the scenario's T * fs + 1 samples."""
    import threading
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs")
    fifo = tmp_path / "scenario.json"
    os.mkfifo(fifo)
    text = '{"seed": 1, "T": 2, "fs": 100, "faults": []}'
    left = threading.Event()

    def write() -> None:
        with open(fifo, "w", encoding="utf-8") as fh:      # waits for bgfdi's reader, then writes and leaves
            fh.write(text)
        left.set()
    import time
    threading.Thread(target=write, daemon=True).start()
    time.sleep(0.3)                                        # the writer is waiting in open(): started first
    from fdi.inputs import open_binary
    with _within(10, lambda: open_binary(fifo)) as fh:
        assert left.wait(10)                               # the writer is gone before the first read
        assert fh.read() == text.encode("utf-8")
    threading.Thread(target=write, daemon=True).start()
    time.sleep(0.3)
    out = tmp_path / "out.csv"
    code = _within(60, lambda: _cli(["simulate", MODELS / "two_tank_valve.yaml", fifo, "-o", out], capsys))[0]
    assert code == 0
    assert len(out.read_text(encoding="utf-8").splitlines()) == 1 + 2 * 100 + 1


def test_standard_output_closed_is_one_line_before_the_work_and_an_output_file_still_written(tmp_path, capsys,
                                                                                                 monkeypatch):
    """``bgfdi tables model >&-`` (Python gives sys.stdout None) ended in an AttributeError traceback,
    exit 1; a diagnosis ran its whole search first. Now one line, exit 2, before the work; with
    -o the command writes its file."""
    import sys
    monkeypatch.setattr(sys, "stdout", None)
    code, err = _cli(["tables", MODELS / "two_tank_valve.yaml"], capsys)
    assert code == 2
    _one_line(err, "standard output is closed", "-o")
    monkeypatch.setattr(sys, "stdout", None)
    code, err = _cli(["tables", MODELS / "two_tank_valve.yaml", "-o", tmp_path / "t.txt"], capsys)
    assert code == 0 and "ARR1" in (tmp_path / "t.txt").read_text(encoding="utf-8")


def test_standard_error_closed_still_gives_the_exit_code(monkeypatch):
    """``2>&-``: nothing can be told, but a user mistake still exits 2 (it raised inside the log
    handler: exit 1)."""
    import sys
    monkeypatch.setattr(sys, "stderr", None)
    from fdi.app.cli import main
    assert main(["tables", "no-such-model.yaml"]) == 2


def test_standard_output_closed_with_an_output_folder_is_no_error(tmp_path, capsys, monkeypatch):
    """codegen -o DIR >&- wrote its files, then said 'standard output is closed ... use -o' and exited
    2 (a review): what a command prints beside its output file has nowhere to go, and that is fine."""
    import sys
    monkeypatch.setattr(sys, "stdout", None)
    code, err = _cli(["codegen", MODELS / "two_tank_valve.yaml", "-o", tmp_path / "c"], capsys)
    assert code == 0, err
    assert any((tmp_path / "c").iterdir())


@pytest.mark.parametrize("ending", ["/", "/."])
def test_an_output_path_ending_as_a_folder_is_refused_and_the_file_of_that_name_kept(tmp_path, capsys, ending):
    """-o precious.txt/ wrote the tables over the existing file precious.txt (Path drops the
    ending), and -o nosuchdir/ made a file 'nosuchdir' (a user trial)."""
    precious = tmp_path / "precious.txt"
    precious.write_text("keep", encoding="utf-8")
    code, err = _cli(["tables", MODELS / "two_tank_valve.yaml", "-o", str(precious) + ending], capsys)
    assert code == 2
    _one_line(err, "names a folder", "name a file")
    assert precious.read_text(encoding="utf-8") == "keep"
    code, err = _cli(["tables", MODELS / "two_tank_valve.yaml", "-o", str(tmp_path / "nosuchdir") + ending], capsys)
    assert code == 2 and not (tmp_path / "nosuchdir").exists()


def test_verify_on_a_momentum_sensor_at_a_switched_junction_gives_a_verdict_not_a_traceback(capsys):
    """A user trial's e-bike freewheel (autonomous mode) whose torque sensor reads the momentum on
    the switched 0c: `check --verify` drew a scouting sample's index from one state's pool and read
    a shorter one's (IndexError, every seed)."""
    from .conftest import ROOT
    code, err = _cli(["check", ROOT / "tests" / "data" / "ebike_freewheel_momentum.yaml", "--verify"], capsys)
    assert code in (0, 1) and "Traceback" not in err, err


def test_check_that_fails_at_the_residuals_prints_no_half_report(tmp_path, capsys):
    """A user trial: a capacitance of .inf (its ARR multiplies by it) was refused after the model's
    summary and the causality had gone to standard output: twelve lines of a report, then the error."""
    text = (MODELS / "three_tank.yaml").read_text(encoding="utf-8")
    model = tmp_path / "inf_c.yaml"
    model.write_text(text.replace("CT1: {value: 1.5698e-6", "CT1: {value: .inf"), encoding="utf-8")
    from fdi.app.cli import main
    code = main(["check", str(model)])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    _one_line(err, "CT1", "infinite")


def test_monitor_with_standard_input_not_readable_is_one_line(tmp_path):
    """``bgfdi monitor M - 0>file`` (standard input open for writing only): a traceback before."""
    import subprocess
    import sys
    with open(tmp_path / "w.txt", "wb") as sink:
        done = subprocess.run([sys.executable, "-m", "fdi", "monitor", str(MODELS / "three_tank.yaml"), "-"],
                              stdin=sink, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stdout == ""
    _one_line(done.stderr, "cannot read standard input")


def test_a_large_file_padded_with_zeros_is_refused_in_bounded_memory(tmp_path):
    """A user trial: a CSV's first rows, then zeros to 1 GB (``truncate -s 1G``): pandas' parser, which
    reads files from 128 MiB, holds a line whole and took 10.6 GB and 34-50 s before the refusal.
    Each MiB of a large file must hold a line end before pandas reads it; else the reader of every
    source refuses the long line (here a 300 MiB sparse file: no disk written)."""
    import subprocess
    import sys
    from fdi.data import PANDAS_BYTES, ends_every_mib
    pytest.importorskip("pandas")
    padded = tmp_path / "padded.csv"
    padded.write_text("t,u,i,v\n" + "0,0,0,0\n" * 5, encoding="utf-8")     # a small model: the peak is the reader's
    os.truncate(padded, PANDAS_BYTES + (172 << 20))
    assert not ends_every_mib(str(padded), padded.stat().st_size)
    whole = tmp_path / "whole.csv"          # rows over 3 MiB, then a last line of 0.6 MB across the last MiB's start
    whole.write_bytes(b"0,1\n" * 786_432 + b"9" * 600_000)   # rows fill 3 MiB exactly
    assert ends_every_mib(str(whole), whole.stat().st_size)
    if not Path("/proc/self/status").exists():
        pytest.skip("the peak is read from /proc (Linux)")
    # the child's own peak: /proc's VmHWM is its new image's (getrusage's ru_maxrss keeps the parent's
    # across exec: a pytest worker's 1 GB in CI)
    child = ("import runpy, sys\n"
             "sys.argv = ['bgfdi', 'diagnose', sys.argv[1], sys.argv[2]]\n"
             "try:\n    runpy.run_module('fdi', run_name='__main__')\n"
             "finally:\n    print('peak', next(l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')),"
             " file=sys.stderr)\n")
    model = Path(__file__).resolve().parent / "data" / "rc_two_sensors.yaml"    # (a fresh cache derives the CyCab: 1 GB)
    run = subprocess.run([sys.executable, "-c", child, str(model), str(padded)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and "line 7 is longer" in run.stderr and "Traceback" not in run.stderr
    peak = int(run.stderr.split("peak ")[-1].split()[0])   # kB: the child's own resident peak
    assert peak < 600 << 10                                 # the reader's lines, not the file (10.6 GB for 1 GB before)


def test_a_record_in_reverse_order_is_named_as_such(tmp_path):
    """A trial's record written last row first was told "time does not increase at line 3", as one
    stuck stamp is. Now a time column that decreases throughout says the rows look reversed; one
    stuck stamp keeps the plain message."""
    from fdi.data import DataError, read_csv
    t = np.arange(10) * 0.1
    path = tmp_path / "rev.csv"
    path.write_text("t,p\n" + "".join(f"{a:g},1\n" for a in t[::-1]), encoding="utf-8")
    with pytest.raises(DataError, match=r"time does not increase at line 3 \(t = 0.8 s\) \(it decreases throughout: "
                                        r"the rows in reverse order\? sort them by time\)"):
        read_csv(path)
    stuck = t.copy()
    stuck[7] = stuck[6]
    path.write_text("t,p\n" + "".join(f"{a:g},1\n" for a in stuck), encoding="utf-8")
    with pytest.raises(DataError, match=r"time does not increase at line 9 \(t = 0.6 s\)$"):
        read_csv(path)


def test_a_law_outside_its_domain_during_a_simulation_is_nan_not_a_traceback(capsys):
    """`check --verify` on the accumulator circuit (tests/data/unverified/) ended in a traceback
    ("must be real number, not complex"): a run pushed the gas spring's (V0 / (V0 - q))**n past its
    shell, Python's power of a negative base is complex, and the simulator's scalar code (math)
    refused it. A compiled line outside its function's domain is now NaN, as numpy gives, and the
    run is left out. Designed: a negative base to a fractional power, and math.sqrt(-1)."""
    import math

    import sympy as sp

    from bondgraph.program import compile_lines
    from .conftest import ROOT
    x = sp.Symbol("x")
    f = compile_lines([x], [], [(1 - x) ** sp.Float(1.4), sp.sqrt(x)], "math")
    assert f(0.5) == pytest.approx([0.5 ** 1.4, math.sqrt(0.5)])
    assert all(math.isnan(v) for v in f(2.0)) and all(math.isnan(v) for v in f(-1.0))
    code, err = _cli(["check", ROOT / "tests" / "data" / "unverified" / "accumulator_check_valve.yaml", "--verify"],
                     capsys)
    assert code in (0, 1) and "Traceback" not in err, err
