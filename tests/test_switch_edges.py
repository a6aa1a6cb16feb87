"""The derivative filter at a mode switch: a stretch four windows long or more is fitted up to its
ends by one-sided fits, several times noisier than the centred filter at the end samples (the
variance of a least-squares polynomial's derivative grows away from the window's centre). Where
that noise is more than EDGE_GAIN times the centre's, no residual is given: on a thermostat that
switches 250 times a day, those samples set the calibrated thresholds (a two-zone building's
zone balance at 4 281 W against a 3 kW heater, 1 334 W without them).

The reference: the noise measured on white noise, 4 000 realisations, against the centred
filter's; and the theory's numbers for a cubic over 101 samples (3.9 times at the end sample for a
first derivative, 5.9 for a second: the norm of the one-sided Savitzky-Golay taps)."""
from __future__ import annotations

import numpy as np
import pytest

from fdi.derivatives import EDGE_GAIN, edge_trim
from fdi.residuals import _piecewise, stretches

N, SWITCH, SIZE = 101, 600, 1200          # a window of 101 samples; stretches of 600 samples (> 4 windows)


@pytest.mark.parametrize("order", [1, 2])
def test_samples_at_a_switch_are_kept_where_their_noise_is_within_the_bound(order):
    x = np.random.default_rng(order).normal(size=(4000, SIZE))
    d = _piecewise(x, 1.0, order, float(N), np.array([SWITCH]))[order]
    noise = np.std(d, axis=0)
    centre = np.median(noise[SWITCH + N:SIZE - N])
    kept = np.isfinite(d[0])
    gone = np.flatnonzero(~kept)
    trim = edge_trim(N, 3, order)
    assert gone.tolist() == list(range(SWITCH - trim, SWITCH + trim))       # at the switch only, both sides
    inner = kept & (np.arange(SIZE) >= N) & (np.arange(SIZE) < SIZE - N)     # the record's own ends keep theirs
    assert np.max(noise[inner]) / centre < EDGE_GAIN * 1.1                    # the 4 000 runs' sampling error
    assert noise[SWITCH - trim - 1] / centre > 0.8 * EDGE_GAIN               # the first kept sample is near the bound
    assert trim == {1: 18, 2: 41}[order]


def test_the_end_samples_noise_is_the_theorys():
    """Without the trim the end sample's first derivative is 3.9 times the centre's noise."""
    x = np.random.default_rng(0).normal(size=(4000, 4 * N + 20))
    (_, d) = [np.asarray(v) for v in _one_sided(x)]
    noise = np.std(d, axis=0)
    assert noise[-1] / np.median(noise[N:-N]) == pytest.approx(3.9, rel=0.05)


def _one_sided(x):
    from fdi.derivatives import estimate
    return estimate(x, 1.0, 1, float(N))


