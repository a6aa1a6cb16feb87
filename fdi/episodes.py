"""Later decisions (episodes): after the first diagnosis, the latched coherence vector may gain a
residual (a second fault, or a first one seen better); each change is decided again T_wt later
on the data since the detection, and the diagnosis follows the last decision.

    >>> import numpy as np
    >>> lit = np.array([[0, 1, 1, 1, 1], [0, 0, 0, 1, 1]], dtype=bool)   # ARR2 joins at sample 3
    >>> next_change(lit, 1), next_change(lit, 3)
    (3, None)
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable, TYPE_CHECKING

import numpy as np

from .data import Measurements
from .decide import effective_samples, select_winner
from .detect import alarms
from .isolate import candidate_sets, fitted_sets, relaxed_sets
from .mode_estimation import mode_change_fits
from .objective import window
from .results import Detection, Episode

if TYPE_CHECKING:
    from .estimators import Estimators
    from .options import Options

MAX_GROWTH = 6      # a re-decision fits at most this many times the identification window


def latched(r: np.ndarray, t: np.ndarray, thresholds: np.ndarray, settle: float, edge: float = 0.0,
            persistence: float = 0.0, span: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The coherence vector latched at every sample (a residual joins at its confirmed alarm,
    :func:`fdi.detect.alarms`), and for each residual the sample where the excursion that raised
    it began (-1: none)."""
    a = alarms(r, t, thresholds, settle, edge, persistence, span)
    return a.latched(t.size), a.start


def next_change(lit: np.ndarray, j: int) -> int | None:
    """The first sample after ``j`` where the latched coherence gains a residual, or None."""
    later = np.flatnonzero((lit[:, j + 1:] != lit[:, j:j + 1]).any(axis=0))
    return int(j + 1 + later[0]) if later.size else None


def decision_index(t: np.ndarray, k: int, wait: float) -> int:
    """The sample of the decision for a change at sample ``k``: the waiting time later, or the last."""
    return max(k, min(t.size - 1, int(np.searchsorted(t, t[k] + wait, side="right")) - 1))


def since_detection(t: np.ndarray, t_d: float, end: float, samples: int, cap: int,
                    keep: str = "latest") -> tuple[float, int]:
    """(start, samples) of the window from the detection t_D to ``end`` (at least ``samples`` long,
    at most ``cap`` identification windows, keeping the ``keep`` ("latest" or "earliest") data
    when capped)."""
    i0 = int(np.searchsorted(t, t_d - 1e-9))
    i1 = int(np.searchsorted(t, end, side="right"))
    span = min(max(samples, i1 - i0), cap * samples, t.size - i0)
    return float(t[i0 if keep == "earliest" else max(i0, min(i1, t.size) - span)]), span


def decision_window(t: np.ndarray, t_d: float, t_decision: float, samples: int, cause: str) -> tuple[float, int]:
    """(start, samples) of the data a later decision fits (:func:`since_detection` from t_D to the
    decision, at most MAX_GROWTH windows): the latest kept when capped, the earliest for a lack of
    fit (where a drift taken for a step began shows its type)."""
    return since_detection(t, t_d, t_decision, samples, MAX_GROWTH, "earliest" if cause == "misfit" else "latest")


