"""Thresholds by mode (fdi.mode_thresholds): the file's tables read and checked, the residual
monitored divided by its mode's threshold, calibrate writing them where a residual's noise differs
between modes, and the diagnosis they make possible on the EV precharge circuit simulated apart
from bgfdi (tests/precharge_plant.py: exact discretisation with the BMS's own contactor logic).

Designed truth: the precharge resistor Rp (50 -> 75 Ohm) shows only while precharging, in the loop
residual (Vb - Rp ib - vdc). With one threshold per residual the link balance is blinded by its
main-contactor mode ((Vb - vdc)/Rm, Rm = 2 mOhm: hundreds of amperes of threshold), so it cannot
exonerate the current sensor's gain, which the loop also reads; with its threshold by mode it stays
quiet at a fraction of an ampere while precharging, and Rp is the one candidate.
"""
from __future__ import annotations

import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from bondgraph.errors import ModelError
from fdi.config import load_text
from fdi.mode_thresholds import threshold_in
from fdi.monitor import Monitor

from . import precharge_plant as plant

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "tests" / "data" / "ev_precharge.yaml"
TEXT = MODEL.read_text(encoding="utf-8")


def _with(thresholds: str) -> str:
    return re.sub(r"^thresholds:.*\n", "", TEXT, flags=re.M) + "\nthresholds: " + thresholds + "\n"


def _signals(n: int = 6000, seed: int = 0):
    """Levels with white noise and the contactors switching (precharge from 1 s, main from 2.5 s,
    precharge open from 3 s): a residual's value in each mode."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    modes = {"p": ((t >= 1.0) & (t < 3.0)).astype(float), "m": (t >= 2.5).astype(float), "d": np.zeros(n)}
    raw = {"Vb": 400 + rng.normal(0, 0.2, n), "iinv": rng.normal(0, 0.1, n), "ib": 5 + rng.normal(0, 0.3, n),
           "vdc": 390 + rng.normal(0, 0.2, n), **modes}
    return t, raw, modes


def test_a_table_by_mode_is_read_in_the_models_mode_order():
    model, config = load_text(_with("{ARR1: {m=1 p=0: 120.0, other: 0.8}, ARR2: 56.8}"), "pc.yaml")
    assert config.thresholds == {"ARR1": 1.0, "ARR2": 56.8}
    table = config.mode_thresholds["ARR1"]
    assert table == {(("p", 0), ("m", 1)): 120.0, (): 0.8}
    assert threshold_in(table, {"p": 0, "m": 1, "d": 1}) == 120.0 and threshold_in(table, {"p": 1, "m": 1}) == 0.8


@pytest.mark.parametrize("table, key, says", [
    ("{ARR1: {}}", "thresholds.ARR1", "at least one entry"),
    ("{ARR1: {q=1: 2.0, other: 1.0}}", "thresholds.ARR1.q=1", "no mode of the model"),
    ("{ARR1: {p=2: 2.0, other: 1.0}}", "thresholds.ARR1.p=2", "mode=0 or mode=1"),
    ("{ARR1: {p=1: 2.0, m=1: 1.0}}", "thresholds.ARR1.m=1", "the same mode variables"),
    ("{ARR1: {p=1: 2.0}}", "thresholds.ARR1", "no threshold for p=0"),
    ("{ARR1: {p=1 p=0: 2.0, other: 1.0}}", "thresholds.ARR1.p=1 p=0", "twice"),
    ("{ARR1: {p=1: -2.0, p=0: 1.0}}", "thresholds.ARR1.p=1", "threshold"),
])
def test_a_bad_table_names_its_key(table, key, says):
    with pytest.raises(ModelError) as err:
        load_text(_with(table), "pc.yaml")
    text = str(err.value)
    assert key in text and says in text and "pc.yaml" in text


def test_the_monitored_residual_is_the_arrs_over_its_modes_threshold():
    model, config = load_text(_with("{ARR1: {p=0 m=1: 120.0, p=1 m=0: 0.9, other: 0.7}, ARR2: 56.8}"), "pc.yaml")
    mon = Monitor(model, config)
    from fdi.residuals import evaluate
    _, raw, modes = _signals()
    undivided = evaluate(model, list(mon.arr_residuals), raw, 1e-3, window=0.009, values=modes)
    divided = evaluate(model, list(mon.residuals), raw, 1e-3, window=0.009, values=modes)
    expected = np.where((modes["p"] == 0) & (modes["m"] == 1), 120.0,
                        np.where((modes["p"] == 1) & (modes["m"] == 0), 0.9, 0.7))
    ok = np.isfinite(undivided[0])
    assert ok.sum() > 4000
    np.testing.assert_allclose(divided[0][ok] * expected[ok], undivided[0][ok], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(divided[1][ok], undivided[1][ok])            # ARR2: one threshold, as it was
    assert mon.units[0] == "1" and mon.units[1] != "1"
    back = pickle.loads(pickle.dumps(mon))            # a worker's copy divides alike
    again = evaluate(model, list(back.residuals), raw, 1e-3, window=0.009, values=modes)
    np.testing.assert_array_equal(again[0][ok], divided[0][ok])


def test_one_threshold_given_as_an_option_replaces_the_table():
    from fdi.pipeline import with_overrides
    model, config = load_text(_with("{ARR1: {p=1: 2.0, p=0: 300.0}, ARR2: 56.8}"), "pc.yaml")
    mon = with_overrides(Monitor(model, config), {"ARR1": 5.0})
    assert mon.config.mode_thresholds == {} and mon.config.thresholds["ARR1"] == 5.0
    assert mon.residuals[0] is mon.arr_residuals[0]


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """The precharge file calibrated on three nominal runs of the plant (9 s, three drive cycles each)."""
    from fdi.calibrate import calibrate, with_thresholds
    from fdi.data import Measurements
    runs = []
    for seed in (21, 22, 23):
        t, cols, _ = plant.simulate(T=9.0, seed=seed)
        runs.append(Measurements(f"nominal{seed}.csv", t, {"t": t, **cols}))
    c = calibrate(str(MODEL), runs)
    path = tmp_path_factory.mktemp("pc") / "ev_precharge.yaml"
    path.write_text(with_thresholds(TEXT, c), encoding="utf-8")
    return c, path


def test_calibrate_gives_the_link_balance_thresholds_by_mode(calibrated):
    c, path = calibrated
    link = c.mode_thresholds["ARR1"]            # predicted 51 A with the main contactor closed, 0.07-0.17 A else
    closed, precharging = link["p=0 m=1 d=0"], link["p=1 m=0 d=0"]
    assert closed > 100 * precharging and precharging < 2.0
    assert c.thresholds[0] == pytest.approx(closed)       # one threshold: the noisiest mode's
    model, config = load_text(path.read_text(encoding="utf-8"), str(path))
    assert config.mode_thresholds["ARR1"][(("p", 1), ("m", 0), ("d", 0))] == pytest.approx(precharging, rel=1e-3)


def test_each_threshold_of_the_loop_says_its_unit(calibrated):
    """By hand (tests/test_switched_selection.py): the precharge loop balances volts while a
    contactor is closed and reads the battery current, in A, while both are open; its table gives
    each mode's unit (one label, V, was wrong for two of its thresholds)."""
    from fdi.calibrate import format_calibration
    c, _ = calibrated
    (name,) = c.mode_units
    units = c.mode_units[name]
    assert units and all(u == ("V" if ("p=1" in k or "m=1" in k) else "A") for k, u in units.items())
    text = format_calibration(c)
    assert f"{name:<10}{'by mode':<10}" in text and "  p=0 m=0 d=0           A" in text


