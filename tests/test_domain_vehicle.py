"""A domain no shipped model covers: a car's longitudinal dynamics on a level road
(tests/data/car_longitudinal.yaml: the traction force known, the speed measured; a quadratic
aerodynamic drag and a Coulomb rolling resistance), data from tests/independent/car.py (scipy,
Newton's law typed by hand). References: the law by hand (Gillespie), the time constant at cruising
speed by hand, nominal runs that raise no alarm, and designed faults: a roof box (drag up 40 %) and
a speed sensor reading 5 % low, told apart by their fits though the one residual reads both.

The model's time constant depends on where it is linearised: at rest the drag has no slope and the
rolling resistance jumps (differenced, a spurious 7e-13 s), at 25 m/s it is m / (2 kd v) = 76 s.
The file gives that operating point (``initial``); without it, calibrate says the rule's window
follows nothing the data show, and what to do."""
from __future__ import annotations

import json
import re
from functools import partial
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from bondgraph.loader import load_model_text
from bondgraph.timescales import time_scales
from fdi.api import Options, diagnose
from fdi.monitor import compiled

from .independent import by_hand, car, measurements, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "car_longitudinal.yaml")
T0 = 500.0

_data = partial(measurements, car.simulate)
thresholds = thresholds_fixture(MODEL, car.simulate)


def test_the_residual_is_newtons_law_along_the_road():
    (arr,) = compiled(MODEL).arrs
    expr, sym, sig = by_hand(arr.expr)
    t = sig["v"].args[0]
    m, kd, Fr, F, v = sym["m"], sym["kd"], sym["Fr"], sig["F"], sig["v"]
    assert sp.simplify(expr - (F - m * sp.diff(v, t) - kd * v * sp.Abs(v) - Fr * sp.sign(v))) == 0


def _variant(drop: str = "", column_only: bool = False):
    text = Path(MODEL).read_text(encoding="utf-8")
    if drop:
        text = text[:text.index(drop)]
    if column_only:
        expr = 'expr: "400 + 250*sin(2*pi*t/90) + 150*sin(2*pi*t/23)",'
        assert expr in text
        text = text.replace(expr, "")
    return load_model_text(text, "car.yaml")


def test_the_time_constant_is_the_cruising_cars_and_none_at_rest():
    kd, m, v = car.NOMINAL["kd"], car.NOMINAL["m"], 25.0
    assert time_scales(_variant()).fastest == pytest.approx(m / (2 * kd * v), rel=1e-4)   # 75.76 s by hand
    at_rest = time_scales(_variant(drop="# At rest"))      # the rolling resistance's jump, differenced
    assert at_rest.fastest < 1e-9
    # the force given by its column only: a nonlinear model is not linearised with its inputs held
    # at 0 (its slopes may depend on them), so no time constant is known and calibrate says why
    measured = time_scales(_variant(column_only=True))
    assert not measured.known and "input 'F' has no expr" in measured.notes[0]


def test_calibrate_says_when_the_rule_has_no_time_constant_to_follow(tmp_path, capsys):
    from fdi.app.cli import main
    text = Path(MODEL).read_text(encoding="utf-8")
    model = tmp_path / "car_at_rest.yaml"
    model.write_text(text[:text.index("# At rest")], encoding="utf-8")
    runs, speeds = [], []
    for seed in (1, 2):
        cols = car.simulate(seed, T=200.0)
        speeds.append(cols["v"])
        path = tmp_path / f"nominal{seed}.csv"
        np.savetxt(path, np.column_stack([cols["t"], cols["F"], cols["v"]]), delimiter=",", header="t,F,v",
                   comments="", fmt="%.10g")
        runs.append(str(path))
    assert main(["calibrate", str(model), *runs, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["window_samples"] == 9 and "below a hundredth of a sample" in out["blind"][0]
    # what the runs say to give as initial: the speed's median, and the time constant there by hand
    speed = float(np.median(np.concatenate(speeds)))
    hint = re.fullmatch(r"at the runs' medians, initial: \{v: ([\d.]+)\}, the fastest time constant is ([\d.]+) s",
                        out["blind"][1])
    assert float(hint.group(1)) == pytest.approx(speed, rel=1e-3)
    assert float(hint.group(2)) == pytest.approx(car.NOMINAL["m"] / (2 * car.NOMINAL["kd"] * speed), rel=2e-3)
    assert main(["calibrate", str(model), *runs]) == 0
    assert "note: the rule's window follows no time constant of the data" in capsys.readouterr().out
    assert main(["calibrate", MODEL, *runs, "--json"]) == 0              # with the operating point: known
    out = json.loads(capsys.readouterr().out)
    assert out["blind"] == [] and out["window_samples"] == 101           # 76 s / 2, at most 101 samples


@pytest.mark.parametrize("which, factor, seed", [("kd", 1.4, 4), ("beta_v", 0.95, 6)])
def test_a_roof_box_and_a_speed_sensor_reading_low_are_found_and_sized(thresholds, which, factor, seed):
    report = diagnose(MODEL, _data(which, seed, t0=T0, factor=factor, which=which),
                      Options(workers=1, seed=0, thresholds=thresholds, max_set=1)).to_dict()
    assert T0 - 5.1 <= report["detection"]["time"] < T0 + 10.0      # half the 10.1 s window before
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (which, "abrupt")
    assert found["value"] == pytest.approx(car.NOMINAL.get(which, 1.0) * factor, rel=0.01)
    assert found["t0"] == pytest.approx(T0, abs=5.1)


def test_calibrate_names_why_the_rule_has_no_time_constant():
    """A mass pushed by a force, its speed measured: linearised, it has an integrator only (m v' =
    F): no time constant, and calibrate says it is the integrator, not a failed linearisation."""
    from fdi.calibrate import _blind
    text = """
parameters: {m: {value: 2.0, unit: kg}}
inputs: {F: {column: F, expr: "1.0", unit: N}}
elements: {push: {type: MSe, input: F}, mass: {type: I, parameter: m}}
junctions: {J: {type: "1"}}
sensors: {v: {type: Df, junction: J, unit: m/s}}
bonds: {1: [push, J], 2: [J, mass]}
"""
    scales = time_scales(load_model_text(text, "mass.yaml"))
    assert not scales.known and scales.eigenvalues
    assert "integrators only" in _blind(scales, 0.01)[0]
    assert _blind(time_scales(_variant()), 0.1) == ()                        # 76 s against 0.1 s samples
    assert "below a hundredth of a sample" in _blind(time_scales(_variant(drop="# At rest")), 0.1)[0]
