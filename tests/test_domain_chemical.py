"""A stirred-tank reactor whose catalyst deactivates (tests/data/cstr.yaml, a chemical pseudo bond
graph: effort a concentration, flow a molar flow; a domain no shipped model covers), data from
tests/independent/cstr.py (scipy, the mole balance typed by hand, apart from bgfdi).

The designed truth: the reaction's resistance 1/(k V) grows as dR/dt = 0.004 R from 400 s (eq. 16),
so it doubles, the failure value 200 s/m^3, at 400 + ln 2 / 0.004 = 573.3 s."""
from __future__ import annotations


import math
from functools import partial

import pytest

from fdi.api import Options, diagnose

from .independent import by_hand, cstr, measurements, thresholds_fixture

MODEL = str(__import__("pathlib").Path(__file__).resolve().parent / "data" / "cstr.yaml")
B, T0 = 0.004, 400.0

_data = partial(measurements, cstr.simulate)    # (name, seed, **the simulator's keywords)
thresholds = thresholds_fixture(MODEL, cstr.simulate)    # two nominal runs; a third asserted quiet


def test_the_residual_is_the_mole_balance():
    """ARR1 is F - V c' - c/Rrx - c/Rout (its sensor and feed factors at 1), by hand."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled
    (arr,) = compiled(MODEL).arrs
    expr, syms, fn = by_hand(arr.expr)
    V, Rrx, Rout = (syms[n] for n in ("V", "Rrx", "Rout"))
    hand = fn["F"] - V * sp.Derivative(fn["c"], t) - fn["c"] / Rrx - fn["c"] / Rout
    assert sp.simplify(expr - hand) == 0 or sp.simplify(expr + hand) == 0


def test_catalyst_deactivation_is_typed_sized_and_its_end_of_life_predicted(thresholds):
    report = diagnose(MODEL, _data("deactivation", 4, t0=T0, b=B),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 < report["detection"]["time"] < T0 + 100.0
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"], found["model"]) == ("catalyst", "incipient", 1)
    assert found["b"][0] == pytest.approx(B, rel=0.02)
    (p,) = report["prognosis"]
    assert p["eol"] == pytest.approx(T0 + math.log(2) / B, abs=3.0)
    assert p["rul_low"] <= p["eol"] - p["at"] <= p["rul_high"]
    # one true fault: every larger set's race stalls no better than one of its subsets' fits, and
    # stops there (fdi.estimators: a set outdone by its subset)
    larger = [e for e in report["estimators"] if len(e["candidate"]) > 1]
    assert len(larger) == 10 and all(e["raced_out"] and set(e["outdone_by"]) < set(e["candidate"]) for e in larger)


@pytest.mark.parametrize("record, seed", [(5, 0), (7, 1)])
def test_one_fault_is_diagnosed_alone_on_other_records(thresholds, record, seed):
    """Designed truth on two more noise records: the catalyst alone, its rate within 2 %. (While
    every larger set ran its race to the end, a spurious analyser fault joined on both, and on
    record 5 with search seed 0 the rate came out 10 % low; fdi.estimators' sets outdone by a
    subset stop where their race stalls.)"""
    report = diagnose(MODEL, _data("deactivation", record, t0=T0, b=B),
                      Options(workers=1, seed=seed, thresholds=thresholds)).to_dict()
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"], found["model"]) == ("catalyst", "incipient", 1)
    assert found["b"][0] == pytest.approx(B, rel=0.02)


def test_the_race_of_candidate_sets_is_bookkeeping_until_it_stops_one(thresholds, monkeypatch):
    """Designed truth: with its reach infinite and no subset preferred, the race of the candidate
    sets of one size (``fdi.estimators``: each set paused after its first and second rungs,
    compared, continued) stops nothing and changes nothing: every estimator is the one of a
    diagnosis without the race. (Here the sets' races end at different rungs: the larger sets must
    still start from the smaller sets' fits in the candidates' order, or their fits move.)
    On a smaller budget than the default (the bookkeeping does not depend on it): of the eighteen
    races of larger sets, one ends at its first rung, seven at their second and ten go on, and the
    test still fails when the race hands its fits on out of the candidates' order (checked; at
    pop 30 and 40 generations it no longer did). The two diagnoses: 50 s at the default budget,
    about 20 s at this one."""
    import fdi.estimators as E

    def report() -> list:
        r = diagnose(MODEL, _data("deactivation", 4, t0=T0, b=B),
                     Options(workers=1, seed=0, thresholds=thresholds, pop=40, generations=60))
        return [(e.candidate, e.cost, e.evaluations, e.faults, e.raced_out) for e in r.estimates]

    monkeypatch.setattr(E, "SET_REACH", float("inf"))
    monkeypatch.setattr(E, "_preferred_subset", lambda *args: None)
    raced = report()
    monkeypatch.setattr(E.Estimators, "_race", lambda self, wave, jobs, fixed, asked, t, t0, samples, *rest: dict(
        zip(wave, self._run([jobs[i] for i in wave], t, t0, samples))))
    assert raced == report()
