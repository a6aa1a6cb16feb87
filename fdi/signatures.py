"""Mode-dependent fault signature matrix (MD-FSM) and mode change signature matrix (MCSM).

A fault's structural signature has a 1 under every AGARR in which its symbols appear (in the
given mode: mode variables substituted first). Its nominal signature has a 1 only where the
AGARR still depends on the fault once every *other* parameter, efficiency factor and mode takes
its nominal value: beta_dp enters ARR2 only through sqrt(|dp/beta_dp|)/R4, which vanishes while
R4 = inf, so beta_dp is structurally in ARR2 but not numerically (Yu & Wang 2014, Table I).

The CyCab's Tables I and II (mode a1 = a2 = 1):

>>> from bondgraph.loader import load_model
>>> from fdi.scaph import derive_arrs
>>> m = load_model("models/cycab_steering.yaml")
>>> arrs = derive_arrs(m)
>>> fsm = fault_signature_matrix(m, arrs)
>>> fsm.row("R4").structural, fsm.row("beta_theta2").structural
((0, 1, 0), (0, 1, 1))
>>> fsm.row("beta_dp").structural, fsm.row("beta_dp").nominal
((1, 1, 1), (1, 0, 1))
>>> [(r.mode_change, r.signature) for r in mode_change_signature_matrix(m, arrs).rows]
[('a1', (1, 0, 0)), ('a2', (1, 1, 0))]
"""
from __future__ import annotations

import html
from dataclasses import dataclass
from itertools import product
from typing import TYPE_CHECKING, Mapping, Sequence

from bondgraph.model import Model

if TYPE_CHECKING:           # sympy and the derivation: imported where a matrix is derived, not where one is read
    import sympy as sp

    from .scaph import ARR


@dataclass(frozen=True)
class FaultRow:
    fault: str
    structural: tuple[int, ...]
    nominal: tuple[int, ...]

    @property
    def Db(self) -> int:
        return int(any(self.structural))


@dataclass(frozen=True)
class FSM:
    mode: Mapping[str, int]
    columns: tuple[str, ...]
    rows: tuple[FaultRow, ...]

    def row(self, fault: str) -> FaultRow:
        return next(r for r in self.rows if r.fault == fault)

    def _repr_html_(self) -> str:
        return fsm_html(self)


@dataclass(frozen=True)
class ModeChangeRow:
    mode_change: str
    variable: str
    signature: tuple[int, ...]
    Db: int
    Ib: int


@dataclass(frozen=True)
class MCSM:
    mode: Mapping[str, int]
    columns: tuple[str, ...]
    rows: tuple[ModeChangeRow, ...]

    def _repr_html_(self) -> str:
        return mcsm_html(self)


def all_modes(model: Model, names: list[str] | None = None) -> list[dict[str, int]]:
    """Every combination of the values of the mode variables ``names`` (all by default; the others
    at their nominal values), the nominal one first."""
    names = list(model.modes) if names is None else list(names)
    base = nominal_mode(model)
    nominal = tuple(base[n] for n in names)
    combos = sorted(product((1, 0), repeat=len(names)), key=lambda c: (c != nominal, [-x for x in c]))
    return [{**base, **dict(zip(names, c))} for c in combos]


OPERATING_MODES = 16          # combinations of switching modes judged, at most (beyond: the nominal mode alone)


def operating_modes(model: Model) -> list[dict[str, int]]:
    """The modes the plant runs in: every combination of its commanded and autonomous mode
    variables (the others, which only a fault changes, at their nominal values), the nominal one
    first; the nominal one alone beyond OPERATING_MODES combinations."""
    switching = [n for n, m in model.modes.items() if m.column or m.autonomous]
    if 2 ** len(switching) > OPERATING_MODES:
        return [nominal_mode(model)]
    return all_modes(model, switching)


def nominal_mode(model: Model) -> dict[str, int]:
    return {n: m.nominal for n, m in model.modes.items()}


def _in_mode(model: Model, expr: sp.Expr, mode: Mapping[str, int]) -> sp.Expr:
    import sympy as sp
    return expr.xreplace({model.symbols[m]: sp.Integer(v) for m, v in mode.items()})


