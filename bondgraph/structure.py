"""The model's equations as a bipartite structure: matchings, over-determined parts, MSO sets.

SCAPH derives one residual per sensor by following causal strokes; where it leaves a storage
element in integral causality or closes a derivative loop, the residuals are still there, but
only structural analysis finds them. This module writes the bond graph as *causality-free*
equations (Blanke et al., "Diagnosis and Fault-Tolerant Control", ch. 5; Krysander, Aslund &
Nyberg 2008) and offers the structural algorithms as plain functions over them:

- :func:`equations` - one :class:`Equation` per constitutive law, junction law, sensor and
  source; a storage element contributes its law ``e = phi(q)`` and the differential constraint
  ``f = dq/dt`` (the energy variable q or p is its own unknown, so a fault on C changes e at
  constant q, exactly as the simulator does);
- :func:`overdetermined` - the over-determined part M+ (Dulmage-Mendelsohn);
- :func:`causal_overdetermined` - M+ when differential constraints may only be differentiated
  (``derivative``) or only integrated (``integral``) (Frisk et al., IEEE TSMC-A 42(5), 2012);
- :func:`mso_sets` - the minimal structurally over-determined sets (Krysander, Aslund & Nyberg,
  IEEE TSMC-A 38(1), 2008, with lumping), each a candidate residual.

Variables are sympy symbols whose names (``e[3]``, ``f[3]``, ``q[tank1]``) are no identifiers,
so they never meet a user's names. Each equation lists the variables it can be solved for
explicitly (``solutions``): a friction law ``e = b f + c sign(f)`` gives e from f, never f from
e, and a controlled junction gives its outputs times its mode variable, never the reverse (the
diagnostic hybrid bond graph: one causality for controlled junctions, valid in every mode).

>>> from bondgraph.examples import source_resistor
>>> m = source_resistor()
>>> system = equations(m)
>>> len(system.equations), len(system.variables), redundancy(system)
(5, 4, 1)
>>> [sorted(system.equations[i].name for i in mso) for mso in mso_sets(system)]
[['i', 'j.balance', 'j.f2', 'res', 'src']]
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Iterable, Mapping

import sympy as sp

from .graph import ports, to_networkx
from .laws import (Equation, bond_variables, equation, junction_equations, model_laws, resistor_equation,
                   source_equation, storage_equations, substitution, two_port_equations)
from .measured import measured_storage, offset
from .model import SOURCE_KINDS, Model, t

MIXED = "mixed"
DERIVATIVE = "derivative"
INTEGRAL = "integral"
CAUSALITIES = (DERIVATIVE, MIXED, INTEGRAL)


@dataclass(frozen=True)
class EquationSystem:
    """All equations of one model (in one mode, if ``mode`` is given)."""
    model: str
    equations: tuple[Equation, ...]
    variables: tuple[sp.Symbol, ...]
    mode: Mapping[str, int] | None = None

    def incidence(self) -> list[frozenset]:
        return [e.variables for e in self.equations]


def equations(model: Model, *, sources: Mapping[str, sp.Expr] | None = None,
              sensors: Mapping[str, sp.Expr] | None = None, signals: Mapping[sp.Symbol, sp.Expr] | None = None,
              strong: Mapping[str, object] | None = None, mode: Mapping[str, int] | None = None) -> EquationSystem:
    """The model's equations, causality-free: the laws of :mod:`bondgraph.laws`, node by node,
    and one equation per sensor.

    ``sources`` gives each source element's output (default ``beta * input``), ``sensors`` the
    value each sensor measures (default the signal itself, ``y(t)``), ``signals`` replaces signal
    symbols in modulated moduli, ``strong`` the strong bond of each controlled junction (its
    DHBG causality; default its first bond), ``mode`` substitutes mode values (equations left
    without unknowns and identically zero are dropped)."""
    g = to_networkx(model)
    sources = sources or {}
    sensors = sensors or {}
    eqs: list[Equation] = []
    variables: list[sp.Symbol] = []
    for b in model.bonds:
        variables += list(bond_variables(b.id))
    modes = {model.symbols[k]: sp.Integer(v) for k, v in (mode or {}).items()}
    sub = substitution(signals, modes)
    shared = not signals and not modes      # the same laws as the causal forms: built once per model

    def law(key, build):
        return model_laws(model, key, lambda: build(sub)) if shared else build(sub)

    read = measured_storage(model)      # storage elements whose state is a sum of sensors' readings

    for node, kind in g.nodes(data="kind"):
        ps = [p for p in ports(g, node) if not isinstance(p[0], str)]
        if kind in ("0", "1", "0c", "1c"):
            eqs += junction_equations(model, node, ps, _reference_bond(g, model.junctions[node], strong), sub)
        elif kind in SOURCE_KINDS:
            el = model.elements[node]
            value = sources.get(node)
            if value is None:
                base = sp.Function(el.input, real=True)(t) if el.input else el.value
                value = model.symbols[f"beta_{el.input or el.name}"] * base
            eqs.append(source_equation(node, kind, ps[0][0], value, sub))
        elif kind == "R":
            eqs.append(law(("R", node), lambda s: resistor_equation(model, model.elements[node], ps[0][0], s)))
        elif kind in ("C", "I"):
            x, new_eqs = law(("storage", node), lambda s: storage_equations(model, model.elements[node], ps[0][0], s))
            variables.append(x)
            if node in read:
                # its state is a sum of readings (q = x - x(0) + q(0) for a spring on a measured mass,
                # q = x1 - x2 + ... between two): that relation in place of its rate, which the
                # junctions and the sensors' own rates already give. The residuals read its law at the
                # measured state: m x'' + b x' + k x = F, not its time derivative.
                xs = {name: reading(name) for name in read[node]}
                readings = sp.Add(*[a * xs[name] for name, a in read[node].items()])
                c = offset(model, node, read[node])
                new_eqs = [new_eqs[0], equation(f"{node}.state", node, x - readings - (sp.Float(c) if c else 0),
                                                 {x, *xs.values()}, linear=[x, *xs.values()])]
            eqs += new_eqs
        elif kind in ("TF", "MTF", "GY", "MGY"):
            eqs += law(("two-port", node), lambda s: two_port_equations(model.elements[node], ps, s))
    for s in model.sensors.values():
        j = model.junctions[s.junction]
        ref = _reference_bond(g, j, strong)
        e, f = bond_variables(ref)
        common = e if j.base == "0" else f
        value = sensors.get(s.name, sp.Function(s.name, real=True)(t))
        if s.measures in ("displacement", "momentum"):
            x = reading(s.name)
            variables.append(x)
            eqs.append(equation(s.name, s.name, x - value, {x}, linear=[x]))
            eqs.append(equation(f"{s.name}.d/dt", s.name, common - sp.Derivative(x, t), {x, common},
                                solutions={}, differential=(x, common)))
        else:
            eqs.append(equation(s.name, s.name, common - value, {common}, linear=[common]))
    if modes:
        eqs = [e for e in eqs if e.variables or e.expr != 0]
    used = set().union(*(e.variables for e in eqs)) if eqs else set()
    return EquationSystem(model.name, tuple(eqs), tuple(v for v in variables if v in used), dict(mode or {}) or None)


def reading(sensor: str) -> sp.Symbol:
    """The unknown of a displacement or momentum sensor's reading, the integral its junction's rate
    is the rate of (``x[theta1]``; a storage element measured by it reads it too)."""
    return sp.Symbol(f"x[{sensor}]", real=True)


def _reference_bond(g, junction, strong) -> int:
    """The bond a junction's law is written against: a controlled junction's strong bond (its
    DHBG causality, where given), otherwise its first bond."""
    ps = [p for p in ports(g, junction.name) if not isinstance(p[0], str)]
    if junction.controlled and strong and strong.get(junction.name) is not None \
            and not isinstance(strong[junction.name], str) and strong[junction.name] in {k for k, _, _ in ps}:
        return strong[junction.name]
    return ps[0][0]


# ------------------------------------------------------------------ structural algorithms

Incidence = list[frozenset]


def _name(v) -> str:
    """A variable's name: the order :func:`_match` tries variables in, the same in every process."""
    return v.name if isinstance(v, sp.Symbol) else str(v)


