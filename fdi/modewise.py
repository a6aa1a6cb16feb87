"""ARRs that hold in every mode: each checked against the ARRs of every mode's own bond graph.

The diagnostic hybrid bond graph gives one ARR per residual for all modes, a controlled junction's
outputs multiplied by its mode variable (Yu & Wang 2014, Sec. II-B). That is exact when a
switched-off junction's outputs are what the physics sets to zero; it is silently wrong when
another part of the graph must take over a variable the junction imposed (a boost converter's
switch node takes its voltage from the diode's branch while the switch is open; the DHBG gives
it 0 V). So every ARR is checked in every mode combination: in mode m it must be a combination
of the ARRs of the plain bond graph of that mode (:func:`bondgraph.modes.in_mode`, on which
SCAPH, or MSO residuals where SCAPH gives up, is the textbook derivation). The check is
numeric and exact in practice: both sides at random values of every signal, derivative and
parameter, a least-squares fit of the DHBG form on the mode's ARRs, which must leave nothing.

An ARR that fails in some mode is rebuilt as ``sum_m chi_m(a) r_m``, with ``chi_m`` the
indicator polynomial of mode m (``a*(1 - b)`` for a = 1, b = 0) and ``r_m`` the ARR it had where
it holds, the mode's own ARR most like it where it does not. In every mode it reduces to a true
ARR of that mode; the mode variables stay symbols, so commanded modes switch it sample by sample
and the MD-FSM of each mode is read off it as before. Where every ARR holds in every mode (the
CyCab's eqs. 5, 9, 13) nothing changes.

The boost converter: with the switch open (s = 0) the diode's branch sets the switch node's
voltage, which the diagnostic bond graph's one causality holds at 0 V; both residuals are wrong
there, right in the other mode, and rebuilt from each mode's own SCAPH ARR of their sensor,
joined by the mode indicators.

>>> from bondgraph.loader import load_model
>>> from fdi.selection import select
>>> m = load_model("models/boost_converter.yaml")
>>> arrs, checks = check_modes(m, list(select(m).arrs))
>>> sorted((c.arr, dict(c.mode)["s"], c.holds) for c in checks)
[('ARR1', 0, False), ('ARR1', 1, True), ('ARR2', 0, False), ('ARR2', 1, True)]
>>> [a.origin for a in arrs]
['SCAPH by mode', 'SCAPH by mode']
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np
import sympy as sp

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.model import Fault, Model, t
from bondgraph.modes import ModeGraph, in_mode

from .scaph import ARR, binary_modes, derive_arrs, sensor_value
from .selection import _deficit, _gain, expression_faults, fault_symbols, select
from .signatures import _mode_label, all_modes, operating_modes

TRIALS = 2            # independent draws of the parameters
SPARE = 6             # random points beyond the number of the mode's ARRs
TOLERANCE = 1e-8      # what the fit may leave, relative to the ARR's size


@dataclass(frozen=True)
class ModeCheck:
    """Whether ARR ``arr`` holds in ``mode`` (``error``: what the fit on the mode's ARRs left,
    relative), and, where not, the mode's ARR put in its place."""
    arr: str
    mode: Mapping[str, int]
    holds: bool
    error: float
    replacement: str | None = None


def mode_arrs(model: Model, mode: Mapping[str, int], graph: ModeGraph | None = None) -> list[ARR]:
    """The ARRs of the plain bond graph of ``mode`` (``graph``, when the caller has it): SCAPH where
    it succeeds, else the MSO residual set; a sensor on a switched-off junction measures zero (its
    ARR: signal / beta)."""
    graph = graph or in_mode(model, mode, keep_states=False)
    spec = graph.model
    causality = assign(spec, DIAGNOSIS)
    arrs: list[ARR] = []
    if causality.ok:
        try:
            arrs = derive_arrs(spec, causality)
        except (ValueError, KeyError):
            arrs = []
    if not arrs and spec.sensors:
        arrs = list(select(spec).arrs)      # the residual selection, on the mode's plain graph
    arrs += [ARR(f"zero:{s}", s, model.sensors[s].junction, sensor_value(model, s)) for s in sorted(graph.zero_sensors)]
    return arrs


