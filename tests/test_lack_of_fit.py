"""The data a decision reads after its first window. A decision is taken again when its fit stops explaining the data (fdi.pipeline.misfit_at): the
residuals, with the decided faults held at their fit, confirm an alarm after the data the fit saw,
though no new residual fires. Designed truth from a plant written apart from bgfdi
(tests/independent/rc.py): the RC circuit's load decays as RL exp(b (t - t0)), b = -0.02 /s from
t0 = 2 s, for 18 s. Fitted on the first second after the detection, the decay was eq. (17)'s
(1/RL growing linearly: the same to first order, 6.5 % apart after 18 s) and stayed so to the
end of the record; its residual left the threshold at 8.3 s and, decided again on the data from
t_D, the decay is eq. (16) with b within 0.2 %. The thresholds are calibrated (bgfdi calibrate)
on two fault-free runs of the same plant (seeds 11 and 12): ARR1 0.001811 V, ARR2 0.00014 A."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fdi.data import Measurements

from .independent import rc

MODEL = Path(__file__).parent / "data" / "rc_two_sensors.yaml"
THRESHOLDS = {"ARR1": 0.001811, "ARR2": 0.00014}


@pytest.fixture(scope="module")
def decay() -> dict:
    from fdi.api import Options, diagnose
    cols = rc.simulate(20.0, 1, drift=(2.0, -0.02))
    return diagnose(str(MODEL), Measurements("decay.csv", cols["t"], cols),
                    Options(workers=1, seed=0, thresholds=THRESHOLDS)).to_dict()


def test_a_fit_the_later_data_refute_is_decided_again_on_the_data_since_the_detection(decay):
    (f,) = decay["diagnosis"]["faults"]
    assert (f["name"], f["type"], f["model"]) == ("RL", "incipient", 1)
    assert f["b"][0] == pytest.approx(-0.02, rel=0.01)
    assert f["t0"] == pytest.approx(2.0, abs=0.05)
    misfits = [e for e in decay["episodes"] if e["cause"] == "misfit"]
    assert misfits and misfits[0]["previous"][0]["model"] != 1          # the first fit was another law
    assert all(e["coherence"] == [0, 1] for e in misfits)               # no new residual fired
    assert decay["window"][0] == pytest.approx(decay["detection"]["time"])   # fitted from t_D


def test_the_report_says_why_it_decided_again(decay):
    from fdi.app.report import to_text
    text = to_text(decay, "rc_two_sensors", "decay.csv")
    assert "the fit no longer explained the data" in text and "the coherence vector still [0, 1]" in text


def test_a_prognosis_is_given_at_the_end_of_the_data_its_fit_read():
    """Eq. (30): the RUL at t_f + N ts, the end of the identification window. A later decision
    within the first window refits on that window (at least N samples from t_D), and its prognosis
    was stamped at the decision's time instead: a trial's hoist with --samples 29930 gave "RUL at
    10.57 s" from a fit that read the record to 40 s. Designed: the RC circuit's voltage sensor's
    gain decays as exp(-0.01 (t - 2)) (applied to the independent plant's reading), failing at 0.8
    at 2 + ln(1.25)/0.01 = 24.31 s; ARR2 fires first, ARR1 0.2 s later, decided again at 2.7 s."""
    import math

    from fdi.api import Options, diagnose
    cols = rc.simulate(10.0, 5)
    t = cols["t"]
    cols["v"] = np.where(t >= 2.0, cols["v"] * np.exp(-0.01 * np.clip(t - 2.0, 0.0, None)), cols["v"])
    d = diagnose(str(MODEL), Measurements("gain.csv", t, cols),
                 Options(workers=1, seed=0, thresholds=THRESHOLDS, samples=4000, failures={"beta_v": 0.8}))
    assert [e.cause for e in d.episodes] == ["coherence"] and d.episodes[0].decision_time < 3.0
    (p,) = d.prognosis
    assert p.at == pytest.approx(d.detection.time + 4000 * rc.TS, abs=1e-6) == pytest.approx(d.window[1], abs=1e-6)
    assert p.eol == pytest.approx(2.0 + math.log(1.25) / 0.01, abs=0.1)


def test_the_monitor_decides_again_as_the_samples_refute_its_fit():
    """``bgfdi monitor`` judges the samples after a decision against its fit every refresh period
    (fdi.pipeline.refuted, each sample once) and decides again when they refute it: the decay's
    eq. (16) is emitted as the samples arrive (decided at 8.8 s, known at 9.3 s), not with the
    summary at the end of the stream (20 s), where it came before."""
    from fdi.api import Options
    from fdi.monitor import Monitor
    cols = rc.simulate(20.0, 1, drift=(2.0, -0.02))
    header = ["t", "u", "i", "v"]
    table = np.column_stack([cols[k] for k in header])
    events: list[dict] = []
    mon = Monitor(str(MODEL)).stream(events.append, Options(workers=1, seed=0, thresholds=THRESHOLDS), live=False,
                                     worker="thread")
    for a in range(0, table.shape[0], 500):
        mon.feed(header, table[a:a + 500])
    mon.close()
    decisions = [e for e in events if e["event"] == "decision"]
    assert [d["faults"][0]["model"] for d in decisions] == [2, 1]
    assert decisions[1]["faults"][0]["b"][0] == pytest.approx(-0.02, rel=0.01)
    assert decisions[1]["t"] < decisions[1]["known_at"] < 10.0
