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
    """A stored quantity formed from measured samples adds only its rate's filter (in parallel with
    the signals'); one reading a derivative adds that filter in series; one inside another, two."""
    measured = SimpleNamespace(signals=(("p", 0),), composites=())
    derived = SimpleNamespace(signals=(("x", 1),), composites=())
    assert hints.nesting_depth(SimpleNamespace(signals=(("p", 1),), composites=())) == 1
    assert hints.nesting_depth(SimpleNamespace(signals=(), composites=((1, measured),))) == 1
    assert hints.nesting_depth(SimpleNamespace(signals=(), composites=((1, derived),))) == 2
    nested = SimpleNamespace(signals=(("p", 0),), composites=((1, measured),))
    assert hints.nesting_depth(SimpleNamespace(signals=(), composites=((1, nested),))) == 2


def test_a_stored_volume_jump_reaches_half_a_window_ahead():
    """One tank (CT = 1e-5 m^3/Pa, outlet Rv = 1e6 Pa s/m^3, pump 1e-5 m^3/s) at rest at 10 Pa; its
    capacitance drops to 8e-6 at 100 s: the volume V is continuous, so p jumps to 12.5 Pa and
    V relaxes to 8e-5 with tau = 8 s, written out by hand. The ARR reads d(CT p)/dt: at the design
    it stays at the derivative filter's error away from the kink's half window, and at the
    nominal CT it first moves 2.5 s (half the 5 s window) before the jump, not 5 s (the rate's
    filter after a smoothing filter)."""
    from bondgraph.chains import fault_chain_yaml
    from fdi.monitor import Monitor
    from fdi.residuals import evaluate

    m = Monitor(fault_chain_yaml(1))
    ts, t = 0.5, np.arange(0.0, 200.0, 0.5)
    q0 = 1e-5 * np.ones_like(t)
    ct = np.where(t >= 100.0, 0.8e-5, 1e-5)
    volume = np.where(t >= 100.0, 0.8e-4 + 0.2e-4 * np.exp(-(t - 100.0) / 8.0), 1e-4)
    p = volume / ct
    r_design = evaluate(m.model, list(m.residuals), {"q0": q0, "p1": p}, ts, window=5.0, values={"CT1": ct})[0]
    r_nominal = evaluate(m.model, list(m.residuals), {"q0": q0, "p1": p}, ts, window=5.0)[0]
    moved = t[(t > 10) & (np.abs(r_nominal) > 1e-12)]
    assert moved.min() == 97.5
    away = (t > 10) & (t < 190) & (np.abs(t - 100.0) > 2.6)
    assert np.abs(r_design[away]).max() < 0.01 * 2.5e-6      # 1 % of the outflow's step


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


def test_a_drift_through_zero_has_no_abrupt_value_on_a_log_scale():
    """Designed truth: eq. (18) with b = [-0.5, -5] takes a resistance (coded by its logarithm)
    from 1 through zero to about -120 over 10 s; its median after the onset is negative, so no
    abrupt value reproduces it: the translation leaves the value to the engine (NaN), silently
    (it printed numpy's "invalid value encountered in log10" in bench accuracy's output). A drift
    that stays positive still translates to its median."""
    import warnings

    from fdi import encoding
    s = encoding.FaultSpace.make("R", 1.0, (0.001, 10.0))
    t = np.linspace(0.0, 10.0, 101)
    _, abrupt = encoding.encode([s], [{"type": "abrupt", "value": 1.0}])
    through, bits = encoding.encode([s], [{"type": "incipient", "model": 3, "b": [-0.5, -5.0]}])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(hints.translate([s], through, bits, abrupt, t, 0.0)[0])
    rising, bits = encoding.encode([s], [{"type": "incipient", "model": 1, "b": [0.1]}])
    value = 10.0 ** hints.translate([s], rising, bits, abrupt, t, 0.0)[0]
    assert abs(value - np.median(np.exp(0.1 * t[t >= 0.0]))) < 1e-9


def test_an_eq19_drift_that_is_an_eq18_drift_translates_to_its_coefficients():
    """Designed truth from the models' equations: eq. (19), P'' = b5 P'^2 + b6 P + b7, with b5 = 0
    and b6 = 1 is eq. (18), P'' = b3 P' + P + b4, with b3 = 0 and b4 = b7 (both from P(t0) = P0,
    P'(t0) = 0). Re-expressed in eq. (18), an eq. (19) drift of that form must come back as it:
    b3 near 0 (the search of two coefficients stops within some thousandths of it) and b4 within
    0.5 %; the profile it gives within 0.5 % of the drift's excursion at every sample (the search
    stops some 0.2 % short at the window's end; eq. (19)'s RK4 on its 0.1 s grid is within 1e-4 of
    the closed form)."""
    from fdi import encoding, profiles
    s = encoding.FaultSpace.make("beta", 1.0, (0.05, 1.5))
    t = np.linspace(0.0, 3.0, 301)
    _, to = encoding.encode([s], [{"type": "incipient", "model": 3, "b": [0.0, 0.0]}])
    for b7 in (-0.9, -0.5):
        real, bits = encoding.encode([s], [{"type": "incipient", "model": 4, "b": [0.0, 1.0, b7]}])
        out = hints.translate([s], real, bits, to, t, 0.0)
        b3, b4 = encoding.describe([s], np.where(np.isnan(out), real, out), to)[0]["b"]
        assert abs(b3) < 0.01 and abs(b4 - b7) < 5e-3 * abs(b7)
        drift = profiles.incipient(t, 0.0, 1.0, 4, np.array([[0.0, 1.0, b7]]))[0]
        again = profiles.incipient(t, 0.0, 1.0, 3, np.array([[b3, b4]]))[0]
        assert np.max(np.abs(again - drift)) < 5e-3 * np.ptp(drift)
        closed = -b7 + (1.0 + b7) * np.cosh(t)                  # P'' = P + b7 solved by hand
        assert np.max(np.abs(drift - closed)) < 1e-4


def test_a_translations_distances_in_c_are_numpys_to_the_bit():
    """The translation's profile distances (hints._distance) on the C path against numpy's own three
    passes: equal to the bit on random populations of 2 to 60 rows with zeros, infinities and NaN
    among the profiles, either scale, any first sample; a single row stays with numpy (which sums
    one column pairwise: a sequential sum differs in the last bits there)."""
    from fdi import kernels
    if "c" not in kernels.available():
        import pytest
        pytest.skip("no C compiler")
    rng = np.random.default_rng(1)
    before = kernels.use("c")
    try:
        for trial in range(400):
            rows, n = (int(rng.integers(1, 60)), int(rng.integers(1, 300))) if trial < 300 else (1, 300)
            q = rng.standard_normal((rows, n)) * 10 ** rng.uniform(-3, 3, (rows, n))
            for value in (np.inf, 0.0, np.nan):
                q[rng.random((rows, n)) < 0.01] = value
            target, first, inverse = rng.standard_normal(n), int(rng.integers(0, n)), bool(rng.random() < 0.5)
            with np.errstate(all="ignore"):
                fast = hints._distance(q, target, first, inverse)
                kernels.use("numpy")
                plain = hints._distance(q, target, first, inverse)
                kernels.use("c")
            assert np.array_equal(fast, plain, equal_nan=True)
    finally:
        kernels.use(before)
