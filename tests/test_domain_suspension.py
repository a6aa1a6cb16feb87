"""A quarter-car suspension (tests/data/quarter_car.yaml: translational mechanics, two masses, two
springs given by their stiffness, a damper, the road's vertical velocity a measured flow source),
data from tests/independent/quarter_car.py (scipy, Newton's laws typed by hand).

What this domain found and checks: the two residuals are the suspension's and the tyre's force
balances differentiated once (each holds a second derivative of a measured velocity); the damper
and the spring share a signature, as do the two velocity sensors, and identification tells them
apart; the designed truths at 8 s, one at a time: the damper losing oil (1000 -> 400 N s/m), the
spring sagging, the tyre losing pressure, each velocity sensor's gain. The model file sets its
derivative window (0.06 s): the rule's window from the 11 Hz wheel hop (9 samples) leaves ARR1
with noise 20 times its signal and the damper undetected (the xfail below)."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
import pytest

from fdi.api import Options, diagnose

from .independent import measurements, quarter_car, thresholds_fixture

MODEL = Path(__file__).resolve().parent / "data" / "quarter_car.yaml"
T0 = 8.0
HALF_WINDOW = 0.03      # s: half the model's derivative_window

_data = partial(measurements, quarter_car.simulate)
thresholds = thresholds_fixture(str(MODEL), quarter_car.simulate)


def test_the_model_file_describes_the_simulated_car():
    """The parameters and columns are the simulator's, and the time scales are those of the state
    matrix written by hand (states vs, vu, xs, xt): the wheel hop at 68.7 rad/s is the fastest."""
    from bondgraph import load_model
    from bondgraph.timescales import model_time_scales
    model = load_model(str(MODEL))
    assert {k: p.value for k, p in model.parameters.items()} == quarter_car.NOMINAL
    assert list(model.columns) == quarter_car.COLUMNS
    ms, mu, ks, bs, kt = (quarter_car.NOMINAL[n] for n in ("ms", "mu", "ks", "bs", "kt"))
    a = np.array([[-bs / ms, bs / ms, ks / ms, 0.0], [bs / mu, -bs / mu, -ks / mu, kt / mu],
                  [-1.0, 1.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0]])
    lam = np.abs(np.linalg.eigvals(a))
    scales = model_time_scales(model)
    assert scales.fastest == pytest.approx(1.0 / lam.max(), rel=1e-4)
    assert scales.slowest == pytest.approx(1.0 / lam.min(), rel=1e-4)


def test_the_residuals_are_the_suspension_and_tyre_balances():
    """By hand (factors at 1): the body's balance ms vs' = Fs with Fs = ks xs + bs (vu - vs) and
    xs' = vu - vs, differentiated to drop xs: ks (vu - vs) - d/dt(ms vs' - bs (vu - vs)); the tyre's
    force kt xt = ms vs' + mu vu' with xt' = vr - vu: kt (vr - vu) - d/dt(ms vs' + mu vu'). bgfdi
    writes them divided by ks and kt; up to their signs."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled

    from .independent import by_hand
    got = [by_hand(arr.expr) for arr in compiled(str(MODEL)).arrs]
    assert len(got) == 2
    sym = {**got[0][1], **got[1][1]}
    sig = {**got[0][2], **got[1][2]}
    ms, mu, ks, bs, kt = (sym[n] for n in ("ms", "mu", "ks", "bs", "kt"))
    vr, vs, vu = sig["vr"], sig["vs"], sig["vu"]
    body = ms * sp.diff(vs, t)                       # the suspension's force on the body
    suspension = (ks * (vu - vs) - sp.diff(body - bs * (vu - vs), t)) / ks
    tyre = (kt * (vr - vu) - sp.diff(body + mu * sp.diff(vu, t), t)) / kt
    for (expr, _, _), want in zip(got, (suspension, tyre)):
        assert sp.simplify(expr - want) == 0 or sp.simplify(expr + want) == 0


