"""A part a switched-off junction cuts off from every sensor and state holds no residual
(bondgraph.modes.in_mode): a user trial's quarter car (tests/data/quarter_car_bump_stop.yaml) wrote
its bump stop as an R whose force law reads the measured compression, kb (xs - gb), behind a 0c
that is off while there is no contact. The mode's own bond graph kept the stop with the junction's
zero effort, and the two made a residual, kb (xs - gb) = 0, added as the free mode's own: false
on every record (13 164 N on the plant's noise-free run). Physics (Gillespie ch. 5): an open stop
exerts nothing, so its stiffness is undetectable while open and every residual vanishes on the
plant in both modes. The plant: tests/independent/quarter_car_stop.py, scipy's DOP853 with the
contact located by event detection."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from fdi.data import Measurements, commanded, signals_from_data
from fdi.monitor import Monitor
from fdi.residuals import evaluate

from .independent import quarter_car_stop as plant

MODEL = Path(__file__).resolve().parent / "data" / "quarter_car_bump_stop.yaml"


@pytest.fixture(scope="module")
def monitor():
    return Monitor(MODEL)


def test_an_open_stop_is_in_no_residual_and_a_closed_one_is(monitor):
    kb, stop, v = (monitor.model.symbols[n] for n in ("kb", "stop", "v"))
    for valve in (0, 1):
        free = [a.expr.xreplace({stop: 0, v: valve}) for a in monitor.arrs]
        assert not any(e.has(kb) for e in free)
    closed = [sp.expand(a.expr.xreplace({stop: 1, v: 1})) for a in monitor.arrs]
    assert any(e.has(kb) for e in closed)           # the body's balance with the stop's force


def test_every_residual_vanishes_on_the_plant_in_contact_and_free(monitor):
    columns, contacts = plant.simulate()
    assert contacts >= 1
    meas = Measurements("plant.csv", columns["t"], columns)
    raw = signals_from_data(monitor.model, meas)
    modes = commanded(monitor.model, raw)
    r = np.asarray(evaluate(monitor.model, list(monitor.residuals), raw, meas.ts, window=0.01, values=modes))
    for i, a in enumerate(monitor.arrs):
        for s in (0, 1):
            x = r[i][(modes["stop"] == s) & np.isfinite(r[i])]
            # measured: 0.49 at most (a wheel balance, N, with xs''' from noise-free samples); the free
            # mode's contradiction was kb (xs - gb), 13 164 N
            assert x.size and np.abs(x).max() < 1.0, (a.name, s, np.abs(x).max())


def test_the_simulator_takes_the_model_and_every_residual_verifies(monitor):
    from fdi.verify import verify
    v = verify(monitor.model, monitor.arrs)
    assert v.checks and not v.failures and not v.unverified       # the simulator refused the model before
    assert ("ARR4", "v=0,stop=0") in v.zero                     # the contact mode's own: 0 there
