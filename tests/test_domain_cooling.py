"""An engine cooling circuit, a thermal pseudo bond graph (a user trial's model and plant).

Temperature is the effort (K), heat flow the flow (W): the engine block's and the radiator's heat
capacities, a wax thermostat opening the radiator branch above 85 degC (an autonomous mode), a
fan the ECU switches with hysteresis (a commanded mode), the radiator's conductance to ambient.
Data from the trial's plant, simulated apart from bgfdi (tests/cooling_plant.py); thresholds and
the derivative window from ``bgfdi calibrate --window auto`` on three of its fault-free runs.

A fan that dies while commanded on halves the radiator's conductance. The fan's switching on
40 s earlier put two residuals above their thresholds for 4 s, unconfirmed; the failure's
excursion confirmed 19 s of quiet later, inside the evidence span, so t_D is the switch's
excursion, and every onset searched ended half a window after it: the fault mode fitted from
579 s worse than a radiator fouling drift that "reached its failure value" (a user would have
replaced a clean radiator). The onsets now reach half a window past the confirming excursion
(fdi.detect.excursion_start).
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from fdi.api import diagnose
from fdi.options import Options

from . import cooling_plant as plant

MODEL = Path(__file__).parent / "data" / "engine_cooling.yaml"


@pytest.mark.slow
def test_a_fan_that_dies_while_commanded_on_is_the_fan_from_its_failure(tmp_path):
    path = tmp_path / "fan_dead.csv"
    t, cmd = plant.run(str(path), seed=14, T=800.0, fan_dead=600.0)
    assert cmd[(t >= 560.0) & (t <= 700.0)].all()           # commanded on from before the failure to past the window
    d = diagnose(str(MODEL), str(path), Options(workers=1))
    assert d.detection is not None and d.detection.time < 580.0    # t_D: the switch's excursion (the test's point)
    (fault,) = d.faults
    assert fault.name == "fan_dead" and 599.0 <= fault.t0 <= 601.5, d.faults


def test_calibrating_at_the_rules_window_says_how_large_a_change_each_fault_needs(tmp_path):
    """The rule's window (half the fastest time constant: the radiator's, 2.2 s) differentiates the
    engine's 45 kJ/K heat capacity over 23 noisy samples; its thresholds are tens of kW and the
    pump's wear needs a change over 10 % to be seen, which a calibration at it did not say (a user
    trial: 28.8 kW, three quarters of the engine's heat). It says so now, with --window auto's
    score of the same window, and names the option."""
    from fdi.calibrate import calibrate, format_calibration

    runs = []
    for seed in (1, 2):
        path = tmp_path / f"nominal{seed}.csv"
        plant.run(str(path), seed=seed, T=600.0)
        runs.append(str(path))
    text = re.sub(r"^(thresholds|diagnosis):.*\n", "", MODEL.read_text(encoding="utf-8"), flags=re.M)
    model = tmp_path / "cooling.yaml"                   # the model as written, before its calibration
    model.write_text(text, encoding="utf-8")
    at_rule = calibrate(str(model), runs)
    auto = calibrate(str(model), runs, window="auto")
    (rule,) = at_rule.window_scores
    assert rule.rule and rule.detectable == auto.window_scores[0].detectable       # the same score as auto's
    assert max(rule.detectable.values()) > 0.10
    report = format_calibration(at_rule)
    assert "at it the faults need a change of" in report and "calibrate --window auto" in report
    assert auto.window > at_rule.window and min(s.score for s in auto.window_scores) < rule.score / 2


def test_a_thermostat_whose_lift_reads_the_measured_temperature_is_simulated(tmp_path):
    """The thermostat's law reads the engine-outlet temperature Te, a De sensor on the 0-junction
    that holds the engine's capacitance: the simulator refused it ("write the law in a storage
    element's state", which no syntax allows), so check --verify, simulate and evaluate were closed
    to the model. Te is q/Ce there: the law reads that now. Against scipy on the physics, the same
    commands (Qin, the fan's square wave), the trajectories agree to a few mK."""
    import numpy as np
    from scipy.integrate import solve_ivp

    from bondgraph.loader import load_model
    from bondgraph.simulation import simulate

    m = load_model(MODEL)
    P = {k: p.value for k, p in m.parameters.items()}
    fan = lambda tt: np.where(np.sin(2 * np.pi * np.asarray(tt) / 900.0) > 0, 1.0, 0.0)  # noqa: E731

    def values(tt):
        out = {s.name: float(v) for s, v in m.nominal_values().items()}
        out["fan"] = fan(tt) if np.ndim(tt) else float(fan(tt))
        return out

    t = np.arange(0.0, 900.0 + 0.05, 0.1)
    got = simulate(m, t, values=values, breakpoints=[450.0], vectorised=True, initial=m.initial)

    def rhs(tt, y):
        Te, Tr = y
        q = P["Gt"] * min(max((Te - P["Tst"]) / P["dTst"], 0.0), 1.0) * (Te - Tr)
        qin = 40000 + 15000 * np.sin(2 * np.pi * tt / 600)
        return [(qin - P["Gh"] * (Te - 303.15) - q) / P["Ce"],
                (q - P["eta"] * (P["Ua0"] + float(fan(tt)) * P["Uf"]) * (Tr - 303.15)) / P["Cr"]]
    ref = np.empty((2, t.size))
    y, edges = [360.15, 340.15], [0.0, 450.0, 900.0]
    for a, b in zip(edges[:-1], edges[1:]):
        k = (t >= a) & (t <= b)
        sol = solve_ivp(rhs, (a, b), y, t_eval=t[k], rtol=1e-10, atol=1e-10, method="LSODA")
        ref[:, k] = sol.y
        y = sol.y[:, -1]
    assert np.ptp(ref[0]) > 1.0 and np.ptp(ref[1]) > 10.0              # it moves: the fan and the load swing it
    assert np.max(np.abs(got.signals["Te"] - ref[0])) < 0.01
    assert np.max(np.abs(got.signals["Tr"] - ref[1])) < 0.01


def test_check_verify_passes_the_cooling_circuits_residuals_in_every_mode():
    """The residuals verified on the simulated model (fdi.verify), the thermostat's lift read from
    the state; its kink where the lift saturates, min(max(x, 0), 1) at x = 1, is a switching surface
    the verification leaves out (it watched only each argument's sign: ARR1 and ARR2 failed at
    2-4e-4 of their terms in both modes with the thermostat open, correct by hand)."""
    from bondgraph.loader import load_model
    from fdi.verify import verify

    got = verify(load_model(MODEL), seed=0)
    assert got.ok and got.complete