def _untouched(arr: ARR, gone: frozenset[str]) -> bool:
    """An MSO residual none of whose equations belongs to what the mode switches out: its
    equations are the mode's own (a switched-on junction's are the plain junction's), so it holds
    there, whatever the mode's residuals, which need not span every relation, say (a trial's
    battery pack: the pack's voltage sum, read as wrong with the contactor open)."""
    if not arr.equations or not gone:
        return False
    return not any(name.split(".")[0] in gone for name in arr.equations)


def _signal_basis(spec: Model) -> list[ARR]:
    """The residual selection on a mode's plain graph ``spec`` with every sensor and measured source
    a fault candidate (:func:`_every_signal_a_fault`): more of the mode's relations than its ARRs."""
    return list(select(_every_signal_a_fault(spec)).arrs) if spec.sensors else []


def _every_signal_a_fault(model: Model) -> Model:
    """``model`` with a gain fault on each sensor and measured source no declared fault names."""
    named = {f.targets[0] for f in model.faults.values() if f.kind in ("sensor", "source")}
    extra = {f"~{s}": Fault(f"~{s}", "sensor", (s,)) for s in model.sensors if s not in named}
    for e in model.sources():
        name = e.input or e.name
        if name not in named and f"beta_{name}" in model.symbols and (e.input or not sp.sympify(e.value).is_number):
            extra[f"~{name}"] = Fault(f"~{name}", "source", (name,))
    return replace(model, faults={**model.faults, **extra}) if extra else model


def _indicator(model: Model, mode: Mapping[str, int]) -> sp.Expr:
    out = sp.Integer(1)
    for name, v in mode.items():
        a = model.symbols[name]
        out *= a if v else 1 - a
    return out


def _atoms(exprs: list[sp.Expr]) -> tuple[list[sp.Expr], list[sp.Symbol]]:
    """The signals, their derivatives and the rates kept whole (each a free number here), and
    the parameters."""
    points: set = set()
    symbols: set = set()
    for e in exprs:
        points |= e.atoms(sp.Derivative)
        points |= {f for f in e.atoms(sp.core.function.AppliedUndef)}
        symbols |= {s for s in e.free_symbols if s.name != "t"}
    return sorted(points, key=sp.srepr), sorted(symbols, key=lambda s: s.name)


def _values(exprs: list[sp.Expr], points: list, symbols: list, rng: np.random.Generator, n: int,
            nominal: Mapping[sp.Symbol, float]) -> np.ndarray:
    """(len(exprs), n): every expression at n random points (signals ~ N(0, 1); parameters
    positive, around their nominal values where finite, one draw for all n points)."""
    params = {}
    for s in symbols:
        v = nominal.get(s)
        scale = abs(v) if v is not None and np.isfinite(v) and v != 0 else 1.0
        params[s] = sp.Float(scale * float(np.exp(rng.uniform(-0.7, 0.7))))
    out = np.empty((len(exprs), n))
    fixed = [e.xreplace(params) for e in exprs]
    for k in range(n):
        # rates kept whole hold signals inside: replaced whole first (xreplace matches a node
        # before its arguments)
        point = {p: sp.Float(rng.normal()) for p in points}
        for i, e in enumerate(fixed):
            v = e.xreplace(point)
            try:
                out[i, k] = float(v)
            except (TypeError, ValueError):
                out[i, k] = np.nan
    return out


def _fit(exprs: list[sp.Expr], basis: list[sp.Expr], rng: np.random.Generator,
         nominal: Mapping[sp.Symbol, float]) -> tuple[np.ndarray, np.ndarray]:
    """How far each of ``exprs`` is from the span of ``basis`` (the worst relative residual of a
    least-squares fit at random points, over ``TRIALS`` draws of the parameters: 0 when it is a
    fixed combination of them), and how like each basis expression it is (summed |cosines|)."""
    points, symbols = _atoms(exprs + basis)
    n = len(basis) + SPARE
    errors = np.zeros(len(exprs))
    likeness = np.zeros((len(exprs), max(len(basis), 1)))
    for _ in range(TRIALS):
        values = _values(exprs + basis, points, symbols, rng, n, nominal)
        E, B = values[:len(exprs)], values[len(exprs):]
        for i in range(len(exprs)):
            e = E[i]
            if not np.all(np.isfinite(e)):
                errors[i] = np.inf
                continue
            size = np.linalg.norm(e)
            if size == 0:
                continue                      # the ARR vanishes in this mode: no information, no error
            good = [j for j in range(len(basis)) if np.all(np.isfinite(B[j]))]
            if good:
                Bg = B[good].T
                c, *_ = np.linalg.lstsq(Bg, e, rcond=None)
                left = np.linalg.norm(e - Bg @ c) / size
                for j in good:
                    b = B[j]
                    nb = np.linalg.norm(b)
                    if nb > 0:
                        likeness[i, j] += abs(float(e @ b)) / (size * nb)
            else:
                left = 1.0
            errors[i] = max(errors[i], left)
    return errors, likeness


