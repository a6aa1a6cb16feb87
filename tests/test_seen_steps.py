"""The fused objective's kept seen steps (fdi.fused.SeenSteps): a linear fault's unit step as the
order-0 smoothing filter sees it depends on the first sample at or after its onset only, so the
profiles are kept by that sample. Reference: fdi.objective.seen_step_profile on each onset itself,
bit for bit, across calls, past the cap on kept rows, and with a call's own rows after the kept ones."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from fdi.fused import SeenSteps
from fdi.derivatives import STEP_ORDER
from fdi.objective import seen_step_profile

T = np.arange(0.0, 2.0, 0.01)
LEVELS = {0: ("identity", 1.0, 2.0), 1: ("reciprocal", 5.0, 0.25)}


class _Objective:
    """What SeenSteps reads of an objective: the window's times and seen_steps (two faults, each its
    own transform and levels; a 0.05 s window at 0.01 s)."""
    win = SimpleNamespace(t=T)

    def seen_steps(self, j, onsets, periods=None):
        transform, nominal, unit = LEVELS[j]
        return seen_step_profile(T, onsets, transform, nominal, unit, 0.05, 0.01)


def _reference(j, onsets):
    return _Objective().seen_steps(j, np.asarray(onsets, dtype=float))


def test_kept_steps_are_each_onsets_own_profile_across_calls_and_the_cap():
    assert STEP_ORDER == 0
    rng = np.random.default_rng(4)
    seen = SeenSteps(_Objective())
    seen.cap_rows = 40                                           # dropped and formed again many times
    for call in range(60):
        seen.begin()
        onsets = np.concatenate([rng.uniform(-0.1, 2.1, 25), T[rng.integers(0, T.size, 5)], [np.nan, 3.0]])
        pre_at = np.full((2, onsets.size), -1, dtype=np.int64)
        for j in (0, 1):
            pre_at[j] = seen.steps(j, onsets)
        square = rng.normal(size=(3, T.size))                    # a call's own rows come after the kept ones
        rows = np.array([0, 7, 9])
        pre = seen.table([(1, rows, square)], pre_at)
        for j in (0, 1):
            want = _reference(j, onsets)
            got = pre[pre_at[j]]
            keep = np.ones(onsets.size, dtype=bool)
            if j == 1:
                keep[rows] = False
                assert np.array_equal(got[rows], square)
            assert np.array_equal(got[keep].view(np.uint64), want[keep].view(np.uint64))
    assert seen.used <= 2 * (seen.cap_rows + 64)                  # bounded: kept rows dropped past the cap


def test_the_compiled_square_waves_are_the_numpy_path_s_bits():
    """kernels.c's square_seen (an intermittent linear fault's seen square waves as its values, in
    one pass) against the numpy path: fdi.profiles.intermittent_edges, fdi.derivatives.edges_seen
    and fdi.objective.seen_profile, each on numpy; both transforms, an infinite nominal value, onsets
    and periods on the sample grid (edges on samples, windows that meet), NaN and negative ones."""
    import pytest

    from fdi import derivatives, kernels, profiles
    from fdi.objective import seen_profile
    if "c" not in kernels.available():
        pytest.skip("no C compiler")
    from fdi import _native
    rng = np.random.default_rng(11)
    n = derivatives.window_samples(0.05, 0.01, derivatives.DEFAULT_ORDER)
    blend = derivatives.smoothed_step(0.05, 0.01)
    for trial in range(120):
        rows = int(rng.integers(1, 30))
        onsets, periods = rng.uniform(-0.5, 2.5, rows), rng.uniform(0.02, 1.5, rows)
        if trial % 3 == 0:
            onsets, periods = np.round(onsets, 2), np.maximum(np.round(periods, 2), 0.01)
        if trial % 7 == 0:
            onsets[0], periods[-1] = np.nan, -1.0
        transform, nominal, unit = [("identity", 2.0, 3.5), ("reciprocal", 5.0, 0.25), ("reciprocal", np.inf, 1.0)][trial % 3]
        got = _native.square_seen(T, float(T[-1]), onsets, periods, blend, n // 2, T.size >= n,
                                  {"identity": 0, "reciprocal": 1}[transform], nominal, unit)
        before = kernels.use("numpy")
        try:
            edges, signs = profiles.intermittent_edges(float(T[-1]), onsets, periods)
            with np.errstate(all="ignore"):
                want = seen_profile(transform, nominal, unit, derivatives.edges_seen(T, edges, signs, 0, 0.05, 0.01))
        finally:
            kernels.use(before)
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), trial
