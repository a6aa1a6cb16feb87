"""A mode switch whose transient settles between two samples (fdi.scales.switch_settle).

A user trial's drone: the ESC re-arms and the winding current (L/R = 0.36 ms) goes from 0 to 80 A
between two 1 kHz samples. The sample at the switch shows 0 A with the command armed, the next
80 A; every derivative fit that read both misread the current's slope, and three samples at 23 to
67 times the thresholds confirmed a detection in a fault-free record. The samples of such a
transient, and those whose filter window reads them, are left out; a winding fault after the
re-arm is still found. Data from the trial's plant, simulated apart from bgfdi
(tests/drone_plant.py); thresholds calibrated on runs without a switch.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bondgraph.timescales import model_time_scales
from fdi.api import diagnose
from fdi.calibrate import calibrate
from fdi.monitor import compiled
from fdi.options import Options
from fdi.residuals import stretches, switch_samples
from fdi.scales import switch_settle

from . import drone_plant as plant


MODEL = Path(__file__).parent / "data" / "drone_propulsion.yaml"
TS = 1e-3


@pytest.fixture(scope="module")
def thresholds(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("drone")
    runs = []
    for seed in (1, 2):
        path = tmp / f"nominal{seed}.csv"
        plant.run(str(path), seed=seed, T=4.0)
        runs.append(str(path))
    c = calibrate(str(MODEL), runs)
    return tmp, dict(zip(c.names, c.thresholds))


def test_the_winding_settles_within_a_sample_so_three_samples_after_a_switch_hold_it():
    """7 decay times of the electrical mode, La/(Ra + Rb d^2) by hand at full throttle and at rest,
    bound the samples; the mechanical mode (13 ms) is resolved and adds none."""
    monitor = compiled(MODEL)
    tau = 3.0e-5 / 0.08                               # La / Ra: the slowest the winding decays (d = 0)
    seconds = switch_settle(TS, model_time_scales(monitor.model).eigenvalues)
    assert 7 * 3.0e-5 / (0.08 + 0.02) <= seconds <= 7 * tau * 1.01
    assert switch_samples(monitor.model, TS) == math.ceil(seconds / TS) == 3
    assert switch_settle(TS, [-1.0 / 0.013]) == 0.0   # the rotor alone: nothing to leave out


def test_the_samples_left_out_after_a_switch_are_the_transients_and_the_windows_that_read_them():
    need, settle = 9, 3
    ((_, _), before), ((_, _), after) = stretches(1000, np.array([500]), need, 2, settle)
    assert before == slice(0, 498)                    # the stretch before: its edge trim alone
    assert after == slice(500 + settle + need // 2, 1000)
    ((_, _), _), ((_, _), plain) = stretches(1000, np.array([500]), need, 2)
    assert plain == slice(502, 1000)                  # without such a transient: the edge trim alone


def test_a_fault_free_disarm_and_rearm_is_not_a_detection(thresholds):
    tmp, given = thresholds
    path = tmp / "disarm.csv"
    plant.run(str(path), seed=16, T=6.0, disarm=(2.0, 3.0))
    d = diagnose(str(MODEL), str(path), Options(thresholds=given, workers=1))
    assert d.detection is None, d.detection


def test_a_winding_fault_after_a_rearm_is_still_found(thresholds):
    tmp, given = thresholds
    path = tmp / "disarm_ra.csv"
    plant.run(str(path), seed=17, T=6.0, disarm=(2.0, 3.0), fault=dict(target="Ra", type="abrupt", t0=4.0, value=0.12))
    d = diagnose(str(MODEL), str(path), Options(thresholds=given, workers=1))
    assert d.detection is not None and 4.0 - 0.0045 <= d.detection.time <= 4.05    # half the 9 ms window early at most
    ra = next(f for f in d.faults if f.name == "Ra")
    assert ra.type == "abrupt" and abs(ra.value - 0.12) <= 0.05 * 0.12, ra
