"""How a sensor's reading becomes its data columns in simulation (fdi.measure): a one-column
sensor read through an expression is written through its inverse, which bgfdi solves; one it
cannot solve, or several columns, ask for ``columns:`` and say which. A user trial's level sensor,
``expr: "9810.0*h"`` (the column in m, the signal a pressure in Pa), was refused as "it reads several
columns"."""
from __future__ import annotations

import numpy as np
import pytest

from bondgraph.loader import load_model_text
from fdi.measure import SeveralColumns, sensor_columns

MODEL = """
name: drained_tank
parameters: {C: {value: 2.0e-4, unit: m^3/Pa}, R: {value: 1.0e7, unit: Pa*s/m^3}}
data: {columns: [t, Q, COLUMNS]}
inputs: {Q: {unit: m^3/s, column: Q, expr: "1.0e-4"}}
elements: {pump: {type: MSf, input: Q}, tank: {type: C, parameter: C}, drain: {type: R, parameter: R}}
junctions: {J: {type: "0"}}
sensors: {h: {type: De, junction: J, unit: Pa, SENSOR}}
bonds: {1: [pump, J], 2: [J, tank], 3: [J, drain]}
"""


def model(sensor: str, columns: str):
    return load_model_text(MODEL.replace("SENSOR", sensor).replace("COLUMNS", columns))


def test_a_level_read_as_a_pressure_is_written_in_metres():
    m = model('expr: "9810.0*h"', "h")
    p = np.array([0.0, 9810.0, 490500.0])          # Pa: 0, 1 and 50 m of water
    cols = sensor_columns(m, m.sensors["h"], p, np.random.default_rng(0))
    assert list(cols) == ["h"]
    np.testing.assert_allclose(cols["h"], [0.0, 1.0, 50.0], rtol=1e-12)


def test_a_column_bgfdi_cannot_solve_for_asks_for_its_law():
    m = model('expr: "9810.0*lvl**2"', "lvl")      # two roots: which one the sensor writes is the user's to say
    with pytest.raises(SeveralColumns) as err:
        sensor_columns(m, m.sensors["h"], np.ones(3), np.random.default_rng(0))
    assert "it reads column lvl through 9810.0*lvl**2" in str(err.value)
    assert "add columns: {<column>: <expression of h>}" in str(err.value)


def test_several_columns_are_named():
    m = model('expr: "a - b"', "a, b")
    with pytest.raises(SeveralColumns) as err:
        sensor_columns(m, m.sensors["h"], np.ones(3), np.random.default_rng(0))
    assert "it reads several columns (a, b)" in str(err.value)
