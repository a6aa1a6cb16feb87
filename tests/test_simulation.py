"""Simulation from the YAML: CyCab scenarios, an analytic check, other models, bad scenarios."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import scipy.linalg

from bondgraph.loader import load_model
from bondgraph.simulation import build_system, simulate
from fdi.app.cli import main
from fdi.data import Measurements, read_csv, signals_from_data
from fdi.config import load
from fdi.residuals import compile_residuals, evaluate
from fdi.app.scenario import ScenarioError, breakpoints, load_scenario, parse_scenario, run, time_functions

from .conftest import DATA, MODELS

THRESHOLDS = np.array([1.0, 5.5e-6, 15.0])
SUITE = MODELS / "scenarios" / "suite_cycab_steering"
R4_FAULTS = ["r4_incipient", "r4_intermittent", "r4_abrupt_small"]


@pytest.fixture(scope="module")
def residuals(cycab, cycab_arrs):
    return compile_residuals(cycab, cycab_arrs)


def _simulate(model, name, T=None, **override):
    data = json.loads((MODELS / "scenarios" / f"cycab_{name}.json").read_text()) if name else {}
    data.update(override)
    if T:
        data["T"] = T
    cols = run(model, parse_scenario(data, model, name or "inline"))
    return Measurements(name or "inline", cols["t"], cols)


def _residuals(model, residuals, m):
    return evaluate(model, residuals, signals_from_data(model, m), m.ts, window=load(model.path)[1].derivative_window)


def _coherence(t, r, a, b):
    w = (t >= a) & (t <= b)
    return [int(np.any(np.abs(r[i, w]) > THRESHOLDS[i])) for i in range(3)]


def test_nominal_run_is_quiet_and_swings_like_the_rig(cycab, residuals):
    m = _simulate(cycab, "nominal", T=20)
    r = _residuals(cycab, residuals, m)
    after = m.t > 1.0
    assert np.all(np.abs(r[:, after]).max(axis=1) < 0.5 * THRESHOLDS)
    swing = m.columns["theta2"].max() - m.columns["theta2"].min()
    assert 0.2 < swing < 1.0                                   # a few tenths of a radian
    ref = read_csv(DATA / "nominal.csv")
    n = m.t.size
    # same physics as the independent reference simulator: angles agree within a few %
    for col in ("theta1", "theta2"):
        err = np.sqrt(np.mean((m.columns[col] - ref.columns[col][:n]) ** 2))
        assert err < 0.05 * np.ptp(ref.columns[col][:n])


@pytest.mark.parametrize("name, early, late", [
    ("scenario1", [1, 1, 0], [1, 1, 0]),
    ("scenario2", [0, 1, 0], [0, 1, 1]),
    ("scenario3", [1, 0, 0], [1, 0, 0]),
])
def test_own_simulation_gives_the_reference_coherence_vectors(cycab, residuals, name, early, late):
    m = _simulate(cycab, name, T=40)
    r = _residuals(cycab, residuals, m)
    assert _coherence(m.t, r, 1.0, 31.5) == [0, 0, 0]
    assert _coherence(m.t, r, 31.5, 34.0) == early
    assert _coherence(m.t, r, 31.5, 37.0) == late


def test_broken_belt_gives_1_1_0(cycab, residuals):
    m = _simulate(cycab, None, T=36, seed=5, theta2_0=-0.15, faults=[{"target": "a2", "type": "mode", "t0": 32}])
    assert _coherence(m.t, _residuals(cycab, residuals, m), 31.5, 36.0) == [1, 1, 0]


def test_leak_changes_the_configuration(cycab):
    nominal = {s.name: v for s, v in cycab.nominal_values().items()}
    healthy = build_system(cycab, nominal)
    assert healthy.open_resistors == {"R_R4"} and healthy.states == ["I_J1", "theta1", "theta2"]
    leaking = build_system(cycab, {**nominal, "R4": 2.5221e7})
    assert not leaking.open_resistors and set(leaking.states) == {"I_J1", "I_J3", "theta1", "theta2"}


def test_dc_motor_step_response_matches_the_analytic_solution():
    model = load_model(MODELS / "dc_motor_clutch.yaml")
    p = {k: v.value for k, v in model.parameters.items()}
    values = {s.name: v for s, v in model.nominal_values().items()}
    t = np.linspace(0, 2.0, 201)
    traj = simulate(model, t, values=lambda tt: values)
    # x = [i, w]: L di/dt = u - R i - K w;  J dw/dt = K i - (bm + bL) w;  u = 1 V step from rest
    A = np.array([[-p["Ra"] / p["La"], -p["K"] / p["La"]], [p["K"] / p["Jm"], -(p["bm"] + p["bL"]) / p["Jm"]]])
    B = np.array([1 / p["La"], 0.0])
    exact = np.array([np.linalg.solve(A, (scipy.linalg.expm(A * tt) - np.eye(2)) @ B) for tt in t])
    assert np.allclose(traj.signals["i"], exact[:, 0], rtol=1e-4, atol=1e-6)
    assert np.allclose(traj.signals["w"], exact[:, 1], rtol=1e-4, atol=1e-7)


def test_two_tank_simulates_and_fills():
    model = load_model(MODELS / "two_tank_valve.yaml")
    cols = run(model, parse_scenario({"seed": 1, "T": 200, "fs": 10, "p1_0": 3000.0, "p2_0": 2000.0,
                                      "faults": [{"target": "v", "type": "mode", "t0": 100}]}, model))
    p1, p2 = cols["p1"], cols["p2"]
    assert np.all(np.isfinite(p1)) and p1[0] == pytest.approx(3000, abs=100)
    # the valve closes at 100 s: tank 1 only fills from then on, tank 2 only drains
    assert p1[-1] > p1[1000] + 1000 and p2[-1] < p2[1000]


@pytest.mark.parametrize("fault, message", [
    ({"target": "R9", "type": "abrupt", "t0": 1, "value": 1}, "unknown target 'R9'"),
    ({"target": "R4", "type": "sudden", "t0": 1, "value": 1}, "unknown type 'sudden'"),
    ({"target": "R4", "type": "abrupt", "t0": 1}, "missing value"),
    ({"target": "R4", "type": "abrupt", "t0": 99, "value": 1}, "outside the run"),
    ({"target": "beta_theta1", "type": "intermittent", "t0": 1, "value": 0.5}, "missing period"),
    ({"target": "a1", "type": "abrupt", "t0": 1, "value": 0}, "use type mode"),
    ({"target": "beta_theta2", "type": "incipient", "t0": 1, "model": 3, "b": [1]}, "needs b with 2"),
    # a trial's valve stuck with "value": 0.5 was simulated stuck at the model's value without a word
    ({"target": "a1", "type": "mode", "t0": 1, "value": 0.5},
     r"value not read for a fault of type mode \(a mode fault holds its variable at the value the model's fault gives: 0\)"),
    ({"target": "R4", "type": "abrupt", "t0": 1, "value": 2.0, "period": 3.0}, "period not read for a fault of type abrupt"),
    # a trial's friction drift at 1e5 /s reached inf within the run, which went on frozen without a word
    ({"target": "beta_theta2", "type": "incipient", "t0": 1, "model": 1, "b": [1.0e5]}, "beta_theta2's drift leaves the floats by t = "),
])
def test_bad_scenarios(cycab, fault, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario({"T": 60, "fs": 100, "faults": [fault]}, cycab, "bad.json")


def test_a_fault_as_simulate_json_echoes_it_reads_back(cycab):
    """simulate --json gives every key of a fault, the unused ones null or empty: taken as written."""
    s = parse_scenario({"T": 60, "fs": 100, "faults": [{"target": "R4", "type": "abrupt", "t0": 32.0, "value": 2.5e7,
                                                       "period": None, "model": None, "b": [], "failure": None}]},
                       cycab, "echo.json")
    assert s.faults[0].value == 2.5e7


def test_cli_simulate_writes_the_csv_and_rejects_bad_files(tmp_path, capsys):
    sc = tmp_path / "s.json"
    sc.write_text(json.dumps({"seed": 3, "T": 2, "fs": 100, "theta2_0": -0.15, "faults": []}))
    out = tmp_path / "o.csv"
    assert main(["simulate", "models/cycab_steering.yaml", str(sc), "-o", str(out)]) == 0
    assert out.read_text().splitlines()[0] == "t,u_in,theta1,theta2,p1,p2"
    assert read_csv(out).t.size == 201
    bad = tmp_path / "b.json"
    bad.write_text(json.dumps({"T": 2, "fs": 100, "faults": [{"target": "X", "type": "abrupt", "t0": 1, "value": 1}]}))
    assert main(["simulate", "models/cycab_steering.yaml", str(bad), "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "unknown target 'X'" in err
    assert not (tmp_path / "x.csv").exists()


def test_seeded_simulation_is_reproducible(cycab):
    a = _simulate(cycab, "nominal", T=2)
    b = _simulate(cycab, "nominal", T=2)
    assert all(np.array_equal(a.columns[c], b.columns[c]) for c in a.columns)
    c = _simulate(cycab, "nominal", T=2, seed=999)
    assert not np.array_equal(a.columns["p1"], c.columns["p1"])


def test_scenario_file_loads(cycab):
    s = load_scenario(MODELS / "scenarios" / "cycab_scenario2.json", cycab)
    assert s.initial == {"theta2": -0.15} and s.faults[1].model == 2 and s.faults[1].b == (-0.03,)


def _smooth_chain():
    """The benchmark chain with cubic instead of Coulomb friction: smooth, one independent inertia
    and the others dependent (x' solved through the dependent storage)."""
    from bondgraph.chains import chain_yaml
    from bondgraph.loader import load_model_text
    return load_model_text(chain_yaml(12).replace("sign(f)", "f**3"), "smooth_chain")


@pytest.mark.parametrize("make, T", [(lambda: load_model(MODELS / "dc_motor_clutch.yaml"), 2.0), (_smooth_chain, 5.0)])
def test_ros2_converges_at_second_order_to_a_tight_scipy_reference(make, T):
    """The hand-written ROS2 against scipy's DOP853 at rtol 1e-12 on the same smooth state
    equations (no sign or abs): ROS2 is of order 2 (a W-method: whatever the Jacobian), so its
    global error is C h^2: halving the step divides it by about 4 (more than 3 asked, where a
    first-order slip would give 2), and at 1 ms it is far below the signals' size."""
    from scipy.integrate import solve_ivp

    model = make()
    values = {s.name: v for s, v in model.nominal_values().items()}
    system = build_system(model, values)
    assert not system.discontinuous
    p = [values[n] for n in system.param_names]
    t = np.linspace(0.0, T, 201)
    ref = solve_ivp(lambda tt, x: system.derivative(tt, x, p), (0.0, T), np.zeros(len(system.states)),
                    method="DOP853", t_eval=t, rtol=1e-12, atol=1e-14)
    assert ref.success
    errors = []
    for h in (1e-3, 5e-4):
        traj = simulate(model, t, values=lambda tt: values, method="ros2", max_step=h)
        errors.append(max(np.abs(traj.states[s] - ref.y[i]).max() / np.abs(ref.y[i]).max()
                          for i, s in enumerate(system.states)))
    assert errors[0] < 1e-4
    assert errors[0] / errors[1] > 3.0


@pytest.mark.parametrize("name", R4_FAULTS)
def test_r4_faults_simulate_and_the_oil_obeys_the_leak_law(cycab, name):
    """R4 faults other than the reference abrupt ones: an incipient leak from R4 = inf (eq. 17:
    1/R4 = -b2 (t - t0)), one that opens and closes every 3 s, an abrupt one from another state.
    They simulate, and the cylinder's oil balance holds with the orifice law: the flow the pump
    delivers, k5 k4 theta1', minus the flow the piston takes, A r_a cos(beta + theta2) theta2'
    (both from the simulated angles, differentiated), is the leak's flow sign(dp) sqrt|dp| / R4(t)
    while R4 is finite, and nothing while it is infinite."""
    shipped = load_scenario(SUITE / f"{name}.json", cycab)
    exact = dataclasses.replace(shipped, noise={"p1": 0.0, "p2": 0.0},
                                resolution={c: 0.0 for c in ("theta1", "theta2", "p1", "p2")})
    cols = run(cycab, exact)                      # raises on any sample that is not finite
    assert all(np.all(np.isfinite(v)) for v in cols.values())
    t, th1, th2, dp = cols["t"], cols["theta1"], cols["theta2"], cols["p1"] - cols["p2"]
    assert np.abs(dp).max() < 4e6                 # within the transducers' 40 bar
    p = {k: v.value for k, v in cycab.parameters.items()}
    beta = np.arctan(p["w"] / (2 * p["L"]))
    pump = p["k5"] * p["k4"] * np.gradient(th1, t)
    leak = pump - p["A"] * p["r_a"] * np.cos(beta + th2) * np.gradient(th2, t)
    R4 = np.broadcast_to(time_functions(cycab, exact)[0](t)["R4"], t.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        law = np.where(np.isfinite(R4), np.sign(dp) * np.sqrt(np.abs(dp)) / R4, 0.0)
    edges = np.array([0.0, exact.T, *breakpoints(exact)])
    away = np.abs(t[:, None] - edges[None, :]).min(axis=1) > 0.05
    scale = np.abs(pump).max()
    assert np.abs(law[away]).max() > 0.05 * scale                  # it leaks
    assert np.abs(leak - law)[away].max() < 0.01 * scale
    assert np.median(np.abs(leak - law)[away]) < 1e-4 * scale


@pytest.mark.parametrize("name", ["r4_incipient", "r4_intermittent"])
def test_r4_onset_agrees_with_radau_at_tight_tolerances(cycab, name):
    """Across the onset (the configuration switch: a new state whose leak has no flow yet, R4
    falling from inf as 1/(t - t0) for the incipient fault), the ROS2 run of bgfdi simulate (1 ms
    steps) against scipy's Radau at rtol 1e-10 (error-controlled, its own Newton iteration) from
    the same state 0.2 s before: the angles within the encoders' resolution, dp within 5 kPa (2.5
    times the pressure sensors' noise: dp = R4^2 f|f| is steep in the flow, d dp/df = 2 R4 sqrt|dp|,
    some 2e12 Pa s/m^3 at R4 = 2e9, where 1 ms steps leave 3.5 kPa, 1 % of the swing)."""
    sc = load_scenario(SUITE / f"{name}.json", cycab)
    values, _, _ = time_functions(cycab, sc)
    t0 = sc.faults[0].t0
    n0 = int(round((t0 - 0.2) * sc.fs))
    t = np.arange(n0, int(round((t0 + 0.3) * sc.fs)) + 1) / sc.fs
    kw = {"values": values, "breakpoints": breakpoints(sc), "vectorised": True}
    before = simulate(cycab, np.arange(n0 + 1) / sc.fs, initial={**cycab.initial, **sc.initial}, **kw)
    start = {k: v[-1] for k, v in before.states.items()}
    ours = simulate(cycab, t, initial=start, **kw)
    radau = simulate(cycab, t, initial=start, method="Radau", tolerances=(1e-10, 1e-15), **kw)
    err = {s: np.abs(ours.signals[s] - radau.signals[s]) for s in ("theta1", "theta2", "dp")}
    assert err["theta1"].max() < 6.3e-4 and err["theta2"].max() < 7.7e-4
    assert err["dp"].max() < 5e3


STIFFENING_CAP = """
name: stiffening_cap
parameters:
  C:  {value: 1.0e-3, unit: F}
  C2: {value: 1.0e-4, unit: F}
  Q0: {value: 2.0e-3, unit: C}
  R:  {value: 10.0, unit: Ohm}
data: {columns: [t, i, v], sampling_time: 0.001}
inputs: {i: {unit: A, column: i, expr: "sin(2*pi*5*t)"}}
elements:
  src: {type: MSf, input: i}
  cap: {type: C, effort: "q/C + max(q - Q0, 0)/C2", displacement: "min(e*C, (e + Q0/C2)/(1/C + 1/C2))"}
  load: {type: R, parameter: R}
junctions: {j: {type: "0"}}
sensors: {v: {type: De, junction: j, column: v, unit: V}}
bonds: {1: [src, j], 2: [j, cap], 3: [j, load]}
"""


def test_a_law_with_max_simulates_as_scipy_integrates_it():
    """A capacitor that stiffens beyond a charge Q0 (v = q/C + max(q - Q0, 0)/C2) fed a current and
    discharged through R: the law's max and min reach the generated program (numpy's printer writes
    functools.reduce: a NameError until 2026-11, in `simulate` and `check --verify` alike) and the
    run is scipy's of q' = i - v(q)/R."""
    from scipy.integrate import solve_ivp

    from bondgraph.loader import load_model_text
    model = load_model_text(STIFFENING_CAP, "stiffening_cap.yaml")
    t = np.linspace(0.0, 0.6, 601)
    values = {s.name: v for s, v in model.nominal_values().items()}
    traj = simulate(model, t, values=lambda tt: values)

    def volts(q):
        return q / 1.0e-3 + max(q - 2.0e-3, 0.0) / 1.0e-4
    ref = solve_ivp(lambda s, q: [np.sin(2 * np.pi * 5 * s) - volts(q[0]) / 10.0], (0, 0.6), [0.0],
                    t_eval=t, rtol=1e-10, atol=1e-13, max_step=1e-3)
    v = np.array([volts(q) for q in ref.y[0]])
    assert v.max() > 2.0e-3 / 1.0e-3                    # the stiff part is reached
    np.testing.assert_allclose(traj.signals["v"], v, atol=2e-3 * np.ptp(v))


def test_a_reading_that_a_given_state_contradicts_is_named_with_its_cause():
    """A trial's `initial: {ind_a: 0, i: 5}`: the inductor's state fixes the current its sensor reads,
    and no other state reaches it. The refusal named the reading only; it now says that a state
    given fixes it otherwise, and which (the mass's momentum and its speed sensor here)."""
    from bondgraph.loader import load_model_text
    from bondgraph.simulation import SimulationError
    from .conftest import MODELS
    text = (MODELS / "mass_spring_damper_two_sensors.yaml").read_text().replace("initial: {}", "initial: {mass: 0.0, v: 3.0}")
    model = load_model_text(text, "msd_initial.yaml")
    with pytest.raises(SimulationError, match=r"cannot meet the initial values of v .*the state\(s\) given \(mass\) may fix "
                                              r"it otherwise: give the reading or the state, not both"):
        values = {s.name: v for s, v in model.nominal_values().items()}
        simulate(model, np.linspace(0.0, 0.1, 11), values=lambda tt: values, initial=model.initial)