def _match(incidence: Incidence, eqs: Iterable[int], allowed=None) -> dict[int, object]:
    """A maximum matching equation -> variable (augmenting paths, iterative). ``allowed(e, v)``
    restricts which edges may be matched."""
    match_var: dict[object, int] = {}
    match_eq: dict[int, object] = {}
    eqs = list(eqs)
    for root in eqs:
        # iterative DFS for an augmenting path from root
        parent: dict[object, int] = {}
        stack = [root]
        seen_eq = {root}
        found = None
        while stack and found is None:
            e = stack.pop()
            for v in sorted(incidence[e], key=_name):      # a set's order follows the hash seed
                if allowed is not None and not allowed(e, v):
                    continue
                if v in parent:
                    continue
                parent[v] = e
                e2 = match_var.get(v)
                if e2 is None:
                    found = v
                    break
                if e2 not in seen_eq:
                    seen_eq.add(e2)
                    stack.append(e2)
        if found is None:
            continue
        v = found
        while True:
            e = parent[v]
            prev = match_eq.get(e)
            match_eq[e] = v
            match_var[v] = e
            if e == root:
                break
            v = prev
    return match_eq


def overdetermined(incidence: Incidence, eqs: Iterable[int] | None = None) -> frozenset[int]:
    """M+: the equations reachable from an unmatched equation by alternating paths."""
    eqs = list(range(len(incidence))) if eqs is None else list(eqs)
    m = _match(incidence, eqs)
    match_var = {v: e for e, v in m.items()}
    return frozenset(_reach([e for e in eqs if e not in m], lambda e: incidence[e], match_var))