def sees_mode_fault(model: Model, arr: ARR, fault: str, modes: list[Mapping[str, int]] | None = None) -> bool:
    """Whether ``arr`` reacts to the mode fault ``fault`` (its mode variable held at the fault's
    value) in some mode of ``modes`` (default: the modes the plant runs in) where the variable
    should be otherwise: the residual differs between the two modes (the MCSM's test)."""
    import sympy as sp
    f = model.faults[fault]
    var, value = f.targets[0], int(f.value or 0)
    for mode in modes if modes is not None else operating_modes(model):
        mode = {**nominal_mode(model), **mode}
        if int(mode[var]) == value:
            continue
        if sp.expand(_in_mode(model, arr.expr, {**mode, var: value}) - _in_mode(model, arr.expr, mode)) != 0:
            return True
    return False


def unread_faults(model: Model, arrs: list[ARR]) -> list[str]:
    """The declared faults no residual of ``arrs`` reads in any mode the plant runs in
    (:func:`operating_modes`): a parameter or sensor fault whose symbols enter none, a mode fault
    whose switch changes none (:func:`sees_mode_fault`). Data with such a fault read "nothing
    detected": a trial's hoist declared the rope's stiffness, which sits with the rope's damper
    between two unmeasured flows, and derivative causality's residuals never read it (signature
    0 0 0 in both modes); nothing but ``bgfdi isolability`` said so."""
    modes = operating_modes(model)
    exprs = [_in_mode(model, a.expr, m) for m in modes for a in arrs]
    out = []
    for f in model.faults.values():
        if f.kind == "mode":
            seen = any(sees_mode_fault(model, a, f.name, modes) for a in arrs)
        else:
            syms = [model.symbols[n] for n in f.symbols if n in model.symbols]
            seen = any(e.has(s) for e in exprs for s in syms)
        if not seen:
            out.append(f.name)
    return out


def unread_fault_note(model: Model, arrs: list[ARR], causality: str = "derivative") -> list[str]:
    """``check``'s note naming :func:`unread_faults` (none: no note)."""
    names = unread_faults(model, arrs)
    if not names:
        return []
    it, which = ("it", "that fault") if len(names) == 1 else ("them", "one of them")
    other = f"; --causality mixed may read {it}" if causality == "derivative" else ""
    return [f"no residual reads {', '.join(names)} in any mode: data with {which} read \"nothing detected\"; "
            f"bgfdi isolability {model.path or 'MODEL'} says which sensors would read {it}{other}"]


def fault_signature_matrix(model: Model, arrs: list[ARR], mode: Mapping[str, int] | None = None) -> FSM:
    """MD-FSM in one mode (the nominal mode by default) for every non-mode candidate fault."""
    import sympy as sp
    mode = dict(mode or nominal_mode(model))
    exprs = [_in_mode(model, a.expr, mode) for a in arrs]
    nominal = {s: sp.oo if v == float("inf") else sp.Float(v) if v != int(v) else sp.Integer(int(v))
               for s, v in model.nominal_values().items() if s.name not in model.modes}
    rows = []
    for fault in model.faults.values():
        if fault.kind == "mode":
            continue
        syms = {model.symbols[n] for n in fault.symbols}
        structural = tuple(int(any(e.has(s) for s in syms)) for e in exprs)
        others = {s: v for s, v in nominal.items() if s not in syms}
        numeric = tuple(int(bool(st) and any(_safe_subs(e, others).has(s) for s in syms))
                        for st, e in zip(structural, exprs))
        rows.append(FaultRow(fault.name, structural, numeric))
    return FSM(mode, tuple(a.name for a in arrs), tuple(rows))


def over_modes(fsms: Sequence[FSM]) -> FSM:
    """The signatures over several modes a record went through: a fault enters a residual if it
    does in any of them (each row's entries OR-ed; the mode is the first's). A later decision's
    coherence vector gathers residuals lit in different modes: a sensor offset that a pump line's
    residual reads only while the check valve conducts lit it when the pump started, and the FSM of
    the mode at t_D (valve shut) left that residual to another fault (a trial's accumulator: a
    spurious pump leak beside the right offset).

    >>> a = FSM({"c": 0}, ("ARR1", "ARR2"), (FaultRow("bias", (0, 1), (0, 1)),))
    >>> b = FSM({"c": 1}, ("ARR1", "ARR2"), (FaultRow("bias", (1, 1), (1, 1)),))
    >>> over_modes([a, b]).row("bias").structural, over_modes([a]) is a
    ((1, 1), True)
    """
    if len(fsms) == 1:
        return fsms[0]
    first = fsms[0]
    rows = []
    for row in first.rows:
        others = [f.row(row.fault) for f in fsms[1:]]
        rows.append(FaultRow(row.fault, tuple(int(any(x)) for x in zip(row.structural, *(o.structural for o in others))),
                             tuple(int(any(x)) for x in zip(row.nominal, *(o.nominal for o in others)))))
    return FSM(first.mode, first.columns, tuple(rows))


