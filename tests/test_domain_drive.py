"""An electromechanical drive with a flexible shaft (models/electromechanical_drive.yaml): a DC motor,
gearbox and a compliant, damped shaft to a load; current and both speeds measured. References: the
motor, rotor and shaft equations by hand (Karnopp, Margolis & Rosenberg, Sec. 8.2 and ch. 4), and
data from tests/independent/drive.py, a scipy simulation of the four state equations written apart
from bgfdi, with designed faults injected there.

Diagnoses run under the single-fault hypothesis (``max_set=1``) to keep this file near 15 s; the
default search (sets of up to three) gives the same answers on these runs (measured with
``bgfdi diagnose``: Ra 1.3000, beta_u 0.8500, beta_i 0.8000, bL 0.0150), 10 to 80 s each."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from fdi.app.scenario import parse_scenario, run
from fdi.arrs import select_arrs
from fdi.calibrate import calibrate, nominal_residuals
from fdi.config import load
from fdi.data import Measurements
from fdi.api import Options, diagnose

from .conftest import MODELS
from .independent import drive
from .independent.faults import Fault, drift

MODEL = MODELS / "electromechanical_drive.yaml"
T0 = 1.3                               # fault onsets, after the 1 s that detection ignores


def _data(name: str, seed: int, *faults: Fault) -> Measurements:
    cols = drive.simulate(faults=faults, seed=seed)
    return Measurements(name, cols["t"], cols)


def test_the_model_file_describes_the_simulated_drive():
    model, _ = load(MODEL)
    assert {k: p.value for k, p in model.parameters.items()} == drive.NOMINAL
    assert list(model.columns) == drive.COLUMNS
    assert {n: s.noise[n] for n, s in model.sensors.items()} == drive.NOISE


def test_the_residuals_are_the_armature_torque_and_shaft_equations():
    model, _ = load(MODEL)
    arrs = {a.name: a for a in select_arrs(model).arrs}
    sig = {f.func.__name__: f for a in arrs.values() for f in a.expr.atoms(sp.core.function.AppliedUndef)}
    i, wm, wL, u = sig["i"], sig["wm"], sig["wL"], sig["u"]
    t = i.args[0]
    s = {n: model.symbols[n] for n in ("Ra", "La", "K", "Jm", "bm", "n", "ks", "ds", "JL", "bL")}
    bi, bwm, bwL, bu = (model.symbols[f"beta_{n}"] for n in ("i", "wm", "wL", "u"))
    cur, speed, load_speed = i / bi, wm / bwm, wL / bwL                       # true values
    d = lambda x: sp.diff(x, t)                                               # noqa: E731
    armature = bu * u - s["Ra"] * cur - s["La"] * d(cur) - s["K"] * speed    # voltage round the loop
    motor_torque = s["n"] * (s["K"] * cur - s["Jm"] * d(speed) - s["bm"] * speed)   # shaft torque, motor side
    load_torque = s["JL"] * d(load_speed) + s["bL"] * load_speed             # shaft torque, load side
    armature_speed = (bu * u - s["Ra"] * cur - s["La"] * d(cur)) / s["K"]   # wm from the armature loop
    twist_rate = armature_speed / s["n"] - load_speed

    def spring(ks):                                                          # twist rate = d/dt(spring torque/ks)
        return twist_rate - sp.diff((load_torque - s["ds"] * twist_rate) / ks, t)

    assert sp.simplify(arrs["ARR2"].expr - armature) == 0
    assert sp.simplify(arrs["ARR3"].expr - (motor_torque - load_torque) / s["n"]) == 0
    assert sp.simplify(arrs["ARR1"].expr - spring(s["ks"])) == 0
    # a stiffness that changes: the residual must differentiate the twist (torque/ks) whole
    ks_t = sp.Function("ks_t")(t)
    exact = arrs["ARR1"].exact.xreplace({s["ks"]: ks_t}).doit()        # xreplace: into the d/dt too
    assert sp.simplify(exact - spring(ks_t)) == 0


@pytest.mark.parametrize("faults", [(), (Fault("ks", "abrupt", T0, 25.0),)], ids=["nominal", "cracked"])
def test_bgfdi_simulation_agrees_with_the_independent_simulator(faults):
    # a stiffness fault is a storage fault: both keep the twist (the C's q) and let the torque jump
    model, _ = load(MODEL)
    events = [{"target": f.target, "type": "abrupt", "t0": f.t0, "value": f.value} for f in faults]
    scenario = {"seed": 0, "T": 2.0, "fs": 1.0e4, "faults": events, "noise": {c: 0.0 for c in drive.NOISE}}
    ours = run(model, parse_scenario(scenario, model, "quiet"))
    t, (i, wm, th, wL) = drive.states(2.0, 1.0e4, faults)
    assert np.array_equal(ours["t"], t)
    for name, ref in (("i", i), ("wm", wm), ("wL", wL)):     # measured: 1e-3 of the sensor noise
        assert np.abs(ours[name] - ref).max() < 0.1 * drive.NOISE[name], name


def test_thresholds_from_two_nominal_runs_raise_no_alarm_on_a_third():
    runs = [_data(f"nominal{s}", s) for s in (1, 2, 3)]
    cal = calibrate(str(MODEL), runs[:2])
    held_out = nominal_residuals(str(MODEL), runs[2])
    assert (held_out.max(axis=1) < np.asarray(cal.thresholds)).all()
    thresholds = dict(zip(cal.names, cal.thresholds))
    report = diagnose(str(MODEL), runs[2], Options(workers=1, thresholds=thresholds)).to_dict()
    assert report["detection"] is None


ABRUPT = [Fault("Ra", "abrupt", T0, 1.3),          # winding 30 % up
          Fault("ks", "abrupt", T0, 25.0),         # shaft stiffness halved (a crack)
          Fault("bL", "abrupt", T0, 1.5e-2),       # load bearing friction tripled
          Fault("beta_i", "abrupt", T0, 0.8),      # current sensor reads 20 % low
          Fault("beta_wm", "abrupt", T0, 0.9),     # motor encoder 10 % low
          Fault("beta_u", "abrupt", T0, 0.85)]     # amplifier delivers 15 % less


@pytest.mark.parametrize("fault", ABRUPT, ids=lambda f: f.target)
def test_an_abrupt_fault_is_detected_isolated_and_sized(fault):
    model, config = load(MODEL)
    report = diagnose(str(MODEL), _data(fault.target, 10, fault), Options(workers=1, seed=0, max_set=1)).to_dict()
    window, half_window = config.derivative_window, config.derivative_window / 2
    # centred filters see a fault early; a term differentiated whole (d/dt(Cc pc)) is filtered twice
    assert T0 - window - 1e-3 <= report["detection"]["time"] <= T0 + 0.06
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault.target, "abrupt")
    assert found["value"] == pytest.approx(fault.value, rel=0.05)
    assert found["t0"] == pytest.approx(T0, abs=half_window)


DRIFTS = [Fault("Ra", "incipient", T0, rate=0.2),        # Ra = exp(0.2 (t - 1.3)): fails (2 Ohm) at 4.77 s
          Fault("beta_i", "incipient", T0, rate=-0.2)]   # the current sensor's gain sinks 10 % in 0.5 s


@pytest.mark.parametrize("fault", [pytest.param(f, marks=pytest.mark.slow) if f.target == "Ra" else f for f in DRIFTS],
                         ids=lambda f: f.target)                                # Ra: 15 s (--durations)
def test_a_drift_is_typed_incipient_sized_and_its_life_predicted(fault):
    _, config = load(MODEL)
    report = diagnose(str(MODEL), _data(f"{fault.target} drift", 10, fault), Options(workers=1, seed=0, max_set=1)).to_dict()
    assert T0 <= report["detection"]["time"] <= T0 + 0.05
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault.target, "incipient")
    nominal = drive.NOMINAL.get(fault.target, 1.0)
    end = report["window"][1]
    truth = nominal * math.exp(fault.rate * (end - T0))
    fitted = drift(nominal, found["model"], found["b"], end - found["t0"])
    assert abs(fitted - truth) <= 0.05 * abs(truth - nominal)      # 5 % of the change over the data
    failure = config.failure(fault.target)
    if failure is None:
        assert report["prognosis"] == []
        return
    (life,) = report["prognosis"]
    eol = T0 + math.log(failure / nominal) / fault.rate
    assert (life["name"], life["failure"]) == (fault.target, failure)
    assert life["rul"] == pytest.approx(eol - life["at"], rel=0.05)