def _reach(start: list, neighbours, matched: Mapping) -> set:
    """Nodes reachable by alternating paths: from a node to any neighbour, then along the
    neighbour's matching edge (Dulmage-Mendelsohn: M+ from free equations, M- from free variables)."""
    seen = set(start)
    stack = list(start)
    while stack:
        for n in neighbours(stack.pop()):
            other = matched.get(n)
            if other is not None and other not in seen:
                seen.add(other)
                stack.append(other)
    return seen


def redundancy(system_or_incidence, eqs: Iterable[int] | None = None) -> int:
    """Structural redundancy of the over-determined part: |M+| - |var(M+)|."""
    inc = system_or_incidence.incidence() if isinstance(system_or_incidence, EquationSystem) else system_or_incidence
    plus = overdetermined(inc, eqs)
    return len(plus) - len(set().union(*(inc[e] for e in plus))) if plus else 0


def _underdetermined_vars(incidence: Incidence, eqs: list[int]) -> set:
    """Variables of the under-determined part M-: reachable from unmatched variables."""
    m = _match(incidence, eqs)
    matched = set(m.values())
    var_eqs: dict[object, list[int]] = {}
    for e in eqs:
        for v in incidence[e]:
            var_eqs.setdefault(v, []).append(e)
    return _reach([v for v in var_eqs if v not in matched], lambda v: var_eqs[v], m)


def causal_overdetermined(system: EquationSystem, eqs: Iterable[int] | None = None,
                          causality: str = MIXED) -> frozenset[int]:
    """M+ under a causal interpretation of the differential constraints (Frisk et al. 2012):
    ``mixed`` (no restriction), ``derivative`` (a constraint dx = d/dt x may only give dx from
    x) or ``integral`` (only x from dx)."""
    inc = system.incidence()
    eqs = sorted(range(len(inc)) if eqs is None else eqs)
    if causality == MIXED:
        return overdetermined(inc, eqs)
    diff = {i: system.equations[i].differential for i in eqs if system.equations[i].differential}
    if causality == DERIVATIVE:
        known: set = set()
        while True:
            active = [i for i in eqs if not (i in diff and diff[i][0] not in known)]
            sub_inc = {i: inc[i] - known for i in active}
            full = [frozenset()] * len(inc)
            for i in active:
                full[i] = sub_inc[i]
            allvars = set().union(*(sub_inc[i] for i in active)) if active else set()
            new = allvars - _underdetermined_vars(full, active)
            if not new:
                break
            known |= new
        keep = [i for i in eqs if inc[i] <= known]
        return overdetermined(inc, keep)
    if causality == INTEGRAL:
        current = list(eqs)
        while True:
            current = sorted(overdetermined(inc, current))
            no_der = list(inc)
            for i in current:
                if i in diff:
                    no_der[i] = inc[i] - {diff[i][1]}
            under = _underdetermined_vars(no_der, current)
            if not under:
                return frozenset(current)
            current = [i for i in current if not (inc[i] & under)]
    raise ValueError(f"causality must be one of {', '.join(CAUSALITIES)}")


