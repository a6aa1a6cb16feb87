"""Residual selection on the structure first: which MSO residuals complete the SCAPH AGARRs.

The SCAPH AGARRs come first (the CyCab keeps eqs. 5, 9, 13). What they miss of the model's best
structural isolability is asked of :class:`fdi.isolability.StructuralBest` pair by pair, never
by listing residuals. Candidates are MSO sets:

- every MSO set, where the model's structural redundancy is small (at most
  :data:`ENUMERATE_REDUNDANCY`: polynomially many sets, milliseconds for the shipped models);
- otherwise the MSO sets close to each missed fault (:func:`bondgraph.structure.msos_around`),
  inside the part of the model blind to the other fault of the pair. A chain of n measured
  tanks has redundancy n and about 3^n MSO sets; the few near a missed pair are what it needs.

Each candidate is described by structure alone (:func:`describe`, no sympy): the faults it
reacts to, the highest time derivative of a measured signal its residual needs, how many
differentiations, how many equations. The greedy choice looks at the candidates that add
something and whose derivative order is at most :data:`ORDER_WINDOW` above the lowest of them (a
residual that needs nine derivatives to cover many faults at once waits while second-order ones
cover them a few at a time). Of those it takes the one that adds most (new detections, then new
pairs told apart), ties to the lowest derivative order, then the fewest differentiations (a
measured speed before a differentiated position), then the smallest set. Only candidates equal
in all of these are realised together, and the smallest expression wins; nothing else is
realised with sympy (:func:`bondgraph.sequential.realize`). A candidate that fails is dropped;
one whose expression reacts to other faults than its equations say is ranked again.

Afterwards a residual the others make redundant is dropped (highest derivative order first), and
one is replaced by at most two of lower derivative order when they keep the same detectability
and isolability (an algebraic relation instead of a third derivative). A time budget bounds the
search; the residual set's notes say when it cut it.

The three tanks: SCAPH stops at derivative loops, and two MSO residuals reach the model's best
structural isolability (:mod:`fdi.isolability`):

>>> from bondgraph.loader import load_model
>>> from fdi.isolability import signature_isolability, structural_isolability
>>> from fdi.scaph import structural_system
>>> from fdi.signatures import fault_signature_matrix
>>> m = load_model("models/three_tank.yaml")
>>> chosen = select(m)
>>> chosen.scaph_ok, [(a.name, a.origin, a.sensor) for a in chosen.arrs]
(False, [('ARR1', 'MSO', 'p1, q2'), ('ARR2', 'MSO', 'p1, q2')])
>>> fsm = fault_signature_matrix(m, list(chosen.arrs))
>>> reached = signature_isolability([r.fault for r in fsm.rows], {r.fault: r.structural for r in fsm.rows})
>>> reached.covers(structural_isolability(m, structural_system(m)))
True
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Mapping

import sympy as sp

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.model import Model
from bondgraph.deep import free_symbols
from bondgraph.sequential import realize, residual_plan
from bondgraph.structure import (DERIVATIVE, EquationSystem, Structure, derivative_plan, mso_enumerate, msos_around,
                                 redundancy_of, residual_choices)

from .isolability import Shortfall, StructuralBest
from .scaph import ARR, binary_modes, derive_arrs, storage_fault_parameters, structural_system
from .signatures import all_modes, nominal_mode, operating_modes, sees_mode_fault

ORDER_WINDOW = 1              # candidates more derivatives above the lowest that still adds something wait
BUDGET = 30.0                 # s of computing for the whole selection (SCAPH included); notes say when it cuts
ENUMERATE_REDUNDANCY = 4      # up to this redundancy every MSO set is a candidate
TARGETS_PER_ROUND = 2         # missed (fault, other fault) targets searched before each choice
PLAN_TRIES = 24               # residual equations tried for a plan before an MSO set is passed over
SEEDS_PER_TARGET = 3          # equations of a fault tried as the seed of a local search
BALL_LIMIT = 60               # MSO sets listed around one seed
TIES_REALISED = 4             # structurally equal best candidates realised to compare their expressions' size


@dataclass(frozen=True)
class ResidualSet:
    """The residuals bgfdi diagnoses with, and why: the SCAPH AGARRs where they reach the model's
    best structural isolability, completed by MSO residuals where they do not."""
    arrs: tuple[ARR, ...]
    causality: str
    scaph_ok: bool
    scaph_problems: tuple[str, ...]
    candidates: int = 0                 # MSO sets whose residual is computable in this causality
    msos: int = 0                       # MSO sets examined (all of them where mso_complete)
    mso_complete: bool = True
    mso_seconds: float = 0.0
    notes: tuple[str, ...] = field(default_factory=tuple)



@dataclass(frozen=True)
class Candidate:
    """An MSO set described by structure: the faults whose equations it holds, the equation
    :func:`~bondgraph.sequential.realize` keeps as its residual, the highest time derivative of a
    measured signal the residual needs and the differentiations on the way."""
    equations: frozenset[int]
    faults: frozenset[str]
    residual: int
    order: int
    differentiations: int

    def quality(self) -> tuple:
        """Lower is better: derivative order, differentiations, size, then the equations."""
        return self.order, self.differentiations, len(self.equations), sorted(self.equations)


def describe(system: EquationSystem, eqs: Iterable[int], causality: str,
             fault_equations: Mapping[str, frozenset], st: Structure | None = None) -> Candidate | None:
    """The candidate residual of the MSO set ``eqs``, or None when no equation of it leaves a
    computable rest in ``causality``. The residual equation is the one ``realize`` keeps: fewest
    differentiations, then a junction balance, a sensor or law, a differential constraint. In
    derivative causality every differential constraint of the rest is differentiated, so that
    order is known before any plan and the first equation in it whose rest has a plan
    (:func:`~bondgraph.structure.derivative_plan`, on the numbered structure ``st``) is the one;
    a set none of whose first :data:`PLAN_TRIES` equations gives one is passed over (a set that
    needs an integration fails them all, and a long chain has many such sets)."""
    eqs = frozenset(eqs)
    faults = frozenset(f for f, fe in fault_equations.items() if fe & eqs)
    if causality == DERIVATIVE and st is not None:
        def kind(r: int) -> tuple:
            eq = system.equations[r]
            return (0 if eq.differential else 1, 0 if eq.name.endswith(".balance") else 1 if not eq.differential else 2, r)
        for r in sorted(residual_choices(st, eqs), key=kind)[:PLAN_TRIES]:
            found = derivative_plan(st, eqs - {r})
            if found is not None:
                m, blocks = found
                diffs = sum(1 for e in eqs - {r} if e in st.differential)
                return Candidate(eqs, faults, r, _order(st, r, m, blocks), diffs)
        return None
    best = residual_plan(system, eqs, causality)
    if best is None:
        return None
    r, p = best
    return Candidate(eqs, faults, r, derivative_order(system, r, p), p["differentiations"])


def _order(st: Structure, residual: int, m: Mapping[int, int], blocks: list[list[int]]) -> int:
    """:func:`derivative_order` on the numbered structure (derivative causality)."""
    order: dict[int, int] = {}
    for block in blocks:
        if len(block) == 1:
            e = block[0]
            v = m[e]
            if e in st.differential:
                order[v] = order.get(st.differential[e][0], 0) + 1
            else:
                order[v] = max((order.get(u, 0) for u in st.rows[e] if u != v), default=0)
        else:
            outs = {m[e] for e in block}
            ins = set().union(*(st.rows[e] for e in block)) - outs
            k = max((order.get(u, 0) for u in ins), default=0)
            order.update({v: k for v in outs})
    if residual in st.differential:
        x, dx = st.differential[residual]
        return max(order.get(dx, 0), order.get(x, 0) + 1)
    return max((order.get(u, 0) for u in st.rows[residual]), default=0)


def derivative_order(system: EquationSystem, residual: int, p: dict) -> int:
    """The highest time derivative of a known signal (measurement or input) in the residual of
    plan ``p``: a variable solved from others has their highest order, one differentiated from x
    has x's plus one, an algebraic loop its inputs' highest."""
    order: dict = {}
    m = p["matching"]
    for block in p["blocks"]:
        if len(block) == 1:
            eq = system.equations[block[0]]
            v = m[block[0]]
            if eq.differential:
                x, dx = eq.differential
                order[v] = order.get(x, 0) + 1 if v == dx else max(order.get(dx, 0) - 1, 0)
            else:
                order[v] = max((order.get(u, 0) for u in eq.variables if u != v), default=0)
        else:
            outs = {m[e] for e in block}
            ins = set().union(*(system.equations[e].variables for e in block)) - outs
            k = max((order.get(u, 0) for u in ins), default=0)
            order.update({v: k for v in outs})
    eq = system.equations[residual]
    if eq.differential:
        x, dx = eq.differential
        return max(order.get(dx, 0), order.get(x, 0) + 1)
    return max((order.get(u, 0) for u in eq.variables), default=0)


def expression_faults(model: Model, arr: ARR, mode: Mapping[str, int] | list[Mapping[str, int]],
                      fault_symbols: Mapping[str, frozenset]) -> frozenset[str]:
    """The faults a residual reacts to structurally in ``mode`` (or in any of a list of modes): the
    symbols of its expression (its column of :func:`fdi.signatures.fault_signature_matrix`, from
    one pass over them) and of the right-hand sides of its integrated states (mixed causality: a
    fault there moves X(t))."""
    if isinstance(mode, list):
        return frozenset().union(*(expression_faults(model, arr, m, fault_symbols) for m in mode))
    modes = {model.symbols[m]: sp.Integer(v) for m, v in mode.items()}
    present = free_symbols(arr.expr.xreplace(modes) if modes else arr.expr)     # each shared part once
    for _, rhs in arr.states:
        present |= free_symbols(sp.sympify(rhs).xreplace(modes))
    return frozenset(f for f, syms in fault_symbols.items() if syms & present)


@dataclass(frozen=True)
class _Pick:
    arr: ARR
    faults: frozenset[str]
    candidate: Candidate | None = None


def _signatures(faults: Iterable[str], picks: list[_Pick]) -> dict[str, frozenset[int]]:
    return {f: frozenset(k for k, p in enumerate(picks) if f in p.faults) for f in faults}


def _deficit(reached: Mapping[str, frozenset], target: Mapping[str, frozenset]) -> Shortfall:
    """What ``target`` detects and tells apart and ``reached`` does not (signatures by fault)."""
    undetected = tuple(f for f in target if target[f] and not reached[f])
    groups: dict[frozenset, list[str]] = {}
    for f in target:
        groups.setdefault(reached[f], []).append(f)
    pairs = [(fa, fb) for members in groups.values() for x, fa in enumerate(members)
             for fb in members[x + 1:] if target[fa] != target[fb]]
    return Shortfall(undetected, tuple(pairs))


def _gain(faults: frozenset[str], short: Shortfall, partners: Mapping[str, set]) -> tuple[int, int]:
    """New detections and new pairs told apart (one fault of the pair in ``faults``, not both)."""
    detected = sum(1 for f in short.undetected if f in faults)
    pairs = sum(len(partners[f] - faults) for f in faults if f in partners)
    return detected, pairs


def select(model: Model, causality: str = DERIVATIVE, budget: float = BUDGET) -> ResidualSet:
    """See :func:`fdi.arrs.select_arrs`."""
    deadline = time.perf_counter() + budget
    diag = assign(model, DIAGNOSIS)
    scaph = derive_arrs(model, diag) if diag.ok else []
    problems = tuple(diag.problems) + tuple(diag.loops)
    search = _Search(model, lambda: structural_system(model, diag), causality, deadline)
    picks = [_Pick(a, search.faults_of(a)) for a in scaph]
    search.seen.update(a.expr for a in scaph)
    if diag.ok and not search.shortfall(picks):
        return ResidualSet(tuple(scaph), causality, True, problems)
    search.candidates()
    picks = search.complete(picks, search.shortfall, targeted=True)
    picks = search.prune(picks)
    picks = search.lower(picks)
    picks = search.operating(picks)
    picks = search.switches(picks)
    k = len(scaph)
    out = []
    for p in picks:
        a = p.arr
        if a.origin == "MSO":
            k += 1
            a = ARR(f"ARR{k}", a.sensor, a.junction, a.expr, a.origin, a.equations, a.causality, a.states, a.exact)
        out.append(a)
    notes = list(search.notes)
    short = search.shortfall(picks)
    if search.stopped and short:
        notes.append(f"residual search stopped at its time budget ({budget:g} s); the residuals do not reach "
                     f"the best structural isolability")
    elif search.stopped:
        notes.append(f"the time budget ({budget:g} s) cut the search for residuals of lower derivative order")
    elif short:
        switched = (", or, with switches, pairs that only a mode other than the nominal one tells apart: residuals "
                    "are chosen in the nominal mode and completed only for faults no residual detects in any mode "
                    "(bgfdi isolability names the pairs)") if len(operating_modes(model)) > 1 else ""
        notes.append("the computable residuals do not reach the best structural isolability: a law given in one "
                     f"form only, or an algebraic loop sympy cannot solve{switched}")
    return ResidualSet(tuple(out), causality, diag.ok, problems, len(search.pool), len(search.described),
                       search.enumerated and search.enumeration_complete, search.mso_seconds, tuple(notes))


def fault_symbols(model: Model, names: Iterable[str]) -> dict[str, frozenset]:
    """The model's symbols each fault of ``names`` acts through (what :func:`expression_faults` looks for)."""
    return {f: frozenset(model.symbols[s] for s in model.faults[f].symbols if s in model.symbols) for f in names}


