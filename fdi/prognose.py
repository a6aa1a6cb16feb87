"""Prognosis of incipient faults: end of life and remaining useful life (eqs. 30-31).

EOL(tf) = inf{t >= tf + N ts : P(t) has reached the failure value}, RUL(tf) = EOL(tf) - (tf + N ts),
with the identified degradation model run from P(tf) = P (the window starts at tf = tD). Closed
forms for (16), P = P0 exp(b1 tau) -> tau = ln(Pf/P0)/b1, and (17), 1/P = 1/P0 - b2 tau ->
tau = (1/P0 - 1/Pf)/b2 (the paper's (1/R4(0) - 1/R4F)/b2 of Sec. III-D); (18) and (19) are
integrated forward (the profile functions of fdi.profiles) until the failure value is crossed or
a horizon passes (EOL = inf: no failure predicted). The failure value is reached from above when
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
"""
from __future__ import annotations

import itertools

import numpy as np

from .profiles import incipient

HORIZON = 3600.0   # s, how far ahead a numerically integrated profile is followed


def end_of_life(model_no: int, b: list[float], nominal: float, failure: float, tf: float, now: float,
                horizon: float = HORIZON) -> float:
    """The first time >= ``now`` at which the profile started at ``tf`` reaches ``failure``."""
    down = failure < nominal
    if model_no in (1, 2):
        bb = b[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            if model_no == 1:
                tau = np.log(failure / nominal) / bb if bb != 0 and failure / nominal > 0 else np.inf
            else:
                inv0 = 0.0 if np.isinf(nominal) else 1.0 / nominal
                tau = (inv0 - 1.0 / failure) / bb if bb != 0 else np.inf
        if not np.isfinite(tau) or tau < 0:
            return float("inf")
        return max(tf + float(tau), now)
    step = 0.01
    t = np.arange(tf, now + horizon, step)
    p = incipient(t, tf, nominal, model_no, [list(b)])[0]
    reached = (p <= failure) if down else (p >= failure)
    reached &= t >= now
    if not reached.any():
        return float("inf")
    i = int(np.argmax(reached))
    if i == 0 or not np.isfinite(p[i - 1]) or not np.isfinite(p[i]) or p[i] == p[i - 1]:
        return float(t[i])
    return float(t[i - 1] + (failure - p[i - 1]) / (p[i] - p[i - 1]) * step)


def prognose(fault: dict, nominal: float, failure: float, tf: float, now: float) -> dict:
    """EOL, RUL at ``now`` = tf + N ts, and the RUL band: the RULs at the corners of the 95 %
    profile-likelihood intervals of the coefficients and the onset (``b_band``, ``t0_band``, from
    the final fit: see ``fdi.estimators.coefficient_band``; the RUL is monotone in each, so the
    corners bound it over the box); without a band, the band is the RUL itself."""
    eol = end_of_life(fault["model"], fault["b"], nominal, failure, tf, now)
    ruls = [eol - now]
    band = fault.get("b_band") or []
    onsets = list(fault.get("t0_band") or []) or [tf]
    for corner in itertools.product(*band) if band else ():      # product() of nothing is one empty corner
        for start in onsets:
            ruls.append(end_of_life(fault["model"], list(corner), nominal, failure, start, now) - now)
    finite = [r for r in ruls if np.isfinite(r)]
    return {"name": fault["name"], "failure": failure, "eol": eol, "rul": eol - now, "at": now,
            "rul_low": min(finite) if finite else float("inf"), "rul_high": max(finite) if finite else float("inf")}
