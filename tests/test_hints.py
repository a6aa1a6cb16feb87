"""Seeds from the data (fdi.hints), onsets the evidence allows, and the AHDE's family champions,
each against a designed truth."""
from types import SimpleNamespace

import numpy as np

import optim
from fdi import hints
from optim.ahde import AHDE, AHDEOptions

TS = 0.01


def _square(t, period, t0):
    """Eq. (15)'s switching: high during the first half of each period from t0."""
    return (np.sin(2 * np.pi * (t - t0) / period) > 0).astype(float)


def test_a_square_wave_under_a_sign_changing_excitation_gives_its_period_and_phase():
    # a residual = excitation x (fault switched by a square wave of 1.3 s from 0.4 s) + noise: |r| carries
    # the square wave whatever the excitation's sign
    t = np.arange(0.0, 10.0, TS)
    rng = np.random.default_rng(3)
    r = np.sin(2.0 * t + 0.3) * _square(t, 1.3, 0.4) + 0.05 * rng.standard_normal(t.size)
    waves = hints.square_waves(np.abs(r), TS, 0.5, 10.0)
    assert waves, "no period found"
    periods = hints.candidate_periods(np.abs(r), TS, waves, 0.5, 10.0)
    T, phase = min(periods, key=lambda p: abs(p[0] - 1.3))
    assert abs(T - 1.3) <= 0.005 * 1.3
    assert min(abs(phase - 0.4), abs(phase - 0.4 - T), abs(phase - 0.4 + T)) <= 0.03


def test_edges_at_half_the_period_give_the_period_as_a_multiple():
    # a gain switching on a sensor: the derivative spikes at both edges, every T/2 = 0.35 s, below the
    # shortest period searched (0.5 s): the period 0.7 s is still proposed
    t = np.arange(0.0, 10.0, TS)
    s = _square(t, 0.7, 0.2)
    edges = np.abs(np.gradient(s, TS))
    rng = np.random.default_rng(5)
    x = edges + 0.5 * s + 0.3 * np.abs(rng.standard_normal(t.size))
    periods = hints.candidate_periods(x, TS, hints.square_waves(x, TS, 0.5, 10.0), 0.5, 10.0)
    assert any(abs(T - 0.7) <= 0.002 for T, _ in periods)


def test_noise_alone_gives_no_period():
    rng = np.random.default_rng(11)
    for seed in range(5):
        white = np.abs(np.random.default_rng(seed).standard_normal(1000))
        assert hints.square_waves(white, TS, 0.5, 10.0) == ()
    # noise through a moving average of 25 samples (a derivative filter's smoothing): coloured, no peak
    coloured = np.convolve(rng.standard_normal(1100), np.ones(25) / 25, mode="valid")[:1000]
    assert hints.square_waves(np.abs(coloured), TS, 0.5, 10.0) == ()


def test_departure_from_the_noise_band_at_a_designed_step():
    t = np.arange(0.0, 30.0, TS)
    rng = np.random.default_rng(2)
    noise = 0.1 * rng.uniform(-1, 1, t.size)
    r = noise + np.where(t >= 18.0, 0.5, 0.0)
    dep = hints.departure(r, t, 2.0, 20.0)
    assert dep is not None and 18.0 <= dep <= 18.0 + TS
    assert hints.departure(noise, t, 2.0, 29.0) is None or hints.departure(noise, t, 2.0, 29.0) > 0   # no crash
    # the band: the reference's largest deviation from its median, with a margin
    centre, band = hints.noise_band(r, (t >= 2.0) & (t < 11.0))
    assert abs(centre) < 0.02 and 0.1 * 0.9 < band / hints.BAND_MARGIN <= 0.1 + abs(centre)