def test_the_precharge_resistor_is_told_from_the_current_sensor(calibrated, tmp_path):
    from fdi.api import diagnose
    from fdi.data import Measurements
    from fdi.options import Options
    _, path = calibrated
    t, cols, _ = plant.simulate(T=9.0, seed=31, faults=[{"target": "Rp", "t0": 4.0, "value": 75.0}])
    d = diagnose(str(path), Measurements("rp.csv", t, {"t": t, **cols}), Options(workers=1, seed=1))
    assert d.detection is not None and 6.0 < d.detection.time < 6.5     # the next precharge, from 6.1 s
    assert [sorted(s) for s in d.candidates] == [["Rp"]]
    (fault,) = d.faults
    assert fault.name == "Rp" and fault.value == pytest.approx(75.0, rel=0.02)


def test_a_mode_where_the_residual_is_exactly_zero_gets_no_zero_threshold():
    """A reading quantised to 0 while a contactor is open makes the residual exactly 0 there: a
    threshold of 0 would alarm on any noise (and the file written would not load); that mode is
    judged as one the runs never visited (the visited mode's threshold, scaled by the predicted noise)."""
    from fdi.calibrate import _mode_table
    from fdi.noise import ModeNoise
    rng = np.random.default_rng(3)
    p = np.r_[np.zeros(500), np.ones(500)]
    row = np.where(p == 1, np.abs(rng.normal(0, 1.0, 1000)), 0.0)
    predicted = [ModeNoise({"p": 0}, 0.5, {}), ModeNoise({"p": 1}, 1.0, {})]
    table, unvisited = _mode_table([row], [{"p": p}], ("p",), None, 1.5, 100, predicted)
    high = 1.5 * row.max()
    assert table == {(("p", 1),): pytest.approx(high), (("p", 0),): pytest.approx(high * 0.5)}
    assert unvisited == [(("p", 0),)]
