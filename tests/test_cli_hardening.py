"""Issue 12, the parts the hostile corpus (tests/hostile.py) cannot show by an exit code: outputs
made with the user's umask, ``-o -``, a reader that goes away, reports that do not change between
two runs, and each family of scenario and option checks beyond its one listed value."""
from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import threading

import pytest

from fdi.app.cli import main
from fdi.errors import UsageError
from fdi.api import Options, diagnose
from fdi.options import min_samples
from fdi.app.output import write_atomic
from fdi.app.scenario import MAX_SAMPLES, MAX_STEPS, ScenarioError, check_method, check_steps, parse_scenario

from .conftest import CYCAB, DATA, ROOT

FAST = ["--workers", "1", "--pop", "8", "--generations", "5"]      # a full diagnosis, in about half a second


def one_error_line(capsys) -> str:
    """The single line a refused input leaves on stderr (and nothing on stdout)."""
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("bgfdi: error: ")
    return lines[0]


# ------------------------------------------------------------------ outputs

@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_new_output_files_follow_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        write_atomic(tmp_path / "r.txt", "x\n")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "r.txt").stat().st_mode) == 0o666 & ~mask


def test_a_replaced_file_keeps_its_mode_and_a_link_stays_a_link(tmp_path):
    target = tmp_path / "r.txt"
    target.write_text("old\n")
    target.chmod(0o640)
    link = tmp_path / "link.txt"
    link.symlink_to(target)
    write_atomic(link, "new\n")
    assert link.is_symlink() and target.read_text() == "new\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []     # no temporary left


