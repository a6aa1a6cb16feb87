"""Simulators written apart from bgfdi (scipy, the physics typed by hand), and the two steps every
domain test takes with them: their columns as measurements, and thresholds calibrated on two nominal
runs and checked quiet on a third."""
from __future__ import annotations

from typing import Callable

import numpy as np


def measurements(simulate: Callable[..., dict], name: str, seed: int, **kw):
    """``simulate(seed, **kw)``'s columns as :class:`fdi.data.Measurements` named ``name``."""
    from fdi.data import Measurements
    cols = simulate(seed, **kw)
    return Measurements(name, cols["t"], cols)


def thresholds(model: str, simulate: Callable[..., dict]) -> dict:
    """The model's thresholds calibrated on nominal runs 1 and 2 (seeds 1, 2), asserted quiet on a
    third (seed 3): no alarm on a run the calibration did not see."""
    from fdi.calibrate import calibrate, nominal_residuals
    cal = calibrate(model, [measurements(simulate, "nominal1", 1), measurements(simulate, "nominal2", 2)])
    held_out = nominal_residuals(model, measurements(simulate, "nominal3", 3))
    assert (held_out.max(axis=1) < np.asarray(cal.thresholds)).all()
    return dict(zip(cal.names, cal.thresholds))
