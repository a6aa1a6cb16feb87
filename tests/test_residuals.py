"""Residuals on the CyCab reference measurements; derivative estimation."""
from __future__ import annotations

import numpy as np
import pytest

from fdi import derivatives
from fdi.data import DataError, read_csv, signals_from_data
from fdi.config import load
from fdi.residuals import compile_residuals, evaluate

from .conftest import DATA

THRESHOLDS = np.array([1.0, 5.5e-6, 15.0])


@pytest.fixture(scope="module")
def residuals(cycab, cycab_arrs):
    return compile_residuals(cycab, cycab_arrs)


def _run(model, residuals, name):
    data = read_csv(DATA / f"{name}.csv")
    r = evaluate(model, residuals, signals_from_data(model, data), data.ts, window=load(model.path)[1].derivative_window)
    return data.t, r


def _coherence(t, r, t_from, t_to):
    window = (t >= t_from) & (t <= t_to)
    return [int(np.any(np.abs(r[i, window]) > THRESHOLDS[i])) for i in range(3)]


def test_nominal_residuals_stay_under_thresholds(cycab, residuals):
    t, r = _run(cycab, residuals, "nominal")
    after = t > 1.0
    assert np.all(np.abs(r[:, after]).max(axis=1) < THRESHOLDS)
    assert np.all(np.abs(r[:, after]).max(axis=1) < 0.5 * THRESHOLDS)


@pytest.mark.parametrize("name, expected", [
    ("scenario1", [1, 1, 0]), ("scenario2", [0, 1, 1]), ("scenario3", [1, 0, 0])])
def test_scenario_coherence_vectors(cycab, residuals, name, expected):
    t, r = _run(cycab, residuals, name)
    assert _coherence(t, r, 1.0, 31.5) == [0, 0, 0]         # healthy before the faults
    assert _coherence(t, r, 31.5, 37.0) == expected


def test_scenario2_theta2_residual_crosses_late(cycab, residuals):
    # the incipient sensor fault hides in the noise at first: [0 1 0], then [0 1 1] by 37 s
    t, r = _run(cycab, residuals, "scenario2")
    assert _coherence(t, r, 31.5, 34.0) == [0, 1, 0]
    first = t[np.flatnonzero((np.abs(r[2]) > THRESHOLDS[2]) & (t > 31.5))[0]]
    assert 34.0 < first <= 37.0


def test_residuals_broadcast_over_a_population(cycab, residuals):
    data = read_csv(DATA / "nominal.csv")
    sig = signals_from_data(cycab, data)
    betas = {"theta1": np.array([[1.0], [0.8]])}
    r = evaluate(cycab, residuals, sig, data.ts, betas=betas, values={"R4": np.array([[np.inf], [1e7]])})
    assert r.shape == (3, 2, data.t.size)
    single = evaluate(cycab, residuals, sig, data.ts)
    assert np.allclose(r[:, 0, :], single)
    assert not np.allclose(r[0, 1], single[0])


def test_savitzky_golay_is_exact_on_polynomials():
    ts = 0.01
    t = np.arange(0, 2, ts)
    x = 3 * t ** 3 - t ** 2 + 0.5
    x0, x1, x2 = derivatives.estimate(x, ts, 2, window=0.2, polyorder=3)
    assert np.allclose(x0, x) and np.allclose(x1, 9 * t ** 2 - 2 * t, atol=1e-8)
    assert np.allclose(x2, 18 * t - 2, atol=1e-6)


def test_derivative_window_is_odd_and_long_enough():
    assert derivatives.window_samples(0.25, 0.01, 3) == 25
    assert derivatives.window_samples(0.001, 0.01, 3) == 5


def test_bad_measurement_files(tmp_path, cycab):
    def write(text):
        p = tmp_path / "d.csv"
        p.write_text(text)
        return p
    with pytest.raises(DataError, match="NaN"):
        read_csv(write("t,u_in,theta1,theta2,p1,p2\n0,0,0,0,0,0\n0.01,,0,0,0,0\n0.02,0,0,0,0,0\n"))
    with pytest.raises(DataError, match="non-uniform"):
        read_csv(write("t,u_in,theta1,theta2,p1,p2\n0,0,0,0,0,0\n0.01,0,0,0,0,0\n0.05,0,0,0,0,0\n"))
    with pytest.raises(DataError, match="does not increase"):
        read_csv(write("t,u_in,theta1,theta2,p1,p2\n0,0,0,0,0,0\n0.01,0,0,0,0,0\n0.01,0,0,0,0,0\n"))
    other = read_csv(write("t,Qin,p1,p2\n0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n"))
    with pytest.raises(DataError, match="missing column"):
        signals_from_data(cycab, other)