def redecide(est: "Estimators", meas: Measurements, raw: dict, det: Detection, weights: np.ndarray, o: "Options",
             fsm, known: list[dict], t_change: float, t_decision: float, coherence: tuple[int, ...],
             samples: int, episode: int, mode_changes: list[tuple[str, int]] = (),
             modes: dict[str, float] | None = None, onsets: tuple[float, float] | None = None,
             earliest: float | None = None, progress: Callable | None = None,
             floors: np.ndarray | None = None, quiet: tuple | None = None, cause: str = "coherence") -> Episode:
    """A later decision: the coherence vector gained a residual at ``t_change`` after the diagnosis
    ``known`` was made (``cause`` "coherence"), or the residuals with ``known`` held left their
    thresholds there ("misfit", :func:`fdi.pipeline.misfit_at`; the coherence vector unchanged:
    only sets no larger than the known one are fitted, afresh, since a fault more would absorb a
    drift's extrapolation error: the reference suite's eq. (18) ΔP drift gained a spurious R5
    step; their window keeps the data from t_D). Candidate sets come from the new coherence
    vector; every set is fitted on the data since the first onset (t_D to the new decision, at most MAX_GROWTH windows), so their
    costs compare. A set that contains the known faults is fitted twice: keeping them at their fit,
    each with its own onset, while the others are searched with an onset at the change (a second
    fault), and afresh with one onset (a slow fault seen late); a set no larger than the known one
    is fitted afresh (the first decision may have been wrong); all start from the known fit.
    Larger sets that drop a known fault are not tried. Beside them, each mode change of
    ``mode_changes`` (fault name, value) that could explain the new residuals, with the known
    faults held (:func:`fdi.mode_estimation.mode_change_fits`: no parameter, its onset near the
    change; ``floors``, the residuals' noise floors, charged where it switches a residual off): a
    burnt driver after a leak. The winner is chosen as at the first decision; when no set
    matches the new vector exactly, the smallest sets covering it are tried (as the first decision
    does) with the known set refitted beside them (a piezoelectric stack's capacitance drift lit a
    second residual the signature did not give it: the covering set alone, the coupling's modulus,
    won though the drift went on), and when nothing is left to try the known diagnosis stands. A set fitted
    afresh is refitted with an earlier onset as the first decision's are
    (:func:`fdi.estimators.refit_early_onsets` over ``onsets``, the interval the evidence allows, and
    for a drift back to ``earliest``): a slow drift first seen in one residual and decided again when
    a second joins started before t_D (measured: an eq. (19) encoder drift from 20 s, detected at
    25.8 s, decided again at 40.3 s: fitted from t_D, {R4, R5, beta_theta2} won with beta_theta2 as
    eq. (17)); ``quiet`` (thresholds, the detector's rule): such a refit that the quiet data before
    t_D contradict is not kept (:func:`fdi.estimators.contradicted`)."""
    w = est.monitor.config.derivative_window
    names = {f["name"] for f in known}
    model = est.monitor.model
    sets = fitted_sets(model, candidate_sets(fsm, coherence, o.exoneration, o.max_set))
    if not sets and o.exoneration:       # as the first decision: the smallest sets covering the vector,
        sets = fitted_sets(model, relaxed_sets(fsm, coherence, o.max_set))   # and the known set refitted beside them
        known_set = tuple(f["name"] for f in known if f["type"] != "mode")
        if known_set and len(known_set) <= o.max_set and all(set(known_set) != set(x) for x in sets):
            sets.append(known_set)
    plan = []
    for s in sets:
        if cause == "misfit" and len(s) > len(names):
            continue                     # (a lack of fit: the known fit's type or size, not a fault more)
        if names < set(s):
            plan.append((tuple(x for x in s if x not in names), known, (t_change, t_change + w)))
        if names < set(s) or len(s) <= len(names):
            plan.append((tuple(s), [], None))
    start, span = decision_window(meas.t, det.time, t_decision, samples, cause)
    from .estimators import refit_early_onsets, steps_at_window_start
    fresh = [i for i, p in enumerate(plan) if not p[1]]
    ts = float(meas.t[1] - meas.t[0])
    refitted = set(fresh) if onsets is not None else set()     # their final checks wait for the fit kept
    results = est.run(meas.t, raw, start, span, [p[0] for p in plan], weights, o.seed + 7919 * episode, progress,
                      [p[1] for p in plan], [p[2] for p in plan], [[known] for _ in plan],
                      lambda i, e: i in refitted and steps_at_window_start(e, start, ts)) if plan else []
    if onsets is not None and fresh:
        refits = refit_early_onsets(est, meas.t, raw, start, span, [plan[i][0] for i in fresh],
                                    [results[i] for i in fresh], weights, o.seed + 7919 * episode, onsets, earliest,
                                    [[[f for f in known if f["name"] in plan[i][0]]] for i in fresh], pinned=False,
                                    quiet=quiet)
        results = list(results)
        for i, r in zip(fresh, refits):
            results[i] = r
    full = [replace(e, candidate=tuple(f["name"] for f in p[1]) + e.candidate, faults=tuple(p[1]) + tuple(e.faults),
                    held=tuple(f["name"] for f in p[1])) for e, p in zip(results, plan)]
    if mode_changes:
        win = window(meas.t, raw, start, span, w)
        full += mode_change_fits(est.monitor, win, weights, known, list(mode_changes), t_change, modes, floors)
    finite = [e for e in full if np.isfinite(e.cost)]
    if not finite:                       # nothing to try (or every fit overflowed): the diagnosis stands
        return Episode(t_change, t_decision, tuple(coherence), tuple(known), tuple(full),
                       tuple(f["name"] for f in known), tuple(known), cause)
    n_eff = effective_samples(span, len(est.monitor.residuals), meas.ts, w)
    best = select_winner(finite, n_eff)
    k = next((i for i, e in enumerate(full) if e is best), None)
    if earliest is not None and k is not None and k < len(plan) and not plan[k][1]:
        # a set fitted afresh (nothing held): its steps' and drifts' bands past the onset search's
        # bound, as at the first decision (a heater element's step, hidden while the relay was off,
        # was dated 13 s after t_D with nothing said: a user trial)
        from .estimators import drift_onset_band, step_onset_band
        if quiet is not None:
            best = step_onset_band(est, meas.t, raw, best, quiet[0], earliest, quiet[1])
        best = drift_onset_band(est, meas.t, raw, start, span, best, weights, earliest)
    return Episode(t_change, t_decision, tuple(coherence), tuple(known), tuple(full), tuple(best.candidate),
                   tuple(best.faults), cause)
