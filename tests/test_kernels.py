"""The compiled kernels (fdi.kernels, numba) against the numpy path and against independent
references: eq. (19) against its closed form where it has one, the weighted median against a
brute-force L1 minimum, and the identification objective's costs on random populations of every
fault type and degradation model against the numpy path (1e-9 relative)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fdi import kernels
from fdi.encoding import N_BITS
from fdi.objective import weighted_median
from fdi.profiles import incipient


@pytest.fixture(params=["numpy", "numba", "c"])
def path(request):
    """Run the test on each path (the compiled ones only where this machine has them)."""
    if request.param != "numpy" and request.param not in kernels.available():
        pytest.skip(f"no {request.param} path here")
    before = kernels.use(request.param)
    assert kernels.enabled() == (request.param != "numpy")
    yield request.param
    kernels.use(before)


def same(a, b) -> None:
    """a and b equal to the bit (arrays, or tuples and lists of them); NaNs in the same places."""
    if isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            same(x, y)
    else:
        assert np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f")


def both(fn):
    """fn() on the numpy path, then on each compiled path (numba, C) this machine has, which must
    agree with each other to the bit (the C is numba's operations in numba's order); returns
    (numpy's, the first compiled path's)."""
    paths = kernels.available()
    if not paths:
        pytest.skip("no compiled path (numba or a C compiler)")
    before = kernels.use("numpy")
    try:
        plain = fn()
        got = []
        for p in paths:
            kernels.use(p)
            assert kernels.enabled()
            got.append(fn())
        for other in got[1:]:
            same(got[0], other)
        return plain, got[0]
    finally:
        kernels.use(before)


def test_eq19_harmonic_case_is_a_cosine(path):
    """b5 = 0, b6 = -w^2, b7 = 0: P'' = -w^2 P, P(t0) = P0, P'(t0) = 0, so P = P0 cos(w tau)
    (RK4 on a 0.1 s grid, Hermite-read: error O(h^4))."""
    t = np.linspace(0.0, 10.0, 1001)
    w = np.array([0.5, 1.0, 2.0])
    p = incipient(t, 1.0, 3.0, 4, np.column_stack([0 * w, -w ** 2, 0 * w]))
    tau = np.maximum(t - 1.0, 0.0)
    assert np.allclose(p, 3.0 * np.cos(w[:, None] * tau[None, :]), atol=3e-4 * 3.0)


def test_eq19_over_hours_is_a_cosine_on_at_most_steps19_steps(path):
    """A window of hours (the water heater's, 1 s samples): eq. (19)'s grid has at most STEPS19
    intervals (not 0.1 s ones: 10^5 steps an individual), the same in numpy, numba and C, and
    its harmonic case is still P0 cos(w tau) to 1e-8 of P0 (periods of 1 h and 2 h over 2 h,
    h = 7.2 s: RK4's global error ~ w tau (w h)^4 / 120, 2.7e-9 for the hour; measured 2.3e-9);
    the fused objective's kernels read this grid too (tests of fdi.fused against the numpy path)."""
    from fdi import _jit, profiles
    assert profiles.STEPS19 == _jit.STEPS19 == 1000
    assert "#define STEPS19 1000" in (Path(profiles.__file__).parent / "kernels.c").read_text()
    t = np.linspace(0.0, 7200.0, 2001)
    w = 2 * np.pi / np.array([3600.0, 7200.0])
    p = incipient(t, 0.0, 3.0, 4, np.column_stack([0 * w, -w ** 2, 0 * w]))
    assert np.allclose(p, 3.0 * np.cos(w[:, None] * t[None, :]), rtol=0, atol=1e-8 * 3.0)
    grid, slope, h = profiles._rk4_grid(3.0, *(np.array([x]) for x in (0.0, -w[0] ** 2, 0.0)), 1, 7200.0, 0.1)
    assert grid.shape == (1, profiles.STEPS19 + 1) and h == 7.2


def test_eq19_over_milliseconds_is_a_cosine_on_at_least_min_steps19_steps(path):
    """A window of 2 ms (a converter's, 1 MHz samples): eq. (19)'s grid has at least MIN_STEPS19
    intervals (a 0.1 s grid gave it one RK4 step), the same in numpy, numba and C. Its harmonic
    case at the bounds' fastest, |b6| W^2 = 100 (fdi.encoding.coefficient_bounds: 10 radians over
    the window), is P0 cos(w tau) to 1e-5 of P0 (RK4's global error ~ w tau (w h)^4 / 120 = 8e-7
    at h = W / 100), and an eq. (19) drift slower than the window to 1e-9."""
    from fdi import _jit, profiles
    assert profiles.MIN_STEPS19 == _jit.MIN_STEPS19 == 100
    assert "#define MIN_STEPS19 100" in (Path(profiles.__file__).parent / "kernels.c").read_text()
    W = 2e-3
    t = np.linspace(0.0, W, 2001)
    w = np.array([np.sqrt(100.0) / W, 1.0 / W])
    p = incipient(t, 0.0, 3.0, 4, np.column_stack([0 * w, -w ** 2, 0 * w]))
    exact = 3.0 * np.cos(w[:, None] * t[None, :])
    assert np.abs(p[0] - exact[0]).max() < 1e-5 * 3.0
    assert np.abs(p[1] - exact[1]).max() < 1e-9 * 3.0
    grid, slope, h = profiles._rk4_grid(3.0, *(np.array([x]) for x in (0.0, -w[0] ** 2, 0.0)), 1, W, 0.1)
    assert grid.shape == (1, profiles.MIN_STEPS19 + 1) and h == pytest.approx(W / 100)


def test_eq19_constant_forcing_is_a_parabola(path):
    """b5 = b6 = 0: P'' = b7, so P = P0 + b7 tau^2 / 2 (RK4 and cubic Hermite are exact)."""
    t = np.linspace(0.0, 5.0, 333)
    b7 = np.array([-0.2, 0.0, 0.7])
    p = incipient(t, 0.5, 2.0, 4, np.column_stack([0 * b7, 0 * b7, b7]))
    tau = np.maximum(t - 0.5, 0.0)
    assert np.allclose(p, 2.0 + b7[:, None] * tau[None, :] ** 2 / 2, rtol=1e-12, atol=1e-12)


def test_eq19_paths_agree_on_random_populations():
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 10.5, 0.01)
    t0 = rng.uniform(-1.0, 6.0, 200)
    t0[3] = 10.5 - 1e-12                                 # an onset within a sample of the end
    b = np.column_stack([rng.uniform(-3, 3, 200), rng.uniform(-1, 1, 200), rng.uniform(-2, 2, 200)])
    for p0 in (1.0, 0.62, 2.5e7, 0.0):
        plain, fast = both(lambda: incipient(t, t0, p0, 4, b))
        assert np.array_equal(np.isinf(plain), np.isinf(fast))
        finite = np.isfinite(plain)
        assert np.allclose(fast[finite], plain[finite], rtol=1e-9, atol=0.0)


def test_weighted_median_minimises_the_weighted_l1_cost(path):
    """The result is a minimiser of sum_k w_k |x - p_k| (checked at every point, brute force)."""
    rng = np.random.default_rng(3)
    points = rng.normal(size=(40, 57))
    points[:, :5] = points[:, 5:10]                     # ties
    weights = rng.exponential(size=(40, 57))
    weights[:, 10:20] = 0.0                             # points that count for nobody
    m = weighted_median(points, weights)
    best = np.array([min(cost_row(points[r], weights[r], x) for x in points[r][weights[r] > 0]) for r in range(40)])
    got = np.array([cost_row(points[r], weights[r], m[r]) for r in range(40)])
    assert np.allclose(got, best, rtol=1e-12)
    assert np.array_equal(weighted_median(points, 0 * weights), np.zeros(40))


def cost_row(p: np.ndarray, w: np.ndarray, x: float) -> float:
    return float((w * np.abs(x - p)).sum())


@pytest.mark.parametrize("m", [251, 600, 2000])
def test_weighted_median_paths_agree(m):
    """Below 256 points the compiled path selects on every point; from 256 a sample brackets the
    median first (and falls back when it misses): both give numpy's sorted cumulative sum's point,
    on heavy tails, on drifting series (time-ordered residual ratios) and on a few heavy weights."""
    rng = np.random.default_rng(11)
    rows = 300 if m < 1000 else 60
    points = rng.standard_cauchy(size=(rows, m))
    points[::3] = np.cumsum(rng.normal(size=(len(points[::3]), m)), axis=1)
    weights = rng.random((rows, m)) * (rng.random((rows, m)) > 0.2)
    weights[1::4, ::97] = 1e3                            # a sample that misrepresents the weight
    plain, fast = both(lambda: weighted_median(points, weights))
    assert np.array_equal(plain, fast)


def random_population(obj, rows: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """Random reals in the bounds; per fault every type, and for incipient faults every degradation
    model, in turn."""
    b = obj.bounds()
    real = b[:, 0] + rng.random((rows, b.shape[0])) * (b[:, 1] - b[:, 0])
    bits = np.zeros((rows, N_BITS * len(obj.spaces)), dtype=bool)
    structures = [(k, m) for k in range(2) for m in (0,)] + [(2, m) for m in range(4)]
    for j in range(len(obj.spaces)):
        pick = (np.arange(rows) + 3 * j) % len(structures)
        for r, s in enumerate(pick):
            kind, model = structures[s]
            bits[r, N_BITS * j + kind] = True
            bits[r, N_BITS * j + 3], bits[r, N_BITS * j + 4] = bool(model // 2), bool(model % 2)
    return real, bits


def test_objective_costs_equal_on_every_fault_type_and_model():
    """Scenario 2's identification (R4, a parametric fault solved in closed form, and beta_theta2, a
    sensor fault): the costs and the solved magnitudes of 72 random individuals, full and coarse,
    on both paths."""
    from fdi.app.bench import benchmark_problem

    obj = benchmark_problem("scenario2", 0).objective
    real, bits = random_population(obj, 72, np.random.default_rng(5))
    for stride in (1, obj.stride):
        (c0, r0), (c1, r1) = both(lambda: obj.evaluate(real, bits, stride))
        assert np.array_equal(np.isfinite(c0), np.isfinite(c1))
        ok = np.isfinite(c0)
        assert ok.sum() > 36
        assert np.allclose(c1[ok], c0[ok], rtol=1e-9, atol=0.0)
        assert np.allclose(r1, r0, rtol=1e-9, atol=0.0)


def test_intermittent_paths_agree_at_and_between_switches():
    """Eq. (15) on a grid that lands on the switching instants (onsets on the grid, periods of whole
    samples: sin is ~1e-16 there, not 0, and the sign must still be the sine's) and on random ones."""
    from fdi.profiles import intermittent

    rng = np.random.default_rng(13)
    t = np.arange(0.0, 20.0, 0.01)
    t0 = np.concatenate([np.round(rng.uniform(0, 10, 100), 2), rng.uniform(0, 10, 100), [np.nan, 3.0]])
    period = np.concatenate([np.round(rng.uniform(0.1, 5, 100), 2), rng.uniform(0.1, 5, 100), [1.0, 0.02]])
    value = rng.uniform(0.1, 3, t0.size)
    for nominal in (1.0, np.inf, 0.0):
        plain, fast = both(lambda: intermittent(t, t0, nominal, value, period))
        assert np.array_equal(plain, fast, equal_nan=True)


def test_square_waves_seen_by_the_filter_are_the_numpy_path_s_bits():
    """fdi.derivatives.edges_seen (an intermittent fault's profile as the smoothing filter sees
    it) compiled and on numpy, to the bit: square waves of eq. (15) with periods long and short
    (edges whose windows meet: the blends then add in np.add.at's order), edges on the grid, in the
    window's first and last half-window and beyond its end; a window shorter than the filter."""
    from fdi.derivatives import edges_seen
    from fdi.profiles import intermittent_edges

    rng = np.random.default_rng(5)
    t = np.arange(0.0, 10.5, 0.01)
    t0 = np.concatenate([rng.uniform(-0.2, 10.6, 60), np.round(rng.uniform(0, 10, 20), 2), [np.nan, 0.0, 10.49]])
    period = np.concatenate([rng.uniform(0.05, 4.0, 60), np.round(rng.uniform(0.1, 2, 20), 2), [1.0, 0.12, 1.0]])
    edges, signs = intermittent_edges(float(t[-1]), t0, period)
    for window in (0.25, 0.05):
        plain, fast = both(lambda: edges_seen(t, edges, signs, 0, window, 0.01))
        same(plain, fast)
    assert (0.0 < plain).any() and (plain < 1.0).any() and not np.isin(plain, (0.0, 1.0)).all()
    short = t[:10]
    plain, fast = both(lambda: edges_seen(short, np.array([[0.03, 0.07]]), np.array([[1.0, -1.0]]), 0, 0.25, 0.01))
    same(plain, fast)


def test_eq17_paths_agree_and_follow_the_closed_form(path):
    """1/P = 1/P0 - b2 tau (infinite past the pole), for finite and infinite P0, on both paths."""
    rng = np.random.default_rng(17)
    t = np.arange(0.0, 30.0, 0.01)
    t0 = np.concatenate([rng.uniform(0, 20, 50), [np.nan]])
    b2 = rng.uniform(-0.5, 0.5, t0.size)
    for p0 in (2.0, np.inf, -3.0):
        p = incipient(t, t0, p0, 2, b2[:, None])
        tau = t[None, :] - t0[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            den = (0.0 if np.isinf(p0) else 1 / p0) - b2[:, None] * tau
            want = np.where(tau > 0, np.where(den > 0, 1 / den, np.inf), p0)
        assert np.array_equal(p, want)


def test_eq16_eq18_paths_give_the_same_bits_and_solve_their_equations():
    """Eqs. (16) and (18): the compiled pass (fdi.profiles._exponential) gives the numpy path's
    numbers bit for bit (NaN where it has NaN), for onsets off and on the grid, NaN onsets,
    infinite and NaN coefficients, one or many rows; and the profile solves its equation: (16)
    P' = b1 P, (18) P'' = b3 P' + P + b4 with P(t0) = P0, P'(t0) = 0 (central differences).

    The compiled kernels take their own exponential (vexp, a loop that vectorises: within 1 ulp of
    the correctly rounded value, test below); numpy's differs in the last bit. So the bits are
    compared with the numpy path run on that exponential (``fdi.profiles._exp``, element by
    element), and numpy's own path is held to round-off."""
    from fdi.profiles import _exp

    def libm_exp(x):
        x = np.asarray(x, dtype=float)
        return np.array([_exp(float(v)) for v in x.ravel()]).reshape(x.shape)

    rng = np.random.default_rng(1618)
    t = np.arange(0.0, 12.0, 0.01)
    t0 = np.concatenate([rng.uniform(-1, 10, 40), [np.nan, 3.0, 0.0]])
    b = rng.normal(0, 1, (t0.size, 2)) * 10 ** rng.uniform(-2, 1, (t0.size, 1))
    b[5, 0], b[6, 1], b[7, 0] = np.inf, -np.inf, np.nan
    for p0 in (2.0, np.inf, -3.0, 0.0):
        for model in (1, 3):
            for rows in (slice(0, 1), slice(None)):
                own, fast = both(lambda: incipient(t, t0[rows], p0, model, b[rows]))
                before = kernels.use("numpy")
                try:
                    with pytest.MonkeyPatch.context() as mp, np.errstate(all="ignore"):
                        mp.setattr(np, "exp", libm_exp)
                        plain = incipient(t, t0[rows], p0, model, b[rows])
                finally:
                    kernels.use(before)
                nan = np.isnan(plain)
                assert np.array_equal(nan, np.isnan(fast)) and np.array_equal(nan, np.isnan(own))
                assert np.array_equal(plain[~nan].view(np.uint64), fast[~nan].view(np.uint64))
                finite = np.isfinite(plain)
                assert np.array_equal(finite, np.isfinite(own))
                assert np.array_equal(plain[~finite & ~nan], own[~finite & ~nan])
                scale = np.abs(plain[finite]) + np.abs(b[rows][np.isfinite(b[rows])]).max() + 1.0
                assert np.all(np.abs(own[finite] - plain[finite]) <= 1e-12 * scale)
    h, p0 = 1e-3, 2.0
    tt = np.arange(0.0, 3.0, h)
    b1 = np.array([[0.3], [-0.2]])
    p = incipient(tt, 1.0, p0, 1, b1)
    after = tt[1:-1] > 1.0 + h
    dp = (p[:, 2:] - p[:, :-2]) / (2 * h)
    assert np.allclose(dp[:, after], (b1 * p[:, 1:-1])[:, after], rtol=1e-5)
    coef = np.array([[0.4, 0.5], [-1.0, -2.5]])
    p = incipient(tt, 1.0, p0, 3, coef)
    d1 = (p[:, 2:] - p[:, :-2]) / (2 * h)
    d2 = (p[:, 2:] - 2 * p[:, 1:-1] + p[:, :-2]) / h ** 2
    rhs = coef[:, :1] * d1 + p[:, 1:-1] + coef[:, 1:]
    assert np.allclose(d2[:, after], rhs[:, after], rtol=1e-4, atol=1e-4)
    assert np.allclose(p[:, tt <= 1.0], p0) and np.allclose(d1[:, np.searchsorted(tt, 1.0 + 2 * h)], 0.0, atol=0.02)


def test_filter_paths_give_the_same_bits_and_scipy_s_numbers():
    """The Savitzky-Golay filter (fdi.derivatives.fir: each sample's taps summed in one fixed order)
    gives the same bits on both paths, on a record and on a population, every sample and every
    4th (the identification's screening); and scipy's savgol_filter (mirrored ends) to round-off."""
    from scipy.signal import savgol_filter

    from fdi.derivatives import estimate

    rng = np.random.default_rng(19)
    record = np.cumsum(rng.normal(size=3000)) * 1e-3
    population = np.cumsum(rng.normal(size=(7, 1050)), axis=1)
    for x, at in ((record, None), (population, slice(25, 1025)), (population, slice(25, 1025, 4)),
                  (population, slice(0, 1050, 3))):
        plain, fast = both(lambda: estimate(x, 0.01, 2, 0.25, edges="mirror", at=at))
        for p, f in zip(plain, fast):
            assert np.array_equal(p, f, equal_nan=True)
        for k, p in enumerate(plain):
            want = savgol_filter(x, 25, 3, deriv=k, delta=0.01, mode="mirror", axis=-1)[..., at or slice(None)]
            got = p[..., at or slice(None)]
            assert np.allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())


def _objective(model_path, columns: dict, t0: float, candidate: tuple, fixed=(), thresholds=None):
    """The identification objective of ``candidate`` on the window from ``t0`` of the data
    ``columns`` (the estimators' own construction, fdi.estimators.fit)."""
    from fdi.data import Measurements, signals_from_data
    from fdi.monitor import compiled
    from fdi.objective import Objective, window

    c = compiled(str(model_path))
    t = columns["t"]
    raw = signals_from_data(c.model, Measurements("x", t, columns))
    win = window(t, raw, t0, c.config.samples, c.config.derivative_window)
    th = thresholds or c.config.thresholds
    weights = 1.0 / np.array([th.get(a.name, 1.0) for a in c.arrs])     # a model without thresholds: 1
    return Objective(c.model, c.residuals, win, candidate, weights, c.config.derivative_window, fixed=list(fixed),
                     config=c.config)


def _cycab(name: str) -> dict:
    from fdi.data import read_csv
    from .conftest import ROOT
    d = read_csv(ROOT / "models" / "data" / "cycab" / name)
    return d.columns


@pytest.mark.parametrize("case", ["group+two linear+sensor", "sensor, a fault held", "intermittent sensor", "offset"])
def test_fused_objective_is_the_numpy_path_s(case):
    """The compiled objective (fdi.fused: one call per population, residual tapes) against the
    numpy path on random populations of every type and model, full and coarse: costs and solved
    magnitudes to 1e-9, the same individuals finite. Cases: the CyCab's R4 (a reciprocal linear
    fault), R5 (a group factor, linear) and beta_theta2 (a sensor) at once; beta_theta2 with R4
    held at an earlier fit (a fixed fault's profile folded into the nominal values); scenario 1's
    intermittent encoder fault beta_theta1 with R4; an RC circuit's voltage-sensor offset."""
    pytest.importorskip("numba")
    from .conftest import ROOT
    from .test_sensor_faults import MODEL, circuit
    cycab = ROOT / "models" / "cycab_steering.yaml"
    if case == "group+two linear+sensor":
        obj = _objective(cycab, _cycab("scenario2.csv"), 32.0, ("R4", "R5", "beta_theta2"))
    elif case == "sensor, a fault held":
        obj = _objective(cycab, _cycab("scenario2.csv"), 32.0, ("beta_theta2",),
                         fixed=[{"name": "R4", "type": "abrupt", "value": 2.5e7, "t0": 32.0}])
    elif case == "intermittent sensor":
        obj = _objective(cycab, _cycab("scenario1.csv"), 32.0, ("R4", "beta_theta1"))
    else:
        data = circuit(6.0, seed=1, bias=(3.0, 0.3))
        obj = _objective(MODEL, data, 3.0, ("bias_v", "RL"), thresholds={"ARR1": 0.05, "ARR2": 0.01})
    assert _fused(obj) is not None
    real, bits = random_population(obj, 60, np.random.default_rng(23))
    for stride in (1, obj.stride):
        (c0, r0), (c1, r1) = both(lambda: obj.evaluate(real, bits, stride))
        assert np.array_equal(np.isfinite(c0), np.isfinite(c1))
        ok = np.isfinite(c0)
        assert ok.sum() >= 20
        assert np.allclose(c1[ok], c0[ok], rtol=1e-9, atol=0.0)
        assert np.allclose(r1, r0, rtol=1e-9, atol=0.0)
    # bits as 0/1 integers and as other numbers (zeta read as booleans, eta as integers): the compiled
    # decoding and its numpy fallback read them as fdi.encoding.decode does
    for given in (bits.astype(np.int64), bits * np.where(np.random.default_rng(2).random(bits.shape) < 0.5, 1.0, 1.6)):
        (c0, r0), (c1, r1) = both(lambda: obj.evaluate(real, given, obj.stride))
        ok = np.isfinite(c0)
        assert np.array_equal(ok, np.isfinite(c1)) and ok.sum() >= 20
        assert np.allclose(c1[ok], c0[ok], rtol=1e-9, atol=0.0) and np.allclose(r1, r0, rtol=1e-9, atol=0.0)


def _hydraulic_clog() -> dict:
    import gzip

    from fdi.data import read_csv
    from .conftest import ROOT
    with gzip.open(ROOT / "tests" / "golden" / "hydraulic_clog.csv.gz", "rt") as fh:
        text = fh.read()
    path = ROOT / "tests" / "golden" / "_hydraulic_clog_kernels.csv"
    try:
        path.write_text(text)
        return read_csv(path).columns
    finally:
        path.unlink()


def _fused(obj):
    """The objective's compiled path (fdi.fused.Fused, or None) as numba builds it."""
    before = kernels.use_numba(True)
    try:
        return obj.fused()
    finally:
        kernels.use_numba(before)


def _assert_same_costs(obj) -> None:
    """The compiled objective against the numpy path on a random population, full and coarse:
    the same individuals finite, costs and population to 1e-9."""
    real, bits = random_population(obj, 60, np.random.default_rng(23))
    for stride in (1, obj.stride):
        (c0, r0), (c1, r1) = both(lambda: obj.evaluate(real, bits, stride))
        ok = np.isfinite(c0)
        assert np.array_equal(ok, np.isfinite(c1)) and ok.sum() >= 20
        assert np.allclose(c1[ok], c0[ok], rtol=1e-9, atol=0.0)
        assert np.allclose(r1, r0, rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("case", ["chamber capacitance", "chamber transducer", "capacitance and valve",
                                  "air vessel", "orifice"])
def test_stored_quantities_compiled_are_the_numpy_path_s(case):
    """A residual that differentiates a stored quantity a candidate changes, d(C p)/dt with C the
    fault's parameter or p a faulty transducer's corrected reading, is compiled too (q formed per
    individual on every sample, its rate filtered at the samples evaluated): the hydraulic
    actuator's chamber (its capacitance Cc; its pressure transducer beta_pc, a corrected signal
    inside the stored quantity; Cc with the valve Kv, whose residual reads a stored quantity no
    individual changes), the compressed-air vessels' bladder intrusion (an independent simulator's
    data), and the orifice tanks' clog (a derivative inside the stored quantity)."""
    pytest.importorskip("numba")
    from .conftest import ROOT
    from .independent import air_vessels
    from .test_nonsmooth import MODEL as ORIFICE, P as ORIFICE_P, simulate as orifice_data
    if case == "air vessel":
        cols = air_vessels.simulate(3, t0=600.0, factor=0.7)
        obj = _objective(ROOT / "tests" / "data" / "air_vessels.yaml", cols, 600.0, ("intrusion",))
    elif case == "orifice":
        cols = orifice_data(4.0, seed=3, kv_after=(2.0, 0.7 * ORIFICE_P["Kv"]))
        obj = _objective(ORIFICE, cols, 2.0, ("Kv",))
    else:
        cols = _hydraulic_clog()
        candidate = {"chamber capacitance": ("Cc",), "chamber transducer": ("beta_pc",),
                     "capacitance and valve": ("Cc", "Kv")}[case]
        obj = _objective(ROOT / "models" / "hydraulic_actuator.yaml", cols, float(cols["t"][len(cols["t"]) // 2]),
                         candidate)
    assert any(obj.residuals[i].composites for i in obj.active)
    fast = _fused(obj)
    assert fast is not None and fast.stored
    _assert_same_costs(obj)


@pytest.mark.parametrize("t0, candidate", [(0.0, ("Cc",)), (7.6, ("Cc",)), (7.6, ("beta_pc",)), (7.6, ("Cc", "Kv")),
                                         (7.97, ("Cc",))])
def test_a_stored_quantity_s_rate_at_the_data_s_ends_is_compiled_as_the_numpy_path_s(t0, candidate):
    """A window that begins or ends with the data (a prognosis refreshed at the last sample,
    evaluate's RUL checkpoints): the rate of the chamber's Cc pc (Cc a candidate, or pc a faulty
    transducer's corrected reading) is filtered within half a filter of the ends, where the numpy
    path fits the edge window's polynomial (derivatives.estimate's ``interp``). Those windows kept
    the numpy path until 2026-11; the compiled kernels give their costs to 1e-9, full and coarse
    (the hydraulic actuator's 8 s clog record; windows from 0 s, to the end from 7.6 s, and one
    of 60 samples, shorter than the filter's 101, from 7.97 s)."""
    pytest.importorskip("numba")
    from .conftest import ROOT
    obj = _objective(ROOT / "models" / "hydraulic_actuator.yaml", _hydraulic_clog(), t0, candidate)
    assert any(obj.residuals[i].composites for i in obj.active)
    n = obj.win.t.size
    for stride in (1, obj.stride):
        crop = obj.crop(stride)
        last = range(crop.start, crop.stop, stride)[-1]
        assert crop.start < 50 or last >= n - 50          # within half a filter of an end
    fast = _fused(obj)
    assert fast is not None and fast.stored
    _assert_same_costs(obj)


def _simulated(name: str, T: float, fs: float) -> dict:
    """Data of a shipped model from bgfdi's simulator (the kernels are compared with each other on
    them; nothing is graded)."""
    from bondgraph.loader import load_model
    from fdi.app.scenario import parse_scenario, simulate_scenario
    from .conftest import ROOT
    model = load_model(ROOT / "models" / name)
    return simulate_scenario(model, parse_scenario({"seed": 1, "T": T, "fs": fs}, model))


@pytest.mark.parametrize("model, candidate", [("three_tank.yaml", ("fT1",)), ("three_tank.yaml", ("fT1", "fV2")),
                                              ("two_mass_spring_damper.yaml", ("m1",)),
                                              ("two_mass_spring_damper.yaml", ("beta_v1", "m1"))])
def test_stored_quantities_inside_stored_quantities_compiled_are_the_numpy_path_s(model, candidate):
    """A stored quantity whose rate enters another (the three tanks' d(CT2 (q1 - d(CT1 p1)/dt ...))/dt:
    tank 1's rate over the whole window, its edge half-windows fitted, inside tank 2's quantity;
    the two-mass oscillator's by its speeds, with a speed sensor's efficiency factor a candidate
    too: its corrected derivative filtered on every sample) is compiled level by level: costs equal
    the numpy path's. (The two-mass oscillator by its positions had them until 2026-12; its
    spring's compression is now read as x1 - x2.)"""
    pytest.importorskip("numba")
    from .conftest import ROOT
    fs = 10.0 if model == "three_tank.yaml" else 100.0
    cols = _simulated(model, 3000 / fs, fs)
    obj = _objective(ROOT / "models" / model, cols, 1000 / fs, candidate)
    fast = _fused(obj)
    assert fast is not None and (fast.full_at >= 0).any()
    _assert_same_costs(obj)


def test_an_objective_the_tapes_do_not_cover_keeps_the_numpy_path():
    """A mode switch inside the window (the boost converter's commanded switch: its residuals and
    derivatives are broken at each switch) has no tape: the objective evaluates on numpy."""
    pytest.importorskip("numba")
    import gzip

    from fdi.data import read_csv
    from fdi.monitor import compiled
    from .conftest import ROOT
    path = ROOT / "tests" / "golden" / "_boost_kernels.csv"
    try:
        path.write_text(gzip.open(ROOT / "tests" / "golden" / "boost_rL.csv.gz", "rt").read())
        cols = read_csv(path).columns
    finally:
        path.unlink()
    model = ROOT / "models" / "boost_converter.yaml"
    before = kernels.use_numba(True)
    try:
        obj = _objective(model, cols, float(cols["t"][len(cols["t"]) // 2]),
                         (next(iter(compiled(str(model)).model.faults)),))
        assert obj.fused() is None
    finally:
        kernels.use_numba(before)


def test_a_signal_standing_still_has_a_derivative_of_exactly_zero(path):
    """An encoder that stands still over a whole window (a burnt driver: CyCab scenario 3) gives
    dθ/dt = 0 exactly, not ±1e-16 of round-off whose sign a Coulomb term sign(dθ/dt) would turn
    into a whole friction torque: the filter pairs x[i+j] - x[i-j] (derivatives.centred, .fir)."""
    from fdi.derivatives import estimate

    rng = np.random.default_rng(29)
    level = 0.7318296459873219
    x = np.concatenate([np.cumsum(rng.normal(size=200)) * 1e-3, np.full(300, level), rng.normal(size=200)])
    for at in (None, slice(0, 700, 4)):
        v = estimate(x, 0.01, 2, 0.25, edges="mirror", at=at)[1]
        still = np.arange(200 + 12, 500 - 12)             # every window wholly on the flat stretch
        if at is not None:
            still = still[still % 4 == 0]
        assert np.all(v[still] == 0.0) and np.all(np.sign(v[still]) == 0.0)
        rows = estimate(np.vstack([x, 2 * x]), 0.01, 2, 0.25, edges="mirror", at=at)[1]
        assert np.all(rows[:, still] == 0.0)


def test_tape_registers_never_write_over_an_operand_and_compute_the_expression():
    """The register allocator reuses a register once its last reader is past, but never for that
    reader's own result (an operation in place makes the kernel's loops fall back from SIMD to
    scalar code): checked on a residual-like expression with shared subexpressions, whose tape,
    run by a plain Python interpreter of the instructions, gives numpy's value of the expression."""
    from fdi import tape
    rng = np.random.default_rng(5)
    n = 64
    sig, p, q = rng.normal(size=n), rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    source = ("def f(_a0, _a1, _a2, _a3):\n    x0 = _a1 * _a0\n    x1 = cos(x0 + _a3) * _a2\n"
              "    return (x0 - x1) * (x0 + x1) / (_a2 ** 2 + 1) - sin(x1) * 3.0\n")
    t = tape.build(source, {"cos": np.cos, "sin": np.sin},
                   [sig, tape.Row(tape.LOADP, 0), tape.Row(tape.LOADP, 1), 0.25], n)
    unary = {tape.NEG: np.negative, tape.SQUARE: np.square, tape.RECIP: np.reciprocal, tape.COS: np.cos,
             tape.SIN: np.sin, tape.SQRT: np.sqrt}
    binary = {tape.ADD: np.add, tape.SUB: np.subtract, tape.MUL: np.multiply, tape.DIV: np.divide}
    R = np.zeros((t.registers, n))
    P = np.stack([p, q])
    for op, dst, a, b in t.code:
        if op >= tape.ADD:
            assert dst not in (a, b)
        if op == tape.LOADP:
            R[dst] = P[a]
        elif op == tape.LOADF:
            R[dst] = t.fixed[a]
        elif op == tape.CONST:
            R[dst] = t.consts[a]
        elif op in binary:
            R[dst] = binary[op](R[a], R[b])
        else:
            R[dst] = unary[op](R[a])
    x0 = p * sig
    x1 = np.cos(x0 + 0.25) * q
    expected = (x0 - x1) * (x0 + x1) / (q ** 2 + 1) - np.sin(x1) * 3.0
    assert np.allclose(R[t.results[0, 0]], expected, rtol=1e-13, atol=0.0)


def test_a_profile_at_one_instant_is_the_array_functions_value_to_the_bit():
    """fdi.profiles.at (a simulation's right-hand side asks one instant at a time) against the
    array functions on the same instants: eqs. (14), (16)-(18) at onsets before, at and after the
    instant, infinite and zero nominal values, rates that overflow, a NaN onset; None for eqs.
    (15) and (19), which only the array functions compute."""
    from fdi import profiles
    rng = np.random.default_rng(3)
    cases = [("abrupt", {"value": 4.0}), ("incipient", {"model": 1, "b": [-0.3]}),
             ("incipient", {"model": 1, "b": [900.0]}), ("incipient", {"model": 2, "b": [-0.5]}),
             ("incipient", {"model": 2, "b": [0.7]}), ("incipient", {"model": 3, "b": [-0.4, -1.2]}),
             ("incipient", {"model": 3, "b": [2.0, 0.3]})]
    for kind, kw in cases:
        for nominal in (2.5, 0.0, np.inf):
            for t0 in (1.0, float("nan")):
                for t in np.concatenate([rng.uniform(-1.0, 5.0, 40), [1.0, 0.0]]):
                    want = profiles.profile(kind, np.array([t]), t0, nominal,
                                            **({"b": [kw["b"]], "model": kw["model"]} if "b" in kw else kw))[0][0]
                    with np.errstate(all="ignore"):
                        got = profiles.at(kind, float(t), t0, nominal, **kw)
                    assert np.array_equal(np.float64(got), want, equal_nan=True), (kind, kw, nominal, t0, t, got, want)
    assert profiles.at("intermittent", 2.0, 1.0, 1.0, value=2.0) is None
    assert profiles.at("incipient", 2.0, 1.0, 1.0, model=4, b=[0.1, 0.1, 0.1]) is None      # no span: no table


def test_eq19_at_one_instant_reads_one_integration_to_the_runs_end(monkeypatch):
    """Eq. (19) has no closed form: fdi.profiles.at integrates its RK4 once to the run's end
    (``span``) and reads the grid at each instant, where the array function integrated from the
    onset at every call (quadratic in a run's length under LSODA). Reference: the array function
    (numpy path, the same operations: to the bit) on the whole run's window, whose last sample is
    t0 + span; a P that overflows to inf; None past the run's end or for a NaN onset; the nominal
    value before the onset."""
    from fdi import profiles
    t0 = 1.0
    window = t0 + np.linspace(0.0, 7.3, 2001)
    span = float(window[-1] - t0)                  # the array function's last tau, as a simulation's t_end - t0
    for nominal, b in ((2.5, [-0.2, -1.5, 0.4]), (1.0, [0.05, -4.0, 0.0]), (3.0, [2.0, 1.0, 5.0]),
                       (np.inf, [0.1, 0.1, 0.1])):
        monkeypatch.setattr(profiles.kernels, "jit", lambda: None)
        want = profiles.incipient(window, t0, nominal, 4, [b])[0]
        monkeypatch.undo()
        with np.errstate(all="ignore"):
            got = np.array([profiles.at("incipient", float(x), t0, nominal, model=4, b=b, span=span) for x in window])
        assert np.array_equal(got, want), (nominal, b, np.max(np.abs(got - want)))
        compiled = profiles.incipient(window, t0, nominal, 4, [b])[0]
        assert np.allclose(got, compiled, rtol=1e-9, atol=0), (nominal, b)          # the 1e-9 contract
        assert profiles.at("incipient", 0.5, t0, nominal, model=4, b=b, span=span) == nominal
        assert profiles.at("incipient", t0 + span + 0.1, t0, nominal, model=4, b=b, span=span) is None
    assert np.isinf(got[-1]) and np.isinf(profiles.incipient(window, t0, 3.0, 4, [[2.0, 1.0, 5.0]])[0][-1])
    assert profiles.at("incipient", 2.0, float("nan"), 1.0, model=4, b=[0.1, 0.1, 0.1], span=span) is None


def test_eq19_profiles_in_one_c_call_are_the_grid_and_select_to_the_bit():
    """fdi._native.incipient19 (the RK4 grid, its Hermite reads and the nominal value before each
    onset in one call) against the composition it replaces: rk4_19 on max(t - t0, 0), then numpy's
    select; onsets before the window, inside it, at its last sample, after it and NaN; coefficients
    that overflow (P infinite) among them."""
    if "c" not in kernels.available():
        pytest.skip("no C compiler")
    from fdi import _native
    from fdi.profiles import STEP19
    rng = np.random.default_rng(19)
    t = np.arange(0.0, 10.5, 0.01)
    t0 = np.concatenate([rng.uniform(-1.0, 12.0, 60), [10.49, np.nan, 0.0]])
    b = np.column_stack([rng.uniform(-20, 20, t0.size), rng.uniform(-1, 1, t0.size), rng.uniform(-2, 2, t0.size)])
    b[5] = (20.0, 1.0, 5.0)                              # grows past any float
    for p0 in (1.0, 0.62, 2.5e7, 0.0):
        with np.errstate(all="ignore"):
            tau = np.maximum(t[None, :] - t0[:, None], 0.0)
            want = np.where(t[None, :] >= t0[:, None], _native.rk4_19(tau, p0, b[:, 0], b[:, 1], b[:, 2], STEP19), p0)
        got = _native.incipient19(t, t0, p0, b[:, 0], b[:, 1], b[:, 2], STEP19)
        assert np.array_equal(got, want, equal_nan=True)


def test_the_kernels_exponential_is_within_one_ulp_of_the_correctly_rounded_one():
    """The exponential of eqs. (16) and (18) in the compiled kernels (fdi/kernels.c vexp, fdi._jit._vexp)
    and in a simulation's instant (fdi.profiles._exp): within 1 ulp of math.exp (correctly rounded in
    practice) over the whole range, normal and subnormal results, the same bits on every path; inf
    above 709.78, 0 below -745.13, NaN kept."""
    import math

    from fdi.profiles import _exp
    rng = np.random.default_rng(2718)
    xs = np.concatenate([rng.uniform(-745.2, 709.9, 20000), rng.uniform(-2.0, 2.0, 20000),
                         rng.uniform(-1e-6, 1e-6, 2000),
                         [0.0, -0.0, 1.0, -1.0, 709.78, 709.782712893383, 709.782712893384, 709.7827128933841,
                          -708.39, -708.4, -745.13, -745.1332191019411, -745.1332191019413, np.inf, -np.inf, np.nan]])
    spec = np.array([_exp(float(x)) for x in xs])

    def exact(x: float) -> float:
        try:
            return math.exp(x)
        except OverflowError:
            return math.inf
    want = np.array([exact(float(x)) for x in xs])
    assert np.array_equal(np.isnan(spec), np.isnan(xs))
    normal = np.isfinite(want) & (want >= np.finfo(float).tiny)
    assert np.all(np.abs(spec[normal] - want[normal]) <= np.spacing(want[normal]))
    tiny = np.isfinite(want) & ~normal & np.isfinite(xs)
    assert np.all(np.abs(spec[tiny] - want[tiny]) <= 5e-324)
    assert np.array_equal(spec[~np.isfinite(xs) & ~np.isnan(xs)], [np.inf, 0.0])
    assert spec[xs == 709.7827128933841][0] == np.inf and spec[xs == -745.1332191019413][0] == 0.0
    import mpmath                                  # against the exact value (sympy's mpmath): 1.16 ulp at most
    mpmath.mp.dps = 40
    worst = [float.fromhex(h) for h in ("-0x1.49975dfc1df53p+8", "0x1.03ef1c214c598p+7", "0x1.d4e028a5632b0p+5")]
    for x in list(rng.uniform(-700.0, 700.0, 1500)) + list(rng.uniform(-0.5, 0.5, 500)) + worst:
        y = _exp(float(x))
        assert abs(mpmath.mpf(y) - mpmath.exp(mpmath.mpf(float(x)))) <= 1.16 * math.ulp(y), x
    t = np.array([0.0, 1.0])
    for path in kernels.available():
        before = kernels.use(path)
        try:                                   # eq. (16) with P0 = 1 and tau = 1: exp(b1) itself
            got = incipient(t, np.zeros(xs.size), 1.0, 1, xs[:, None])[:, 1]
        finally:
            kernels.use(before)
        assert np.array_equal(got, spec, equal_nan=True), path


def test_the_tapes_cos_sin_and_tan_are_within_one_ulp_and_the_same_on_every_compiled_path():
    """The tapes' cos, sin and tan (fdi/kernels.c vtrig, fdi._jit._vtrig, fdi.trig._trig: fdlibm's
    reduction and kernels as selects): within 0.8 ulp of the exact value (mpmath, 40 digits; libm
    0.5-0.68) on arguments near 0, near multiples of pi/4 and pi/2 (the reduction's cancellation,
    among them the closest doubles to one below 2^20), and out to the reduction's limit; the same bits from the Python statement, numba and the C; signed zeros
    kept; libm's own past the limit; NaN for inf and NaN."""
    import math

    import mpmath

    from fdi.trig import LIMIT, _trig
    rng = np.random.default_rng(3141)
    near = np.array([k * math.pi / 4 for k in range(-64, 65)] + [k * math.pi / 2 for k in (1, 29, 1001, 650001)]
                    # among the doubles closest to a multiple of pi/2 below 2^20 (a reviewer's search): the
                    # reduction's third part taken with the second lost 0.94 ulp of y0 there, tan 1.83 ulp
                    + [float.fromhex(h) for h in ("0x1.93c05c9ed3cbcp+18", "0x1.44bdb557e1dc1p+20")])
    xs = np.concatenate([rng.uniform(-4.0, 4.0, 1500), rng.uniform(-LIMIT, LIMIT, 300), rng.normal(0, 1e-9, 100),
                         near, np.nextafter(near, np.inf), [0.6743354797363281, np.nextafter(0.6743354797363281, 0),
                                                            -0.6743354797363281, 5e-324, -1e-300]])
    mpmath.mp.dps = 40
    for which, exact in enumerate((mpmath.cos, mpmath.sin, mpmath.tan)):
        for x in xs:
            y, want = _trig(float(x), which), exact(mpmath.mpf(float(x)))
            assert abs(mpmath.mpf(y) - want) <= 0.8 * math.ulp(float(want)), (which, float(x).hex())
    special = np.array([0.0, -0.0, LIMIT, -LIMIT, np.nextafter(LIMIT, 0), 1e300, np.inf, -np.inf, np.nan])
    for which, libm in enumerate((math.cos, math.sin, math.tan)):
        spec = np.array([_trig(float(x), which) for x in special])
        assert [str(v) for v in spec[:2]] == (["1.0", "1.0"] if which == 0 else ["0.0", "-0.0"])
        assert spec[2] == libm(LIMIT) and spec[5] == libm(1e300) and np.isnan(spec[-3:]).all()
        every = np.concatenate([xs, special, rng.uniform(-10.0, 10.0, 20000)])
        want = np.array([_trig(float(x), which) for x in every])
        for path in kernels.available():
            before = kernels.use(path)
            try:
                got = kernels.jit().trig(every, which)
            finally:
                kernels.use(before)
            assert np.array_equal(got, want, equal_nan=True), path
            assert np.array_equal(np.signbit(got[~np.isnan(got)]), np.signbit(want[~np.isnan(want)])), path


def test_the_inverse_hyperbolic_functions_run_compiled_as_numpy_computes_them(tmp_path):
    """asinh, acosh and atanh (whitelisted in model files) on the tapes: an electrode's charge
    transfer by the symmetric Butler-Volmer law (Bard & Faulkner, eq. 3.4.11 with alpha = 1/2:
    i = 2 i0 sinh(eta / (2 V0)), eta = 2 V0 asinh(i / (2 i0))) driven by a voltage and read by its
    current has the residual u - 2 V0 asinh(i / (2 i0)), the exchange current i0 (a fouled
    electrode) a candidate fault inside the asinh; the compiled objective (C, numba) takes it whole
    (a tape, not the numpy fallback) and gives numpy's costs on the law's own data."""
    text = """
name: electrode
parameters: {i0: {value: 0.02, unit: A}, V0: {value: 0.0257, unit: V}}
data: {columns: [t, u, i], sampling_time: 0.001}
inputs: {u: {unit: V, column: u, expr: "0.1*sin(2*pi*t)"}}
elements:
  source: {type: MSe, input: u}
  transfer: {type: R, effort: "2*V0*asinh(f/(2*i0))", flow: "2*i0*sinh(e/(2*V0))"}
junctions: {J: {type: "1"}}
sensors: {i: {type: Df, junction: J, column: i, unit: A}}
bonds: {1: [source, J], 2: [J, transfer]}
faults: {i0: {kind: parametric, parameters: [i0], bounds: [0.0002, 2.0]}}
thresholds: {ARR1: 0.001}
diagnosis: {derivative_window: 0.02}
"""
    model = tmp_path / "m.yaml"
    model.write_text(text)
    t = np.arange(3001) * 0.001
    u = 0.1 * np.sin(2 * np.pi * t)
    i = 2 * 0.02 * np.sinh(u / (2 * 0.0257)) * np.where(t >= 1.5, 0.5, 1.0)     # i0 halved from 1.5 s
    obj = _objective(model, {"t": t, "u": u, "i": i}, 1.0, ("i0",))
    assert "asinh" in str(obj.residuals[0].expr)
    real, bits = random_population(obj, 24, np.random.default_rng(2))
    (c0, _), (c1, _) = both(lambda: obj.evaluate(real, bits, 1))
    assert np.array_equal(np.isfinite(c0), np.isfinite(c1)) and np.isfinite(c0).sum() > 12
    assert np.allclose(c1[np.isfinite(c0)], c0[np.isfinite(c0)], rtol=1e-9, atol=0.0)
    before = kernels.use(kernels.available()[0])
    try:
        assert obj.fused() is not None               # the tape took the asinh
    finally:
        kernels.use(before)
    from fdi import tape
    assert {tape.UNARY[f] for f in (np.arcsinh, np.arccosh, np.arctanh)} == {tape.ASINH, tape.ACOSH, tape.ATANH}