@dataclass
class MSOSearch:
    """The result of :func:`mso_sets`: the sets, whether a limit cut the search, and its time."""
    sets: list[frozenset]
    complete: bool
    seconds: float


def mso_sets(system: EquationSystem, eqs: Iterable[int] | None = None, *, limit: int = 5000,
             time_limit: float = 30.0) -> list[frozenset]:
    """The MSO sets of the model (or of ``eqs``), sorted by size then by equation indices."""
    return mso_search(system, eqs, limit=limit, time_limit=time_limit).sets


def mso_search(system: EquationSystem, eqs: Iterable[int] | None = None, *, limit: int = 5000,
               time_limit: float = 30.0) -> MSOSearch:
    """Krysander, Aslund & Nyberg's algorithm with lumping: remove one equivalence class of
    equations at a time from a proper over-determined set, keep the over-determined part; a set of
    redundancy one is an MSO. Stops after ``limit`` sets or ``time_limit`` seconds (reported).
    Runs on the numbered structure (:func:`mso_enumerate`)."""
    return mso_enumerate(structure_of(system), eqs, limit=limit, deadline=time.perf_counter() + time_limit)


# ------------------------------------------------------------------ integer structure (large models)
#
# The algorithms above hash sympy symbols at every step; the ones below work on the same structure
# with equations and variables as integers and a matching that discards the alternating tree of a
# failed search for good (Hungarian-tree pruning: no later augmenting path can pass through it), so a
# model of a thousand equations takes milliseconds per over-determined part. They give the same sets
# as :func:`overdetermined` and :func:`causal_overdetermined` (tests/test_selection.py compares them on
# every shipped model).

@dataclass(frozen=True)
class Structure:
    """The incidence of an :class:`EquationSystem` with variables numbered: ``rows[e]`` the
    variables of equation e, ``cols[v]`` the equations of variable v, ``differential[e]`` the
    (x, dx) pair of a differential constraint dx = d/dt x."""
    rows: tuple[frozenset, ...]
    cols: tuple[tuple[int, ...], ...]
    differential: Mapping[int, tuple[int, int]]
    variables: tuple[sp.Symbol, ...]
    solvable: tuple[frozenset, ...] = ()     # the variables each equation gives explicitly (``solutions``)


def structure_of(system: EquationSystem) -> Structure:
    """Number the variables of ``system`` (in the order of first appearance)."""
    index: dict = {}
    rows = []
    for eq in system.equations:
        for v in sorted(eq.variables, key=str):
            index.setdefault(v, len(index))
        rows.append(frozenset(index[v] for v in eq.variables))
    cols: list[list[int]] = [[] for _ in index]
    for e, row in enumerate(rows):
        for v in row:
            cols[v].append(e)
    diff = {e: (index[eq.differential[0]], index[eq.differential[1]])
            for e, eq in enumerate(system.equations) if eq.differential}
    solvable = tuple(frozenset(index[v] for v in eq.solutions if v in index) for eq in system.equations)
    return Structure(tuple(rows), tuple(tuple(c) for c in cols), diff, tuple(index), solvable)


