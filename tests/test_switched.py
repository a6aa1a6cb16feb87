"""Switched systems as engineers write them: a PWM boost converter (models/boost_converter.yaml)
whose switch and diode are two controlled junctions, the diode's mode written as 1 - s.

References: the converter's circuit equations in each switch position (Erickson & Maksimovic,
Fundamentals of Power Electronics, ch. 2), written here by hand, and the converter integrated
from them by scipy (tests/independent/boost.py), apart from bgfdi. The one-causality diagnostic
hybrid bond graph gave the inductor's ARR 0 V at the switch node while the diode conducts; each
mode's own bond graph gives vo + Rd iL."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from bondgraph.errors import ModelError
from bondgraph.loader import load_model, load_model_text
from bondgraph.simulation import simulate as bg_simulate
from fdi.arrs import _select, select_arrs
from fdi.modewise import check_modes
from fdi.residuals import compile_residuals, evaluate

from .conftest import ROOT
from .independent import boost

MODEL = ROOT / "models" / "boost_converter.yaml"


def _signals(expr):
    return {f.func.__name__: f for f in expr.atoms(sp.core.function.AppliedUndef)}


def test_each_mode_has_the_converters_circuit_equations():
    m = load_model(MODEL)
    arrs = {a.sensor: a for a in select_arrs(m).arrs}
    sig = _signals(arrs["iL"].expr) | _signals(arrs["vo"].expr)
    i, v, vin = sig["iL"], sig["vo"], sig["Vin"]
    t = i.args[0]
    p = m.symbols
    i, v, vin = i / p["beta_iL"], v / p["beta_vo"], vin * p["beta_Vin"]
    hand = {1: (vin - (p["rL"] + p["Ron"]) * i - p["L"] * sp.diff(i, t), -p["Co"] * sp.diff(v, t) - v / p["Rload"]),
            0: (vin - (p["rL"] + p["Rd"]) * i - v - p["L"] * sp.diff(i, t), i - p["Co"] * sp.diff(v, t) - v / p["Rload"])}
    for s, (inductor, capacitor) in hand.items():
        at = {p["s"]: s}
        assert sp.simplify(arrs["iL"].expr.xreplace(at) - inductor) == 0
        assert sp.simplify(arrs["vo"].expr.xreplace(at) - capacitor) == 0


def test_the_one_causality_form_is_found_wrong_while_the_diode_conducts():
    m = load_model(MODEL)
    one = list(_select(m).arrs)           # the diagnostic hybrid bond graph's single causality
    _, checks = check_modes(m, one)
    wrong = {(c.arr, c.mode["s"]) for c in checks if not c.holds}
    assert wrong and all(s == 0 for _, s in wrong)
    assert all(c.error > 0.1 for c in checks if not c.holds)


def test_the_residuals_vanish_on_the_independent_simulation_and_a_capacitor_fault_moves_them():
    m = load_model(MODEL)
    arrs = list(select_arrs(m).arrs)
    kernels = compile_residuals(m, arrs)
    clean = boost.simulate(0.003)
    r = evaluate(m, kernels, clean, 1.0e-6, values={"s": clean["s_cmd"]}, window=1.0e-5)[:, 100:-100]
    ok = np.isfinite(r)
    assert ok.mean() > 0.5                       # only stretches shorter than the window are skipped
    # 24 V and 4 A: what is left is the derivative filter's bias, far under the noise
    assert np.max(np.abs(r[0][ok[0]])) < 0.01 and np.max(np.abs(r[1][ok[1]])) < 0.01
    aged = boost.simulate(0.003, changes={"Co": (0.0015, 0.5e-4)})
    r2 = evaluate(m, kernels, aged, 1.0e-6, values={"s": aged["s_cmd"]}, window=1.0e-5)[:, 1600:-100]
    # a halved output capacitor: the output balance (ARR2) moves by Co/2 * dvo/dt, amps; the
    # inductor's (ARR1) does not
    assert np.nanmax(np.abs(r2[1])) > 1.0 and np.nanmax(np.abs(r2[0])) < 0.01


def test_bgfdi_simulates_each_switch_position_as_the_independent_simulator():
    m = load_model(MODEL)
    t = np.round(np.arange(0.0, 0.002 + 0.5e-6, 1.0e-6), 12)
    edges = [k * 2.5e-5 for k in range(1, 80)]
    traj = bg_simulate(m, t, values=_pwm_values(m), breakpoints=edges, vectorised=True)
    ref = boost.simulate(0.002)
    assert np.max(np.abs(traj.signals["vo"] - ref["vo"])) < 0.02 * np.max(ref["vo"])
    assert np.max(np.abs(traj.signals["iL"] - ref["iL"])) < 0.02 * np.max(np.abs(ref["iL"]))


@pytest.mark.parametrize("mode, message", [
    ("2*s", "is 2 at s=1"),
    ("1 - q", "undefined symbol 'q'"),
    ("1", "uses no mode variable"),
])
def test_a_junction_mode_must_be_zero_or_one_in_every_combination(mode, message):
    text = MODEL.read_text().replace('mode: "1 - s"', f'mode: "{mode}"')
    with pytest.raises(ModelError, match=message) as info:
        load_model_text(text, "boost.yaml")
    assert "junctions.diode.mode" in str(info.value)


def test_switched_off_takes_all_or_outputs():
    text = MODEL.read_text().replace('diode:  {type: 1c, mode: "1 - s",', 'diode:  {type: 1c, mode: "1 - s", switched_off: open,')
    with pytest.raises(ModelError, match="switched_off must be all or outputs"):
        load_model_text(text, "boost.yaml")


def test_an_algebraic_loop_is_solved_while_switch_and_diode_both_conduct():
    """Both branches on at once (the diode given its own mode, held at 1 with the switch): the
    switch node sits between two resistors with no storage, a linear algebraic loop the simulator
    solves with the state derivatives. Reference: node voltage v0 = (iL + vo/Rd)/(1/Ron + 1/Rd)."""
    from scipy.integrate import solve_ivp

    text = MODEL.read_text().replace('mode: "1 - s"', "mode: d").replace(
        "modes:\n", "modes:\n  d: {nominal: 1, description: diode held conducting}\n")
    m = load_model_text(text, "both_on.yaml")
    p = {k: v for k, v in boost.NOMINAL.items()}
    t = np.round(np.arange(0.0, 0.002 + 0.5e-6, 1.0e-6), 12)
    nominal = {s.name: float(v) for s, v in m.nominal_values().items()}
    traj = bg_simulate(m, t, values=lambda tt: nominal)

    def rhs(_t, y):
        i, v = y
        v0 = (i + v / p["Rd"]) / (1 / p["Ron"] + 1 / p["Rd"])
        return [(p["Vin"] - p["rL"] * i - v0) / p["L"], ((v0 - v) / p["Rd"] - v / p["Rload"]) / p["Co"]]
    ref = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, method="LSODA").y
    assert np.max(np.abs(traj.signals["iL"] - ref[0])) < 1e-5 * np.max(np.abs(ref[0]))
    assert np.max(np.abs(traj.signals["vo"] - ref[1])) < 1e-4 * np.max(np.abs(ref[1]))


DCM = ROOT / "tests" / "data" / "boost_dcm.yaml"


def _pwm_values(m):
    """The parameters at nominal and the switch following the 20 kHz PWM of the independent
    simulator (on in the first half of each 50 us period)."""
    nominal = {s.name: float(v) for s, v in m.nominal_values().items()}

    def values(tt):
        out = dict(nominal)
        out["s"] = np.where((np.asarray(tt) % 5e-5) < 2.5e-5, 1.0, 0.0) if np.ndim(tt) else \
            float((tt % 5e-5) < 2.5e-5)
        return out
    return values


def test_a_diode_that_blocks_when_its_current_ends_is_an_autonomous_mode():
    """Discontinuous conduction (tests/data/boost_dcm.yaml, diode mode c*(1 - s), c: positive: iL):
    bgfdi's simulator switches the diode off where the current reaches zero, within one sample of
    the independent simulation's located event; the residuals, with c read off the measured
    current, vanish in all three phases (switch on, diode on, both off)."""
    m = load_model(DCM)
    assert m.modes["c"].autonomous and not m.modes["s"].autonomous
    t = np.round(np.arange(0.0, 0.003 + 0.5e-6, 1.0e-6), 12)
    traj = bg_simulate(m, t, values=_pwm_values(m), breakpoints=[k * 2.5e-5 for k in range(1, 120)],
                       vectorised=True)
    ref = boost.simulate_dcm(0.003, p={"L": 2.0e-5, "Rload": 100.0})
    assert np.sum(ref["iL"] == 0.0) > 0.2 * t.size                # it is discontinuous
    assert np.max(np.abs(traj.signals["iL"] - ref["iL"])) < 0.01 * np.max(ref["iL"])
    assert np.max(np.abs(traj.signals["vo"] - ref["vo"])) < 0.01 * np.max(ref["vo"])
    from fdi.data import autonomous_modes
    raw = dict(ref)
    raw["s"] = ref["s_cmd"]
    raw.update(autonomous_modes(m, raw))
    kernels = compile_residuals(m, list(select_arrs(m).arrs))
    r = evaluate(m, kernels, raw, 1.0e-6, values={"s": raw["s"], "c": raw["c"]}, window=1.0e-5)[:, 100:-100]
    ok = np.isfinite(r)
    assert ok.mean() > 0.4
    assert np.max(np.abs(r[ok])) < 0.05


def test_an_autonomous_condition_that_reads_a_mode_variable_is_refused_at_its_key():
    """A user trial's thermostat opened on "fan - 0.5": "undefined symbol 'fan' ...; define it under
    ... modes", where fan was a mode. The condition reads signals only; the line says so."""
    text = DCM.read_text(encoding="utf-8").replace('positive: "iL"', 'positive: "iL - s"')
    with pytest.raises(ModelError) as e:
        load_model_text(text, "dcm.yaml")
    assert e.value.where == "modes.c.positive" and "reads the mode variable(s) s" in str(e.value)
    assert "undefined symbol" not in str(e.value)


