"""Structural detectability and isolability, of a model and of a set of residuals; sensor placement.

A fault acts on the equations that carry its symbols (a parameter's constitutive law, a
sensor's measurement equation, a source's equation, a controlled junction's equations). Fault
f_i is *isolable* from f_j when some residual reacts to f_i and not to f_j. For the model (the
best any residual set can do), this is decided without enumerating residuals, as the Fault
Diagnosis Toolbox does: f_i is isolable from f_j when f_i's equations lie in the over-determined
part of the model with f_j's equations removed, that part taken under the causal interpretation
of the differential constraints (Frisk, Bregon, Aslund, Krysander, Pulido & Biswas, IEEE TSMC-A
42(5), 2012). For a residual set it is read off the fault signature matrix.

Sensor placement (Krysander & Frisk, IEEE TSMC-A 38(6), 2008) is answered by search: the
smallest sets of added fault-free sensors, De on a 0-junction, Df on a 1-junction, or the effort
or flow of a bond to a one-port element, that make every fault detectable and isolable (or, where
no set can, as isolable as all candidates together make it).

From signatures (the CyCab's R4, R5, beta_theta2 columns of Table I): beta_theta2 is isolable
from R4 (it lights ARR3, R4 does not), not the other way round; one direction tells them apart.
Two faults with one signature are a class no residual splits.

>>> iso = signature_isolability(["R4", "R5", "beta_theta2"], {"R4": (0, 1, 0), "R5": (0, 0, 1), "beta_theta2": (0, 1, 1)})
>>> iso.isolable[2][0], iso.isolable[0][2], iso.full()
(True, False, True)
>>> signature_isolability(["a", "b"], {"a": (1, 0), "b": (1, 0)}).classes()
[('a', 'b')]

For a model, by structure: the three tanks (Frisk et al. 2012) with a pressure sensor on the
first tank and a flow sensor through the second valve cannot tell valve 1 from tank 1, nor
valve 2, the outlet valve and tank 3 apart, whatever residuals are built.

>>> from bondgraph.loader import load_model
>>> from fdi.scaph import structural_system
>>> m = load_model("models/three_tank.yaml")
>>> structural_isolability(m, structural_system(m)).classes()
[('fV1', 'fT1'), ('fV2', 'fV3', 'fT3'), ('fT2',)]
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Mapping, Sequence

import networkx as nx
import sympy as sp

from bondgraph.model import Model, t
from bondgraph.structure import DERIVATIVE, Equation, EquationSystem, bond_variables, causal_plus, structure_of


@dataclass(frozen=True)
class Isolability:
    """``isolable[i][j]``: fault i can be told apart from fault j (i reacts where j does not)."""
    faults: tuple[str, ...]
    detectable: tuple[bool, ...]
    isolable: tuple[tuple[bool, ...], ...]

    def classes(self) -> list[tuple[str, ...]]:
        """Groups of faults no residual tells apart in either direction (detectable faults only)."""
        g = nx.Graph()
        det = [f for f, d in zip(self.faults, self.detectable) if d]
        g.add_nodes_from(det)
        idx = {f: i for i, f in enumerate(self.faults)}
        for a, b in combinations(det, 2):
            if not self.isolable[idx[a]][idx[b]] and not self.isolable[idx[b]][idx[a]]:
                g.add_edge(a, b)
        out = [tuple(sorted(c, key=idx.get)) for c in nx.connected_components(g)]
        return sorted(out, key=lambda c: idx[c[0]])

    def undetectable(self) -> list[str]:
        return [f for f, d in zip(self.faults, self.detectable) if not d]

    def distinguishes(self, i: int, j: int) -> bool:
        """Faults i and j are told apart (in at least one direction: their signatures differ)."""
        return self.isolable[i][j] or self.isolable[j][i]

    def pairs(self) -> int:
        """How many pairs of faults are told apart (a measure to compare residual sets)."""
        n = len(self.faults)
        return sum(self.distinguishes(i, j) for i in range(n) for j in range(i + 1, n))

    def full(self) -> bool:
        return all(self.detectable) and all(len(c) == 1 for c in self.classes())

    def restricted(self, names: Sequence[str]) -> "Isolability":
        """The same analysis over the faults ``names`` only (in their order): to compare it with
        one made over fewer faults (the structural best holds no mode fault)."""
        idx = [self.faults.index(f) for f in names]
        return Isolability(tuple(names), tuple(self.detectable[i] for i in idx),
                           tuple(tuple(self.isolable[i][j] for j in idx) for i in idx))

    def covers(self, other: "Isolability") -> bool:
        """Detects every fault ``other`` detects and tells apart every pair ``other`` tells apart
        (the isolability classes; a one-way isolation counts, as a differing signature does)."""
        n = len(self.faults)
        return all(a or not b for a, b in zip(self.detectable, other.detectable)) and all(
            self.distinguishes(i, j) or not other.distinguishes(i, j) for i in range(n) for j in range(i + 1, n))


def fault_equations(model: Model, system: EquationSystem, faults: Sequence[str] | None = None) -> dict[str, frozenset]:
    """The equations each candidate fault acts on (by its symbols)."""
    names = list(faults or model.faults)
    by_symbol: dict[sp.Symbol, list[str]] = {}
    for name in names:
        for s in model.faults[name].symbols:
            if s in model.symbols:
                by_symbol.setdefault(model.symbols[s], []).append(name)
    out: dict[str, set] = {name: set() for name in names}
    for i, e in enumerate(system.equations):
        for s in e.expr.free_symbols:
            for name in by_symbol.get(s, ()):
                out[name].add(i)
    return {name: frozenset(v) for name, v in out.items()}


class StructuralBest:
    """The best detectability and isolability, asked fault by fault and pair by pair (see the
    module doc). Each over-determined part (the model without fault j's equations) is computed
    once, when first needed, on the numbered structure. Residual selection asks only about the
    pairs its residuals do not yet tell apart: a chain of hundreds of faults costs a few parts."""

    def __init__(self, model: Model, system: EquationSystem, causality: str = DERIVATIVE,
                 faults: Sequence[str] | None = None):
        self.system = system
        self.causality = causality
        self.structure = structure_of(system)
        self.fault_equations = fault_equations(model, system, faults)
        self.faults = tuple(self.fault_equations)
        self._parts: dict[str | None, frozenset] = {}

    def part(self, without: str | None = None) -> frozenset[int]:
        """The over-determined part (in this causality) of the model without ``without``'s
        equations (None: the whole model): where a residual blind to that fault can come from."""
        if without not in self._parts:
            drop = self.fault_equations[without] if without is not None else frozenset()
            keep = [i for i in range(len(self.system.equations)) if i not in drop]
            self._parts[without] = causal_plus(self.structure, keep, self.causality)
        return self._parts[without]

    def detectable(self, fault: str) -> bool:
        return bool(self.fault_equations[fault] & self.part(None))

    def isolable(self, fault: str, other: str) -> bool:
        """Some residual reacts to ``fault`` and not to ``other``."""
        return fault != other and bool(self.fault_equations[fault] & self.part(other))

    def isolability(self) -> Isolability:
        names = self.faults
        return Isolability(names, tuple(self.detectable(f) for f in names),
                           tuple(tuple(self.isolable(fi, fj) for fj in names) for fi in names))

    def shortfall(self, signatures: Mapping[str, frozenset]) -> "Shortfall":
        """What the best reaches and a residual set does not; ``signatures[f]`` is the set of
        residuals reacting to fault f (two faults are told apart when their sets differ)."""
        undetected = tuple(f for f in self.faults if not signatures[f] and self.detectable(f))
        groups: dict[frozenset, list[str]] = {}
        for f in self.faults:
            groups.setdefault(frozenset(signatures[f]), []).append(f)
        pairs = []
        for members in groups.values():
            for x, fa in enumerate(members):
                for fb in members[x + 1:]:
                    if self.isolable(fa, fb) or self.isolable(fb, fa):
                        pairs.append((fa, fb))
        order = {f: i for i, f in enumerate(self.faults)}
        return Shortfall(undetected, tuple(sorted(pairs, key=lambda p: (order[p[0]], order[p[1]]))))


@dataclass(frozen=True)
class Shortfall:
    """Faults the best residual set detects and a given one does not, and pairs the best tells
    apart (in at least one direction) and the given one does not."""
    undetected: tuple[str, ...]
    pairs: tuple[tuple[str, str], ...]

    def __bool__(self) -> bool:
        return bool(self.undetected or self.pairs)


def structural_isolability(model: Model, system: EquationSystem, causality: str = DERIVATIVE,
                           faults: Sequence[str] | None = None) -> Isolability:
    """The best detectability and isolability any residual set can reach (see the module doc)."""
    return StructuralBest(model, system, causality, faults).isolability()


def signature_isolability(faults: Sequence[str], signatures: Mapping[str, Sequence[int]]) -> Isolability:
    """Detectability and isolability of a residual set from its fault signatures."""
    names = tuple(faults)
    sig = [tuple(signatures[f]) for f in names]
    detectable = tuple(any(s) for s in sig)
    rows = tuple(tuple(i != j and any(a and not b for a, b in zip(sig[i], sig[j])) for j in range(len(names)))
                 for i in range(len(names)))
    return Isolability(names, detectable, rows)


@dataclass(frozen=True)
class CandidateSensor:
    """A sensor that could be added: its kind, where, and the bond variable it measures."""
    kind: str            # De | Df
    junction: str
    bond: int | None     # None: the junction's common variable
    label: str

    def equation(self, model: Model) -> Equation:
        var = self.variable(model)
        y = sp.Function(f"new_{self.label}", real=True)(t)
        return Equation(f"+{self.label}", self.label, var - y, frozenset([var]), {var: y})

    def variable(self, model: Model) -> sp.Symbol:
        bond = self.bond if self.bond is not None else next(
            b.id for b in model.bonds if self.junction in (b.source, b.target))
        e, f = bond_variables(bond)
        return e if self.kind == "De" else f


def candidate_sensors(model: Model) -> list[CandidateSensor]:
    """De on every 0-junction, Df on every 1-junction, and on each bond joining a junction to a
    one-port element the variable the junction does not share (flow next to a 0, effort next to a 1)."""
    out = []
    for j in model.junctions.values():
        kind = "De" if j.base == "0" else "Df"
        out.append(CandidateSensor(kind, j.name, None, f"{kind} on {j.name}"))
    for b in model.bonds:
        for jn, other in ((b.source, b.target), (b.target, b.source)):
            if jn in model.junctions and other in model.elements and model.elements[other].kind in ("R", "C", "I"):
                kind = "Df" if model.junctions[jn].base == "0" else "De"
                out.append(CandidateSensor(kind, jn, b.id, f"{kind} on bond {b.id} ({b.source} -> {b.target})"))
    return out


def with_sensors(system: EquationSystem, model: Model, sensors: Sequence[CandidateSensor]) -> EquationSystem:
    return EquationSystem(system.model, system.equations + tuple(s.equation(model) for s in sensors),
                          system.variables, system.mode)


@dataclass(frozen=True)
class Placement:
    """Smallest sensor sets reaching ``target`` (full isolability where any set can reach it)."""
    sets: tuple[tuple[CandidateSensor, ...], ...]
    target: Isolability
    full: bool


def sensor_placement(model: Model, system: EquationSystem, causality: str = DERIVATIVE,
                     max_size: int = 3, limit: int = 20000) -> Placement:
    """All smallest sets of added sensors that make every fault detectable and isolable (in
    ``causality``), or as isolable as adding every candidate would make it."""
    cands = candidate_sensors(model)
    existing = {(s.junction, s.kind) for s in model.sensors.values()}
    cands = [c for c in cands if c.bond is not None or (c.junction, c.kind) not in existing]
    target = structural_isolability(model, with_sensors(system, model, cands), causality)
    now = structural_isolability(model, system, causality)
    if now.covers(target):
        return Placement(((),), target, target.full())
    tried = 0
    for k in range(1, max_size + 1):
        found = []
        for combo in combinations(cands, k):
            tried += 1
            if tried > limit:
                return Placement(tuple(found), target, target.full())
            iso = structural_isolability(model, with_sensors(system, model, combo), causality)
            if iso.covers(target):
                found.append(combo)
        if found:
            return Placement(tuple(found), target, target.full())
    return Placement((), target, target.full())