def test_a_fifo_is_written_into_not_replaced(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    write_atomic(fifo, "through the pipe\n")
    reader.join(5)
    assert stat.S_ISFIFO(fifo.stat().st_mode) and got == [b"through the pipe\n"]


@pytest.mark.parametrize("where, message", [
    ("{tmp}", "is a folder"),
    ("{tmp}/missing/t.txt", "does not exist"),
    ("{tmp}/file.txt/t.txt", "is not a folder"),
    ("", "the path is empty"),
])
def test_bad_output_paths_are_refused_before_any_work(tmp_path, capsys, where, message):
    (tmp_path / "file.txt").write_text("keep\n")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    assert main(["tables", str(CYCAB), "-o", where.replace("{tmp}", str(tmp_path))]) == 2
    line = one_error_line(capsys)
    assert line.startswith("bgfdi: error: -o: ") and message in line
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_dash_is_standard_output_and_no_file_named_dash(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["tables", str(CYCAB), "--mode", "a1=1,a2=1", "--format", "csv", "-o", "-"]) == 0
    assert capsys.readouterr().out.startswith("table,mode,name,signature")
    assert list(tmp_path.iterdir()) == []


def test_simulate_to_standard_output_keeps_the_csv_clean(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.json").write_text('{"T": 0.5, "fs": 100, "theta2_0": -0.15}')
    assert main(["simulate", str(CYCAB), "s.json", "-o", "-"]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert lines[0] == "t,u_in,theta1,theta2,p1,p2" and len(lines) == 52    # header + 51 samples
    assert "wrote standard output: 51 samples" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_a_reader_that_goes_away_ends_the_command_quietly():
    """``bgfdi check ... | head -0``: the read end is closed before anything is written, so every
    write fails with EPIPE; the command must end with code 1 and no traceback."""
    proc = subprocess.Popen([sys.executable, "-m", "fdi.app.cli", "check", str(CYCAB)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(60) == 1 and err == ""


def test_sigterm_while_standard_input_is_copied_removes_the_copy(tmp_path):
    """``producer | timeout 60 bgfdi diagnose model.yaml -``: standard input is copied to a temporary
    file before it is read (a 1.5 GB copy outlived the command killed by ``timeout``). SIGTERM while
    the copy grows ends the command with 128 + 15 and one line, and nothing of the copy is left."""
    import signal
    import time
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    proc = subprocess.Popen([sys.executable, "-m", "fdi.app.cli", "diagnose", str(CYCAB), "-"], cwd=ROOT, env=env,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    block = b"t,u_in,theta1,theta2,p1,p2\n" + b"0,0,0,0,1,1\n" * 50_000
    deadline = time.monotonic() + 60
    while not any(tmp_path.iterdir()) and time.monotonic() < deadline:   # the copy has begun
        proc.stdin.write(block)
        proc.stdin.flush()
    assert any(tmp_path.iterdir())
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)        # (closes standard input)
    assert proc.returncode == 128 + signal.SIGTERM
    assert err.decode().strip() == "bgfdi: terminated by signal 15" and "Traceback" not in err.decode()
    assert list(tmp_path.iterdir()) == []


def test_sigterm_while_a_command_reads_the_copy_of_standard_input_removes_it(tmp_path):
    """SIGTERM after standard input was copied, while the diagnosis runs on the copy: the copy is
    removed and the command ends by the signal (as every command does: unwinding would wait for a
    pool's queued jobs), no traceback."""
    import signal
    import time
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    proc = subprocess.Popen([sys.executable, "-m", "fdi.app.cli", "diagnose", str(CYCAB), "-", "--workers", "2"],
                            cwd=ROOT, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdin.write((DATA / "scenario2.csv").read_bytes())
    proc.stdin.close()
    proc.stdin = None                       # (communicate would flush it)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob("bgfdi-stdin-*/stdin.csv")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)                    # the copy is complete (renamed) and the command reads it
    time.sleep(0.3)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode in (-signal.SIGTERM, 128 + signal.SIGTERM)
    assert b"Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_a_real_shell_pipe_into_head():
    shell = f"'{sys.executable}' -m fdi.app.cli tables '{CYCAB}' --format latex | head -1"
    done = subprocess.run(["bash", "-c", shell], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and len(done.stdout.splitlines()) == 1
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr


# ------------------------------------------------------------------ deterministic reports

def _json_report(capsys, *extra: str) -> str:
    assert main(["diagnose", str(CYCAB), str(DATA / "scenario1.csv"), "--json", *FAST, *extra]) == 0
    return capsys.readouterr().out


def test_two_identical_diagnoses_give_byte_identical_json(capsys):
    first, second = _json_report(capsys), _json_report(capsys)
    assert first == second
    report = json.loads(first)
    assert report["estimators"] and not {"wall_s", "objective_s"} & set(report["estimators"][0])
    assert "timings" not in report and "_timings" not in first


def test_timings_only_when_asked(capsys):
    assert main(["diagnose", str(CYCAB), str(DATA / "nominal.csv"), "--json", "--timings", "--workers", "1"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report["timings"]) >= {"load", "residuals"} and all(v >= 0 for v in report["timings"].values())
    assert main(["diagnose", str(CYCAB), str(DATA / "nominal.csv"), "--timings", "--workers", "1"]) == 0
    assert capsys.readouterr().out.splitlines()[-1].startswith("timings: load ")


# ------------------------------------------------------------------ options

@pytest.mark.parametrize("option, value, message", [
    ("--pop", "3", "--pop: must be an integer from 4 to"),
    ("--pop", "1e9", "--pop: must be an integer"),
    ("--generations", "-1", "--generations: must be an integer from 1"),
    ("--wait", "inf", "--wait: must be a finite number >= 0"),
    ("--wait", "1e999", "--wait: must be a finite number >= 0"),
    ("--threshold", "ARR1=0", "--threshold: ARR1: must be a finite number > 0"),
    ("--threshold", "ARR1=nan", "--threshold: ARR1: must be a finite number > 0"),
    ("--threshold", "ARR1", "--threshold: must be NAME=VALUE"),
    ("--samples", "1", "--samples: must be an integer >= 2"),
    ("--samples", "49", "--samples: must be at least 50 for data sampled every 0.01 s"),
    ("--workers", "-2", "--workers: must be an integer from 1"),
    ("--workers", "100000", "--workers: must be an integer from 1 to 256"),
    ("--seed", "-1", "--seed: must be an integer >= 0"),
    ("--seed", "x", "--seed: must be an integer >= 0"),
    ("--failure", "beta_theta2=-inf", "--failure: beta_theta2: must be a finite number"),
    ("--failure", "R9=0.5", "--failure: 'R9' is no fault of cycab_steering"),
])
def test_diagnosis_options_are_checked_before_any_work(capsys, option, value, message):
    assert main(["diagnose", str(CYCAB), str(DATA / "scenario1.csv"), option, value]) == 2
    assert message in one_error_line(capsys)


@pytest.mark.parametrize("argv, message", [
    (["bench", "derive", "--sizes", "0"], "--sizes: must be comma-separated chain sizes from 1"),
    (["bench", "derive", "--sizes", "100000"], "--sizes: must be comma-separated chain sizes from 1 to 10000"),
    (["bench", "optim", "--runs", "0"], "--runs: must be an integer >= 1"),
    (["bench", "optim", "--workers", "0"], "--workers: must be an integer from 1"),
    (["bench", "accuracy", "--seed", "-1"], "--seed: must be an integer >= 0"),
    (["isolability", str(CYCAB), "--max-sensors", "7"], "--max-sensors: must be an integer from 0 to 6"),
    (["simulate", str(CYCAB), "s.json", "-o", "o.csv", "--method", "euler"], "--method: must be one of auto, ros2"),
    (["simulate", str(CYCAB), "s.json", "-o", "o.csv", "--seed", "-5"], "--seed: must be an integer >= 0"),
    (["tables"], "the following arguments are required: model"),
])
def test_other_options_one_line(capsys, argv, message):
    assert main(argv) == 2
    assert message in one_error_line(capsys)


def test_options_checked_by_the_api_too(tmp_path):
    """diagnose() refuses bad Options before it reads the data (the file does not even exist)."""
    for bad in (Options(pop=0), Options(generations=0), Options(workers=0), Options(waiting_time=-1.0),
                Options(thresholds={"ARR1": float("inf")}), Options(seed=-1), Options(engine="bogus")):
        with pytest.raises(UsageError, match=r"^Options\."):
            diagnose(CYCAB, tmp_path / "absent.csv", bad)
    assert min_samples(0.01) == 50 and min_samples(0.1) == 5 and min_samples(1.0) == 2


def test_data_ending_just_after_the_detection_is_reported_not_identified(tmp_path, capsys):
    lines = (DATA / "scenario1.csv").read_text().splitlines()[:3210]          # ends 0.21 s after t_D
    (tmp_path / "cut.csv").write_text("\n".join(lines) + "\n")
    assert main(["diagnose", str(CYCAB), str(tmp_path / "cut.csv"), "--workers", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["detection"]["time"] == 31.88 and report["diagnosis"]["faults"] == []
    assert "needs at least 0.5 s after t_D" in report["note"]


# ------------------------------------------------------------------ scenario files

GOOD_FAULT = {"target": "beta_theta1", "type": "intermittent", "t0": 1, "value": 0.5, "period": 2}


@pytest.mark.parametrize("edit, message", [
    ({"T": float("nan")}, "T: the run's length (s) must be a finite number"),
    ({"T": -1}, "T: the run's length (s) must be > 0"),
    ({"T": 10 ** 400}, "T: the run's length (s) must be a finite number"),
    ({"T": "1e7"}, "is the text '1e7'"),
    ({"T": True}, "must be a number, got True"),
    ({"fs": 0}, "fs: the sampling rate (Hz) must be > 0"),
    ({"T": 1e5, "fs": 1e3}, f"more than the limit of {MAX_SAMPLES:,}"),
    ({"T": 1, "fs": 0.5}, "at least 2 samples"),
    ({"seed": -1}, "seed must be an integer >= 0"),
    ({"seed": 2.5}, "seed must be an integer >= 0"),
    ({1: 2}, "the key 1 is no name"),
    ({"noise": [1, 2]}, "noise must be a mapping"),
    ({"noise": {1: 2.0}}, "noise: the key 1 is no name"),
    ({"noise": {"p1": -1.0}}, "noise.p1: a standard deviation must be >= 0"),
    ({"resolution": {"p1": float("inf")}}, "resolution.p1: a quantisation step must be a finite number"),
    ({"theta2_0": float("nan")}, "theta2_0: an initial value must be a finite number"),
    ({"faults": {"a": 1}}, "faults must be a list"),
    ({"faults": [["R4"]]}, "faults[0]: a fault is a mapping"),
    ({"faults": [{**GOOD_FAULT, "target": ["R4"]}]}, "faults[0].target: unknown target ['R4']"),
    ({"faults": [{**GOOD_FAULT, "type": 3}]}, "faults[0]: unknown type 3"),
    ({"faults": [{**GOOD_FAULT, "t0": float("inf")}]}, "faults[0].t0: the start time (s) must be a finite"),
    ({"faults": [{**GOOD_FAULT, "value": float("nan")}]}, "faults[0].value: the faulty value must be a finite"),
    ({"faults": [{"target": "R4", "type": "abrupt", "t0": 1, "value": -1.0e7}]},
     "faults[0].value: -1e+07 for R4, whose parameter R4 is positive"),
    ({"faults": [{**GOOD_FAULT, "period": 1e-300}]}, "faults[0].period: 1e-300 s is shorter than two samples"),
    ({"T": 60, "fs": 200, "faults": [{**GOOD_FAULT, "period": 0.011, "t0": 0}] * 2}, "switch 21818 times"),
    ({"faults": [{"target": "beta_theta2", "type": "incipient", "t0": 1, "model": True, "b": [1]}]},
     "faults[0].model: must be 1, 2, 3 or 4"),
    ({"faults": [{"target": "beta_theta2", "type": "incipient", "t0": 1, "model": 1, "b": "x"}]},
     "faults[0].b: must be a list of numbers"),
    ({"faults": [{"target": "beta_theta2", "type": "incipient", "t0": 1, "model": 1, "b": [float("inf")]}]},
     "faults[0].b[0]: a coefficient must be a finite number"),
])
def test_scenario_numbers_and_keys_are_checked_where_they_enter(cycab, edit, message):
    data = {"T": 10, "fs": 100, "faults": [GOOD_FAULT], **edit}
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, cycab, "bad.json")
    text = str(info.value)
    assert text.startswith("bad.json: ") and message in text and "\n" not in text


def test_alias_bombs_and_long_values_give_short_messages(cycab):
    bomb: list = ["x"] * 9
    for _ in range(8):
        bomb = [bomb] * 9                        # 9**9 leaves, as a YAML alias bomb loads
    with pytest.raises(ScenarioError) as info:
        parse_scenario({"T": 1, "noise": {"p1": bomb}}, cycab, "bomb.yaml")
    assert len(str(info.value)) < 200


def test_integrator_names_and_the_fixed_step_limit(cycab):
    assert check_method("lsoda") == "LSODA" and check_method("ROS2") == "ros2"
    with pytest.raises(ScenarioError, match="--method: unknown integrator 'euler'"):
        check_method("euler")
    long = parse_scenario({"T": 2 * MAX_STEPS / 1000, "fs": 1}, cycab, "long.json")
    with pytest.raises(ScenarioError, match="steps of ROS2"):
        check_steps(long, "auto")
    check_steps(long, "LSODA")                  # scipy's methods step by the samples: 20 000 here


def test_bad_scenario_files_on_disk(tmp_path, capsys):
    cases = {"latin1.json": '{"T": 1, "th\u00e9ta_0": 1}'.encode("latin-1"),
             "deep.json": b"[" * 100_000 + b"]" * 100_000,
             "digits.json": b'{"T": ' + b"9" * 5000 + b"}",
             "big.json": b'{"T": 1}' + b" " * (2 << 20),
             "int-key.yaml": b"1: 2\nT: 1.0\n",
             "tag.yaml": b"T: !!python/object/apply:os.system [echo hi]\n"}
    expect = {"latin1.json": "not UTF-8 text", "deep.json": "nested too deeply", "digits.json": "too many digits",
              "big.json": "larger than 1 MB", "int-key.yaml": "the key 1 is no name", "tag.yaml": "not valid YAML"}
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
        assert main(["simulate", str(CYCAB), str(tmp_path / name), "-o", str(tmp_path / "o.csv")]) == 2, name
        line = one_error_line(capsys)
        assert f"{name}: " in line and expect[name] in line, line
    assert not (tmp_path / "o.csv").exists()


def test_a_diverging_simulation_writes_nothing(tmp_path, capsys):
    (tmp_path / "s.json").write_text(json.dumps({"T": 1, "fs": 100, "faults": [
        {"target": "beta_theta2", "type": "incipient", "t0": 0, "model": 1, "b": [1e300]}]}))
    assert main(["simulate", str(CYCAB), str(tmp_path / "s.json"), "-o", str(tmp_path / "o.csv")]) == 2
    # refused before it runs since 2026-12: the drift itself leaves the floats (a user trial's 1e5 /s ran frozen)
    assert "faults[0].b: beta_theta2's drift leaves the floats by t = 0.001 s" in one_error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_the_models_thresholds_name_only_its_residuals_and_monitor_says_so_in_one_line(tmp_path, capsys):
    """A threshold in the model for a residual it does not have (ARR9: a residual renamed or gone
    since calibrate wrote them) was ignored silently while --threshold ARR9=1 is refused; and
    `monitor` ended a model without thresholds with a traceback (a ValueError). Both: one line
    naming the file and the key, exit 2, for diagnose and for monitor."""
    from pathlib import Path
    text = (Path(__file__).parent / "data" / "rc_two_sensors.yaml").read_text()
    assert "thresholds:" not in text
    data = tmp_path / "run.csv"
    from .independent import rc
    rc.write(data, rc.simulate(1.0, 1))
    line = len(text.splitlines()) + 1                   # the appended thresholds' line
    for extra, where, said in (("thresholds: {ARR1: 0.01, ARR2: 0.001, ARR9: 3}\n", f":{line}: thresholds.ARR9: ",
                                "ARR9 name(s) no residual of the model"),
                               ("", ": thresholds: ", "no threshold for ARR1, ARR2")):
        model = tmp_path / "m.yaml"
        model.write_text(text + extra)
        for command in (["diagnose", str(model), str(data), "--workers", "1"], ["monitor", str(model), str(data)]):
            assert main(command) == 2
            err = capsys.readouterr().err.strip()
            assert err.startswith(f"bgfdi: error: {model}{where}") and said in err and "\n" not in err


def test_a_record_stamped_in_milliseconds_is_named_not_the_model(tmp_path, capsys):
    """A record whose step is 1000 times the model file's sampling time and longer than its derivative
    window: the record is the likely mistake (ms for s), so the one line names it (a trial: the
    message blamed the model's window)."""
    rows = ["t,u,i,v"] + [f"{k},{5.0:.3f},{0.01:.4f},{3.3:.3f}" for k in range(400)]     # t in ms
    csv = tmp_path / "ms.csv"
    csv.write_text("\n".join(rows) + "\n")
    code = main(["diagnose", str(ROOT / "tests" / "data" / "rc_two_sensors.yaml"), str(csv), "--threshold", "ARR1=1",
                 "--threshold", "ARR2=1", "--workers", "1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith(f"bgfdi: error: {csv}: sampled every 1 s, 1000 times the model file's data.sampling_time")
    assert "ms for s" in err[0]


def test_check_refuses_a_threshold_for_no_residual_and_names_residuals_without_one(tmp_path, capsys):
    """What diagnose refuses, check refuses (a trial: check passed a threshold for ARR9 of a model
    with five residuals, diagnose then stopped); residuals without a threshold are a note (a model
    before calibration is valid)."""
    text = (ROOT / "tests" / "data" / "rc_two_sensors.yaml").read_text()
    stray = tmp_path / "stray.yaml"
    stray.write_text(text + "thresholds: {ARR1: 1.0, ARR9: 2.0}\n")
    assert main(["check", str(stray)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    line = len(text.splitlines()) + 1
    assert len(err) == 1 and (f"{stray}:{line}: thresholds.ARR9: ARR9 name(s) no residual of the model (its "
                              f"residuals: ARR1, ARR2)") in err[0]
    assert main(["check", str(stray), "--json"]) == 2
    capsys.readouterr()
    half = tmp_path / "half.yaml"
    half.write_text(text + "thresholds: {ARR1: 1.0}\n")
    assert main(["check", str(half)]) == 0
    assert "note: no threshold for ARR2 in the file" in capsys.readouterr().out


def test_simulate_names_the_model_for_what_the_model_lacks(tmp_path, capsys):
    """An input without an expression is the model's to fix: the one line names the model file and
    its key, not the scenario (a trial: 'sc.json: input u has no expr')."""
    text = (ROOT / "tests" / "data" / "rc_two_sensors.yaml").read_text()
    model = tmp_path / "rc.yaml"
    model.write_text(text.replace('u: {column: u, expr: "5 + 2*sin(3*t)", unit: V}', "u: {column: u, unit: V}"))
    scenario = tmp_path / "sc.json"
    scenario.write_text('{"seed": 1, "T": 0.5}')
    out = tmp_path / "out.csv"
    assert main(["simulate", str(model), str(scenario), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"bgfdi: error: {model}") and "inputs.u" in err[0]
    assert "sc.json" not in err[0] and not out.exists()