def test_a_stretch_shorter_than_four_windows_still_loses_half_a_window_at_each_switch():
    ((_, _), keep), = [s for s in stretches(1000, np.array([300, 500]), N, edge_trim(N, 3, 1)) if s[0] == (300, 500)]
    assert (keep.start, keep.stop) == (300 + N // 2, 500 - N // 2)
    long, = [s for s in stretches(2000, np.array([300, 1000]), N, edge_trim(N, 3, 1)) if s[0][0] == 300]
    assert (long[1].start, long[1].stop) == (318, 982)


PRECHARGE_N, PRECHARGE_TS, PRECHARGE_WINDOW = 4000, 1e-3, 0.025


def _precharge(seed: int):
    """The EV precharge model (tests/data/ev_precharge.yaml), its residuals, and 4 s of signals at
    1 kHz around its switches: white noise on levels, the precharge contactor closing at 1.0 s and
    the main one at 2.5 s (a residual's gaps, not its values, are what is tested)."""
    from pathlib import Path

    from bondgraph.loader import load_model
    from fdi.monitor import derive

    model = load_model(Path(__file__).parent / "data" / "ev_precharge.yaml")
    _, residuals = derive(model)
    n = PRECHARGE_N
    rng = np.random.default_rng(seed)
    t = np.arange(n) * PRECHARGE_TS
    modes = {"p": (t >= 1.0).astype(float), "m": (t >= 2.5).astype(float), "d": np.zeros(n)}
    raw = {"Vb": 400 + rng.normal(0, 0.1, n), "iinv": rng.normal(0, 0.1, n), "ib": rng.normal(0, 0.1, n),
           "vdc": 300 + rng.normal(0, 0.1, n), **modes}
    return model, list(residuals), t, raw, modes


def test_the_gaps_left_by_design_count_every_channel_a_stored_quantitys_rate_too():
    """The EV precharge link residual filters the capacitor's charge C (vdc - Resr iC) for its first
    rate while reading the signals undifferentiated: its gaps at a switch are the first rate's (4
    samples each side of a 25-sample window), not the smoothed values' (2). The report's note on
    samples that are not finite counted only the signals' orders and called the difference an
    overflow of the record."""
    from types import SimpleNamespace

    from fdi import pipeline
    from fdi.residuals import designed_gaps, evaluate, switch_samples

    model, residuals, t, raw, modes = _precharge(1)
    n, ts, window = PRECHARGE_N, PRECHARGE_TS, PRECHARGE_WINDOW
    r = evaluate(model, residuals, raw, ts, window=window, values=modes)
    settle = switch_samples(model, ts)
    assert settle == 1       # a contactor's transient settles within the 1 ms sampling time: the switch's sample
    gaps = designed_gaps(residuals, n, np.array([1000, 2500]), window, ts, settle=settle)
    # 4 samples before each switch (the rate's end trim); after it that sample and the 12 whose windows read it
    assert np.flatnonzero(gaps).tolist() == [*range(996, 1013), *range(2496, 2513)]
    assert not (~np.isfinite(r) & ~gaps).any()
    p = SimpleNamespace(monitor=SimpleNamespace(names=[x.name for x in residuals], model=model,
                                                residuals=residuals),
                        meas=SimpleNamespace(t=t, ts=ts), raw=raw, window_s=window)
    assert pipeline.blind(p, r) is None


def test_a_sensor_faults_fit_across_a_switch_skips_the_rates_gaps():
    """The identification's objective left out the samples its signals' filters leave NaN at a mode
    switch, not the wider gaps of a stored quantity's rate: a set with the precharge current
    sensor's gain (its corrected signal filtered again) summed NaN and cost infinity, so it never
    competed (the trial's precharge resistor won by that alone). The cost is finite, and at the
    designed truth (no fault: beta 1, the record is nominal) it is the noise's."""
    from fdi.objective import Objective, window

    model, residuals, t, raw, _ = _precharge(2)
    window_s = PRECHARGE_WINDOW
    win = window(t, raw, 2.0, 1000, window_s)                      # 2 to 3 s: the main contactor closes at 2.5 s
    obj = Objective(model, tuple(residuals), win, ("beta_ib",), np.ones(len(residuals)), window_s)
    real, bits = obj.encode([{"name": "beta_ib", "type": "abrupt", "value": 1.0, "t0": 2.0}])
    cost = obj(np.atleast_2d(real), np.atleast_2d(bits))
    assert np.isfinite(cost).all() and cost.max() > 0


@pytest.mark.parametrize("n, polyorder", [(2003, 3), (2401, 4)])
def test_long_windows_trim_from_the_normal_equations_as_the_pseudo_inverses_do(n, polyorder):
    """Windows over EXACT_EDGE samples take their noise gains from the normal equations (a record
    stamped in hours asked for a 39 601-sample window: two minutes of pseudo-inverses); the
    reference is the pseudo-inverse of every position's Vandermonde matrix."""
    from fdi.derivatives import _edge_gains, _edge_gains_by_moments
    exact, moments = _edge_gains(n, polyorder, polyorder), _edge_gains_by_moments(n, polyorder, polyorder)
    assert np.allclose(moments, exact, rtol=1e-4, atol=0)
    for k in range(polyorder + 1):
        over = [g[:k + 1] > EDGE_GAIN * g[:k + 1, -1:] for g in (exact, moments)]
        assert [int(np.flatnonzero(o.any(axis=0)).max() + 1) for o in over] == [edge_trim(n, polyorder, k)] * 2