def test_onsets_the_evidence_allows():
    # residual 0 leaves its band at 18 s and crosses its threshold at 20 s (t_D); residual 1 never fires;
    # look-ahead 0.25 s for residual 0 (two nested filters of a 0.25 s window), 0.125 s for residual 1
    t = np.arange(0.0, 30.0, TS)
    r0 = 0.05 * np.sin(41 * t) + np.where(t >= 18.0, 0.5 * (t - 18.0), 0.0)
    r = np.vstack([r0, 0.05 * np.cos(37 * t)])
    lo, hi = hints.onset_interval(r, t, np.array([1.0, 1.0]), 20.0, 1.0, np.array([0.25, 0.125]))
    assert 18.0 - 0.25 <= lo <= 18.0 - 0.25 + 0.2       # never earlier than the departure minus the look-ahead
    assert hi == 20.0 + 0.25                              # never after t_D plus the look-ahead


def test_nesting_depth_counts_filters_in_series():
    plain = SimpleNamespace(composites=())
    stored = SimpleNamespace(composites=((1, plain),))
    assert hints.nesting_depth(plain) == 1 and hints.nesting_depth(stored) == 2
    assert hints.nesting_depth(SimpleNamespace(composites=((1, stored), (2, plain)))) == 3


def test_aligned_onsets_switch_on_inside_the_interval():
    assert np.allclose(hints.aligned_onsets(0.7, 0.1, 30.0, 30.0, 31.0), [30.1, 30.8])
    assert hints.aligned_onsets(0.7, 0.5, 30.0, 30.0, 30.2) == [30.0]     # none inside: the nearest (29.8), clipped


def _narrow_models(real, bits):
    """One fault, four degradation models (one-hot bits): models 0-2 wide basins with their floor at
    1.0-1.2; model 3 a narrow funnel at x = 0.7123 whose floor, 0.1, is the truth, and costs 5-20
    a tenth of the range away."""
    x = real[:, 0]
    k = np.argmax(bits, axis=1)
    wide = 1.0 + 0.1 * k + (x - 0.3 - 0.1 * k) ** 2
    narrow = 0.1 + 60.0 * np.sqrt(np.abs(x - 0.7123))
    return np.where(k == 3, narrow, wide)


def test_each_degradation_model_is_checked_at_its_bottom():
    problem = optim.pose(_narrow_models, bounds=[[0.0, 1.0]], n_bits=4, onehot=[(0, 1, 2, 3)],
                         family=lambda b: frozenset({("model", int(np.argmax(b)))}))
    for seed in range(3):
        r = optim.minimize(problem, engine="AHDE", seed=seed)
        assert int(np.argmax(r.bits)) == 3 and abs(r.real[0] - 0.7123) < 1e-3 and r.cost < 0.2


def test_family_bests_are_the_winners_structure_with_one_family_changed():
    # two faults, two models each (bits 0-1 fault 0, 2-3 fault 1); families (fault, model)
    e = AHDE(optim.pose(lambda real, bits: real[:, 0] ** 2, bounds=[[-1, 1]], n_bits=4, onehot=[(0, 1), (2, 3)],
                        family=lambda b: frozenset({(0, int(b[1])), (1, int(b[3]))})), AHDEOptions(seed=0))
    e.init_population()
    win = next(b for b in e.branches.values() if not b.bits[1] and not b.bits[3])     # models (0, 0)
    near = e.family_bests([win])
    assert sorted(tuple(np.flatnonzero(b.bits)) for b in near) == [(0, 3), (1, 2)]    # (0, 1) and (1, 0), not (1, 1)


def test_proposed_points_join_the_screen():
    # a needle at x = 0.61803 (width 1e-4) no screen of 50 draws finds; proposed, it is found
    cost = lambda real, bits: np.where(np.abs(real[:, 0] - 0.61803) < 1e-4, 0.0, 1.0) + 0.0 * real[:, 1]
    problem = optim.pose(cost, bounds=[[0.0, 1.0], [0.0, 1.0]],
                         propose=lambda bits: np.array([[0.61803, np.nan]]))
    assert optim.minimize(problem, engine="AHDE", seed=0).cost == 0.0
