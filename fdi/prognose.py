"""Prognosis of incipient faults: end of life and remaining useful life (eqs. 30-31).

EOL(tf) = inf{t >= tf + N ts : P(t) has reached the failure value}, RUL(tf) = EOL(tf) - (tf + N ts),
with the identified degradation model run from P(tf) = P (the window starts at tf = tD). One
departure: a profile that reached the failure value before now = tf + N ts has its EOL where it
crossed it, in the past (a passed EOL, ``eol < at``), and RUL 0, where eq. (30) puts the EOL at
now: a trial's penstock fouling fitted to cross at 516.1 s (the truth's 516.2 s) was reported at the
data's last sample, 519.9 s, as if it were failing at that very sample. The RUL is never negative,
nor is either end of its band: a corner of the band already failed has no life left (0), one
that has not bounds the life that may remain. Closed
forms for (16), P = P0 exp(b1 tau) -> tau = ln(Pf/P0)/b1, and (17), 1/P = 1/P0 - b2 tau ->
tau = (1/P0 - 1/Pf)/b2 (the paper's (1/R4(0) - 1/R4F)/b2 of Sec. III-D); (18) is read forward
(the profile functions of fdi.profiles) on a grid of one sampling period of the data (``ts``), and
(19) marched by RK4 in steps of its own time scales (:func:`_ends19`), until the failure value is
crossed or a horizon of HORIZON_SAMPLES periods passes (EOL = inf: no failure predicted): the
CyCab's 10 ms and hour, a water heater's seconds and 100 hours, a converter's microseconds and third of a second. (A grid of 10 ms and an hour in
seconds, the defaults when no ``ts`` is given, left a slow system's end of life past the hour
infinite and a fast one's resolved to ten milliseconds.) The failure value is reached from above when
it is below the nominal value (an efficiency factor that decays) and from below otherwise.

The CyCab's encoder fault of scenario 2 (README): beta_theta2 from 1 at tf = 32 s as (17) with
b2 = -0.03, 1/P = 1 + 0.03 (t - tf), fails at 0.5 when 0.03 (t - tf) = 1, at 32 + 100/3 s; a
an exponential decay (16), P = exp(-0.1 tau), reaches 0.5 after ln 2 / 0.1 s:

>>> round(end_of_life(2, [-0.03], 1.0, 0.5, tf=32.0, now=37.0), 4)
65.3333
>>> p = prognose({"name": "beta_theta2", "model": 2, "b": [-0.03]}, 1.0, 0.5, tf=32.0, now=37.0)
>>> round(p["rul"], 4), p["rul"] == p["rul_low"] == p["rul_high"]      # no band given: the RUL itself
(28.3333, True)
>>> round(end_of_life(1, [-0.1], 1.0, 0.5, tf=0.0, now=0.0), 4), round(10 * float(np.log(2)), 4)
(6.9315, 6.9315)
>>> end_of_life(2, [0.03], 1.0, 0.5, tf=32.0, now=37.0)             # drifting away from failure
inf
>>> p = prognose({"name": "beta_theta2", "model": 2, "b": [-0.03]}, 1.0, 0.5, tf=32.0, now=70.0)
>>> round(p["eol"], 4), p["rul"], p["eol"] < p["at"]                # failed 4.67 s before now: passed
(65.3333, 0.0, True)
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from .profiles import hermite, incipient, rk4_step19

STEP = 0.01                  # s: the grid of a caller that gives no sampling period (the CyCab's)
HORIZON_SAMPLES = 360_000    # grid steps a numerically integrated profile is followed ahead (an hour at 10 ms)


def end_of_life(model_no: int, b: list[float], nominal: float, failure: float, tf: float, now: float,
                horizon: float | None = None, ts: float | None = None) -> float:
    """The first time at which the profile started at ``tf`` reaches ``failure``: before ``now``
    when it already has (a passed end of life); ``now`` sets how far ahead it is first looked for."""
    return float(ends_of_life(model_no, [b], nominal, failure, [tf], now, horizon, ts)[0])


def ends_of_life(model_no: int, bs, nominal: float, failure: float, tfs, now: float,
                 horizon: float | None = None, ts: float | None = None) -> np.ndarray:
    """:func:`end_of_life` of several coefficient vectors ``bs`` (rows) with their onsets ``tfs``:
    closed forms for (16) and (17); (18) and (19) integrated together (one population of the
    profile functions) over a look-ahead that grows fourfold from the time already elapsed until
    every row has failed or ``horizon`` is passed (a row that failed before ``now`` at its
    crossing, not at ``now``: :func:`end_of_life`): an RUL of seconds is not looked for an hour
    ahead, and a row that never fails costs 1.3 passes of the hour (measured: the 17 corners of an
    eq. (19) band took 11 s one at a time over the whole hour, 4 ms together). ``ts``: the grid
    (default STEP); ``horizon``: how far ahead, s (default HORIZON_SAMPLES grid steps)."""
    bs = np.atleast_2d(np.asarray(bs, dtype=float))
    tfs = np.asarray(tfs, dtype=float).reshape(-1)
    down = failure < nominal
    if model_no in (1, 2):
        with np.errstate(divide="ignore", invalid="ignore"):
            if model_no == 1:
                tau = np.log(failure / nominal) / bs[:, 0] if failure / nominal > 0 else np.full(len(bs), np.inf)
            else:
                inv0 = 0.0 if np.isinf(nominal) else 1.0 / nominal
                tau = (inv0 - 1.0 / failure) / bs[:, 0]
        tau = np.where((bs[:, 0] != 0) & np.isfinite(tau) & (tau >= 0), tau, np.inf)
        return np.where(np.isfinite(tau), tfs + tau, np.inf)
    step = float(ts) if ts is not None and ts > 0 and math.isfinite(ts) else STEP
    horizon = HORIZON_SAMPLES * step if horizon is None else horizon
    if model_no == 4:
        return _ends19(bs, tfs, nominal, failure, now + horizon)
    out = np.full(len(bs), np.inf)
    todo = np.arange(len(bs))
    ahead = max(1.0, now - float(tfs.min()))
    while todo.size:
        ahead = min(4.0 * ahead, horizon)
        t = np.arange(float(tfs[todo].min()), now + ahead, step)
        p = incipient(t, tfs[todo], nominal, model_no, bs[todo])
        with np.errstate(invalid="ignore"):
            reached = ((p <= failure) if down else (p >= failure)) & (t[None, :] >= tfs[todo, None])
        hit = reached.any(axis=1)
        for row, r in zip(todo[hit], np.flatnonzero(hit)):
            out[row] = _crossing(t, p[r], int(np.argmax(reached[r])), failure, down, step)
        todo = todo[~hit]
        if ahead >= horizon:
            break
    return out


STEPS_PER_SCALE19 = 8       # RK4 steps per time scale of eq. (19) (1/sqrt|b6|, 1/|2 b5 dP/dt|) marched ahead
MAX_STEPS19 = 10_000        # steps an eq. (19) row is marched ahead at most (then followed no further: EOL inf)


def _ends19(bs: np.ndarray, tfs: np.ndarray, nominal: float, failure: float, until: float) -> np.ndarray:
    """Eq. (19)'s ends of life, P'' = b5 P'^2 + b6 P + b7 from P(tf) = P0, P'(tf) = 0, marched by RK4
    from each onset to ``until`` or its crossing, all rows together, each in steps of its own time
    scales (:data:`STEPS_PER_SCALE19` per 1/sqrt|b6| and per 1/|2 b5 P'|, re-read at every step),
    the crossing found on the step's cubic Hermite (P and P' at both ends: the profile functions'
    reading). Not the profile functions over the look-ahead: their grid (at most 1 000 steps over a
    span, :func:`fdi.profiles.steps19`, for the estimators' windows) ran 0.26 s steps over 255 s and
    1 s steps over 1 000 s, where an oscillating fit (b6 = -18.7 /s^2) went to infinity: a trial's
    cylinder friction, fitted between 200 and 271 N s/m, was given an end of life at 600 passed
    3.7 s before the decision. A row marched :data:`MAX_STEPS19` steps without crossing is followed
    no further (EOL inf)."""
    rows = len(bs)
    out = np.full(rows, np.inf)
    down = failure < nominal
    if nominal == failure:                  # failed from the onset
        return tfs.astype(float).copy()
    if np.isinf(nominal):                   # eq. (19) never leaves an infinite P0 (fdi.profiles)
        return out
    b5, b6, b7 = bs[:, 0], bs[:, 1], bs[:, 2]
    p, v, t = np.full(rows, float(nominal)), np.zeros(rows), tfs.astype(float).copy()
    todo = np.flatnonzero(t < until)
    with np.errstate(all="ignore"):
        base = 1.0 / (STEPS_PER_SCALE19 * np.sqrt(np.abs(b6)))            # inf where b6 = 0
        for _ in range(MAX_STEPS19):
            if not todo.size:
                break
            c5, c6, c7, pa, va = b5[todo], b6[todo], b7[todo], p[todo], v[todo]
            # (each scale infinite where its coefficient or the slope is 0: then the step runs to ``until``)
            h = np.minimum(np.minimum(base[todo], 1.0 / (STEPS_PER_SCALE19 * np.abs(2.0 * c5 * va))), until - t[todo])
            pb, vb = rk4_step19(pa, va, h, c5, c6, c7)
            crossed = ~np.isfinite(pb) | ((pb <= failure) if down else (pb >= failure))
            if crossed.any():
                out[todo[crossed]] = t[todo[crossed]] + h[crossed] * _hermite_root(
                    pa[crossed], pb[crossed], va[crossed] * h[crossed], vb[crossed] * h[crossed], failure)
            p[todo], v[todo], t[todo] = pb, vb, t[todo] + h
            todo = todo[~crossed & (t[todo] < until) & (h > 0)]
    return out


def _hermite_root(pa: np.ndarray, pb: np.ndarray, da: np.ndarray, db: np.ndarray, level: float) -> np.ndarray:
    """The first s in [0, 1] where the cubic Hermite from (pa, da) to (pb, db) (slopes per step)
    reaches ``level`` from pa's side, by bisection on where it first has (1 where pb is not finite or
    the cubic does not reach it: the step's end)."""
    s = np.linspace(0.0, 1.0, 65)[None, :]
    with np.errstate(all="ignore"):
        h = hermite(s, pa[:, None], pb[:, None], da[:, None], db[:, None])
        reached = np.where(pa[:, None] > level, h <= level, h >= level) & np.isfinite(pb)[:, None]
    hit = reached.any(axis=1)
    i = np.where(hit, np.argmax(reached, axis=1), 64)
    lo, hi = (np.maximum(i - 1, 0) / 64.0), i / 64.0
    for _ in range(44):
        mid = (lo + hi) / 2
        with np.errstate(all="ignore"):
            val = hermite(mid, pa, pb, da, db)
        got = np.where(pa > level, val <= level, val >= level)
        hi, lo = np.where(got, mid, hi), np.where(got, lo, mid)
    return np.where(hit, hi, 1.0)


def _crossing(t: np.ndarray, p: np.ndarray, i: int, failure: float, down: bool, step: float) -> float:
    """Where a profile ``p`` sampled at ``t`` crosses ``failure``, ``i`` its first sample at or
    after its onset that has reached it: interpolated between the sample before and ``i``; at
    ``t[i]`` when the sample before has reached it too (a nominal value past the failure value:
    failed from the onset), there is none, or either value is not finite (never extrapolated: an
    interpolation across two failed samples put an end of life hundreds of seconds early)."""
    a, c = (p[i - 1] if i else np.nan), p[i]
    if not (np.isfinite(a) and np.isfinite(c)) or a == c or ((a <= failure) if down else (a >= failure)):
        return float(t[i])
    return float(t[i - 1] + (failure - a) / (c - a) * step)


def _region_ruls(model_no: int, b_band, onsets: list[float], profile, nominal: float, failure: float,
                 now: float, ts: float | None = None) -> list[float]:
    """The RULs at the corners of a model's 95 % intervals (``b_band`` times ``onsets``) and at its
    plausible fits along the onset (``profile``: t0, b)."""
    points = [(list(c), start) for c in itertools.product(*b_band) for start in onsets] if b_band else []
    points += [(list(p["b"]), p["t0"]) for p in profile or ()]
    if not points:
        return []
    return [max(float(e) - now, 0.0) for e in ends_of_life(model_no, [c for c, _ in points], nominal, failure,
                                                  [start for _, start in points], now, ts=ts)]


def prognose(fault: dict, nominal: float, failure: float, tf: float, now: float, ts: float | None = None) -> dict:
    """EOL, RUL at ``now`` = tf + N ts, and the RUL band: the RULs at the corners of the 95 %
    profile-likelihood intervals of the coefficients and the onset (``b_band``, ``t0_band``, from
    the final fit: see ``fdi.estimators.coefficient_band``; the RUL is monotone in each, so the
    corners bound it over the box) and at its plausible fits along the onset (``onset_profile``:
    a second-order drift that started earlier and grew slower, :func:`fdi.estimators.onset_profile`),
    widened to the RULs of each other degradation model the data
    cannot tell from the fit's (``other_models``, :func:`fdi.estimators.other_models`: its best
    point, the corners of its own intervals and its onset profile); without a band, the band is the RUL itself.
    ``ts``: the data's sampling period, the grid of eqs. (18) and (19) (see the module's text).
    An end of life already passed stays where the fit crossed the failure value (``eol`` before
    ``at``), its RUL 0, the band from 0 (see the module's text)."""
    eol = end_of_life(fault["model"], fault["b"], nominal, failure, tf, now, ts=ts)
    rul = max(eol - now, 0.0)
    ruls = [rul] + _region_ruls(fault["model"], fault.get("b_band"), list(fault.get("t0_band") or []) or [tf],
                                      fault.get("onset_profile"), nominal, failure, now, ts)
    for other in fault.get("other_models") or []:      # a degradation model the data cannot tell apart
        ruls.append(max(end_of_life(other["model"], other["b"], nominal, failure, other["t0"], now, ts=ts) - now, 0.0))
        ruls += _region_ruls(other["model"], other.get("b_band"), list(other.get("t0_band") or []) or [other["t0"]],
                             other.get("onset_profile"), nominal, failure, now, ts)
    finite = [r for r in ruls if np.isfinite(r)]
    return {"name": fault["name"], "failure": failure, "eol": eol, "rul": rul, "at": now,
            "rul_low": min(finite) if finite else float("inf"), "rul_high": max(finite) if finite else float("inf")}