def _safe_subs(expr: sp.Expr, values: Mapping[sp.Symbol, sp.Expr]) -> sp.Expr:
    """Nominal values in; an infinite parameter in a denominator makes its term vanish."""
    try:
        return expr.xreplace(dict(values))
    except (TypeError, ValueError):        # pragma: no cover - sympy edge cases
        return expr


def mode_fault_name(model, variable: str, value: int) -> str:
    """The model's mode fault that puts ``variable`` at ``value`` (a valve stuck closed, or one stuck
    open), else the variable itself: the name of a mode change in the MCSM and in the report (a
    relay's only fault, stuck off, is not the name of its switching on)."""
    on = [f for f in model.faults.values() if f.kind == "mode" and f.targets[0] == variable]
    exact = [f for f in on if (0 if f.value is None else int(f.value)) == int(value)]
    return exact[0].name if exact else variable


def mode_change_signature_matrix(model: Model, arrs: list[ARR], mode: Mapping[str, int] | None = None) -> MCSM:
    """MCSM: which AGARRs react when each mode variable leaves its value in ``mode`` (the paper's
    mode change: a switch that did not switch as commanded, or a mode other than the one claimed).
    The row is named for the mode fault that holds the variable at the value it changes to
    (``v_closed`` from v = 1), else for the variable. A residual reacts when it differs between
    the two modes, not when the symbol merely appears in it (``s*r + (1 - s)*r`` does not react
    to s: a residual set rebuilt mode by mode reads every mode variable).

    >>> from bondgraph.loader import load_model
    >>> from fdi.arrs import select_arrs
    >>> from fdi.app.resources import shipped_model
    >>> m = load_model(shipped_model("two_tank_commanded"))
    >>> [(r.mode_change, r.signature) for r in mode_change_signature_matrix(m, list(select_arrs(m).arrs), {"v": 1}).rows]
    [('v_closed', (1, 1, 0))]
    """
    import sympy as sp
    mode = {**nominal_mode(model), **(mode or {})}      # a variable the mode leaves out: its nominal value
    sigs = []
    for var in model.modes:
        value = 1 - int(mode[var])
        name = mode_fault_name(model, var, value)
        after = {**mode, var: value}
        sig = tuple(int(sp.expand(_in_mode(model, arr.expr, after) - _in_mode(model, arr.expr, mode)) != 0)
                    for arr in arrs)
        sigs.append((name, var, sig))
    rows = []
    for name, var, sig in sigs:
        unique = sum(1 for _, _, s in sigs if s == sig) == 1
        rows.append(ModeChangeRow(name, var, sig, int(any(sig)), int(any(sig) and unique)))
    return MCSM(mode, tuple(a.name for a in arrs), tuple(rows))


def _mode_label(mode: dict) -> str:
    return " ".join(f"{k}={v}" for k, v in mode.items()) or "(no modes)"


def _html_table(caption: str, header: list[str], rows: list[list[str]]) -> str:
    esc = lambda x: html.escape(str(x))
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><caption>{esc(caption)}</caption><tr>{head}</tr>{body}</table>"


def fsm_html(fsm: FSM) -> str:
    """An MD-FSM as an HTML table (a notebook's view): the structural signature, the nominal one
    in brackets where it differs (a term that vanishes at the nominal values), Db."""
    rows = [[r.fault] + [str(s) if s == n else f"{s} [{n}]" for s, n in zip(r.structural, r.nominal)] + [r.Db]
            for r in fsm.rows]
    return _html_table(f"MD-FSM at mode {_mode_label(dict(fsm.mode))}", ["fault", *fsm.columns, "Db"], rows)


def mcsm_html(mcsm: MCSM) -> str:
    """The MCSM as an HTML table: each mode change's signature, Db and Ib."""
    rows = [[r.mode_change, *r.signature, r.Db, r.Ib] for r in mcsm.rows]
    return _html_table(f"MCSM from mode {_mode_label(dict(mcsm.mode))}", ["mode change", *mcsm.columns, "Db", "Ib"],
                       rows)
