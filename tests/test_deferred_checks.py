"""A final check put off (``Estimators.run``'s ``defer``, ``Estimators.settle``) gives the fit it
would have given in place: a refitted set's check runs only for the fit that is kept.

The reference is the check run in place (the engine continues from the state its first pass left:
the same state, the same draws), on CyCab scenario 2 with a small budget."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from fdi.app.resources import reference_data, shipped_model
from fdi.data import read_csv, signals_from_data
from fdi.estimators import Estimators, Search, steps_at_window_start
from fdi.monitor import compiled

CANDIDATES = [("beta_theta2",), ("R4", "beta_theta2")]


@pytest.fixture(scope="module")
def setting():
    monitor = compiled(shipped_model("cycab_steering"))
    data = read_csv(reference_data("scenario2.csv"))
    raw = signals_from_data(monitor.model, data)
    weights = 1.0 / np.array([monitor.config.thresholds[a.name] for a in monitor.arrs])
    return monitor, data.t, raw, weights


@pytest.fixture(scope="module")
def in_place(setting):
    return _run(setting)[1]


def _run(setting, defer=None, counted=None):
    monitor, t, raw, weights = setting
    est = Estimators(monitor, Search("AHDE", 12, 5))
    if counted is not None:
        inner = est._map
        est._map = lambda jobs: counted.extend(jobs) or inner(jobs)
    got = est.run(t, raw, 32.0, 250, CANDIDATES, weights, 3, defer=defer)
    return est, got


def _fit(e):
    return e.cost, [(f["name"], f["type"], f.get("model"), f.get("value"), f.get("b"), f["t0"]) for f in e.faults]


def test_a_check_put_off_gives_the_fit_the_check_in_place_gives(setting, in_place):
    est, first = _run(setting, defer=lambda i, e: True)
    assert est._pending                                      # at least the best set's check waits
    settled = est.settle(first)
    assert [_fit(e) for e in settled] == [_fit(e) for e in in_place]
    assert [e.evaluations for e in settled] == [e.evaluations for e in in_place]
    assert not est._pending


def test_the_work_a_refit_added_is_kept_and_a_replaced_fits_check_never_runs(setting, in_place):
    est, first = _run(setting, defer=lambda i, e: True)
    k = next(i for i, e in enumerate(first) if e.resume is not None and id(e.resume) in est._pending)
    # a caller that added work of its own (a search before it, as _refit adds an earlier fit's),
    # and holds the same first pass twice: checked once, the added work kept
    grown = replace(first[k], evaluations=first[k].evaluations + 1000, history=(9.0, 8.0) + first[k].history,
                    wall_s=first[k].wall_s + 5.0)
    ran: list = []
    inner = est._map
    est._map = lambda jobs: ran.extend(jobs) or inner(jobs)
    settled, again = est.settle([grown, grown])
    assert len(ran) == 1 and settled == again
    assert settled.evaluations == in_place[k].evaluations + 1000
    assert settled.history[:2] == (9.0, 8.0) and settled.history[2:] == in_place[k].history
    assert settled.cost == in_place[k].cost and settled.wall_s >= 5.0
    # a fit a refit replaced: its check is dropped, no estimator runs
    ran: list = []
    est2, first2 = _run(setting, defer=lambda i, e: True, counted=ran)
    before = len(ran)
    kept = [replace(e, resume=None) for e in first2]         # none of them the deferred fits
    assert est2.settle(kept) == kept and len(ran) == before and not est2._pending


def test_only_steps_dated_at_the_window_start_wait():
    from fdi.results import Estimate
    e = lambda *faults: Estimate(("x",), 1.0, 1.0, (), None, tuple(faults), 0, 0.0)   # noqa: E731
    step = {"name": "x", "type": "abrupt", "value": 2.0, "t0": 10.0}
    assert steps_at_window_start(e(step), 10.0, 0.01)
    assert not steps_at_window_start(e({**step, "t0": 10.5}), 10.0, 0.01)                 # dated later: not refitted
    assert not steps_at_window_start(e({"name": "x", "type": "incipient", "model": 1, "b": [0.1], "t0": 10.0}), 10.0, 0.01)
    assert not steps_at_window_start(e(), 10.0, 0.01)


def test_a_question_asked_again_gets_the_earlier_fit_and_another_question_does_not(setting):
    """A later decision that fits a set on the same window with the same bounds (its seed and
    starting points aside) gets the fit the diagnosis made, its work not counted again: no job
    runs; a set asked with another onset interval is fitted; a question asked twice in one call
    is fitted once, and the jobs after it get their own answers."""
    monitor, t, raw, weights = setting
    counted: list = []
    est, first = _run(setting, counted=counted)
    ran = len(counted)
    again = est.run(t, raw, 32.0, 250, CANDIDATES, weights, 97, known=[[], [dict(f) for f in first[0].faults]])
    assert len(counted) == ran                                # nothing fitted again
    assert [_fit(a) for a in again] == [_fit(b) for b in first]
    assert [a.evaluations for a in again] == [0, 0] and all(b.evaluations > 0 for b in first)
    other = est.run(t, raw, 32.0, 250, CANDIDATES[:1], weights, 3, onsets=[(31.0, 32.5)])
    assert len(counted) == ran + 1 and other[0].evaluations > 0
    fresh = Estimators(monitor, Search("AHDE", 12, 5))
    jobs: list = []
    inner = fresh._map
    fresh._map = lambda js: jobs.extend(js) or inner(js)
    win = fresh.run(t, raw, 32.0, 250, CANDIDATES[:1], weights, 3)[0]
    job = jobs[0]
    twice = fresh._run([replace(job, seed=5, pause=1), replace(job, seed=6, pause=1), job], t, 32.0, 250)
    assert len(jobs) == 2                                     # the paused question once; the last asked before
    assert _fit(twice[0]) == _fit(twice[1]) and twice[1].evaluations == 0
    assert _fit(twice[2]) == _fit(win)