@pytest.mark.parametrize("keywords, name, value, rel, seed", [
    ({"bs_fault": 400.0}, "damper", 400.0, 0.03, 4),          # the damper losing oil
    ({"ks_fault": 12000.0}, "spring", 12000.0, 0.03, 5),      # a sagging coil spring
    ({"kt_fault": 120000.0}, "tyre", 120000.0, 0.03, 5),      # a tyre losing pressure
    ({"gain_vs": 0.8}, "beta_vs", 0.8, 0.02, 5),              # the body's velocity sensor 20 % low
    ({"gain_vu": 0.8}, "beta_vu", 0.8, 0.02, 5),              # the wheel's 20 % low
])
def test_each_fault_is_found_typed_and_sized(thresholds, keywords, name, value, rel, seed):
    """Single faults only (``max_set=1``): the designs are single faults. The damper and the spring
    share ARR1 alone, the sensors both residuals: the fit tells each pair apart. The spring's force
    changes by (ks - 12000) xs, small while the spring passes through its static length just after
    the onset: ARR1 crosses at 7.996-8.023 s, under the persistence of one window, and is confirmed
    at its next crossing, t_D = 8.381 s; the step is dated from the evidence before t_D
    (fdi.estimators.date_onsets), where the window from t_D left it at 8.36 s."""
    report = diagnose(str(MODEL), _data(name, seed, t0=T0, **keywords),
                      Options(workers=1, seed=0, thresholds=thresholds, max_set=1)).to_dict()
    assert T0 - HALF_WINDOW <= report["detection"]["time"] < T0 + 0.5   # the derivative window is centred
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (name, "abrupt")
    assert found["value"] == pytest.approx(value, rel=rel)
    assert found["t0"] == pytest.approx(T0, abs=0.05)


@pytest.mark.xfail(strict=False, reason=(
    "bgfdi: without diagnosis.derivative_window the rule's window is tau/2 of the fastest mode (the "
    "11 Hz wheel hop, tau = 0.0142 s), clipped to 9 samples at 1 ms; ARR1 holds ms*vs''/ks, and "
    "calibrated on nominal runs its threshold is 3.65 m/s against velocities of 0.1-0.2 m/s: the "
    "damper's 60 % loss (0.06 m/s in ARR1) is never detected (calibrate now names the rule's 9-sample "
    "window and that second derivatives may need a longer one; the rule itself is for the next round)"))
def test_the_damper_is_detected_with_the_rules_derivative_window(tmp_path):
    from .independent import thresholds as calibrated
    text = MODEL.read_text()
    model = tmp_path / "quarter_car_rule_window.yaml"
    model.write_text(text[:text.index("\ndiagnosis:")] + "\n")
    assert "derivative_window" not in model.read_text()
    limits = calibrated(str(model), quarter_car.simulate)
    report = diagnose(str(model), _data("damper", 4, t0=T0, bs_fault=400.0),
                      Options(workers=1, seed=0, thresholds=limits, max_set=1)).to_dict()
    assert report["detection"] is not None