def _order(*exprs: sp.Expr) -> int:
    """The highest time derivative in ``exprs``."""
    return max((sum(int(c) for v, c in d.variable_count if v == t) for e in exprs for d in e.atoms(sp.Derivative)),
               default=0)


def _by_sensor(model: Model, own_sets: Mapping[tuple, list[ARR]]) -> list[ARR] | None:
    """One ARR per sensor, ``sum_m chi_m(a) r_m,k`` with r_m,k the SCAPH ARR of sensor k in mode m
    (zero where the sensor measures zero): each mode's textbook ARRs joined, when every mode has
    them; None otherwise."""
    mode_syms = [model.symbols[m] for m in model.modes]
    per: dict[str, list[sp.Expr]] = {s: [] for s in model.sensors}
    whole: dict[str, list[sp.Expr]] = {s: [] for s in model.sensors}       # the exact forms (fdi.scaph)
    for key, own in own_sets.items():
        found = {a.sensor: a for a in own if a.origin == "SCAPH" and a.sensor in per}
        if set(found) != set(per):
            return None
        for name in per:
            per[name].append(_indicator(model, dict(key)) * found[name].expr)
            whole[name].append(_indicator(model, dict(key)) * (found[name].expr if found[name].exact is None
                                                               else found[name].exact))
    out = []
    for k, (name, terms) in enumerate(per.items()):
        expr = binary_modes(sp.Add(*terms), mode_syms)
        exact = binary_modes(sp.Add(*whole[name]), mode_syms)
        out.append(ARR(f"ARR{k + 1}", name, model.sensors[name].junction, expr, "SCAPH by mode",
                       exact=None if exact == expr else exact))
    return out


def _joined(model: Model, forms: Mapping[tuple, sp.Expr]) -> sp.Expr:
    """One expression equal to ``forms[key]`` in each mode ``key`` (sorted (variable, value) pairs):
    ``(1 - a)*f0 + a*f1`` split on each mode variable in turn, and no split where both sides agree
    (a relay's current balance with its sensor's zero, ``(1 - s)*I/beta_I + s*(U - Rh*I/beta_I)``,
    whatever a draw's tap does)."""
    keys = list(forms)
    names = [n for n, _ in keys[0]] if keys else []

    def join(fixed: dict[str, int], rest: list[str]) -> sp.Expr:
        if not rest:
            return forms[tuple(sorted(fixed.items()))]
        v, more = rest[0], rest[1:]
        parts = [join({**fixed, v: b}, more) for b in (0, 1)]
        if sp.expand(parts[0] - parts[1]) == 0:
            return parts[0]
        a = model.symbols[v]
        return (1 - a) * parts[0] + a * parts[1]
    return join({}, names)


