"""``optim.simplex.nelder_mead`` is scipy's Nelder-Mead without importing ``scipy.optimize`` on the
diagnosis path: on each problem here it must return the very ``x``, ``fun``, evaluation count,
iteration count and status that ``scipy.optimize.minimize(method="Nelder-Mead")`` returns with
the same options (the reference: scipy itself, run in the test). The problems cover the default
and a given initial simplex, unbounded and bounded (an optimum outside the box, a start above an
upper bound, one-sided bounds), the adaptive coefficients, a noisy objective, budgets spent by
``maxfev`` and by ``maxiter``, and non-finite values."""
from __future__ import annotations

import warnings
import zlib

import numpy as np
import pytest
from scipy.optimize import minimize, rosen

from optim.simplex import nelder_mead


def _noisy(x: np.ndarray) -> float:
    """A quadratic bowl plus noise of amplitude 1e-3 that is a deterministic function of x's bytes
    (so both implementations see the same value at the same point)."""
    noise = np.random.default_rng(zlib.crc32(np.ascontiguousarray(x).tobytes())).uniform(-1e-3, 1e-3)
    return float(((x - np.array([0.3, -0.2, 0.1])) ** 2).sum() + noise)


def _cliff(x: np.ndarray) -> float:
    """A bowl that is infinite (as ``fdi.estimators`` maps a failed evaluation to 1e300) left of 0.2."""
    return np.inf if x[0] < 0.2 else float((x[0] - 0.25) ** 2 + (x[1] - 1.0) ** 2)


def _bowl(x: np.ndarray) -> float:
    return float(((x - np.array([1.5, -2.0])) ** 2 * np.array([1.0, 30.0])).sum())


def _valley(x: np.ndarray) -> float:
    """A curved valley like a second-order drift's coefficients against its onset."""
    return float((x[1] - x[0] ** 2) ** 2 * 50 + (1 - x[0]) ** 2 + 0.1 * x[2] ** 2)


EYE = np.eye(3)
U0 = np.array([0.4, 0.1, 0.3])
CASES = {
    "rosenbrock, defaults": (rosen, [-1.2, 1.0, 0.5], {}, None),
    "rosenbrock, tight tolerances": (rosen, [1.3, 0.7, 0.8, 1.9, 1.2], {"xatol": 1e-10, "fatol": 1e-12}, None),
    "a zero start coordinate": (_bowl, [0.0, 0.0], {"xatol": 1e-8, "fatol": 1e-10}, None),
    "adaptive, 6 variables": (rosen, [0.5, -0.4, 1.1, 0.9, 0.0, 1.4], {"adaptive": True, "maxiter": 3000}, None),
    "bounded, optimum outside the box": (_bowl, [0.2, 0.3], {"xatol": 1e-9, "fatol": 1e-12},
                                         [(-1.0, 1.0), (-1.0, 1.0)]),
    "bounded, start at an upper bound": (_bowl, [1.0, 2.0], {}, [(0.0, 1.0), (None, 2.0)]),
    "bounded, start outside": (_bowl, [3.0, 0.5], {}, [(0.0, 2.0), (-5.0, None)]),
    "noisy": (_noisy, [1.0, 1.0, 1.0], {"xatol": 1e-6, "fatol": 1e-9}, None),
    "noisy, bounded": (_noisy, [0.9, 0.5, 0.5], {"xatol": 1e-6, "fatol": 1e-9}, [(0.0, 1.0), (0.0, 1.0), (0.2, 1.0)]),
    "maxfev spent": (rosen, [-1.2, 1.0, 0.5], {"maxfev": 37}, None),
    "maxfev spent in the first simplex": (rosen, [-1.2, 1.0, 0.5], {"maxfev": 2}, None),
    "maxiter spent": (rosen, [-1.2, 1.0, 0.5], {"maxiter": 25}, None),
    "infinite values": (_cliff, [0.5, 0.0], {"xatol": 1e-8, "fatol": 1e-10}, None),
    # the call fdi.estimators._simplex makes: a 2 % simplex in unit coordinates, 60 evaluations a variable
    "the diagnosis's polish": (_valley, U0, {"maxfev": 180, "xatol": 1e-6, "fatol": 7e-10,
                                             "initial_simplex": np.vstack([U0] + [U0 + 0.02 * e for e in EYE])},
                               None),
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_same_answer_as_scipy(name):
    func, x0, options, bounds = CASES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # scipy warns of a start outside the bounds, then clips it
        expected = minimize(func, np.array(x0, dtype=float), method="Nelder-Mead", bounds=bounds, options=dict(options))
    got = nelder_mead(func, np.array(x0, dtype=float), bounds=bounds, **options)
    np.testing.assert_array_equal(got.x, expected.x)
    assert got.fun == expected.fun
    assert (got.nfev, got.nit, got.status) == (expected.nfev, expected.nit, expected.status)
    np.testing.assert_array_equal(got.simplex, expected.final_simplex[0])
    assert got.success == expected.success


def test_it_finds_a_hand_computed_minimum():
    """Independent of scipy: the bowl's minimum is (1.5, -2); inside the box [-1, 1]^2 it is the
    corner (1, -1), where the bowl is 0.25 + 30."""
    r = nelder_mead(_bowl, [0.0, 0.0], xatol=1e-10, fatol=1e-14)
    np.testing.assert_allclose(r.x, [1.5, -2.0], atol=1e-8)
    r = nelder_mead(_bowl, [0.0, 0.0], xatol=1e-10, fatol=1e-14, bounds=[(-1, 1), (-1, 1)])
    np.testing.assert_allclose(r.x, [1.0, -1.0], atol=1e-8)
    assert r.fun == pytest.approx(30.25, rel=1e-12)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="lower bound"):
        nelder_mead(_bowl, [0.0, 0.0], bounds=[(1, 0), (0, 1)])
    with pytest.raises(ValueError, match="shape"):
        nelder_mead(_bowl, [0.0, 0.0], initial_simplex=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="scalar"):
        nelder_mead(lambda x: x, [0.0, 0.0])