def max_matching(st: Structure, eqs: Iterable[int], hidden: frozenset | set = frozenset()) -> dict[int, int]:
    """A maximum matching equation -> variable of ``eqs``, variables in ``hidden`` left out
    (known ones). Greedy start, then one augmenting-path search per free equation."""
    eqs = list(eqs)
    match_eq: dict[int, int] = {}
    match_var: dict[int, int] = {}
    for e in eqs:
        for v in st.rows[e]:
            if v not in match_var and v not in hidden:
                match_eq[e], match_var[v] = v, e
                break
    dead: set = set(hidden)
    for root in eqs:
        if root in match_eq:
            continue
        parent: dict[int, int] = {}
        stack = [root]
        found = None
        while stack and found is None:
            e = stack.pop()
            for v in st.rows[e]:
                if v in dead or v in parent:
                    continue
                parent[v] = e
                e2 = match_var.get(v)
                if e2 is None:
                    found = v
                    break
                stack.append(e2)
        if found is None:
            dead.update(parent)                 # the failed search's tree: never on an augmenting path
            continue
        v = found
        while v is not None:
            e = parent[v]
            prev = match_eq.get(e)
            match_eq[e], match_var[v] = v, e
            v = prev
    return match_eq


def plus(st: Structure, eqs: Iterable[int], hidden: frozenset | set = frozenset()) -> frozenset[int]:
    """M+ of ``eqs`` (variables in ``hidden`` known): the equations reachable from an unmatched
    equation by alternating paths. As :func:`overdetermined`."""
    eqs = list(eqs)
    m = max_matching(st, eqs, hidden)
    match_var = {v: e for e, v in m.items()}
    seen = {e for e in eqs if e not in m}
    stack = list(seen)
    while stack:
        for v in st.rows[stack.pop()]:
            e2 = match_var.get(v)
            if e2 is not None and e2 not in seen:
                seen.add(e2)
                stack.append(e2)
    return frozenset(seen)


def minus_variables(st: Structure, eqs: Iterable[int], hidden: frozenset | set = frozenset(),
                    drop: Mapping[int, int] | None = None) -> set[int]:
    """The variables of the under-determined part M- of ``eqs`` (those reachable from a variable
    some maximum matching leaves free). ``hidden`` variables are known; ``drop[e]`` is a variable
    equation e does not contain here (a derivative the integral interpretation may not use)."""
    eqs = list(eqs)
    hide = set(hidden)
    if drop:
        rows = {e: st.rows[e] - {drop[e]} if e in drop else st.rows[e] for e in eqs}
        view = Structure(tuple(rows.get(e, frozenset()) for e in range(len(st.rows))), (), {}, ())
    else:
        view = st
    m = max_matching(view, eqs, hide)
    var_eqs: dict[int, list[int]] = {}
    for e in eqs:
        for v in view.rows[e]:
            if v not in hide:
                var_eqs.setdefault(v, []).append(e)
    matched = set(m.values())
    seen = {v for v in var_eqs if v not in matched}
    stack = list(seen)
    while stack:
        for e in var_eqs[stack.pop()]:
            v2 = m.get(e)
            if v2 is not None and v2 not in seen:
                seen.add(v2)
                stack.append(v2)
    return seen


def causal_plus(st: Structure, eqs: Iterable[int] | None = None, causality: str = MIXED) -> frozenset[int]:
    """M+ under a causal interpretation of the differential constraints, as
    :func:`causal_overdetermined` (Frisk et al. 2012), on the numbered structure."""
    eqs = sorted(range(len(st.rows)) if eqs is None else eqs)
    if causality == MIXED:
        return plus(st, eqs)
    diff = {e: st.differential[e] for e in eqs if e in st.differential}
    if causality == DERIVATIVE:
        known: set = set()
        while True:
            active = [e for e in eqs if not (e in diff and diff[e][0] not in known)]
            present = set().union(*(st.rows[e] for e in active)) - known if active else set()
            new = present - minus_variables(st, active, known)
            if not new:
                break
            known |= new
        return plus(st, [e for e in eqs if st.rows[e] <= known])
    if causality == INTEGRAL:
        current = list(eqs)
        while True:
            current = sorted(plus(st, current))
            under = minus_variables(st, current, drop={e: diff[e][1] for e in current if e in diff})
            if not under:
                return frozenset(current)
            current = [e for e in current if not (st.rows[e] & under)]
    raise ValueError(f"causality must be one of {', '.join(CAUSALITIES)}")


