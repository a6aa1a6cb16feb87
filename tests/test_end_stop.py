"""A base-excited vibration isolator with a gap end stop (tests/data/isolator_end_stop.yaml, a user
trial's model of a domain bgfdi did not ship; Karnopp, Margolis & Rosenberg ch. 4), against runs of
its own plant simulated apart from bgfdi (tests/isolator_plant.py: scipy's DOP853 with the
contacts located by event detection).

The contact is an autonomous mode (c = 1 while the compression delta exceeds the gap), and delta's
derivative is left out by design for a few samples at each switch. Until 2026-11 two residuals
differentiated a stored quantity that read delta's derivative (the force balance differentiated
once), and one such sample made its rate NaN on the whole record: one contact blinded both
residuals everywhere, and calibrate refused the runs ("every stretch between two mode switches is
shorter than the derivative window"). Since 2026-12 the force balance reads the spring's compression
from delta, the sensor on its junction (the balance in delta, v and their rates, with the stop's
force in contact): no residual here carries a stored quantity, and each is still blind only where designed. Designed
truth here: the plant is the model, so each residual is its sensors' noise alone, in both modes, as
fdi.noise predicts it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fdi.data import Measurements, commanded, signals_from_data
from fdi.monitor import compiled
from fdi.residuals import designed_gaps, evaluate, mode_breaks

from . import isolator_plant as plant

MODEL = Path(__file__).resolve().parent / "data" / "isolator_end_stop.yaml"
FS, SECONDS, AMPLITUDE = 2000, 8.0, 0.04


def _run(seed: int) -> Measurements:
    columns = plant.measured(SECONDS, FS, seed, AMPLITUDE)
    return Measurements(f"isolator-{seed}.csv", columns["t"], columns)


@pytest.fixture(scope="module")
def runs():
    return [_run(seed) for seed in (1, 2)]


def test_a_contact_leaves_each_residual_blind_only_near_its_switches(runs):
    m = compiled(MODEL)
    meas = runs[0]
    raw = signals_from_data(m.model, meas)
    modes = commanded(m.model, raw)
    assert 0.005 < modes["c"].mean() < 0.2                 # the stop is hit, now and then
    window = 2.5e-3
    r = np.asarray(evaluate(m.model, list(m.residuals), raw, meas.ts, window=window, values=modes))
    # every residual (since 2026-12 none carries a stored quantity here: the spring's compression is
    # read from delta, the sensor on its junction; the gaps of one inside another are tested below)
    stored = range(len(m.residuals))
    gaps = designed_gaps(list(m.residuals), meas.t.size, mode_breaks(m.model, raw), window, meas.ts)
    edge = int(window / meas.ts)
    inside = slice(edge, meas.t.size - edge)               # the record's own ends aside
    for i in stored:
        blind = ~np.isfinite(r[i])
        assert blind[inside].mean() < 0.1
        assert not (blind & ~gaps)[inside].any()           # every blind sample is one left out by design
        assert np.isfinite(r[i][modes["c"] == 1]).sum() > 50   # the contact itself is judged


def test_each_residual_is_its_predicted_noise_in_contact_and_free(runs):
    from fdi.calibrate import calibrate
    c = calibrate(str(MODEL), runs)
    seen = {(x["residual"], x["mode"]["c"]): x["level"] / x["predicted"] for x in c.noise}
    assert {mode for _, mode in seen} == {0, 1} and {name for name, _ in seen} == set(c.names)
    for key, ratio in seen.items():
        assert 0.8 < ratio < 1.25, (key, ratio)


@pytest.mark.parametrize("window", [2.5e-3, 1.0e-2])
def test_the_gaps_of_a_stored_quantity_inside_another_are_counted_where_they_are(runs, window):
    """d/dt(2 d/dt(3 delta + v) + v) - v on the contact runs: the inner rate is left out at each switch
    and the outer one reads it half a window further; designed_gaps says exactly where (the report's
    overflow note and the identification's cost skip those samples, and only those)."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.residuals import _compile
    m = compiled(MODEL)
    delta, v = sp.Function("delta")(t), sp.Function("v")(t)
    nested = _compile(m.model, sp.Derivative(2 * sp.Derivative(3 * delta + v, t) + v, t) - v, "X", None)
    assert nested.composites[0][1].composites                  # a rate inside a rate
    meas = runs[0]
    raw = signals_from_data(m.model, meas)
    x = np.asarray(evaluate(m.model, [nested], raw, meas.ts, window=window, values=commanded(m.model, raw)))[0]
    gaps = designed_gaps([nested], meas.t.size, mode_breaks(m.model, raw), window, meas.ts)
    assert gaps.any() and np.array_equal(~np.isfinite(x), gaps)
