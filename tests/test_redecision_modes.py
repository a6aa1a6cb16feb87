"""A later decision reads the residuals a fault enters in every mode the record went through.

Designed truth: the accumulator circuit of tests/data/unverified/accumulator_check_valve.yaml (a
user trial's domain), simulated by the trial's own scipy plant (tests/accumulator_plant.py), with
the accumulator's pressure transducer reading 3 bar high from 30 s. The pump line's residual
reads pa only while the check valve conducts (MD-FSM: pa_bias is [0 1 1] with the pump off,
[1 1 1] with it delivering), so when the pump starts at 33 s that residual lights too. Decided
again with the FSM of the mode at t_D (pump off), only sets with a pump fault covered it, and a
pump leak intermittent with the load valve's period was reported beside the offset (seed 13).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fdi.api import Options, diagnose
from fdi.calibrate import calibrate
from fdi.data import Measurements

from . import accumulator_plant as plant

MODEL = str(Path(__file__).parent / "data" / "unverified" / "accumulator_check_valve.yaml")
OFFSET = 3.0e5          # Pa, from 30 s


def _measurements(name: str, rows: np.ndarray) -> Measurements:
    head = ["t", "Qp", "v_cmd", "pp", "pa", "Ql"]
    return Measurements(name, rows[:, 0].copy(), {h: rows[:, i].copy() for i, h in enumerate(head)})


def test_a_transducer_offset_seen_anew_when_the_pump_starts_is_the_whole_diagnosis():
    runs = [_measurements(f"nominal{s}", plant.simulate(T=60.0, seed=s)) for s in (1, 2, 3)]
    got = calibrate(MODEL, runs)
    data = _measurements("offset", plant.simulate(T=60.0, seed=13, sensor_bias={"value": OFFSET, "t0": 30.0}))
    d = diagnose(MODEL, data, Options(workers=1, seed=0, thresholds=dict(zip(got.names, got.thresholds))))
    assert d.episodes and d.episodes[0].coherence == (1, 1, 1)        # the pump line's residual joined later
    assert all(e.winner == ("pa_bias",) for e in d.episodes)
    (fault,) = d.faults
    assert fault.name == "pa_bias" and fault.type == "abrupt" and fault.value == pytest.approx(OFFSET, rel=0.01)
