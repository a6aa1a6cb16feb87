"""Causality assignment: SCAPH for diagnosis, SCAP (integral causality) for simulation.

A bond's causality is recorded as the node that *receives* its effort (the end that carries the
causal stroke). The procedure is the sequential one of Karnopp et al., extended for the
diagnostic hybrid bond graph (Low, Wang et al.; Yu & Wang 2014, Sec. II-B):

1. sources, and sensors (inverted in diagnosis: De imposes effort, Df imposes flow), propagated
   through junctions, TF and GY;
2. storage elements in their preferred causality (derivative for diagnosis, integral for
   simulation), each propagated before the next;
3. resistors whose law is given in one form only, then the others (an arbitrary choice, which
   may close an algebraic loop: these are detected and reported);
4. bonds still open between junctions (loops of the junction structure).

Controlled junctions are ordinary junctions here: the DHBG multiplies each of their *output*
variables by the mode variable, so one assignment serves every mode and no causality is
reassigned at a switch. Where a controlled junction is still free after step 2, its strong bond
is taken on the side whose causality is already fixed (preferred causality). Conflicts (two
sources of effort on a 0-junction, a storage element forced out of its preferred causality,
algebraic loops) are collected, never guessed away.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product
from typing import Mapping

from typing import TYPE_CHECKING

if TYPE_CHECKING:                       # networkx is imported where a graph is built (bgfdi's warm start needs none)
    import networkx as nx

from .errors import CausalityError
from .graph import BondKey, port_table, to_networkx
from .laws import STORAGE_KEYS, bond_variables, has_inverse, model_laws, resistor_equation
from .measured import measured_storage
from .model import SOURCE_KINDS, Model

DIAGNOSIS = "diagnosis"
SIMULATION = "simulation"


@dataclass(frozen=True)
class Causality:
    """One causal assignment of a model."""
    purpose: str
    effort_to: Mapping[BondKey, str]
    storage: Mapping[str, str]                  # element -> 'integral' | 'derivative'
    resistors: Mapping[str, str]                # element -> 'resistance' (e=law(f)) | 'conductance'
    strong: Mapping[str, BondKey]               # junction -> its strong bond
    problems: tuple[str, ...] = ()
    loops: tuple[str, ...] = ()
    modes_checked: tuple[Mapping[str, int], ...] = field(default_factory=tuple)
    detectors: frozenset[str] = frozenset()     # sensors left as detectors (a junction's 2nd, 3rd... sensor)

    @property
    def ok(self) -> bool:
        return not self.problems and not self.loops

    def receives_effort(self, bond: BondKey, node: str) -> bool:
        return self.effort_to[bond] == node


class _Assigner:
    def __init__(self, model: Model, purpose: str) -> None:
        self.model = model
        self.purpose = purpose
        self.g = to_networkx(model)
        self.ports = port_table(self.g)
        self.effort_to: dict[BondKey, str] = {}
        self.fixed: dict[str, str] = {}   # one-port node -> 'gives' | 'receives' (effort)
        self.problems: list[str] = []
        self.kind = dict(self.g.nodes(data="kind"))
        self._bond_ends = {k: (u, v) for u, v, k in self.g.edges(keys=True)}

    # -- helpers
    def _bond_of(self, node: str) -> tuple[BondKey, str]:
        key, other, _ = self.ports[node][0]
        return key, other

    def _describe(self, bond: BondKey) -> str:
        return f"bond {bond}" if isinstance(bond, int) else f"sensor bond {bond}"

    def set(self, bond: BondKey, receiver: str, why: str) -> None:
        current = self.effort_to.get(bond)
        if current is not None:
            if current != receiver:
                self.problems.append(f"causal conflict on {self._describe(bond)}: {why}, but effort already "
                                     f"goes into {current}")
            return
        for node in self._ends(bond):
            want = self.fixed.get(node)
            if want is not None:
                gives = receiver != node
                if (want == "gives") != gives:
                    self.problems.append(f"causal conflict at {node} ({self.kind[node]}) on {self._describe(bond)}: "
                                         f"{why}")
                    return
        self.effort_to[bond] = receiver
        self._queue.extend(self._ends(bond))

    def _ends(self, bond: BondKey) -> list[str]:
        return list(self._bond_ends[bond])

    def propagate(self) -> None:
        while self._queue:
            node = self._queue.pop()
            kind = self.kind[node]
            if kind in ("0", "1", "0c", "1c"):
                self._junction(node, kind[0])
            elif kind in ("TF", "MTF", "GY", "MGY"):
                self._two_port(node, kind)

    def _junction(self, node: str, base: str) -> None:
        # strong bond: effort in (0-junction) / flow in = junction gives effort (1-junction)
        def is_strong(key: BondKey, other: str) -> bool:
            receiver = self.effort_to[key]
            return receiver == node if base == "0" else receiver == other
        assigned = [(k, o) for k, o, _ in self.ports[node] if k in self.effort_to]
        free = [(k, o) for k, o, _ in self.ports[node] if k not in self.effort_to]
        strong = [k for k, o in assigned if is_strong(k, o)]
        if len(strong) > 1:
            what = "effort" if base == "0" else "flow"
            msg = (f"causal conflict at {base}-junction {node}: bonds {', '.join(map(str, strong))} all impose "
                   f"{what}")
            if msg not in self.problems:
                self.problems.append(msg)
            return
        if len(strong) == 1:
            for k, o in free:   # every other bond is weak
                self.set(k, o if base == "0" else node, f"{base}-junction {node} has its strong bond")
        elif len(free) == 1:
            k, o = free[0]
            self.set(k, node if base == "0" else o, f"last open bond of {base}-junction {node} must be strong")

    def _two_port(self, node: str, kind: str) -> None:
        (k1, o1, _), (k2, o2, _) = self.ports[node]
        for (ka, _oa), (kb, ob) in (((k1, o1), (k2, o2)), ((k2, o2), (k1, o1))):
            if ka in self.effort_to and kb not in self.effort_to:
                receives_a = self.effort_to[ka] == node
                if kind in ("TF", "MTF"):   # effort in on one side -> effort out on the other
                    self.set(kb, ob if receives_a else node, f"{kind} {node} passes effort through")
                else:                       # GY: both ports receive effort, or both receive flow
                    self.set(kb, node if receives_a else ob, f"{kind} {node} turns flow into effort")

    # -- steps
    def run(self) -> Causality:
        self._queue: list[str] = []
        diag = self.purpose == DIAGNOSIS
        for e in self.model.elements.values():
            if e.kind in SOURCE_KINDS:
                key, other = self._bond_of(e.name)
                gives = e.kind in ("Se", "MSe")
                self.set(key, other if gives else e.name, f"source {e.name}")
                self.fixed[e.name] = "gives" if gives else "receives"
        self.detectors: set[str] = set()
        inverted: set[str] = set()
        for s in self.model.sensors.values():
            key, other = self._bond_of(s.name)
            # diagnosis: inverted (De imposes effort, Df imposes flow); simulation: a detector.
            # A junction has one common variable: its first sensor is inverted, the others detect.
            invert = diag and s.junction not in inverted
            if invert:
                inverted.add(s.junction)
            elif diag:
                self.detectors.add(s.name)
            gives = (s.kind == "De") == invert
            self.set(key, other if gives else s.name, f"sensor {s.name}")
            self.fixed[s.name] = "gives" if gives else "receives"
        self.propagate()
        storage: dict[str, str] = {}
        read = measured_storage(self.model) if diag else {}
        for e in self.model.elements.values():
            if e.kind not in ("C", "I"):
                continue
            key, other = self._bond_of(e.name)
            # derivative causality needs the law's inverse (q of e, p of f): without it, integral
            can = has_inverse(e)
            want = "derivative" if diag and can else "integral"
            # integral: C receives flow (gives effort), I receives effort; derivative is the reverse
            gives = (e.kind == "C") == (want == "integral")
            if key in self.effort_to:
                got_gives = self.effort_to[key] != e.name
                storage[e.name] = want if got_gives == gives else ("integral" if want == "derivative" else "derivative")
            else:
                self.set(key, other if gives else e.name, f"storage {e.name}")
                self.propagate()
                storage[e.name] = want
            law_key, inv_key, energy, local = STORAGE_KEYS[e.kind]
            add = f"add {inv_key}: <law in {local}> to elements.{e.name} (the {energy} of a given {local})"
            held = diag and not can            # integral by SCAPH's own choice, for want of the inverse
            if not can and storage[e.name] == "derivative":
                # (diagnosis or simulation: the law is read backwards here; without that form no residual
                # or simulation can be computed, however the other elements are assigned)
                self.problems.append(f"storage {e.name} ({e.kind}) needs derivative causality here, and its "
                                     f"'{law_key}' law gives {local} of {energy} only: {add}")
            elif storage[e.name] != want or held:
                twin = self._twin_storage(e.name, other) if diag and not held else None
                self.problems.append(
                    f"storage {e.name} ({e.kind}) "
                    + (f"is held in integral causality: its '{law_key}' law gives {local} of {energy} only "
                       f"(derivative causality needs the inverse) " if held else
                       f"is forced into {storage[e.name]} causality ")
                    + (f"(its state follows {twin}'s: both on {other}, whose common "
                       f"{'flow' if e.kind == 'C' else 'effort'} is the rate of both; write them as one "
                       f"{e.kind} whose {'effort law in q' if e.kind == 'C' else 'flow law in p'} sums theirs, "
                       f"docs/model-format.md)" if twin else
                       (f"(its state is measured: {_readings(read[e.name])}; the residuals that read it there come "
                        f"from structural analysis, below)" if e.name in read else
                        "(its state is not measured: residuals that eliminate it come from structural analysis, "
                        f"below; {add + ', or ' if held else ''}a sensor on its junction measuring its state "
                        "(measures: displacement for a C on a 1-junction, momentum for an I on a 0-junction) gives "
                        "residuals that read it)") if diag else
                       "(a dependent storage element: the simulator reduces it, see bondgraph.simulation)"))
        self._free_controlled_junctions()
        resistors = self._resistors()
        self._junction_loops()
        strong = self._strong_bonds()
        for j in self.model.junctions.values():
            if j.name not in strong and self.ports[j.name]:
                what = "effort" if j.base == "0" else "flow"
                self.problems.append(f"{j.base}-junction {j.name} has no strong bond: every bond takes its {what} "
                                     f"from it and none gives it (its {what} is undetermined)")
        return Causality(self.purpose, dict(self.effort_to), storage, resistors, strong, tuple(self.problems),
                         detectors=frozenset(self.detectors))

    def _twin_storage(self, name: str, junction: str) -> str | None:
        """Another storage element of ``name``'s kind on the same junction when that junction makes
        their states dependent (two C on a 1-junction share their flow, the rate of each charge; two
        I on a 0-junction share their effort): e.g. a core and an air gap in series in a magnetic
        circuit, two springs in series. None otherwise."""
        kind = self.model.elements[name].kind
        if self.kind.get(junction) != ("1" if kind == "C" else "0"):
            return None
        for _, o, _ in self.ports[junction]:
            e = self.model.elements.get(o)
            if o != name and e is not None and e.kind == kind:
                return o
        return None

    def _free_controlled_junctions(self) -> None:
        for j in self.model.junctions.values():
            if not j.controlled:
                continue
            free = [(k, o) for k, o, _ in self.ports[j.name] if k not in self.effort_to]
            if not free or self._has_strong(j.name):
                continue
            # preferred: the strong bond on a side whose causality is already determined
            fixed = [(k, o) for k, o in free if o in self.fixed or self.kind[o] in ("0", "1", "0c", "1c")]
            k, o = (fixed or free)[0]
            self.set(k, j.name if j.base == "0" else o, f"preferred causality of controlled junction {j.name}")
            self.propagate()

    def _has_strong(self, node: str) -> bool:
        base = self.kind[node][0]
        for k, _o, _ in self.ports[node]:
            if k in self.effort_to and ((self.effort_to[k] == node) == (base == "0")):
                return True
        return False

    def _resistors(self) -> dict[str, str]:
        out: dict[str, str] = {}
        rs = [e for e in self.model.elements.values() if e.kind == "R"]
        forms = {e.name: resistor_forms(self.model, e, self._bond_of(e.name)[0]) for e in rs}
        # those with one law form first: their causality is not a free choice
        rs.sort(key=lambda e: 0 if len(forms[e.name]) == 1 else 1)
        for e in rs:
            key, other = self._bond_of(e.name)
            if key not in self.effort_to:
                form = "resistance" if "resistance" in forms[e.name] else "conductance"
                self.set(key, other if form == "resistance" else e.name, f"resistor {e.name}")
                self.propagate()
            # resistance causality: the R receives flow and gives effort (e = law(f))
            form = "resistance" if self.effort_to[key] != e.name else "conductance"
            if form not in forms[e.name]:
                give = "effort: <law in f>" if form == "resistance" else "flow: <law in e>"
                self.problems.append(f"resistor {e.name} needs {form} causality here; add {give} to its laws")
            out[e.name] = form
        return out

    def _junction_loops(self) -> None:
        for _u, v, k in self.g.edges(keys=True):
            if k not in self.effort_to:
                self.set(k, v, "arbitrary choice in a loop of the junction structure")
                self.propagate()

    def _strong_bonds(self) -> dict[str, BondKey]:
        out: dict[str, BondKey] = {}
        for j in self.model.junctions.values():
            for k, _o, _ in self.ports[j.name]:
                if k in self.effort_to and ((self.effort_to[k] == j.name) == (j.base == "0")):
                    out[j.name] = k
        return out


def resistor_forms(model: Model, element, bond=None) -> frozenset[str]:
    """The causal forms a resistor's law gives in closed form: ``resistance`` (e from f) and/or
    ``conductance`` (f from e), read off its equation's explicit solutions (:mod:`bondgraph.laws`).
    With its ``bond``, the equation is the one the causal forms solve (built once per model)."""
    if not element.laws and element.parameter is not None:      # e = R f: both ways, nothing to solve
        return frozenset(("resistance", "conductance"))
    bond = element.name if bond is None else bond
    effort, flow = bond_variables(bond)
    solutions = model_laws(model, ("R", element.name) if bond != element.name else ("R forms", element.name),
                           lambda: resistor_equation(model, element, bond)).solutions
    return frozenset(form for form, v in (("resistance", effort), ("conductance", flow)) if v in solutions)


def assign(model: Model, purpose: str = DIAGNOSIS) -> Causality:
    """Assign causality (SCAPH for ``diagnosis``, SCAP for ``simulation``) and check it."""
    if purpose not in (DIAGNOSIS, SIMULATION):
        raise ValueError(f"purpose must be {DIAGNOSIS!r} or {SIMULATION!r}")
    # once per model and purpose: check, selection and the AGARRs all ask for SCAPH
    return model_laws(model, ("causality", purpose), lambda: _assign(model, purpose))


def _assign(model: Model, purpose: str) -> Causality:
    causality = _Assigner(model, purpose).run()
    loops = tuple(algebraic_loops(model, causality))
    modes = tuple(dict(zip(model.modes, values)) for values in product((1, 0), repeat=len(model.modes)))
    return Causality(causality.purpose, causality.effort_to, causality.storage, causality.resistors,
                     causality.strong, causality.problems, loops, modes, causality.detectors)


def require(causality: Causality) -> Causality:
    """Raise CausalityError listing every problem unless the assignment is clean."""
    if not causality.ok:
        raise CausalityError(list(causality.problems) + list(causality.loops))
    return causality


def dependency_graph(model: Model, causality: Causality) -> nx.DiGraph:
    """Which bond variable is computed from which: nodes ('e'|'f', bond); edge attribute
    ``kind`` is 'algebraic' or 'derivative' (through a storage element in derivative causality).
    Read off the laws solved for their causal outputs (:func:`bondgraph.equations.causal_forms`).

    >>> from bondgraph.examples import source_resistor
    >>> m = source_resistor()
    >>> sorted(f"{a}{i} -> {b}{o}" for (a, i), (b, o) in dependency_graph(m, assign(m)).edges)
    ['e1 -> ei', 'e2 -> ei', 'f2 -> e2', 'fi -> f1', 'fi -> f2']
    """
    from .equations import causal_forms
    import networkx as nx
    dep = nx.DiGraph()
    for form in causal_forms(model, causality):
        kind = "derivative" if form.kind == "derivative" else "algebraic"
        for i in form.inputs:
            dep.add_edge(i, form.output, kind=kind)
    return dep


def algebraic_loops(model: Model, causality: Causality) -> list[str]:
    """Causal loops made of algebraic relations only (and derivative loops), as readable text."""
    dep = dependency_graph(model, causality)
    out: list[str] = []
    import networkx as nx
    if nx.is_directed_acyclic_graph(dep):          # the common case, decided in linear time
        return out
    for cycle in nx.simple_cycles(dep):
        kinds = {dep.edges[cycle[i], cycle[(i + 1) % len(cycle)]]["kind"] for i in range(len(cycle))}
        bonds = sorted({v[1] for v in cycle}, key=lambda b: (not isinstance(b, int), b if isinstance(b, int) else 0,
                                                           str(b)))
        names = [str(b) for b in bonds]
        if len(names) > 12:          # (a trial's 500-cell chain printed one line of 15.9 kB)
            names = names[:6] + [f"... ({len(names)} bonds) ..."] + names[-3:]
        what = "derivative loop" if "derivative" in kinds else "algebraic loop"
        out.append(f"{what} through bonds {', '.join(names)}")
        if len(out) >= 20:
            break
    return sorted(out, key=lambda x: (len(x), x))    # the cycles come in a set's order: one order in every process


def _readings(coefficients: Mapping[str, object]) -> str:
    """``x``, ``x1 - x2``: a storage element's state as the sum of readings that measures it."""
    import sympy as sp
    return str(sp.Add(*[a * sp.Symbol(name) for name, a in coefficients.items()]))