def test_verification_passes_the_rebuilt_residuals_and_fails_the_one_causality_form_while_the_diode_conducts():
    from fdi.verify import verify
    m = load_model(MODEL)
    good = verify(m, seed=1)
    assert good.ok and good.complete
    bad = verify(m, list(_select(m).arrs), seed=1)
    assert not bad.ok
    assert {c.mode_text for c in bad.failures} == {"s=0"}


def test_an_autonomous_condition_that_reads_the_time_is_refused_saying_what_a_timed_mode_is():
    """A user trial's bump stop written "t - 30" was told "undefined symbol 't' ..." (and elsewhere
    "did you mean 'kt'?"): a mode that switches at given times is a commanded one."""
    text = DCM.read_text(encoding="utf-8").replace('positive: "iL"', 'positive: "t - 30"')
    with pytest.raises(ModelError) as e:
        load_model_text(text, "dcm.yaml")
    assert e.value.where == "modes.c.positive" and "reads the time t" in str(e.value)
    assert "a commanded one" in str(e.value) and "undefined symbol" not in str(e.value)
    text = DCM.read_text(encoding="utf-8").replace('positive: "iL"', 'positive: "iL - 0.01*tanh(iL)"')
    load_model_text(text, "dcm.yaml")                   # a name that merely contains t is no time