def check_modes(model: Model, arrs: list[ARR], modes: list[Mapping[str, int]] | None = None,
                seed: int = 0) -> tuple[list[ARR], list[ModeCheck]]:
    """Every ARR checked in every mode (default: all combinations, at most 16); those that fail
    somewhere rebuilt as described in the module doc. Returns the ARRs (unchanged ones are the
    same objects) and one :class:`ModeCheck` per ARR and mode."""
    if not any(j.controlled and j.off == "all" for j in model.junctions.values()):
        return list(arrs), []
    modes = [dict(m) for m in (modes or all_modes(model))][:16]
    mode_syms = [model.symbols[m] for m in model.modes]
    nominal = {s: float(v) for s, v in model.nominal_values().items()}
    rng = np.random.default_rng(seed)
    checks: list[ModeCheck] = []
    forms: dict[str, dict[tuple, sp.Expr]] = {a.name: {} for a in arrs}
    exacts: dict[str, dict[tuple, sp.Expr]] = {a.name: {} for a in arrs}    # each mode's exact form (or expr)
    own_sets: dict[tuple, list[ARR]] = {}
    lost: set[tuple[str, tuple]] = set()     # (ARR, mode) where it vanished and its sensor reads 0 (below)
    for mode in modes:
        key = tuple(sorted(mode.items()))
        subs = {model.symbols[k]: sp.Integer(v) for k, v in mode.items()}
        graph = in_mode(model, mode, keep_states=False)
        own = mode_arrs(model, mode, graph)
        own_sets[key] = own
        exprs = [a.expr.xreplace(subs) for a in arrs]
        basis = [r.expr for r in own]
        errors, likeness = _fit(exprs, basis, rng, nominal)
        gone = graph.removed | graph.zero_sensors         # what the mode switches out
        holds = [bool(errors[i] <= TOLERANCE) or _untouched(a, gone) for i, a in enumerate(arrs)]
        # an ARR that vanishes in this mode while its sensor, on a junction switched off, measures 0
        # there holds nothing: it loses that relation (a relay's current balance s*(U - Rh*I) is 0 = 0
        # with the relay open, where the current must read 0: a welded relay went unseen, a user
        # trial); the sensor's zero takes its place
        zeros = {r.sensor: j for j, r in enumerate(own) if r.name.startswith("zero:")}
        vacuous = [i for i, a in enumerate(arrs) if a.sensor in zeros and sp.expand(exprs[i]) == 0]
        for i in vacuous:
            holds[i], errors[i] = False, 1.0
            likeness[i, :] = 0.0
            likeness[i, zeros[arrs[i].sensor]] = 1.0
            lost.add((arrs[i].name, key))
        # an ARR may be the mode's ARRs combined with their time derivatives (zone 1's balance with T1
        # taken from zone 2's reads T2''): one that fails is fitted again with those derivatives in
        # the span, on a generator of its own (the first fit's draws, so every choice below, as before)
        again = [i for i in range(len(arrs)) if not holds[i]]
        depth = max((_order(exprs[i]) for i in again), default=0)
        if again and own and depth:         # only the orders the mode's ARRs lack (each one squares the fit's work)
            wider = basis + [sp.diff(b, t, k) for k in range(1, max(1, depth - _order(*basis)) + 1) for b in basis]
            more, _ = _fit([exprs[i] for i in again], wider, np.random.default_rng([seed, 1]), nominal)
            for i, e in zip(again, more):
                if e <= TOLERANCE:
                    holds[i], errors[i] = True, float(e)
        # the mode's ARRs are chosen for the declared faults and need not span every relation of the
        # mode: one that still fails is fitted again with the residuals a selection gives where every
        # sensor and measured source is a fault candidate too (a trial's battery pack: the contactor's
        # balance, through no declared fault, read as wrong with the contactor open); the replacement
        # below is still one of the mode's own ARRs
        again = [i for i in range(len(arrs)) if not holds[i] and (arrs[i].name, key) not in lost]
        if again and own:
            known = set(basis)
            extra = [r.expr for r in _signal_basis(graph.model) if r.expr not in known]
            if extra:
                more, _ = _fit([exprs[i] for i in again], basis + extra, np.random.default_rng([seed, 2]), nominal)
                for i, e in zip(again, more):
                    if e <= TOLERANCE:
                        holds[i], errors[i] = True, float(e)
        # each ARR that fails takes the mode's ARR most like it among those no other residual
        # stands for (the holding ones first claim theirs): the set keeps its rank in the mode
        used = {int(np.argmax(likeness[i, :len(own)])) for i in range(len(arrs)) if holds[i] and own}
        for i, a in enumerate(arrs):
            choice = None
            if holds[i] or not own:
                forms[a.name][key] = exprs[i]
                exacts[a.name][key] = exprs[i] if a.exact is None else a.exact.xreplace(subs)
            else:
                order = [int(j) for j in np.argsort(-likeness[i, :len(own)])]
                j = next((j for j in order if j not in used), order[0])
                used.add(j)
                choice = own[j].name
                forms[a.name][key] = own[j].expr
                exacts[a.name][key] = own[j].expr if own[j].exact is None else own[j].exact
            checks.append(ModeCheck(a.name, mode, holds[i], float(errors[i]), choice))
    if any(not c.holds and (c.arr, tuple(sorted(c.mode.items()))) not in lost for c in checks):
        by_sensor = _by_sensor(model, own_sets)
        if by_sensor is not None:
            return by_sensor + complete_by_mode(model, by_sensor, own_sets), checks
    out = []
    for a in arrs:
        if all(c.holds for c in checks if c.arr == a.name):
            out.append(a)
            continue
        if all((c.arr, tuple(sorted(c.mode.items()))) in lost for c in checks if c.arr == a.name and not c.holds):
            # only the sensor's zero joined: each mode variable's split kept where it changes the form
            out.append(replace(a, expr=binary_modes(_joined(model, forms[a.name]), mode_syms),
                               exact=None if a.exact is None else binary_modes(_joined(model, exacts[a.name]), mode_syms),
                               origin=a.origin + "+zero"))
            continue
        combined = sp.Add(*[_indicator(model, dict(k)) * e for k, e in forms[a.name].items()])
        # the exact form (a storage law's fault parameter inside its rate, fdi.scaph) joined by mode too:
        # dropped here, a gas accumulator's precharge drift lost its d(p0)/dt term and was typed wrong
        # (a user trial: 1.4e-5 m^3/s left on noise-free drift data, 55 % of the threshold)
        exact = (binary_modes(sp.Add(*[_indicator(model, dict(k)) * e for k, e in exacts[a.name].items()]), mode_syms)
                 if any(exacts[a.name][k] != forms[a.name][k] for k in forms[a.name]) else None)
        out.append(replace(a, expr=binary_modes(combined, mode_syms), exact=exact,
                           origin=a.origin + "+modes"))
    return out + complete_by_mode(model, out, own_sets), checks