def redundancy_of(st: Structure, eqs: Iterable[int] | None = None) -> int:
    """Structural redundancy |M+| - |var(M+)| of ``eqs`` (all equations by default), as
    :func:`redundancy`: the MSO sets are polynomially many in the equations for a bounded
    redundancy, exponentially many as it grows (a chain of n measured tanks has redundancy n)."""
    p = plus(st, range(len(st.rows)) if eqs is None else eqs)
    return len(p) - len(set().union(*(st.rows[e] for e in p))) if p else 0


def mso_enumerate(st: Structure, eqs: Iterable[int] | None = None, *, keep: int | None = None,
                  limit: int = 5000, deadline: float | None = None) -> MSOSearch:
    """The MSO sets of ``eqs`` (of the whole structure by default), by the algorithm of
    :func:`mso_search` (Krysander, Aslund & Nyberg, with lumping) on the numbered structure; with
    ``keep``, only those that contain equation ``keep`` (its class is never removed, and a branch
    whose over-determined part loses it is cut). Stops after ``limit`` sets or at ``deadline``
    (a ``time.perf_counter()`` value), and says so."""
    start = time.perf_counter()
    found: set[frozenset] = set()
    state = {"complete": True}

    def variables(s: frozenset) -> set:
        return set().union(*(st.rows[e] for e in s)) if s else set()

    def lump(S: list[frozenset], R: set[frozenset]) -> tuple[list[frozenset], set[frozenset]]:
        union = frozenset().union(*S)
        out, out_r, done = [], set(), set()
        for E in S:
            if E in done:
                continue
            rest = plus(st, union - E)
            group = [E] + [F for F in S if F is not E and F not in done and F.isdisjoint(rest)]
            done.update(group)
            merged = frozenset().union(*group)
            out.append(merged)
            if all(F in R for F in group):
                out_r.add(merged)
        return out, out_r

    def sub(S: list[frozenset], R: set[frozenset]) -> None:
        if len(found) >= limit or (deadline is not None and time.perf_counter() > deadline):
            state["complete"] = False
            return
        S, R = lump(S, R)
        union = frozenset().union(*S)
        if len(union) - len(variables(union)) == 1:
            found.add(union)
            return
        todo = [E for E in S if E in R]
        while todo:
            E = todo.pop()
            R = R - {E}
            rest = plus(st, union - E)
            if keep is not None and keep not in rest:
                continue
            S2 = [F for F in S if F is not E and F <= rest]
            if not S2:
                continue
            sub(S2, {F for F in R if F in S2})

    base = plus(st, range(len(st.rows)) if eqs is None else eqs)
    if base and len(base) - len(variables(base)) >= 1 and (keep is None or keep in base):
        singles = [frozenset([e]) for e in sorted(base)]
        sub(singles, {E for E in singles if keep not in E})
    sets = sorted(found, key=lambda s: (len(s), sorted(s)))
    return MSOSearch(sets, state["complete"], time.perf_counter() - start)


def msos_around(st: Structure, seed: int, within: Iterable[int], causality: str = DERIVATIVE, *,
                accept=None, further: int = 1, limit: int = 200, deadline: float | None = None) -> MSOSearch:
    """MSO sets of ``within`` that contain equation ``seed``, looked for close to it: the
    equations sharing a variable with it, then with those, layer by layer, until the
    over-determined part of the layers (in ``causality``) holds ``seed`` and some of its MSO sets
    pass ``accept`` (a residual computable in that causality, say); then ``further`` more layers
    for alternatives. A residual that tells two faults of a long chain apart lives near them: this
    costs a few small searches where listing every MSO set of the chain would never end."""
    start = time.perf_counter()
    within = set(within)
    if seed not in within:
        return MSOSearch([], True, 0.0)
    ball = {seed}
    frontier_vars = set(st.rows[seed])
    seen_vars: set = set()
    found: dict[frozenset, None] = {}
    complete, extra = True, None
    while True:
        if deadline is not None and time.perf_counter() > deadline:
            complete = False
            break
        seen_vars |= frontier_vars
        grown = {e for v in frontier_vars for e in st.cols[v] if e in within} - ball
        if not grown:
            break
        ball |= grown
        frontier_vars = set().union(*(st.rows[e] for e in grown)) - seen_vars
        part = causal_plus(st, ball, causality)
        if seed not in part:
            continue
        search = mso_enumerate(st, part, keep=seed, limit=limit, deadline=deadline)
        complete = complete and search.complete
        for s in search.sets:
            if accept is None or accept(s):
                found.setdefault(s, None)
        if found:
            extra = further if extra is None else extra - 1
            if extra <= 0:
                break
        if not search.complete:
            break
    sets = sorted(found, key=lambda s: (len(s), sorted(s)))
    return MSOSearch(sets, complete, time.perf_counter() - start)