@pytest.mark.parametrize("edges", ["interp", "mirror"])
def test_savitzky_golay_matches_scipy(edges):
    """Our own coefficients and edge handling against scipy's savgol_filter (the reference)."""
    from scipy.signal import savgol_filter
    x = np.random.default_rng(1).standard_normal((3, 200)).cumsum(axis=1)
    ours = derivatives.estimate(x, 0.01, 2, window=0.25, polyorder=3, edges=edges)
    for k in range(3):
        ref = savgol_filter(x, 25, 3, deriv=k, delta=0.01, axis=-1, mode=edges)
        assert np.allclose(ours[k], ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize("edges", ["interp", "mirror"])
@pytest.mark.parametrize("at", [slice(None, None, 3), slice(5, 190, 4), slice(0, 30, 1), slice(180, None, 2)])
def test_savitzky_golay_at_some_samples_matches_scipy(edges, at):
    """The filter asked for some samples only (a stored quantity's rate at an estimator's coarse
    samples, edges included) gives scipy's savgol_filter there, and NaN elsewhere."""
    from scipy.signal import savgol_filter
    x = np.random.default_rng(2).standard_normal((4, 200)).cumsum(axis=1)
    ours = derivatives.estimate(x, 0.01, 2, window=0.25, polyorder=3, edges=edges, at=at)
    asked = np.zeros(200, dtype=bool)
    asked[at] = True
    for k in range(3):
        ref = savgol_filter(x, 25, 3, deriv=k, delta=0.01, axis=-1, mode=edges)
        assert np.allclose(ours[k][:, asked], ref[:, asked], rtol=1e-9, atol=1e-9 * np.abs(ref).max())
        assert np.isnan(ours[k][:, ~asked]).all()


@pytest.mark.parametrize("order", [0, 1, 2, 3])
@pytest.mark.parametrize("onset", [0.5, 0.5037, 0.2])
def test_a_step_as_the_filter_sees_it_matches_scipy(order, onset):
    """step_seen (a closed form over the filter's taps) against scipy's savgol_filter of the signal
    whose order-th derivative steps at the onset, (t - onset)_+^order / order!: the same numbers away
    from the record's edges, exactly 0 and 1 where the window lies wholly before or after it."""
    from math import factorial

    from scipy.signal import savgol_filter
    ts, window = 0.01, 0.25
    t = np.arange(0.0, 1.0, ts)
    y = (t >= onset).astype(float) if order == 0 else np.maximum(t - onset, 0.0) ** order / factorial(order)
    n = derivatives.window_samples(window, ts, 3)
    want = savgol_filter(y, n, 3, deriv=order, delta=ts)
    got = derivatives.step_seen(t, np.array([onset]), order, window, ts)[0]
    inner = slice(n // 2, t.size - n // 2)
    assert np.allclose(got[inner], want[inner], rtol=0, atol=1e-9)
    away = np.abs(t - onset) > (n // 2 + 1) * ts
    assert set(got[away]) <= {0.0, 1.0}


def test_a_blended_step_of_a_resistance_is_blended_in_its_conductance():
    """seen_profile of a reciprocal fault (R through 1/R): 1/R is the straight blend of 1/R0 and 1/R1,
    R itself exactly R0 and R1 where the filter sees no blend."""
    from fdi.objective import seen_profile
    seen = np.array([0.0, 0.25, 0.5, 1.0, 1.05])
    r = seen_profile("reciprocal", 2.0, 0.5, seen)
    assert r[0] == 2.0 and r[3] == 0.5
    assert np.allclose(1.0 / r, 0.5 + seen * (2.0 - 0.5))
    assert np.allclose(seen_profile("identity", 1.0, 0.6, seen), 1.0 - 0.4 * seen)


def test_a_square_wave_as_the_filter_sees_it_matches_scipy():
    """edges_seen (each edge's closed form, summed) against scipy's savgol_filter of the square wave
    itself: an intermittent fault's on-off profile from 0.3 s, period 0.7 s."""
    from scipy.signal import savgol_filter
    ts, window = 0.01, 0.25
    t = np.arange(0.0, 3.0, ts)
    rises = 0.3 + 0.7 * np.arange(5)
    edges = np.concatenate([rises, rises + 0.35])
    wave = np.sum([(t >= e) * s for e, s in zip(edges, [1.0] * 5 + [-1.0] * 5)], axis=0)
    n = derivatives.window_samples(window, ts, 3)
    want = savgol_filter(wave, n, 3)
    got = derivatives.edges_seen(t, edges[None, :], np.array([[1.0] * 5 + [-1.0] * 5]), 0, window, ts)[0]
    inner = slice(n // 2, t.size - n // 2)
    assert np.allclose(got[inner], want[inner], rtol=0, atol=1e-12)
