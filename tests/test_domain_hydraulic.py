"""A hydraulic actuator with a metering orifice and internal leakage
(models/hydraulic_actuator.yaml): pump, supply line, a sign-sqrt orifice, a leaking chamber and a
piston on a spring-loaded mass; both pressures and the position measured. References: the supply,
chamber and piston balances by hand (Karnopp, Margolis & Rosenberg ch. 10; Merritt ch. 3), and data
from tests/independent/hydraulic.py, a scipy simulation of the state equations written apart from
bgfdi, with designed faults injected there.

Diagnoses run with candidate sets of one fault (two for the orifice, below) to keep this file near
15 s; the default search (up to three) gives the same answers on these runs."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from fdi.app.scenario import parse_scenario, run
from fdi.arrs import arr_unit, select_arrs
from fdi.calibrate import calibrate, nominal_residuals
from fdi.config import load
from fdi.data import Measurements
from fdi.api import Options, diagnose

from .conftest import MODELS
from .independent import hydraulic
from .independent.faults import Fault, drift

MODEL = MODELS / "hydraulic_actuator.yaml"
T0 = 4.0                               # fault onsets


def _data(name: str, seed: int, *faults: Fault) -> Measurements:
    cols = hydraulic.simulate(faults=faults, seed=seed)
    return Measurements(name, cols["t"], cols)


def _diagnose(data: Measurements, max_set: int = 1) -> dict:
    return diagnose(str(MODEL), data, Options(workers=1, seed=0, max_set=max_set)).to_dict()


def test_the_model_file_describes_the_simulated_actuator():
    model, _ = load(MODEL)
    assert {k: p.value for k, p in model.parameters.items()} == hydraulic.NOMINAL
    assert list(model.columns) == hydraulic.COLUMNS
    assert {n: s.noise[n] for n, s in model.sensors.items()} == hydraulic.NOISE


def _hand_balances(model):
    arrs = {a.name: a for a in select_arrs(model).arrs}
    sig = {f.func.__name__: f for a in arrs.values() for f in a.expr.atoms(sp.core.function.AppliedUndef)}
    t = sig["ps"].args[0]
    s = {n: model.symbols[n] for n in hydraulic.NOMINAL}
    ps, pc, x = (sig[n] / model.symbols[f"beta_{n}"] for n in ("ps", "pc", "x"))     # true values
    pump = model.symbols["beta_Qp"] * sig["Qp"]
    dp = ps - pc
    orifice = s["Kv"] * sp.sign(dp) * sp.sqrt(sp.Abs(dp))                           # Merritt's orifice law
    d = lambda e, k=1: sp.diff(e, t, k)                                               # noqa: E731
    supply = pump - s["Cs"] * d(ps) - orifice                                         # supply line
    piston = s["A"] * pc - s["m"] * d(x, 2) - s["b"] * d(x) - s["k"] * x              # Newton on the mass

    def chamber(Cc):                                                                  # oil volume balance
        return orifice - d(Cc * pc) - pc / s["Rl"] - s["A"] * d(x)
    return arrs, s, t, supply, chamber, piston


def test_the_residuals_are_the_supply_and_chamber_balances():
    """The supply line's and the chamber's oil balances, and their sum (the orifice eliminated):
    every candidate fault is hydraulic, so no residual of the piston's mechanics (Newton,
    differentiated to a third derivative of the position) is needed; residuals of the lowest
    derivative order are preferred (fdi.selection)."""
    model, _ = load(MODEL)
    arrs, s, t, supply, chamber, piston = _hand_balances(model)
    assert not any(a.expr.has(sp.DiracDelta) for a in arrs.values())
    assert sp.simplify(arrs["ARR1"].expr - supply) == 0
    assert sp.simplify(arrs["ARR2"].expr - chamber(s["Cc"])) == 0
    assert sp.simplify(arrs["ARR3"].expr - (supply + chamber(s["Cc"]))) == 0       # the orifice eliminated
    Cc_t = sp.Function("Cc_t")(t)                  # a chamber compliance that changes: d/dt(Cc pc) whole
    exact = arrs["ARR3"].exact.xreplace({s["Cc"]: Cc_t}).doit()
    assert sp.simplify(exact - (supply + chamber(Cc_t))) == 0


def test_the_residuals_units():
    model, _ = load(MODEL)
    arrs = {a.name: a for a in select_arrs(model).arrs}
    assert [arr_unit(model, arrs[n]) for n in ("ARR1", "ARR2", "ARR3")] == ["m^3/s", "m^3/s", "m^3/s"]


def _simulated(faults: list[Fault], method: str) -> tuple[dict, dict]:
    model, _ = load(MODEL)
    events = [{"target": f.target, "type": "abrupt", "t0": f.t0, "value": f.value} for f in faults]
    scenario = {"seed": 0, "T": 8.0, "fs": 2.0e3, "faults": events, "noise": {c: 0.0 for c in hydraulic.NOISE}}
    ours = run(model, parse_scenario(scenario, model, "quiet"), method=method)
    return ours, hydraulic.simulate(faults=tuple(faults), noise={})


SIMULATED = {"nominal": [], "clogged": [Fault("Kv", "abrupt", T0, 4.0e-8)],
             "aerated": [Fault("Cc", "abrupt", T0, 1.44e-12)]}     # a storage fault: the oil volume is kept


@pytest.mark.parametrize("case", SIMULATED)
def test_bgfdi_simulation_agrees_with_the_independent_simulator(case):
    # LSODA: measured within 0.03 of the noise; the nominal run with the default (ROS2) below
    ours, ref = _simulated(SIMULATED[case], "LSODA")
    assert np.array_equal(ours["t"], ref["t"])
    for name in hydraulic.NOISE:
        assert np.abs(ours[name] - ref[name]).max() < 0.1 * hydraulic.NOISE[name], name


def test_the_default_integrator_agrees_on_the_nominal_run():
    ours, ref = _simulated([], "auto")                # measured: ps 142 Pa, x 1.1e-7 m
    for name in hydraulic.NOISE:
        assert np.abs(ours[name] - ref[name]).max() < 0.25 * hydraulic.NOISE[name], name


@pytest.mark.xfail(strict=True, reason="issue 20 (found here): `auto` picks ROS2 for the orifice's sign-sqrt law; "
                   "after an abrupt change of Cc the 380 rad/s oil-spring resonance it excites comes out, 20 ms "
                   "after the onset, x 4.6 um and pc 2.9 kPa off (noise 1 um, 5 kPa) at ROS2's step of a twentieth "
                   "of the fastest time constant, 0.13 ms (at the sampling interval, 0.5 ms, it was 66 um and "
                   "41 kPa); LSODA and Radau agree. The error goes as the step squared (a fortieth: x 1.1 um, pc "
                   "0.7 kPa, measured 2026-11-29): the bound needs about an 85th, four times the steps of every "
                   "nonsmooth model; the remedy is error control or a third-order method")
def test_the_default_integrator_agrees_after_a_storage_fault():
    ours, ref = _simulated(SIMULATED["aerated"], "auto")
    for name in hydraulic.NOISE:
        assert np.abs(ours[name] - ref[name]).max() < 0.25 * hydraulic.NOISE[name], name


def test_thresholds_from_two_nominal_runs_raise_no_alarm_on_a_third():
    runs = [_data(f"nominal{s}", s) for s in (1, 2, 3)]
    cal = calibrate(str(MODEL), runs[:2])
    held_out = nominal_residuals(str(MODEL), runs[2])
    assert (held_out.max(axis=1) < np.asarray(cal.thresholds)).all()
    thresholds = dict(zip(cal.names, cal.thresholds))
    report = diagnose(str(MODEL), runs[2], Options(workers=1, thresholds=thresholds)).to_dict()
    assert report["detection"] is None


# The orifice's abrupt clogging kinks both pressures; the Savitzky-Golay derivatives smear the kink
# over the window, and ARR3 (which holds no Kv) crosses its threshold around the onset: the decision
# sees [1 0 1], whose single-fault explanation is the pump. With pairs, {Kv, beta_Qp} fits and
# beta_Qp comes out at 1, dropped as insignificant.
ABRUPT = [(Fault("Kv", "abrupt", T0, 4.0e-8), 2),        # orifice clogged by 20 %
          (Fault("Rl", "abrupt", T0, 8.0e10), 1),        # internal leakage 25 % up
          (Fault("beta_pc", "abrupt", T0, 0.9), 1),      # chamber transducer reads 10 % low
          (Fault("beta_Qp", "abrupt", T0, 0.85), 1)]     # pump delivers 15 % less


@pytest.mark.parametrize("fault, max_set", ABRUPT, ids=[f.target for f, _ in ABRUPT])
def test_an_abrupt_fault_is_detected_isolated_and_sized(fault, max_set):
    _, config = load(MODEL)
    report = _diagnose(_data(fault.target, 10, fault), max_set)
    window, half_window = config.derivative_window, config.derivative_window / 2
    # centred filters see a fault early; a term differentiated whole (d/dt(Cc pc)) is filtered twice
    assert T0 - window - 1e-3 <= report["detection"]["time"] <= T0 + 0.05
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault.target, "abrupt")
    assert found["value"] == pytest.approx(fault.value, rel=0.05)
    assert found["t0"] == pytest.approx(T0, abs=half_window)


def _check_drift(fault: Fault, report: dict, nominal: float) -> dict:
    assert T0 <= report["detection"]["time"] <= T0 + 0.15
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault.target, "incipient")
    end = report["window"][1]
    truth = nominal * math.exp(fault.rate * (end - T0))
    fitted = drift(nominal, found["model"], found["b"], end - found["t0"])
    assert abs(fitted - truth) <= 0.05 * abs(truth - nominal)      # 5 % of the change over the data
    return found


def test_a_spreading_leak_is_typed_incipient_and_sized():
    fault = Fault("Rl", "incipient", T0, rate=-0.2)                # Rl falls 10 % in 0.5 s
    _check_drift(fault, _diagnose(_data("leak drift", 10, fault)), hydraulic.NOMINAL["Rl"])


def test_pump_wear_is_typed_incipient_sized_and_its_life_predicted():
    fault, failure = Fault("beta_Qp", "incipient", T0, rate=-0.05), 0.7    # 70 % of the flow at 11.13 s
    report = _diagnose(_data("pump wear", 10, fault))
    _check_drift(fault, report, 1.0)
    (life,) = report["prognosis"]
    eol = T0 + math.log(failure) / fault.rate
    assert (life["name"], life["failure"]) == ("beta_Qp", failure)
    assert life["rul"] == pytest.approx(eol - life["at"], rel=0.05)


def test_a_drifting_chamber_transducer_is_found():
    """A drifting chamber transducer lights ARR1 and ARR3 and leaves ARR2 (where pc enters as
    A dpc/dt / k) ten times under its threshold: exonerated by signature alone, beta_pc was lost
    and the pump blamed; isolation aware of sensitivity (fdi.sensitivity) keeps it."""
    fault = Fault("beta_pc", "incipient", T0, rate=-0.05)
    _check_drift(fault, _diagnose(_data("transducer drift", 10, fault)), 1.0)
