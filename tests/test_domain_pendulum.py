"""A torque-driven pendulum (tests/data/pendulum.yaml: rotational, gravity as a spring whose torque
mgl sin(theta) is not one-to-one, given with its displacement law asin(e / mgl) on the branch the
arm swings in), data from tests/independent/pendulum.py (scipy, the physics typed by hand).

Designed truths at 6 s, one at a time: the pivot's friction four times its value (bearing wear),
the tachometer reading 20 % low. The angle is an integral of the junction's speed whose offset
the diagnosis does not know, so gravity's state stays unknown and the residuals are the MSO sets:
the speed's momentum balance differentiated through asin, and the two sensors' agreement."""
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
