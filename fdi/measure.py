"""How a sensor's reading becomes its data columns: each column's expression of the signal, plus
the column's noise (standard deviation) and quantisation (resolution), as the model file declares
them (``sensors: {p1: {noise: 5.0, resolution: 1.0}}``).

Simulation (:mod:`fdi.app.scenario`) writes its data this way, and :mod:`fdi.noise` predicts each
residual's noise from the same measurement model, so that a prediction and a simulated run agree.

>>> import numpy as np
>>> from bondgraph.loader import load_model
>>> m = load_model("models/boost_converter.yaml")
>>> cols = sensor_columns(m, m.sensors["vo"], np.full(20000, 12.0), np.random.default_rng(0))
>>> list(cols), round(float(cols["vo"].mean()), 2), round(float(cols["vo"].std()), 3)
(['vo'], 12.0, 0.01)
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from bondgraph.model import Model, Sensor


class SeveralColumns(ValueError):
    """A sensor reads several columns and the file does not say how each is made from its signal."""


def sensor_columns(model: Model, sensor: Sensor, measured: np.ndarray, rng: np.random.Generator,
                   noise: Mapping[str, float] | None = None,
                   resolution: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
    """The data columns ``sensor`` writes for the signal values ``measured``: each column's
    expression of the signal (``columns:``; the signal itself for a one-column sensor) at the
    model's nominal values, plus white noise of the column's standard deviation, rounded to its
    resolution. ``noise``/``resolution`` (by column) override the sensor's. SeveralColumns when a
    sensor reads several columns without ``columns:``."""
    import sympy as sp

    mapping = sensor.column_values(None)
    if mapping is None:
        cols = sorted(str(s) for s in sensor.signal.free_symbols)
        how = (f"it reads several columns ({', '.join(cols)})" if len(cols) > 1 else
               f"it reads column {cols[0]} through {sensor.signal}, which bgfdi cannot solve for {cols[0]} in one way")
        raise SeveralColumns(f"{model.path}: sensors.{sensor.name}: {how}; add columns: "
                             "{<column>: <expression of " + sensor.name + ">} to say how each is made from it")
    nominal = dict(model.nominal_values())
    measured = np.asarray(measured, dtype=float)
    out = {}
    for col, expr in mapping.items():
        fn = sp.lambdify([sp.Symbol(sensor.name, real=True)], expr.xreplace(nominal), modules="numpy")
        x = np.asarray(fn(measured), dtype=float) * np.ones_like(measured)
        sigma = (noise or {}).get(col, sensor.noise.get(col, 0.0))
        if sigma:
            x = x + sigma * rng.standard_normal(x.shape)
        step = (resolution or {}).get(col, sensor.resolution.get(col, 0.0))
        if step:
            x = np.round(x / step) * step
        out[col] = x
    return out
