"""A torque-driven pendulum (tests/data/pendulum.yaml: rotational, gravity as a spring whose torque
mgl sin(theta) is not one-to-one, given with its displacement law asin(e / mgl) on the branch the
arm swings in), data from tests/independent/pendulum.py (scipy, the physics typed by hand).

Designed truths at 6 s, one at a time: the pivot's friction four times its value (bearing wear),
the tachometer reading 20 % low. The encoder on the arm's 1-junction measures gravity's
displacement (its angle, zero where the model's initial values put it: both 0), so the residuals
are the textbook's momentum balance J w' + b w + mgl sin(theta) - tau and the two sensors'
agreement. (Until 2026-12 gravity's state was left unknown: the balance was differentiated through
asin, of order 2 in w and undefined wherever noise took its argument past 1.)"""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from bondgraph.errors import ModelError
from bondgraph.loader import load_model_text
from fdi.api import Options, diagnose

from .independent import measurements, pendulum, thresholds_fixture

MODEL = Path(__file__).resolve().parent / "data" / "pendulum.yaml"
T0 = 6.0

_data = partial(measurements, pendulum.simulate)
thresholds = thresholds_fixture(str(MODEL), pendulum.simulate)


def test_a_law_that_is_not_one_to_one_is_given_by_one_branch_and_a_wrong_branch_is_refused():
    """sin and asin are one relation on |q| < pi/2 (q = 1.9 comes back as pi - 1.9, another angle of
    the same torque): accepted. A displacement law that is no inverse at all is still refused."""
    text = MODEL.read_text()
    m = load_model_text(text, str(MODEL))
    assert set(m.elements["gravity"].laws) >= {"effort", "displacement"}
    wrong = text.replace("displacement: 'asin(e/mgl)'", "displacement: 'asin(e/mgl)/2'")
    with pytest.raises(ModelError, match="'displacement' is not the inverse of 'effort'"):
        load_model_text(wrong, str(MODEL))


def test_the_residuals_are_the_momentum_balance_and_the_sensors_agreement():
    """By hand (factors at 1): the arm's momentum balance with gravity's torque at the encoder's
    angle, J w' + b w + mgl sin(theta) - tau (ARR1); and the encoder's rate against the tachometer,
    theta' - w (ARR2); up to their signs."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled

    from .independent import by_hand
    got = {arr.name: by_hand(arr.expr) for arr in compiled(str(MODEL)).arrs}
    (e1, s1, f1), (e2, _, f2) = got["ARR1"], got["ARR2"]
    J, b, mgl = (s1[n] for n in ("J", "b", "mgl"))
    tau, w, theta = f1["tau"], f1["omega"], f2["theta"]
    assert f1["theta"] == theta
    for expr, want in ((e1, J * sp.diff(w, t) + b * w + mgl * sp.sin(theta) - tau), (e2, sp.diff(theta, t) - w)):
        assert sp.simplify(expr - want) == 0 or sp.simplify(expr + want) == 0


@pytest.mark.parametrize("keywords, name, value, rel", [
    ({"b": 0.08}, "friction", 0.08, 0.06),
    ({"g": 0.8}, "beta_omega", 0.8, 0.01),
])
def test_each_fault_is_found_and_sized(thresholds, keywords, name, value, rel):
    report = diagnose(str(MODEL), _data(name, 3, t0=T0, **keywords),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 0.06 <= report["detection"]["time"] < T0 + 0.05   # the derivative window is centred
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (name, "abrupt")
    assert found["value"] == pytest.approx(value, rel=rel)


def test_runs_recorded_in_degrees_are_named_before_their_thresholds_are_used():
    """A trial's encoder columns in degrees: calibrate wrote a threshold thousands of times the noise
    and said only that the model did not explain something. The encoder in degrees here (57.3 x the
    radians): the momentum balance reads mgl sin(theta) at the wrong angle, and the note names the
    disagreement, a column's unit among its causes, and what such a threshold hides."""
    import numpy as np

    from fdi.calibrate import calibrate, format_calibration
    from fdi.data import Measurements
    runs = []
    for seed in (1, 2):
        cols = dict(pendulum.simulate(seed))
        cols["theta"] = np.degrees(cols["theta"])
        runs.append(Measurements(f"deg{seed}", cols["t"], cols))
    text = format_calibration(calibrate(str(MODEL), runs))
    assert "a column's unit: degrees for radians" in text
    assert "the model and these runs disagree: the threshold hides every fault smaller" in text
    healthy = format_calibration(calibrate(str(MODEL), [_data("nominal", seed) for seed in (1, 2)]))
    assert "disagree" not in healthy
