"""Time derivatives of sampled, noisy, quantised signals.

Savitzky-Golay filtering (a local least-squares polynomial fit in a sliding window, evaluated
with its analytic derivatives) is the default: it is linear, exact for polynomials up to its
order, and handles the quantisation steps of encoders far better than finite differences, whose
noise grows as 1/ts^k. The window length sets the trade-off between noise and lag; it is given in
seconds and rounded to an odd number of samples. All orders come from one fit, so the signal and
its derivatives stay consistent; arrays of any leading shape (population x samples) are handled
along the last axis.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

DEFAULT_WINDOW = 0.25   # s
DEFAULT_ORDER = 3


def window_samples(window: float, ts: float, polyorder: int) -> int:
    """An odd number of samples covering ``window`` seconds, enough for ``polyorder``."""
    n = max(int(round(window / ts)), polyorder + 2)
    return n if n % 2 == 1 else n + 1


def estimate(x: np.ndarray, ts: float, orders: int, window: float = DEFAULT_WINDOW,
             polyorder: int = DEFAULT_ORDER, edges: str = "interp") -> list[np.ndarray]:
    """[x, dx/dt, ..., d^orders x/dt^orders] estimated along the last axis of ``x``.
    ``edges``: how the first and last half-windows are treated (scipy's ``mode``): ``interp`` fits
    a polynomial there; ``mirror`` is cheaper, for callers that crop the edges away."""
    x = np.asarray(x, dtype=float)
    n = window_samples(window, ts, max(polyorder, orders))
    if x.shape[-1] < n:
        raise ValueError(f"{x.shape[-1]} samples are fewer than the derivative window ({n} samples)")
    return [savgol_filter(x, n, max(polyorder, orders), deriv=k, delta=ts, axis=-1, mode=edges)
            for k in range(orders + 1)]
