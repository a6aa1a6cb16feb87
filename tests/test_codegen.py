"""``bgfdi codegen``: the generated C99 monitor, compiled by the system's C compiler with warnings as
errors, computes what Python computes on the same data (docs/deploy.md).

Each model is generated and compiled once (into a temporary folder) and its CSV driver run on the
four CyCab reference files and on runs of one model of each kind: hydraulic (three tanks, whose
residuals differentiate stored quantities inside stored quantities; two tanks behind a commanded
valve, whose switches break the derivative filter), electrical with a switch (the boost converter,
PWM at 20 kHz: stretches shorter than the filter's one-sided fits), mechanical (two inertias on a
shaft, a window the data's sampling time decides). The data come from the independent simulators
of tests/independent/ (boost, shaft) or from ``bgfdi simulate``'s scenarios (tanks).

The reference is Python's evaluation of the residuals (fdi.residuals: the same filter, window and
kernels) and its detection rule (fdi.detect with the settings fdi.pipeline.prepare gives a
diagnosis), with one adjustment, where both are round-off: where a signal's window is symmetric
about its middle (a quantised encoder that stands still or turns back), its odd derivatives are
exactly 0, which the C filter computes and numpy's matrix product misses by ~1e-15; a Coulomb
friction sign() would make that ±Fu. The circuit law of an RC node is the independent reference of
one more test, on a model whose names are hostile to C (a parameter named int, µ, NAN, linux;
columns with quotes and comment ends; a model named with an #include).
"""
from __future__ import annotations

import io
import json
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from numpy.lib.stride_tricks import sliding_window_view

from fdi import derivatives
from fdi.codegen import generate, plan, write_folder
from fdi.codegen_printer import CodegenError
from fdi.data import Measurements, commanded, read_csv, signals_from_data
from fdi.detect import alarms, detect, trusted
from fdi.monitor import Monitor, compiled
from fdi.options import Options
from fdi.pipeline import prepare
from fdi.residuals import corrected_signals, derivative_orders, parameter_values

from .conftest import DATA, MODELS

CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler (cc or gcc) on this machine; CI has gcc")
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]
TOLERANCE = 1e-9          # of each residual's threshold


# ------------------------------------------------------------------ helpers

