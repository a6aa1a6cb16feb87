"""Schwarz's information criterion on the cost of eq. (24), in one place: the diagnosis chooses
among candidate sets with it (:mod:`fdi.decide`) and the engine among the structures of one set
(:meth:`fdi.objective.Objective.penalized`), so that both charge a parameter the same.

    >>> n_eff = effective_samples(1000, 3, 0.01, 0.25)      # 1000 samples x 3 residuals / 25-sample window
    >>> k = parameters([{"name": "R4", "type": "abrupt", "value": 2.4e9, "t0": 31.9}])   # value and onset
    >>> k, round(information(100.0, [{"type": "abrupt"}], n_eff) - 2 * n_eff * math.log(100.0), 6) == round(2 * math.log(n_eff), 6)
    (2, True)
"""
from __future__ import annotations

import math

KINDS = {"abrupt": 1, "intermittent": 2, "mode": 0}    # parameters per fault; incipient: its coefficients


def parameters(faults: list[dict]) -> int:
    """The identified parameters of an explanation: a value per abrupt fault, value and period per
    intermittent one, its coefficients per incipient one, none for a mode fault; plus the onset,
    and a mode fault's own where it was searched (its ``t0``: a fault mode dated, as a component
    fault's onset is, pays for it as that does)."""
    n = sum(KINDS[f["type"]] if f["type"] in KINDS else len(f.get("b", ())) for f in faults)
    dated = sum(1 for f in faults if f["type"] == "mode" and f.get("t0") is not None)
    return n + (1 if any(f["type"] != "mode" for f in faults) else 0) + dated


def effective_samples(samples: int, residuals: int, ts: float, window_s: float) -> float:
    """Independent residual samples in an identification window: the filter correlates the samples
    within one derivative window, so N residual samples carry about N / (window in samples)."""
    return max(1.0, samples * residuals / max(1.0, round(window_s / ts)))


def information(cost: float, faults: list[dict], n_eff: float) -> float:
    """Schwarz's criterion (BIC) of an explanation on the weighted L1 cost of eq. (24): with
    Laplace-distributed residuals of common scale profiled out, -2 ln L = 2 N_eff ln C + const, and
    each identified parameter is charged ln N_eff. Smaller is better; a difference below 2 is not
    a preference (Kass & Raftery 1995)."""
    return 2.0 * n_eff * math.log(max(cost, 1e-300)) + parameters(faults) * math.log(n_eff)


def penalized(cost: float, k: int, n_eff: float) -> float:
    """The criterion as an equivalent cost, exp(information / (2 N_eff)) = C exp(k ln N_eff / (2 N_eff)):
    ``k`` parameters charged on the cost ``cost`` itself, so that an engine can compare structures
    with it where it compares costs."""
    return float(cost) * math.exp(k * math.log(n_eff) / (2.0 * n_eff))
