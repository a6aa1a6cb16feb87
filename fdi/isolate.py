"""Fault isolation: candidate sets from the MD-FSM, suspected mode changes from the MCSM.

Candidates are the paper's delta sets: every set of faults whose signatures' union equals the
coherence vector (Sec. IV: [0 1 1] gives beta_theta2, beta_theta2&R4, beta_theta2&R5,
beta_theta2&R4&R5, R4&R5). Signatures are the *nominal* ones (a structural 1 that vanishes at
nominal values, beta_dp in ARR2 while R4 = inf, cannot light its residual). Without exoneration
(``exoneration=False``) sets whose union merely covers the coherence vector are admitted too (a
fault may leave a residual it is structurally in below its threshold); they are ranked later by
fitness. Mode changes whose MCSM signature equals the coherence vector are suspected.

The paper's delta sets on the CyCab:

>>> from bondgraph.loader import load_model
>>> from fdi.scaph import derive_arrs
>>> from fdi.signatures import fault_signature_matrix, mode_change_signature_matrix
>>> m = load_model("models/cycab_steering.yaml")
>>> arrs = derive_arrs(m)
>>> candidate_sets(fault_signature_matrix(m, arrs), (0, 1, 1))
[('beta_theta2',), ('R4', 'R5'), ('R4', 'beta_theta2'), ('R5', 'beta_theta2'), ('R4', 'R5', 'beta_theta2')]
>>> suspected_mode_changes(mode_change_signature_matrix(m, arrs), (1, 1, 0))
['a2']
"""
from __future__ import annotations

from itertools import combinations

from .signatures import FSM, MCSM


def candidate_sets(fsm: FSM, coherence: tuple[int, ...], exoneration: bool = True, max_size: int = 3) -> list[tuple[str, ...]]:
    """Sets of faults explaining the coherence vector, smallest first, in the FSM's row order."""
    c = tuple(int(x) for x in coherence)
    if not any(c):
        return []
    rows = [r for r in fsm.rows if any(r.nominal)]
    if exoneration:
        rows = [r for r in rows if all(s <= ci for s, ci in zip(r.nominal, c))]
    out = []
    for k in range(1, min(max_size, len(rows)) + 1):
        for combo in combinations(rows, k):
            union = tuple(int(any(col)) for col in zip(*(r.nominal for r in combo)))
            ok = union == c if exoneration else all(u >= ci for u, ci in zip(union, c))
            if ok:
                out.append(tuple(r.fault for r in combo))
    return out


COVERING_NOTE = "the smallest sets covering the coherence vector (a quiet residual exonerating nothing) were identified too"
"""The note of a diagnosis whose exact candidate sets fit badly and which identified these too
(:func:`fdi.pipeline.widen`; the CLI's relaxation line reads it)."""


def relaxed_sets(fsm: FSM, coherence: tuple[int, ...], max_set: int = 3) -> list[tuple[str, ...]]:
    """The smallest fault sets whose signatures cover the coherence vector, when no set matches it
    exactly and no mode change explains it. Exoneration assumes every residual a fault enters
    crosses its threshold; a fault that moves one residual past a tight threshold and leaves
    another under a looser one breaks it (measured: a pump at 30 % of its flow in the two-tank
    model fires ARR1, 1e-4 m^3/s, but not the total mass balance ARR3, 1.5e-4: no candidate, no
    diagnosis). The report says when this relaxation was used."""
    covering = candidate_sets(fsm, coherence, False, max_set)
    smallest = min((len(c) for c in covering), default=0)
    return [c for c in covering if len(c) == smallest]


def pruned_sets(fsm: FSM, coherence: tuple[int, ...], exoneration: bool = True, max_size: int = 3) -> int:
    """How many sets of ``max_size + 1`` faults would also explain the coherence vector: what the cap
    on candidate-set size leaves out (reported, so that a cap never prunes silently)."""
    return sum(len(s) == max_size + 1 for s in candidate_sets(fsm, coherence, exoneration, max_size + 1))


def suspected_mode_changes(mcsm: MCSM, coherence: tuple[int, ...], covering: bool = False) -> list[str]:
    """The mode changes whose MCSM signature is the coherence vector (Sec. III-C); with
    ``covering``, also those whose signature contains it (a residual the change enters but which
    stayed quiet exonerates nothing when exoneration asks whether it could have moved: the
    fault-mode estimator's cost decides).

    >>> from fdi.signatures import MCSM, ModeChangeRow
    >>> m = MCSM({"v": 1}, ("ARR1", "ARR2"), (ModeChangeRow("v_open", "v", (1, 1), 1, 1),))
    >>> suspected_mode_changes(m, (0, 1)), suspected_mode_changes(m, (0, 1), covering=True)
    ([], ['v_open'])
    """
    c = tuple(int(x) for x in coherence)
    if not any(c):
        return []
    exact = [r.mode_change for r in mcsm.rows if r.signature == c]
    if not covering:
        return exact
    return exact + [r.mode_change for r in mcsm.rows if r.signature != c and all(s >= x for s, x in zip(r.signature, c))]


def new_mode_changes(mcsm: MCSM, before: tuple[int, ...], after: tuple[int, ...], covering: bool = False) -> list[str]:
    """The mode changes that explain residuals a later decision gained (``before`` -> ``after``):
    their signature meets the new residuals and lies within ``after`` (with ``covering``, it need
    only meet them).

    >>> from fdi.signatures import MCSM, ModeChangeRow
    >>> m = MCSM({"a1": 1, "a2": 1}, ("ARR1", "ARR2", "ARR3"),
    ...          (ModeChangeRow("a1", "a1", (1, 0, 0), 1, 1), ModeChangeRow("a2", "a2", (1, 1, 0), 1, 1)))
    >>> new_mode_changes(m, (0, 1, 0), (1, 1, 0)), new_mode_changes(m, (0, 1, 1), (0, 1, 1))
    (['a1', 'a2'], [])
    """
    new = [int(a and not b) for a, b in zip(after, before)]
    return [r.mode_change for r in mcsm.rows
            if any(s and n for s, n in zip(r.signature, new))
            and (covering or all(a >= s for s, a in zip(r.signature, after)))]


def fitted_sets(model, sets) -> list[tuple[str, ...]]:
    """The sets an estimator fits: those without a stuck sensor (confirmed by its signal, never
    fitted: a later decision fitted one as a drift and reported "stuck_v: incipient")."""
    return [tuple(c) for c in sets if not any(model.faults[f].effect == "stuck" for f in c)]