def _allowed(st: Structure) -> Structure:
    """The edges a derivative-causality plan may match: an equation's explicit solutions, a
    differential constraint's derivative."""
    return Structure(tuple(frozenset([st.differential[e][1]]) if e in st.differential else st.solvable[e]
                           for e in range(len(st.rows))), (), {}, ())


def residual_choices(st: Structure, mso: Iterable[int]) -> frozenset[int]:
    """The equations of ``mso`` whose rest can be matched in derivative causality (each
    equation to a variable it gives explicitly): those some maximum such matching leaves free.
    Only these can be the residual equation of a derivative plan; empty when none can."""
    mso = sorted(mso)
    variables = set().union(*(st.rows[e] for e in mso)) if mso else set()
    allowed = _allowed(st)
    if len(max_matching(allowed, mso)) < len(variables):
        return frozenset()
    return plus(allowed, mso)


def derivative_plan(st: Structure, eqs: Iterable[int]) -> tuple[dict[int, int], list[list[int]]] | None:
    """The computation order of the just-determined set ``eqs`` in derivative causality, as
    :func:`bondgraph.sequential.plan` decides it, on the numbered structure: a matching that
    solves each equation for a variable it gives explicitly (a differential constraint only for
    its derivative), and the blocks (strongly connected, in computation order); None when no such
    matching exists or a block of several equations holds a differential constraint. In this
    causality the verdict does not depend on the matching found: the blocks of a square structure
    are the same for every complete matching."""
    eqs = sorted(eqs)
    variables = set().union(*(st.rows[e] for e in eqs)) if eqs else set()
    if len(variables) != len(eqs):
        return None
    m = max_matching(_allowed(st), eqs)
    if len(m) != len(eqs):
        return None
    blocks = _strong_blocks(st, eqs, m)
    if any(len(b) > 1 and any(e in st.differential for e in b) for b in blocks):
        return None
    return m, blocks


def _strong_blocks(st: Structure, eqs: list[int], m: Mapping[int, int]) -> list[list[int]]:
    """Strongly connected blocks of ``eqs`` under the matching ``m`` (an equation depends on the
    equations computing its other variables), in computation order (Tarjan, iterative)."""
    owner = {m[e]: e for e in eqs}
    succ = {e: [owner[v] for v in st.rows[e] if v in owner and owner[v] != e] for e in eqs}  # e needs these
    index: dict[int, int] = {}
    low: dict[int, int] = {}
    on_stack: set = set()
    stack: list[int] = []
    out: list[list[int]] = []
    counter = 0
    for root in eqs:
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            node, i = work.pop()
            if i == 0:
                index[node] = low[node] = counter
                counter += 1
                stack.append(node)
                on_stack.add(node)
            nxt = succ[node]
            if i < len(nxt):
                work.append((node, i + 1))
                w = nxt[i]
                if w not in index:
                    work.append((w, 0))
                elif w in on_stack:
                    low[node] = min(low[node], index[w])
                continue
            if low[node] == index[node]:
                block = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    block.append(w)
                    if w == node:
                        break
                out.append(sorted(block))
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
    return out            # Tarjan emits a block after every block it needs: computation order