def build(folder: Path, monitor, options: Options | None = None) -> tuple[object, Path]:
    """Generate the monitor into ``folder`` and compile its driver; (plan, executable)."""
    files = generate(monitor, options=options)
    write_folder(files, folder)
    p = plan(monitor, options=options)
    exe = folder / "monitor"
    done = subprocess.run([CC, *FLAGS, "-o", str(exe), str(folder / "main.c"), str(folder / f"{p.prefix}.c"), "-lm"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return p, exe


def run(exe: Path, csv: Path) -> tuple[np.ndarray, str]:
    done = subprocess.run([str(exe), str(csv)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return np.genfromtxt(io.StringIO(done.stdout), delimiter=",", names=True), done.stderr


def write_csv(columns: dict, path: Path) -> Path:
    names = list(columns)
    rows = zip(*[np.asarray(columns[n], dtype=float) for n in names])
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in rows))
    return path


def reference(monitor, meas: Measurements, window: float) -> np.ndarray:
    """Python's residuals on ``meas`` (fdi.residuals), the odd derivatives of symmetric windows at
    their exact 0 (module doc)."""
    model, residuals = monitor.model, list(monitor.residuals)
    raw = signals_from_data(model, meas)
    orders = derivative_orders(residuals)
    sig = corrected_signals(model, raw, meas.ts, orders, window=window)
    for name, order in orders.items():
        n = derivatives.window_samples(window, meas.ts, max(derivatives.DEFAULT_ORDER, order))
        half = n // 2
        x = np.asarray(raw[name], dtype=float)
        windows = sliding_window_view(x, n)
        symmetric = np.zeros(x.size, dtype=bool)
        symmetric[half:x.size - half] = (windows == windows[:, ::-1]).all(axis=1)
        for k in range(1, order + 1, 2):
            sig[name][k] = np.where(symmetric, 0.0, sig[name][k])
        for edge, first in ((slice(0, half), x[:n]), (slice(x.size - half, x.size), x[-n:])):
            if np.ptp(first) == 0:                 # the data's end windows: one-sided fits of a constant
                for k in range(1, order + 1):
                    sig[name][k][edge] = 0.0
    values = {**parameter_values(model), **commanded(model, raw)}
    return np.stack([np.broadcast_to(r(sig, values, meas.ts, window), meas.t.shape) for r in residuals])


def check(monitor, p, exe: Path, csv: Path) -> dict:
    """Run the C monitor on ``csv`` and hold it against Python; the measured differences."""
    meas = read_csv(csv)
    prepared = prepare(monitor, meas, Options())
    python = reference(prepared.monitor, meas, prepared.window_s)
    out, summary = run(exe, csv)
    names = list(monitor.names)
    assert out.shape[0] == meas.t.size and np.array_equal(out["index"], np.arange(meas.t.size))
    assert np.array_equal(out["t"], meas.t)
    c = np.stack([out[n] for n in names])
    thresholds = np.array([k.threshold for k in p.residuals])
    assert np.array_equal(thresholds, prepared.thresholds)
    # the residuals: NaN (no whole window between two switches) at the same samples, values within tolerance
    assert np.array_equal(np.isnan(c), np.isnan(python))
    both = np.isfinite(python)
    worst = np.nanmax(np.where(both, np.abs(c - python), 0.0), axis=1) / thresholds
    assert worst.max() <= TOLERANCE, dict(zip(names, worst))
    # detection looks at the samples diagnose looks at, and the last centred ones a stream sees first
    judged = out["judged"].astype(bool)
    looked = trusted(meas.t, prepared.settle, prepared.scales.end_edge)
    near_end = meas.t > meas.t[-1] - prepared.scales.end_edge - 1.5 * meas.ts
    assert np.array_equal(judged[~near_end], looked[~near_end]) and np.all(judged[looked])
    # the latched coherence vector at every sample: Python's alarms on the samples C judged
    persistence, span = prepared.rule
    lit = alarms(np.where(judged, python, np.nan), meas.t, thresholds, 0.0, 0.0, persistence, span).latched(meas.t.size)
    assert np.array_equal(np.stack([out[f"coherence_{n}"] for n in names]).astype(bool), lit)
    # the detection: t_D, the alarm and its coherence vector, the decision and its coherence vector
    d = detect(python, meas.t, thresholds, prepared.wait, prepared.settle, prepared.scales.end_edge, persistence, span)
    if d is None:
        assert summary.strip() == "no detection"
    else:
        vector = ",".join(map(str, d.coherence))
        final = ",".join(map(str, d.final_coherence))
        assert summary.strip() == (f"detection: t_D = {d.time:.17g} s, alarm at {d.alarm_time:.17g} s, coherence "
                                   f"{vector}; decision at {d.decision_time:.17g} s, coherence {final}")
    return {"worst": worst, "detection": d}


def calibrated(model: Path, columns: dict) -> Options:
    """Thresholds for a model that gives none: 1.5 times the peak of |r| on a nominal run (bgfdi calibrate)."""
    from fdi.calibrate import calibrate
    c = calibrate(str(model), [Measurements("nominal", np.asarray(columns["t"]), columns)])
    return Options(thresholds=dict(zip(c.names, c.thresholds)))


def scenario(model: Path, spec: dict) -> dict:
    from bondgraph.loader import load_model
    from fdi.app.scenario import parse_scenario, run as simulate
    m = load_model(model)
    return simulate(m, parse_scenario(spec, m, "codegen"))


# ------------------------------------------------------------------ the reference files

@pytest.fixture(scope="module")
def cycab_monitor(tmp_path_factory):
    monitor = compiled(MODELS / "cycab_steering.yaml")
    p, exe = build(tmp_path_factory.mktemp("cycab"), monitor)
    return monitor, p, exe


@pytest.mark.parametrize("name", ["nominal", "scenario1", "scenario2", "scenario3"])
def test_the_cycab_reference_files_give_pythons_residuals_coherence_and_detection(cycab_monitor, name):
    monitor, p, exe = cycab_monitor
    found = check(monitor, p, exe, DATA / f"{name}.csv")
    truth = json.loads((DATA / f"{name}.truth.json").read_text())
    assert (found["detection"] is None) == (not truth.get("faults"))


# ------------------------------------------------------------------ a model of each kind

def test_boost_converter_switching_at_20_khz(tmp_path):
    # electrical with a switch: every PWM half-period (25 samples) is shorter than four windows
    # (11 samples each), so only centred windows give values and the switches leave NaN
    from .independent import boost
    model = MODELS / "boost_converter.yaml"
    nominal = boost.simulate(0.002, noise=0.01, seed=1)
    options = calibrated(model, nominal)
    monitor = compiled(model).with_config(compiled(model).config.replace(thresholds=options.thresholds))
    p, exe = build(tmp_path, monitor)
    assert p.modes and any(c.kind == "signal" for c in p.channels)
    check(monitor, p, exe, write_csv(nominal, tmp_path / "nominal.csv"))
    found = check(monitor, p, exe, write_csv(boost.simulate(0.002, changes={"rL": (0.001, 0.5)}, noise=0.01, seed=2),
                                             tmp_path / "rL.csv"))
    assert found["detection"] is not None and 0.001 <= found["detection"].time < 0.0011


def test_a_diode_that_decides_its_own_mode_and_a_detection_further_back_than_the_ring(tmp_path):
    # discontinuous conduction: the diode's mode is 1 while iL > 0 (an autonomous mode, from the
    # data). Thresholds at 1.5 times the peak of a noise-free run: the sensor noise of a second run
    # crosses them now and then, and its evidence adds up over the span (200 samples) until an
    # alarm whose t_D, the first crossing of that span, lies further back than the ring holds
    from .independent import boost
    model = Path(__file__).parent / "data" / "boost_dcm.yaml"
    clean = boost.simulate_dcm(0.002, p={"L": 2.0e-5})
    options = calibrated(model, clean)
    monitor = compiled(model).with_config(compiled(model).config.replace(thresholds=options.thresholds))
    p, exe = build(tmp_path, monitor)
    assert [(m.name, m.column) for m in p.modes] == [("s", 2), ("c", None)]
    check(monitor, p, exe, write_csv(clean, tmp_path / "clean.csv"))
    noise = np.random.default_rng(0)
    noisy = {k: v + noise.normal(0.0, 0.01, v.size) if k in ("iL", "vo") else v for k, v in clean.items()}
    found = check(monitor, p, exe, write_csv(noisy, tmp_path / "noisy.csv"))["detection"]
    assert found is not None and round((found.alarm_time - found.time) / 1e-6) > p.ring


def test_two_inertia_shaft_with_a_window_from_the_data(tmp_path):
    from .independent import shaft
    model = MODELS / "two_inertia_shaft.yaml"
    nominal = shaft.simulate(3.0, seed=1)
    options = calibrated(model, nominal)
    monitor = compiled(model).with_config(compiled(model).config.replace(thresholds=options.thresholds))
    assert monitor.config.derivative_window is None             # fdi.scales picks it from ts and the model
    p, exe = build(tmp_path, monitor)
    check(monitor, p, exe, write_csv(nominal, tmp_path / "nominal.csv"))
    found = check(monitor, p, exe, write_csv(shaft.simulate(3.0, seed=2, b2_step=(1.5, 0.5)), tmp_path / "b2.csv"))
    assert found["detection"] is not None and 1.45 < found["detection"].time < 1.55


def test_three_tanks_differentiate_a_stored_quantity_inside_another(tmp_path):
    # ARR1 holds d(CT1 p1)/dt alone and inside d(CT2 (p1 - Rv1 (q0 - d(CT1 p1)/dt)))/dt
    model = MODELS / "three_tank.yaml"
    nominal = scenario(model, {"T": 300, "fs": 10, "seed": 1, "faults": []})
    options = calibrated(model, nominal)
    monitor = compiled(model).with_config(compiled(model).config.replace(thresholds=options.thresholds))
    p, exe = build(tmp_path, monitor)
    stored = [c for c in p.channels if c.kind == "stored"]
    assert any(any(p.channels[i].kind == "stored" for i in c.inputs) for c in stored)      # one inside another
    check(monitor, p, exe, write_csv(nominal, tmp_path / "nominal.csv"))
    # tank 1 narrowed to half its capacity (its volume kept, its pressure doubled): the rate of the
    # stored volume CT1 p1 is what the residuals differentiate
    half = monitor.model.parameters["CT1"].value / 2
    faulty = scenario(model, {"T": 300, "fs": 10, "seed": 2,
                              "faults": [{"target": "fT1", "type": "abrupt", "t0": 150, "value": half}]})
    found = check(monitor, p, exe, write_csv(faulty, tmp_path / "fT1.csv"))
    # centred windows (5 s), one inside another: the jump is seen up to a window and a half early
    assert found["detection"] is not None and 150 - 1.5 * 5.0 <= found["detection"].time < 160


def test_two_tanks_behind_a_commanded_valve(tmp_path):
    # the valve's command switches once (at 300 s): one-sided fits on both sides of the switch
    model = MODELS / "two_tank_commanded.yaml"
    monitor = compiled(model)
    p, exe = build(tmp_path, monitor)
    assert [m.name for m in p.modes] == ["v"]
    for name, faults in (("nominal", []), ("stuck_closed", [{"target": "v_closed", "type": "mode", "t0": 150}])):
        columns = scenario(model, {"seed": 403, "T": 400, "fs": 10, "faults": faults})
        assert np.ptp(columns["v_cmd"]) == 1.0
        found = check(monitor, p, exe, write_csv(columns, tmp_path / f"{name}.csv"))
        assert (found["detection"] is None) == (name == "nominal")


# ------------------------------------------------------------------ names, the circuit law

HOSTILE = """
name: "evil */ #include <stdlib.h> /* ??/ µ"
parameters:
  int: {value: 1.0e-3, unit: F}
  µ: {value: 100.0, unit: Ohm}
  NAN: {value: 1.0, unit: "-"}
  linux: {value: 1.0, unit: "-"}
data: {columns: [t, "i in", "v\\"*/x"], sampling_time: 0.001}
inputs: {i_in: {unit: A, column: "i in"}}
elements: {src: {type: MSf, input: i_in}, c: {type: C, parameter: int}, r: {type: R, flow: "e/µ*NAN*linux"}}
junctions: {j: {type: "0"}}
sensors: {v: {type: De, junction: j, column: "v\\"*/x", unit: V}}
bonds: {1: [src, j], 2: [j, c], 3: [j, r]}
thresholds: {ARR1: 0.01}
"""


def test_hostile_names_compile_and_the_residual_is_the_circuit_law(tmp_path):
    # a current source into C || R, v measured: the residual is i_in - C dv/dt - v/R (Kirchhoff).
    # Data from R halved: the residual is the current the model misses, v/R
    path = tmp_path / "hostile.yaml"
    path.write_text(HOSTILE, encoding="utf-8")
    monitor = Monitor(str(path))
    p, exe = build(tmp_path / "out", monitor)
    text = "".join((tmp_path / "out" / f"{p.prefix}{suffix}").read_text() for suffix in (".h", ".c"))
    includes = {line for line in text.splitlines() if line.startswith("#include")}
    assert text.isascii() and includes == {"#include <stdint.h>", "#include <math.h>", "#include <string.h>",
                                           f'#include "{p.prefix}.h"'}
    assert {"int_", "u00b5_", "NAN_", "linux_"} == {x.field for x in p.parameters}
    t = np.arange(0.0, 1.0, 0.001)
    v, dv = 2 + np.sin(2 * np.pi * t), 2 * np.pi * np.cos(2 * np.pi * t)
    rows = "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t.tolist(), (1e-3 * dv + v / 50).tolist(), v.tolist()))
    csv = tmp_path / "rc.csv"
    csv.write_text('t,"i in","v""*/x"\n' + rows)             # the header quoted as CSV quotes it
    out, summary = run(exe, csv)
    inner = slice(50, -50)
    assert np.allclose(out["ARR1"][inner], v[inner] / 100, rtol=1e-4)
    assert summary.strip().startswith("detection:")


def test_a_function_c_lacks_is_one_line(tmp_path, monkeypatch, capsys):
    # the loader admits only functions C99 has (bondgraph.expressions.FUNCTIONS) and never
    # differentiates a nonsmooth law (bondgraph.rates): a model built in Python can still hold one
    from bondgraph.loader import LAW_VARIABLES
    from fdi.app.cli import main
    path = tmp_path / "rc.yaml"
    path.write_text(HOSTILE.replace('flow: "e/µ*NAN*linux"', "parameter: µ"), encoding="utf-8")
    base = Monitor(str(path))
    e = LAW_VARIABLES["e"]
    r = replace(base.model.elements["r"], parameter=None, laws={"flow": sp.besselj(0, e) / base.model.symbols["µ"]})
    model = replace(base.model, elements={**base.model.elements, "r": r})
    monitor = Monitor(model, base.config)
    with pytest.raises(CodegenError, match="besselj.*does not translate"):
        generate(monitor)
    monkeypatch.setattr("fdi.monitor.compiled", lambda _: monitor)
    assert main(["codegen", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "besselj" in err and "ARR1" in err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------ the command line and the driver

def test_the_command_writes_a_folder_and_refuses_outputs_that_are_inputs(tmp_path, capsys):
    from fdi.app.cli import main
    model = MODELS / "cycab_steering.yaml"
    out = tmp_path / "monitor"
    assert main(["codegen", str(model), "--lang", "c", "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["Makefile", "bgfdi_cycab_steering.c", "bgfdi_cycab_steering.h",
                                                     "main.c"]
    header = (out / "bgfdi_cycab_steering.h").read_text()
    assert "/*   4  p1 " in header and "#define BGFDI_CYCAB_STEERING_COLUMNS 6" in header
    assert main(["codegen", str(model), "-o", str(out)]) == 0            # an existing folder: files replaced
    capsys.readouterr()
    # a model file named like a generated file, in the output folder: it would be replaced
    shutil.copy(model, tmp_path / "main.c")
    for argv, words in ((["codegen", str(tmp_path / "main.c"), "-o", str(tmp_path)], "is the input"),
                        (["codegen", str(model), "-o", str(model)], "is the input"),
                        (["codegen", str(model), "-o", "-"], "standard output"),
                        (["codegen", str(model), "-o", str(tmp_path / "main.c" / "x")], "not a folder"),
                        (["codegen", str(model), "-o", str(out), "--lang", "rust"], "--lang"),
                        (["codegen", str(model), "-o", str(out), "--threshold", "ARR9=1"], "ARR9"),
                        (["codegen", str(model), "-o", str(out), "--sampling-time", "0"], "--sampling-time"),
                        (["codegen", str(model), "-o", str(out), "--prefix", "9lives"], "--prefix"),
                        (["codegen", str(MODELS / "three_tank.yaml"), "-o", str(tmp_path / "new")], "no threshold")):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and words in err, (argv, err)
    assert not (tmp_path / "new").exists()
    assert main(["codegen", "--help"]) == 0


@pytest.mark.parametrize("name", ["cycab_steering", "hydraulic_actuator"])
def test_the_generated_files_are_the_same_bytes_in_every_process(tmp_path, name):
    """A reproducible build: two processes with other string hashes (the order sympy's sets give
    their symbols) write the same files, byte for byte (the parameters' struct and the channels
    were in set order: each run a different header)."""
    import os
    import sys
    root = Path(__file__).resolve().parents[1]
    outs = []
    for seed in ("1", "2"):
        out = tmp_path / f"run{seed}"
        env = {**os.environ, "PYTHONHASHSEED": seed, "BGFDI_CACHE": "off", "PYTHONPATH": str(root)}
        done = subprocess.run([sys.executable, "-m", "fdi", "codegen", str(MODELS / f"{name}.yaml"), "-o", str(out)],
                              cwd=root, env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        outs.append({p.name: p.read_bytes() for p in sorted(out.iterdir())})
    assert outs[0] == outs[1]


def test_the_driver_refuses_data_it_cannot_use(cycab_monitor, tmp_path):
    _, _, exe = cycab_monitor
    lines = (DATA / "nominal.csv").read_text().splitlines()[:200]
    header, rows = lines[0], lines[1:]
    slow = [f"{2 * float(r.split(',', 1)[0])!r},{r.split(',', 1)[1]}" for r in rows]
    cases = {"rate": ([header] + slow, "sampling time differs"),
             "nan": ([header] + rows[:50] + [rows[50].replace(rows[50].split(",")[2], "nan", 1)], "NaN"),
             "missing": ([header.replace("theta2", "angle")] + rows, "missing column theta2"),
             "text": ([header] + rows[:10] + [rows[10].replace(rows[10].split(",")[1], "x", 1)], "not a number")}
    for name, (text, words) in cases.items():
        csv = tmp_path / f"{name}.csv"
        csv.write_text("\n".join(text) + "\n")
        done = subprocess.run([str(exe), str(csv)], capture_output=True, text=True)
        assert done.returncode == 2 and words in done.stderr and len(done.stderr.strip().splitlines()) == 1, name


# ------------------------------------------------------------------ thresholds by mode

def test_thresholds_by_mode_divide_the_residual_in_c_as_in_python(tmp_path):
    """The EV precharge's link balance with a threshold by contactor state (fdi.mode_thresholds):
    the generated monitor divides it by its mode's threshold sample by sample, as Python does,
    on a run of the plant simulated apart from bgfdi (tests/precharge_plant.py)."""
    import re

    from . import precharge_plant as plant
    text = (Path(__file__).parent / "data" / "ev_precharge.yaml").read_text(encoding="utf-8")
    text = re.sub(r"^thresholds:.*\n", "", text, flags=re.M)
    model = tmp_path / "ev_precharge.yaml"
    model.write_text(text + "\nthresholds: {ARR1: {p=0 m=1: 480.0, p=1 m=0: 1.0, other: 0.75}, ARR2: 70.0}\n",
                     encoding="utf-8")
    monitor = compiled(model)
    assert monitor.units[0] == "1"
    p, exe = build(tmp_path, monitor)
    t, cols, _ = plant.simulate(T=4.0, seed=5, faults=[{"target": "Rp", "t0": 3.05, "value": 75.0}])
    found = check(monitor, p, exe, write_csv({"t": t, **cols}, tmp_path / "run.csv"))
    assert found["worst"][0] <= TOLERANCE


def test_a_switch_too_fast_for_the_samples_leaves_the_same_samples_out_in_c(tmp_path):
    """The drone's winding settles within a sample (fdi.scales.switch_settle: 3 samples and half the
    9-sample window left out after each switch, SWITCH_SETTLE in C): disarm stretches shorter than a
    window, about one, one and a half, and long ones, the residuals NaN at the same samples and equal
    elsewhere, on the trial's plant (tests/drone_plant.py)."""
    from fdi.calibrate import calibrate

    from . import drone_plant as plant
    source = Path(__file__).parent / "data" / "drone_propulsion.yaml"
    nominal = tmp_path / "nominal.csv"
    plant.run(str(nominal), seed=1, T=2.0)
    c = calibrate(str(source), [str(nominal)])
    model = tmp_path / "drone.yaml"
    model.write_text(source.read_text(encoding="utf-8") + "\nthresholds: {"
                     + ", ".join(f"{n}: {v!r}" for n, v in zip(c.names, c.thresholds)) + "}\n", encoding="utf-8")
    monitor = compiled(model)
    p, exe = build(tmp_path / "c", monitor)
    assert p.switch_settle == 3
    for k, disarm in enumerate([(1.5, 1.509), (1.5, 1.511), (1.5, 1.537), (1.0, 1.9955)]):
        csv = tmp_path / f"run{k}.csv"
        plant.run(str(csv), seed=5 + k, T=2.0, disarm=disarm)
        found = check(monitor, p, exe, csv)
        assert found["worst"].max() <= TOLERANCE
