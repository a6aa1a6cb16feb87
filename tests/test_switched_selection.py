"""Residual selection on a plant whose nominal mode switches a branch off: an EV's precharge
circuit (tests/data/ev_precharge.yaml, written for a user trial from Hauser & Kuhn's precharge
circuit: a battery, a precharge contactor p in series with the precharge resistor Rp, a main
contactor m, the DC link's capacitor, a discharge switch d; contactors open at rest, so the file's
nominal mode is p = m = d = 0).

The reference: Kirchhoff's voltage law round the precharge loop while only the precharge
contactor is closed, Vb - Rp ib - vdc = 0 (by hand; the trial checked it on its scipy data). The
selection judged residuals in the nominal mode only, where Rp carries no current: no residual
held it, and the precharge resistor was undetectable in every mode. And the physics does not
depend on which mode the file calls nominal: the residuals' signatures in every mode are the
same with the contactors' nominal values set to 1."""
from __future__ import annotations

from pathlib import Path

import sympy as sp
from sympy.core.function import AppliedUndef

from bondgraph.loader import load_model
from fdi.arrs import select_arrs
from fdi.signatures import all_modes, fault_signature_matrix

PRECHARGE = Path(__file__).parent / "data" / "ev_precharge.yaml"
PRECHARGING = {"p": 1, "m": 0, "d": 0}


def _in(model, expr, mode, betas_one=True):
    subs = {model.symbols[k]: v for k, v in mode.items()}
    if betas_one:
        subs.update({s: 1 for s in expr.free_symbols if s.name.startswith("beta_")})
    return sp.simplify(expr.xreplace(subs))


def test_the_precharge_loop_is_a_residual_though_the_contactors_rest_open():
    model = load_model(PRECHARGE)
    arrs = list(select_arrs(model).arrs)
    signal = {n: f for a in arrs for f in a.expr.atoms(AppliedUndef) for n in [f.func.__name__]}
    loop = signal["Vb"] - model.symbols["Rp"] * signal["ib"] - signal["vdc"]
    ratios = [sp.simplify(_in(model, a.expr, PRECHARGING) / loop) for a in arrs]
    assert any(r != 0 and not r.atoms(AppliedUndef) for r in ratios)          # a nonzero constant times the loop
    fsm = fault_signature_matrix(model, arrs, PRECHARGING)
    assert any(fsm.row("Rp").structural)                       # the precharge resistor is detected


def test_the_residuals_signatures_do_not_depend_on_the_nominal_mode(tmp_path):
    text = PRECHARGE.read_text(encoding="utf-8")
    closed = tmp_path / "closed.yaml"
    closed.write_text(text.replace("{nominal: 0, column: p_cmd", "{nominal: 1, column: p_cmd")
                      .replace("{nominal: 0, column: m_cmd", "{nominal: 1, column: m_cmd")
                      .replace("{nominal: 0, column: d_cmd", "{nominal: 1, column: d_cmd"), encoding="utf-8")
    rest, run = load_model(PRECHARGE), load_model(closed)
    assert run.modes["p"].nominal == 1 and rest.modes["p"].nominal == 0
    a_rest, a_run = list(select_arrs(rest).arrs), list(select_arrs(run).arrs)
    for mode in all_modes(rest):
        one = fault_signature_matrix(rest, a_rest, mode)
        other = fault_signature_matrix(run, a_run, mode)
        columns = lambda fsm: sorted(zip(*[r.structural for r in sorted(fsm.rows, key=lambda r: r.fault)]))
        assert columns(one) == columns(other), mode


def test_a_residual_whose_modes_sum_different_units_is_named():
    """The precharge loop is a voltage balance while a contactor is closed and reads the battery
    current (ib = 0, in A) while both are open: one threshold cannot judge both (the trial's
    calibrated 56.8 V, set by the precharge's Rp ib noise, left a 4 V sensor offset undetected in
    the main contactor's mode). By hand: V wherever p or m is 1, A where both are 0."""
    from fdi.arrs import mixed_unit_notes, units_by_mode

    model = load_model(PRECHARGE)
    arrs = list(select_arrs(model).arrs)
    loops = [a for a in arrs if "Rp" in {s.name for s in a.expr.free_symbols}]
    assert len(loops) == 1
    units = units_by_mode(model, loops[0], all_modes(model))
    assert set(units) == {"V", "A"}
    assert all(m["p"] or m["m"] for m in units["V"]) and all(not m["p"] and not m["m"] for m in units["A"])
    assert [n.split(" ")[0] for n in mixed_unit_notes(model, arrs)] == [loops[0].name]