def test_calibrate_chooses_a_window_at_which_the_damper_is_found(tmp_path, capsys):
    """`bgfdi calibrate --window auto` on the model without its derivative window: of the rule's
    9-sample window and its multiples clear of the 11 Hz wheel hop (fdi.window_choice.clear_of_modes:
    145 samples, cutoff 8.9 Hz, is left out), the window at which the five faults need the smallest
    changes to be detected, written into the copy (0.1018 s, 103 samples); at it the damper's 60 %
    loss is isolated from a coherence [1 0], typed abrupt and sized within 3 % from its onset (where
    the rule's window never detects it: the xfail above)."""
    import json

    from fdi.app.cli import main
    from fdi.window_choice import cutoff
    from fdi.config import load
    text = MODEL.read_text()
    model = tmp_path / "quarter_car_rule_window.yaml"
    model.write_text(text[:text.index("\ndiagnosis:")] + "\n")
    runs = []
    for seed in (1, 2):
        cols = quarter_car.simulate(seed)
        keys = ["t"] + [k for k in cols if k != "t"]
        runs.append(tmp_path / f"nominal{seed}.csv")
        np.savetxt(runs[-1], np.column_stack([cols[k] for k in keys]), delimiter=",", header=",".join(keys),
                   comments="", fmt="%.12g")
    out = tmp_path / "calibrated.yaml"
    assert main(["calibrate", str(model), *map(str, runs), "--window", "auto", "-o", str(out), "--json"]) == 0
    printed = capsys.readouterr().out                  # the JSON (the note that the copy was written: on stderr)
    cal = json.loads(printed[printed.index("{"):])
    scores = cal["window_scores"]
    assert cal["window_chosen"] and scores[0]["window"] == pytest.approx(0.009)
    wheel_hop = 1.0 / (2 * np.pi * 0.0142)                  # Hz
    assert all(cutoff(s["samples"], 0.001) >= wheel_hop for s in scores)
    assert min(scores, key=lambda s: s["score"])["window"] == pytest.approx(cal["window"])
    assert scores[0]["detectable"]["damper"] > 10 * cal["window_scores"][-1]["detectable"]["damper"]
    _, config = load(out)
    assert config.derivative_window == pytest.approx(cal["window"], rel=1e-3)
    assert 0.06 <= config.derivative_window <= 0.11
    report = diagnose(str(out), _data("damper", 4, t0=T0, bs_fault=400.0),
                      Options(workers=1, seed=0, max_set=1)).to_dict()
    assert report["detection"]["coherence"] == [1, 0]
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("damper", "abrupt")
    assert found["value"] == pytest.approx(400.0, rel=0.03)
    assert found["t0"] == pytest.approx(T0, abs=0.05)


def test_a_step_is_dated_again_only_when_the_evidence_precedes_its_confirmation_by_a_window():
    """Designed: t_D = 8.381 s, a derivative window of 0.06 s. The winner's set is refitted on the
    longer window only when all its faults are abrupt, one dated at or before t_D, and a residual
    left its noise band more than a window before t_D; the refit's dates are taken when it keeps
    the types (else the winner stands)."""
    import numpy as np
    from fdi.estimators import date_onsets
    from fdi.results import Estimate
    t = np.arange(0.0, 20.0, 0.001)
    runs = []

    class Fake:                                     # an Estimators that records its runs
        monitor = type("M", (), {"config": type("C", (), {"derivative_window": 0.06})()})()

        def __init__(self, answer):
            self.answer = answer

        def run(self, t_, raw, start, samples, candidates, *rest):
            runs.append((round(start, 3), samples))
            return [self.answer]

    def est(faults):
        return Estimate(("spring",), 1.0, 1.0, (), None, tuple(faults), 10, 0.0)
    step = {"name": "spring", "type": "abrupt", "value": 12075.0, "t0": 8.36}
    dated = est([{**step, "value": 12166.0, "t0": 8.007}])
    call = lambda winner, evidence, answer=dated: date_onsets(            # noqa: E731
        Fake(answer), t, {}, 8.381, 1000, winner, np.ones(2), 0, (7.97, 8.41), evidence, 1.0)
    assert call(est([step]), 7.998).faults == dated.faults and runs == [(7.91, 1471)]
    assert call(est([step]), 7.998).evaluations == 20                  # the refit's evaluations added
    runs.clear()
    for winner, evidence in ((est([step]), 8.35),                       # evidence within a window of t_D
                             (est([{**step, "t0": 8.40}]), 7.998),      # dated after t_D
                             (est([{**step, "type": "incipient"}]), 7.998)):   # a drift: refitted elsewhere
        assert call(winner, evidence) is winner
    assert runs == []
    other = est([{**step, "type": "intermittent", "period": 0.5}])
    assert call(est([step]), 7.998, other).faults == (step,)             # the refit changed the type
