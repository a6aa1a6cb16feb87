"""Choosing between explanations (issue 10): the information criterion and the candidate-set cap."""
from __future__ import annotations

import math
from itertools import combinations
from types import SimpleNamespace

import pytest

from fdi.decide import effective_samples, information, parameters, select_winner
from fdi.isolate import candidate_sets, pruned_sets
from fdi.signatures import fault_signature_matrix, nominal_mode

ABRUPT = {"name": "R4", "type": "abrupt", "value": 2.5e7, "t0": 32.0}
NOOP = {"name": "R5", "type": "intermittent", "value": 1.0, "period": 3.0, "t0": 32.0}


def test_parameters_counted_per_fault_type():
    assert parameters([ABRUPT]) == 2                                         # value and onset
    assert parameters([ABRUPT, NOOP]) == 4                                   # + value and period
    assert parameters([{"name": "b", "type": "incipient", "model": 3, "b": [-3.0, -1.0], "t0": 1.0}]) == 3
    assert parameters([{"name": "v", "type": "mode", "value": 0}]) == 0


def test_a_larger_set_must_pay_for_its_parameters():
    n_eff = effective_samples(1000, 3, 0.01, 0.25)                           # 1000 samples x 3 / 25
    assert n_eff == pytest.approx(120)
    # two more parameters cost 2 ln(120); the fit must shrink the cost by exp(-ln(120) / 120) = 0.961
    small = SimpleNamespace(cost=100.0, faults=[ABRUPT], candidate=("R4",))
    close = SimpleNamespace(cost=97.0, faults=[ABRUPT, NOOP], candidate=("R4", "R5"))
    better = SimpleNamespace(cost=95.0, faults=[ABRUPT, NOOP], candidate=("R4", "R5"))
    assert select_winner([small, close], n_eff) is small
    assert select_winner([small, better], n_eff) is better
    threshold = math.exp(-math.log(n_eff) / n_eff)
    assert information(100 * threshold, [ABRUPT, NOOP], n_eff) == pytest.approx(information(100, [ABRUPT], n_eff))


def test_a_capped_candidate_search_counts_what_it_leaves_out(cycab, cycab_arrs):
    fsm = fault_signature_matrix(cycab, list(cycab_arrs), nominal_mode(cycab))
    coherence = (1, 1, 1)
    # brute force over the FSM rows: sets of three whose signatures' union is the coherence vector
    rows = [r for r in fsm.rows if any(r.nominal) and all(s <= c for s, c in zip(r.nominal, coherence))]
    three = [c for c in combinations(rows, 3)
             if tuple(int(any(col)) for col in zip(*(r.nominal for r in c))) == coherence]
    assert pruned_sets(fsm, coherence, True, 2) == len(three) > 0
    assert all(len(c) <= 2 for c in candidate_sets(fsm, coherence, True, 2))
