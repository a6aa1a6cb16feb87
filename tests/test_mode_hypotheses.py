"""Which mode hypotheses the fault-mode estimator weighs, and what switching residuals off costs
(fdi.mode_estimation, fdi.pipeline.possible_mode_faults), on a user trial's quarter car
(tests/data/quarter_car_bump_stop.yaml: a valve commanded soft/firm, a bump stop engaged while
the compression passes its gap, each mode with its own body balance)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bondgraph.loader import load_model
from fdi.mode_estimation import off_charge
from fdi.pipeline import possible_mode_faults

MODEL = Path(__file__).resolve().parent / "data" / "quarter_car_bump_stop.yaml"


def test_an_autonomous_switch_no_declared_fault_holds_is_no_hypothesis():
    """The stop is engaged where the measured compression passes the gap: that is its definition,
    and no fault of the file holds it. The estimator had it engaged on a record with no contact
    (a hypothesis that switched every body residual off); the valve, commanded, stays a suspect."""
    m = load_model(MODEL)
    assert possible_mode_faults(m, ["v_soft", "stop"]) == ["v_soft"]
    assert possible_mode_faults(m, ["v_firm"]) == ["v_firm"]


def test_a_swap_of_residuals_is_charged_only_what_it_leaves_unjudged():
    """A hypothesis that switches residual A off on a sample and residual B on (a valve stuck soft:
    the firm mode's body balance for the soft mode's) leaves that sample judged by B: charged A's
    floor less B's (never below 0); switching A off alone is charged A's floor, as before."""
    data = [np.array([0.5, 0.5, 0.5]), np.array([0.0, 0.0, 0.0])]          # A holds, B is the other mode's
    swap = [np.array([[0.0, 0.0, 0.5]]), np.array([[0.2, 0.2, 0.0]])]     # A off, B on, on two samples
    alone = [np.array([[0.0, 0.0, 0.5]]), np.array([[0.0, 0.0, 0.0]])]
    floors, weights = np.array([0.3, 0.1]), np.array([1.0, 2.0])
    assert np.allclose(off_charge(swap, data, floors, weights, each=True), [[0.1, 0.1, 0.0]])   # 0.3 - 2 x 0.1
    assert np.allclose(off_charge(alone, data, floors, weights), [0.6])
    assert np.allclose(off_charge(swap, data, np.array([0.1, 0.3]), weights), [0.0])           # B's floor covers A's
    assert off_charge(swap, data, None, weights) == 0.0
