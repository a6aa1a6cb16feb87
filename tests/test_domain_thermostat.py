"""A two-zone building (thermal; tests/data/two_zone_thermostat.yaml, a user trial's model), graded
on its own scipy plant (tests/thermostat_plant.py).

Designed truth: the zone-2 thermometer reads 1.5 K high from 30 h. The step of its reading jumps
its derivative, so the zone balances that read C2 dT2/dt spike at the onset (10 kW, against a
1 kW level before), while the wall's balance, which reads T2 through (T1 - T2)/R12 only, moves by
1.5 K / R12 = 187 W, under its 2 132 W threshold. The test of quiet residuals (fdi.sensitivity)
read the offset's size from that spike against a constant offset's effect, which has none: 22
times too large, so the quiet wall balance "would have fired" and exonerated the thermometer,
and the zone's envelope (insulation2, 0.0327 K/W) was reported. The offset now steps inside the
window as a real one does.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fdi.api import Options, diagnose
from fdi.data import Measurements

from . import thermostat_plant as plant

MODEL = str(Path(__file__).parent / "data" / "two_zone_thermostat.yaml")


def test_a_thermometer_offset_is_not_exonerated_by_the_wall_balance_it_barely_moves():
    rows = plant.simulate(5, offset=(30 * 3600.0, 1.5))
    data = Measurements("offset", rows[:, 0].copy(), {h: rows[:, i].copy() for i, h in enumerate(plant.HEAD)})
    d = diagnose(MODEL, data, Options(workers=1, seed=0))
    assert d.detection is not None and abs(d.detection.time - 30 * 3600.0) < 900
    assert any("T2_offset" in c for c in d.candidates)
    (fault,) = d.faults
    assert fault.name in ("T2_offset", "T2_gain")      # one thermometer: an offset or a gain read alike at ~290 K
    moved = fault.value if fault.name == "T2_offset" else (fault.value - 1.0) * 290.0
    assert abs(moved - 1.5) < 0.15


def test_a_window_that_leaves_most_of_a_run_without_residuals_is_passed_over(tmp_path):
    """The rule's window here, 2 232 s, against a thermostat that switches
    every ~20 minutes: half a window at each switch is left out, and 8 of 2 881 samples kept a
    residual; calibrate --window auto kept it (a trial's runs: its thresholds from those 8) or refused
    a run without any (these), and a diagnosis at it said "nothing detected" with no note. Now the rule's window is passed over and a shorter one
    chosen; a diagnosis at the rule's window says how few samples it judged."""
    from fdi.calibrate import calibrate
    text = Path(MODEL).read_text(encoding="utf-8").replace("diagnosis: {derivative_window: 660.0}\n", "")
    model = tmp_path / "auto.yaml"
    model.write_text(text, encoding="utf-8")
    runs = [plant.simulate(1, mean=277.15, amp=5.0), plant.simulate(2, mean=279.15, amp=4.0)]
    data = [Measurements(f"nominal{i}", r[:, 0].copy(), {h: r[:, k].copy() for k, h in enumerate(plant.HEAD)})
            for i, r in enumerate(runs)]
    got = calibrate(str(model), data, window="auto")
    assert got.window_scores and not got.window_scores[0].rule        # the rule's window was not scored
    assert got.window < 1000.0
    d = diagnose(str(model), data[0], Options(workers=1, seed=0))     # at the rule's window
    assert d.detection is None and "samples have a residual" in (d.note or "")


def test_a_stream_gives_the_files_residuals_but_the_first_half_window_after_a_switch():
    """The file treats a stretch between switches by its length (one-sided fits up to the switches
    when it lasts four filter windows, half a window left out at each when shorter). The stream
    cannot wait for the length of the stretch it is in without holding its alarms four windows
    (44 minutes here), so it leaves the first half window after a switch out, as in a short
    stretch; everywhere else it gives the file's residuals. It also left samples before a switch
    out where the file keeps them: the rows it carried cut the long stretch before the switch, which
    looked short (3 samples at 9 switches of this run); it now carries the rows that tell."""
    from fdi.data import commanded, signals_from_data
    from fdi.derivatives import DEFAULT_ORDER, window_samples
    from fdi.monitor import compiled
    from fdi.residuals import evaluate, mode_breaks
    # the heater at 60 % from 20 h: it stays on for hours, stretches of over four filter windows
    rows = plant.simulate(7, noise=0.01, heater=(20 * 3600.0, 0.6))
    head = plant.HEAD
    mon = compiled(MODEL).stream(lambda e: None, Options(workers=1))
    pieces, done = [], 0
    for a in range(0, rows.shape[0], 50):
        mon.feed(head, rows[a:a + 50])
        if mon.done > done:
            pieces.append(mon.residuals)
            done = mon.done
    streamed = np.concatenate(pieces, axis=1)
    c = compiled(MODEL)
    meas = Measurements("nominal", rows[:, 0].copy(), {h: rows[:, i].copy() for i, h in enumerate(head)})
    raw = signals_from_data(c.model, meas)
    whole = evaluate(c.model, list(c.residuals), raw, plant.TS, window=c.config.derivative_window,
                     values=commanded(c.model, raw))[:, :streamed.shape[1]]
    assert streamed.shape[1] > 0.9 * rows.shape[0]
    half = window_samples(c.config.derivative_window, plant.TS, DEFAULT_ORDER) // 2
    after = np.zeros(streamed.shape[1], dtype=bool)
    for b in mode_breaks(c.model, raw):
        after[b:b + half] = True
    differ = ~np.isclose(streamed, whole, rtol=1e-9, atol=1e-9, equal_nan=True)
    assert differ.any()                                  # (this run has long stretches)
    assert not differ[:, ~after].any()                   # the file's residuals everywhere else
    assert np.isnan(streamed[differ]).all()              # and left out, not other values, after a switch