def complete_by_mode(model: Model, arrs: list[ARR], own_sets: Mapping[tuple, list[ARR]]) -> list[ARR]:
    """Residuals of one mode, ``chi_m(a) r_m``, for what the set misses in every mode the plant runs
    in (:func:`fdi.signatures.operating_modes`): where the ARRs of the modes' own bond graphs detect
    a fault that no residual of the set detects in any of those modes, or tell apart a pair the
    set never does, the mode's ARR that adds most (new detections, then pairs; the fewest time
    derivatives on a tie) joins the set times its mode's indicator: that ARR where the mode holds,
    0 elsewhere, so it is an ARR in every mode. The one-causality form can miss a relation that
    holds in one mode only: a clutch's spring read through a torque sensor on the switched
    junction divides by the clutch's mode (a user trial: the clutch's stiffness and damping were
    undetectable in both modes; engaged, the plain bond graph's SCAPH gives the clutch's ARR).
    A model whose set sees every fault somewhere keeps its residuals. Residuals that integrate
    states of their mode's graph are not taken (their states are not the model's). Returns the
    residuals added, named after the set's."""
    names = [f for f, v in model.faults.items() if v.kind != "mode"]
    if not names:
        return []
    symbols = fault_symbols(model, names)
    mode_syms = [model.symbols[m] for m in model.modes]
    keys = [tuple(sorted(m.items())) for m in operating_modes(model)]
    pool = [(key, r, expression_faults(model, r, dict(key), symbols))
            for key in keys for r in own_sets.get(key, ()) if not r.states]
    target = {f: frozenset((key, j) for j, (key, _, fs) in enumerate(pool) if f in fs) for f in names}
    have = {f: set() for f in names}
    for k, a in enumerate(arrs):
        for key in keys:
            for f in expression_faults(model, a, dict(key), symbols):
                have[f].add((key, k))
    added: list[ARR] = []
    while True:
        short = _deficit({f: frozenset(v) for f, v in have.items()}, target)
        if not short:
            break
        partners: dict[str, set] = {}
        for fa, fb in short.pairs:
            partners.setdefault(fa, set()).add(fb)
            partners.setdefault(fb, set()).add(fa)
        gains = [(_gain(fs, short, partners), -_order(r.expr), -j) for j, (_, r, fs) in enumerate(pool)]
        best = max(range(len(pool)), key=lambda j: gains[j])
        if gains[best][0] == (0, 0):
            break
        key, r, fs = pool[best]
        mode = dict(key)
        chi = _indicator(model, mode)
        k = len(arrs) + len(added)
        origin = ("SCAPH" if r.origin == "SCAPH" or r.name.startswith("zero:") else "MSO") + f" in mode {_mode_label(mode)}"
        added.append(ARR(f"ARR{k + 1}", r.sensor, r.junction, binary_modes(chi * r.expr, mode_syms), origin,
                         exact=None if r.exact is None else binary_modes(chi * r.exact, mode_syms)))
        for f in fs:
            have[f].add((key, k))
    return added