def shortfall_of(model: Model, arrs: list[ARR], causality: str = DERIVATIVE):
    """What ``arrs`` miss of the model's best structural isolability, each judged in every mode
    combination (:class:`fdi.isolability.Shortfall`; empty when nothing)."""
    diag = assign(model, DIAGNOSIS)
    search = _Search(model, lambda: structural_system(model, diag), causality, time.perf_counter() + BUDGET)
    search.mode = all_modes(model)
    return search.shortfall([_Pick(a, search.faults_of(a)) for a in arrs])


class _Search:
    """The state of one selection: the structure, the candidates described so far (``pool``:
    those with a plan), the ones realised with sympy, and the time budget."""

    def __init__(self, model: Model, system: Callable[[], EquationSystem], causality: str, deadline: float):
        self.model, self._system, self.causality, self.deadline = model, system, causality, deadline
        self.fault_names = [f for f, v in model.faults.items() if v.kind != "mode"]
        self.mode = nominal_mode(model)
        self.fault_symbols = fault_symbols(model, self.fault_names)
        self.described: dict[frozenset, Candidate | None] = {}
        self.pool: dict[frozenset, Candidate] = {}
        self.realised: dict[frozenset, _Pick] = {}
        self.failed: set[frozenset] = set()
        self.searched: set[tuple] = set()
        self.seen: set = set()           # the SCAPH AGARRs' expressions: an MSO set giving one is no candidate
        self.notes: list[str] = []
        self.mso_seconds = 0.0
        self.enumerated = False
        self.enumeration_complete = True
        self.stopped = False
        self.modes = [model.symbols[m] for m in model.modes]
        self.exact = storage_fault_parameters(model)

    # ---------------------------------------------------------------- structure
    # Built when first asked: a model without fault candidates has nothing to isolate, and its
    # SCAPH residuals are the selection (a 10 000-element chain's structure is 2 s of sympy).
    @functools.cached_property
    def system(self) -> EquationSystem:
        return self._system()

    @functools.cached_property
    def best(self) -> StructuralBest:
        return StructuralBest(self.model, self.system, self.causality, self.fault_names)

    @property
    def st(self) -> Structure:
        return self.best.structure

    @property
    def fe(self) -> Mapping[str, frozenset]:
        return self.best.fault_equations

    def operating(self, picks: list[_Pick]) -> list[_Pick]:
        """Residuals for the faults no chosen residual reacts to in any mode the plant runs in
        (:func:`operating_modes`), judged there: the choice above judges residuals in the nominal
        mode, where a switched-off branch's faults enter no residual (an EV's precharge resistor,
        its contactor open at rest: no residual held it, though the loop through it is one while
        the contactor is closed). Only the faults missed everywhere are asked for, so a model
        whose nominal mode sees every fault keeps its residuals."""
        modes = operating_modes(self.model)
        missed = self.shortfall(picks).undetected if len(modes) > 1 else ()
        if not missed:
            return picks
        self.mode = modes
        judged = [replace(p, faults=self.faults_of(p.arr)) for p in picks]
        left = self.shortfall(judged).undetected
        if not left:         # each detected in some mode the plant runs in: the residuals stay, and the final
            return judged    # shortfall is judged in those modes too (in the nominal mode alone, an ABS's
                             # outlet restriction, closed at rest, read as a shortfall `isolability` denied)
        self.realised = {k: replace(p, faults=self.faults_of(p.arr)) for k, p in self.realised.items()}
        picks = self.complete(judged, lambda chosen: Shortfall(self.shortfall(chosen).undetected, ()), targeted=True)
        found = [f for f in left if f not in self.shortfall(picks).undetected]
        if found:
            self.notes.append(f"no residual chosen in the nominal mode reacts to {', '.join(found)} in any mode: "
                              f"residuals added for {'it' if len(found) == 1 else 'them'}, judged in every "
                              f"combination of the switching modes")
        return picks          # (self.mode stays the list: the picks' faults and the final shortfall are judged there)

    def switches(self, picks: list[_Pick]) -> list[_Pick]:
        """A residual for each mode fault (a switch stuck) no chosen residual reacts to in any mode
        the plant runs in, where the structure has one: the MSO set through the equations of its
        mode variable of the lowest derivative order whose residual differs between the two modes.
        Residuals are chosen for the parameter and sensor faults; a trial's battery pack had none
        through its contactor's balance (no parameter fault there), and a contactor stuck open was
        "nothing detected" while the pack's current fell from 60 A to 0."""
        from .isolability import fault_equations
        faults = [f for f, v in self.model.faults.items() if v.kind == "mode"]
        missed = [f for f in faults if not any(sees_mode_fault(self.model, p.arr, f) for p in picks)]
        if not missed:
            return picks
        where = fault_equations(self.model, self.system, missed)
        whole = self.best.part(None)
        added = []
        for f in missed:
            if any(sees_mode_fault(self.model, p.arr, f) for p in picks):
                continue                  # the residual added for another fault of the same switch
            if not where[f] & whole:
                continue                  # no residual can: bgfdi isolability says so
            if not (self.enumerated and self.enumeration_complete):
                self.around(where[f] & whole, whole)
            present = {p.arr.expr for p in picks}
            for c in sorted((c for x, c in self.pool.items() if x & where[f] and x not in self.failed),
                            key=Candidate.quality):
                if time.perf_counter() > self.deadline:
                    self.stopped = True
                    break
                pick = self.realise(c)
                if pick is not None and pick.arr.expr not in present and sees_mode_fault(self.model, pick.arr, f):
                    picks = picks + [pick]
                    added.append(f)
                    break
        if added:
            self.notes.append(f"no residual chosen for the other faults reacts to the mode fault(s) "
                              f"{', '.join(added)}: a residual through the switch's equations added")
        return picks

    def faults_of(self, arr: ARR) -> frozenset[str]:
        return expression_faults(self.model, arr, self.mode, self.fault_symbols)

    def shortfall(self, picks: list[_Pick]) -> Shortfall:
        if not self.fault_names:                 # nothing to detect or tell apart
            return Shortfall((), ())
        return self.best.shortfall(_signatures(self.fault_names, picks))

    def candidate(self, eqs: frozenset) -> Candidate | None:
        if eqs not in self.described:
            self.described[eqs] = describe(self.system, eqs, self.causality, self.fe, self.st)
        return self.described[eqs]

    def candidates(self) -> None:
        """Every MSO set where the redundancy is small; otherwise nothing yet (see :meth:`near`)."""
        redundancy = redundancy_of(self.st)
        self.enumerated = redundancy <= ENUMERATE_REDUNDANCY
        if not self.enumerated:
            self.notes.append(f"MSO sets looked for near the faults the residuals leave apart (structural "
                              f"redundancy {redundancy}: listing every MSO set grows exponentially with it)")
            return
        found = mso_enumerate(self.st, deadline=self.deadline)
        self.mso_seconds += found.seconds
        self.enumeration_complete = found.complete
        for s in found.sets:
            if self.candidate(s) is not None:
                self.pool[s] = self.described[s]
        if not found.complete:
            self.notes.append(f"MSO search stopped after {len(found.sets)} sets")

    def targets(self, short: Shortfall) -> list[tuple[str, str | None]]:
        """(fault, other): a residual reacting to fault and not to other (None: any residual
        reacting to fault), for each miss the best can make good."""
        out: list[tuple[str, str | None]] = [(f, None) for f in short.undetected]
        for a, b in short.pairs:
            out += [(x, y) for x, y in ((a, b), (b, a)) if self.best.isolable(x, y)]
        return out

    def near(self, fault: str, other: str | None) -> None:
        """The MSO sets close to ``fault``'s equations, in the part of the model blind to ``other``."""
        within = self.best.part(other)
        self.around(self.fe[fault] & within, within)

    def around(self, equations: frozenset, within: frozenset) -> None:
        """The MSO sets of ``within`` close to the first SEEDS_PER_TARGET of ``equations``, into the pool."""
        for seed in sorted(equations)[:SEEDS_PER_TARGET]:
            found = msos_around(self.st, seed, within, self.causality, accept=lambda s: self.candidate(s) is not None,
                                limit=BALL_LIMIT, deadline=self.deadline)
            self.mso_seconds += found.seconds
            for s in found.sets:
                self.pool[s] = self.described[s]

    # ---------------------------------------------------------------- choice
    def realise(self, c: Candidate) -> _Pick | None:
        """The candidate's residual with sympy (cached), or None when it fails."""
        if c.equations in self.failed:
            return None
        if c.equations not in self.realised:
            pick = _realise(self.model, self.system, c, self.causality, self.exact, self.modes, self.mode,
                            self.fault_symbols, self.seen)
            if pick is None:
                self.failed.add(c.equations)
                return None
            self.realised[c.equations] = pick
        return self.realised[c.equations]

    def complete(self, picks: list[_Pick], deficit, targeted: bool = False, allowed=None,
                 most: int | None = None) -> list[_Pick]:
        """Add candidates to ``picks`` while ``deficit(picks)`` is not empty: each time the one
        adding most, ties to the best quality, equal ones realised and the smallest expression
        kept; ``targeted``: search near each miss where not every MSO set is listed; ``allowed``
        filters candidates, ``most`` caps how many are added."""
        picks = list(picks)
        added = 0
        while True:
            short = deficit(picks)
            if not short or (most is not None and added >= most):
                return picks
            if time.perf_counter() > self.deadline:
                self.stopped = True
                return picks
            searching = targeted and not (self.enumerated and self.enumeration_complete)
            if searching:
                todo = [x for x in self.targets(short) if x not in self.searched][:TARGETS_PER_ROUND]
                for target in todo:
                    self.searched.add(target)
                    self.near(*target)
            partners: dict[str, set] = {}
            for a, b in short.pairs:
                partners.setdefault(a, set()).add(b)
                partners.setdefault(b, set()).add(a)
            used = {p.candidate.equations for p in picks if p.candidate is not None}
            scored = []
            for s, c in self.pool.items():
                if s in used or s in self.failed or (allowed is not None and not allowed(c)):
                    continue
                faults = self.realised[s].faults if s in self.realised else c.faults
                g = _gain(faults, short, partners)
                if g > (0, 0):
                    scored.append((g, c))
            if not scored:
                if searching and any(x not in self.searched for x in self.targets(short)):
                    continue
                return picks
            low = min(c.order for _, c in scored)
            scored = [(g, c) for g, c in scored if c.order <= low + ORDER_WINDOW]
            top = max(g for g, _ in scored)
            group = [c for g, c in scored if g == top]
            first = min(c.quality()[:3] for c in group)
            tied = sorted((c for c in group if c.quality()[:3] == first), key=Candidate.quality)[:TIES_REALISED]
            fresh = [c for c in tied if c.equations not in self.realised]
            viable = [p for p in (self.realise(c) for c in tied) if p is not None]
            if any(p.faults != p.candidate.faults for p in viable if p.candidate in fresh):
                continue        # an expression reacts to other faults than its equations say: rank again
            present = {p.arr.expr for p in picks}
            for p in viable:
                if p.arr.expr in present:        # the same relation from another set
                    self.failed.add(p.candidate.equations)
            viable = [p for p in viable if p.candidate.equations not in self.failed]
            if not viable:
                continue
            picks.append(min(viable, key=lambda p: (sp.count_ops(p.arr.expr), p.candidate.quality())))
            added += 1

    def prune(self, picks: list[_Pick]) -> list[_Pick]:
        """Drop MSO residuals the others make redundant, the one of highest derivative order first."""
        reached = _signatures(self.fault_names, picks)
        order = sorted((p for p in picks if p.candidate is not None),
                       key=lambda p: (p.candidate.quality()[:3], picks.index(p)), reverse=True)
        for p in order:
            rest = [q for q in picks if q is not p]
            if rest and not _deficit(_signatures(self.fault_names, rest), reached):
                picks = rest
        return picks

    def lower(self, picks: list[_Pick]) -> list[_Pick]:
        """Replace an MSO residual by at most two of lower derivative order that, with the others,
        detect and tell apart the same faults (a third derivative gives way to an algebraic
        relation and a first derivative of the same isolability), highest order first, until no
        replacement is found."""
        reached = _signatures(self.fault_names, picks)
        changed = True
        while changed and time.perf_counter() <= self.deadline:
            changed = False
            for p in sorted((p for p in picks if p.candidate is not None),
                            key=lambda p: p.candidate.quality()[:3], reverse=True):
                rest = [q for q in picks if q is not p]
                order = p.candidate.order
                trial = self.complete(rest, lambda ps: _deficit(_signatures(self.fault_names, ps), reached),
                                      allowed=lambda c, order=order: c.order < order, most=2)
                if not _deficit(_signatures(self.fault_names, trial), reached):
                    picks = self.prune(trial)
                    changed = True
                    break
        return picks


def _realise(model: Model, system: EquationSystem, c: Candidate, causality: str, exact, modes, mode,
             fault_symbols, seen: set) -> _Pick | None:
    """The chosen candidate's residual with sympy, or None (no unique symbolic solution of a
    loop, an identically zero or already chosen expression)."""
    try:
        r = realize(system, c.equations, causality, exact)
    except ValueError:
        return None
    if r is None:
        return None
    expr = binary_modes(r.expr, modes)
    if expr == 0 or expr in seen:
        return None
    eqs = system.equations
    sensors = [eqs[i].name for i in sorted(c.equations) if eqs[i].name in model.sensors]
    arr = ARR("", ", ".join(sensors) or None, eqs[r.residual_equation].node, expr, "MSO",
              tuple(sorted(eqs[i].name for i in c.equations)), r.causality, tuple(r.states),
              None if r.exact is None else binary_modes(r.exact, modes))
    return _Pick(arr, expression_faults(model, arr, mode, fault_symbols), c)
