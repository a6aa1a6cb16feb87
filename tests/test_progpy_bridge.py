"""The ProgPy bridge (fdi.progpy_bridge): ProgPy's MonteCarlo on an identified incipient fault gives
the RUL bgfdi gives, and both the RUL of the degradation solved by hand.

The demo's fault (README, `bgfdi demo`): the absolute encoder's efficiency beta_theta2 from 1 at
t0 = 32 s as eq. (17), d(beta)/dt = -0.03 beta^2. By hand: d(1/beta)/dt = 0.03, so 1/beta = 1 +
0.03 (t - 32) and beta = 0.5 (the model file's failure value) when 0.03 (t - 32) = 1, at
t = 32 + 100/3 = 65.333 s; the demo gives its RUL at 41.98 s (t_D + one window), 23.353 s."""
from __future__ import annotations

import sys

import pytest

from fdi.prognose import prognose
from fdi.results import Fault

NOW = 41.98
ANALYTIC_RUL = 32.0 + 1.0 / 0.03 - NOW            # 23.3533 s
# the truth with a band of +-2 % on b2 and +-0.1 s on the onset, about the demo's fit (22.94 to 23.77 s)
DEMO = Fault("beta_theta2", "incipient", model=2, eta=(0, 1), b=(-0.03,), t0=32.0,
             b_band=((-0.0306, -0.0294),), t0_band=(31.9, 32.1))


def test_demo_drift_median_rul_matches_bgfdi_and_the_analytic_rul():
    pytest.importorskip("progpy")
    from fdi.progpy_bridge import predict_rul

    ours = prognose(DEMO.to_dict(), 1.0, 0.5, tf=DEMO.t0, now=NOW)
    theirs = predict_rul(DEMO, 1.0, 0.5, NOW, n=100, dt=0.05)
    assert abs(ours["rul"] - ANALYTIC_RUL) < 1e-9
    assert abs(theirs["median"] - ours["rul"]) / ours["rul"] < 0.05
    assert abs(theirs["median"] - ANALYTIC_RUL) / ANALYTIC_RUL < 0.01        # measured 0.2 % (dt = 0.05 s)
    # the distribution's 95 % spread sits inside bgfdi's band (its corners) and is not a point
    assert ours["rul_low"] - 0.1 <= theirs["low"] < theirs["median"] < theirs["high"] <= ours["rul_high"] + 0.1


@pytest.mark.parametrize("model_no, b, nominal, failure", [
    (1, (-0.02,), 1.0, 0.5),                       # eq. 16
    (3, (-3.7, -1.01), 1.0, 0.5),                  # eq. 18, integrated (RK4 in the model, closed form in bgfdi)
    (4, (0.5, -0.002, -0.003), 1.0, 0.5),          # eq. 19
    (2, (-1e-8,), float("inf"), 2e6),              # a leakage resistance from infinity, eq. 17
])
def test_each_degradation_model_predicts_bgfdis_end_of_life(model_no, b, nominal, failure):
    pytest.importorskip("progpy")
    from fdi.progpy_bridge import predict_rul

    f = Fault("P", "incipient", model=model_no, b=b, t0=32.0)
    ours = prognose(f.to_dict(), nominal, failure, tf=32.0, now=NOW)["rul"]
    theirs = predict_rul(f, nominal, failure, NOW, n=2, dt=0.01)["median"]
    assert theirs == pytest.approx(ours, abs=0.02)


def test_the_model_is_a_progpy_model_with_the_faults_state_and_event():
    progpy = pytest.importorskip("progpy")
    from fdi.progpy_bridge import degradation_model

    m = degradation_model(DEMO.to_dict(), 1.0, 0.5, NOW)
    assert isinstance(m, progpy.PrognosticsModel)
    assert m.events == ["failure"] and list(m.states) == ["P", "b1"]
    x = m.initialize()
    assert x["P"] == pytest.approx(1.0 / (1.0 + 0.03 * (NOW - 32.0)))
    assert m.event_state(x)["failure"] == pytest.approx((x["P"] - 0.5) / 0.5)
    assert not m.threshold_met(x)["failure"]
    with pytest.raises(ValueError, match="incipient"):
        degradation_model(Fault("R4", "abrupt", value=2.5e7, t0=32.0), float("inf"), 2e6, NOW)


def test_without_progpy_one_line_names_the_extra(monkeypatch):
    import fdi.progpy_bridge as bridge

    monkeypatch.setitem(sys.modules, "progpy", None)          # import progpy raises ImportError
    bridge._model_class.cache_clear()
    try:
        with pytest.raises(ImportError, match=r"pip install 'bgfdi\[progpy\]'") as err:
            bridge.degradation_model(DEMO, 1.0, 0.5, NOW)
        assert "\n" not in str(err.value)
    finally:
        bridge._model_class.cache_clear()
