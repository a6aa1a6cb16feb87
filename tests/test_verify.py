"""Issue 20: every ARR checked on the model's own simulation (fdi.verify, ``bgfdi check --verify``).

References: each shipped model's ARRs against its simulation in every mode (the derivation and the
simulator share only the model file); a hand-derived RC-circuit relation u = R C dv/dt + v with
tau = R C in microseconds and in hours; designed wrong ARRs (a dropped or mis-signed term) whose
failure follows from the physics: the two-tank valve's flow v (p1 - p2)/R12 is zero with the valve
closed (v = 0), so dropping it is wrong in v = 1 only; the CyCab's cylinder is locked when the
belt is broken (a2 = 0: no pump flow, no leak with R4 = inf), so nothing its relations read moves.
"""
from __future__ import annotations

import dataclasses
import json
from functools import lru_cache
from pathlib import Path

import pytest
import sympy as sp

from bondgraph.equations import signal
from bondgraph.loader import load_model, load_model_text
from bondgraph.model import t
from fdi.app.cli import main
from fdi.arrs import ARR, select_arrs
from fdi.verify import THRESHOLD, terms, verify

ROOT = Path(__file__).resolve().parent.parent
MODELS = sorted((ROOT / "models").glob("*.yaml")) + sorted((ROOT / "tests" / "data").glob("*.yaml"))
TANKS = ROOT / "models" / "two_tank_valve.yaml"


@lru_cache(maxsize=None)
def _verified(path: Path):
    return verify(load_model(path))


# A model whose nominal mode is a plant at rest: an ARR relating what moves only in other modes is
# unverified there (the note says so) and verified in a mode that moves it
AT_REST = {"ev_precharge": "contactors open at rest: no battery current, the precharge loop reads 0 = 0"}
LIMITS: dict[str, str] = {}     # a correct model the verification's numerics do not resolve: why
# (the LC ladder was here until its stored quantities' second derivatives were filtered at the
# signals' order: a cubic over 5 samples converged as the square of the step)


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.xfail(strict=False, reason=LIMITS[p.stem]))
                                  if p.stem in LIMITS else p for p in MODELS], ids=[p.stem for p in MODELS])
def test_every_shipped_model_passes_with_a_clear_margin(path):
    v = _verified(path)
    assert v.ok, [(c.arr, c.mode_text, c.violation) for c in v.failures]
    nominal = v.checks[0].mode
    for c in v.checks:
        if c.passed:
            assert c.violation < THRESHOLD / 10, (c.arr, c.mode_text, c.violation)
        if c.mode == nominal and path.stem in AT_REST and c.passed is None:
            assert "at rest" in c.note and any(o.passed for o in v.checks if o.arr == c.arr), (c.arr, c.note)
        elif c.mode == nominal:
            assert c.passed, (c.arr, c.note)                    # every ARR is checked in the nominal mode
    assert not v.notes


def test_the_cycab_relations_of_a_locked_cylinder_are_not_verified_and_say_why():
    v = _verified(ROOT / "models" / "cycab_steering.yaml")
    unverified = {(c.arr, c.mode_text) for c in v.unverified}
    assert unverified == {("ARR2", "a1=1,a2=0"), ("ARR3", "a1=1,a2=0"), ("ARR2", "a1=0,a2=0"), ("ARR3", "a1=0,a2=0")}
    assert all("at rest" in c.note for c in v.unverified)
    assert v.ok and not v.complete


def _without(arr: ARR, dropped: sp.Expr, flip: bool = False) -> ARR:
    """The ARR with one of its terms dropped (or its sign flipped), as a derivation slip would."""
    rest = [u for u in terms(arr.expr) if u != dropped]
    assert len(rest) == len(terms(arr.expr)) - 1
    return dataclasses.replace(arr, expr=sp.Add(*rest) - (dropped if flip else 0), exact=None)


def _valve_term(model, arr: ARR) -> sp.Expr:
    v = model.symbols["v"]
    return next(u for u in terms(arr.expr) if u.has(v) and u.has(signal("p2")))


def test_a_dropped_valve_flow_fails_with_the_valve_open_only():
    model = load_model(TANKS)
    arrs = list(select_arrs(model).arrs)
    arrs[0] = _without(arrs[0], _valve_term(model, arrs[0]))
    v = verify(model, arrs)
    failed = {(c.arr, c.mode_text) for c in v.failures}
    assert failed == {("ARR1", "v=1")}
    bad = v.failures[0]
    assert bad.violation > 100 * THRESHOLD                       # orders of magnitude, not a near miss
    closed = next(c for c in v.checks if c.arr == "ARR1" and c.mode_text == "v=0")
    assert closed.passed and closed.violation < THRESHOLD / 10   # v = 0: the term was zero anyway


def test_a_mis_signed_inflow_fails_in_every_mode():
    model = load_model(TANKS)
    arr = select_arrs(model).arrs[0]
    inflow = next(u for u in terms(arr.expr) if u.has(signal("Qin")))
    v = verify(model, [_without(arr, inflow, flip=True)])
    assert {c.mode_text for c in v.failures} == {"v=1", "v=0"}
    assert min(c.violation for c in v.failures) > 100 * THRESHOLD


RC = """
parameters: {{R: {{value: {R}, unit: Ohm}}, C1: {{value: {C}, unit: F}}}}
inputs: {{u: {{column: u, expr: "12.0", unit: V}}}}
elements: {{src: {{type: MSe, input: u}}, res: {{type: R, parameter: R}}, cap: {{type: C, parameter: C1}}}}
junctions: {{j1: {{type: "1"}}, j0: {{type: "0"}}}}
sensors: {{v: {{type: De, junction: j0, unit: V}}}}
bonds: {{1: [src, j1], 2: [j1, res], 3: [j1, j0], 4: [j0, cap]}}
"""


@pytest.mark.parametrize("R, C", [(10.0, 1.0e-7), (3.6e3, 1.0)], ids=["1 us", "1 h"])
def test_a_hand_derived_rc_relation_passes_at_its_own_time_scale(R, C):
    model = load_model_text(RC.format(R=R, C=C))
    Rs, Cs = model.symbols["R"], model.symbols["C1"]
    u, vc = signal("u"), signal("v")
    hand = ARR("hand", "v", "j0", u - Rs * Cs * sp.Derivative(vc, t) - vc)      # u = R C dv/dt + v
    v = verify(model, [hand, *select_arrs(model).arrs])
    assert v.settings.tau == pytest.approx(R * C, rel=1e-4)      # tau = R C: the simulation follows it
    assert v.ok and v.complete
    assert all(c.violation < THRESHOLD / 10 for c in v.checks)
    wrong = dataclasses.replace(hand, expr=u - Rs * Cs * sp.Derivative(vc, t) + vc)
    w = verify(model, [wrong])
    assert not w.ok and w.failures[0].violation > 0.1


ABS = ROOT / "tests" / "data" / "unverified" / "abs_modulator.yaml"


@lru_cache(maxsize=None)
def _abs():
    model = load_model(ABS)
    return model, select_arrs(model).arrs


def test_a_steep_law_the_sampling_does_not_follow_is_judged_again_finer():
    """The ABS wheel's brake torque kb pc tanh(w/w0), w0 = 0.5 rad/s, locks the wheel along a real
    pole far faster than the rest linearisation's tau (a pole that does not ring: the visited-states
    refinement leaves it): at tau/10 the correct wheel balance failed by 1.6e-1, 1.4e-2, 4.8e-4
    and 1.3e-1 of its terms in its four modes (session 41). The same runs sampled 4x and 16x finer
    bring a truncation error down (measured 1.7e-2 then 4.7e-5 in the worst mode): it passes,
    saying at which sampling."""
    model, arrs = _abs()
    v = verify(model, arrs)
    assert v.ok, [(c.arr, c.mode_text, c.violation) for c in v.failures]
    finer = [c for c in v.checks if c.passed and "finer sampling" in c.note]
    assert {c.mode_text for c in finer} >= {"a_in=1,a_out=0", "a_in=0,a_out=0"}      # where it failed by 10 %
    assert all(c.violation <= THRESHOLD for c in finer)


def test_a_wrong_relation_still_fails_where_finer_sampling_is_tried():
    """The wheel balance with the brake gain slipped (2 kb for kb): wrong by kb pc tanh(w/w0), a
    term's share that no sampling removes; the refinement must not excuse it."""
    model, arrs = _abs()
    wheel = next(a for a in arrs if a.expr.has(sp.tanh))
    kb = model.symbols["kb"]
    slipped = dataclasses.replace(wheel, expr=wheel.expr.subs(kb, 2 * kb))
    v = verify(model, [slipped], modes=[{"a_in": 1, "a_out": 0}])
    assert not v.ok and v.failures[0].violation > 0.01
    assert "finer" not in v.failures[0].note


def test_a_law_that_reads_a_sensor_the_states_set_is_simulated_and_verified():
    """A transformer modulated by the capacitor's measured voltage v = q/C1 (an effort sensor on the
    capacitor's 0-junction): the simulator refused it until session 41 (it read only displacement
    and momentum sensors); it reads v from the state now, and the ARR verifies."""
    model = load_model_text("""
parameters: {R: {value: 100.0, unit: Ohm}, C1: {value: 1.0e-3, unit: F}, n: {value: 2.0, unit: "-"}}
inputs: {u: {column: u, expr: "1.0", unit: V}}
elements: {src: {type: MSe, input: u}, res: {type: R, parameter: R}, cap: {type: C, parameter: C1},
           tf: {type: MTF, modulus: "n + 0.1*v"}}
junctions: {j1: {type: "1"}, j0: {type: "0"}}
sensors: {v: {type: De, junction: j0, unit: V}}
bonds: {1: [src, j1], 2: [j1, res], 3: [j1, tf], 4: [tf, j0], 5: [j0, cap]}
""")
    v = verify(model)
    assert v.ok and v.complete and all(c.passed for c in v.checks)


def test_a_model_the_simulator_refuses_is_not_verified_and_says_why():
    """A resistor's conductance law that reads its own junction's current i: the reading needs the
    law (a loop through the sensor), which the simulator does not solve; the element is named."""
    model = load_model_text("""
parameters: {R: {value: 100.0, unit: Ohm}, C1: {value: 1.0e-3, unit: F}}
inputs: {u: {column: u, expr: "1.0", unit: V}}
elements: {src: {type: MSe, input: u}, res: {type: R, flow: "e/R*(1 + 0.1*i)"}, cap: {type: C, parameter: C1}}
junctions: {j1: {type: "1"}}
sensors: {i: {type: Df, junction: j1, unit: A}}
bonds: {1: [src, j1], 2: [j1, res], 3: [j1, cap]}
""")
    v = verify(model)
    assert v.ok and not v.complete and all(c.passed is None for c in v.checks)
    assert "not verified" in v.notes[0] and "a loop through the sensor" in v.notes[0]
    assert "element(s) res read the measured signal(s) i" in v.notes[0]         # the element named (a trial)
    assert all(c.note == "the simulator cannot linearise the model (the note says why)" for c in v.checks)


# ------------------------------------------------------------------ bgfdi check --verify

def test_check_verify_passes_on_a_shipped_model(capsys):
    assert main(["check", str(TANKS), "--verify", "-q"]) == 0
    out = capsys.readouterr().out
    assert "6 of 6 ARR-mode checks pass, 0 fail, 0 not verified" in out
    assert main(["check", str(TANKS), "--json", "-q"]) == 0
    assert json.loads(capsys.readouterr().out)["verification"] is None


@pytest.fixture
def slipped_derivation(monkeypatch):
    """bgfdi's residual selection with the valve's flow dropped from ARR1: the slip a derivation bug
    would make, where the CLI takes its residuals from."""
    import fdi.arrs

    real = fdi.arrs.select_arrs

    def select(model, causality="derivative"):
        chosen = real(model, causality)
        arrs = list(chosen.arrs)
        arrs[0] = _without(arrs[0], _valve_term(model, arrs[0]))
        return dataclasses.replace(chosen, arrs=tuple(arrs))
    monkeypatch.setattr(fdi.arrs, "select_arrs", select)


def test_check_verify_fails_naming_the_arr_and_the_mode(slipped_derivation, capsys):
    assert main(["check", str(TANKS), "--verify"]) == 1
    captured = capsys.readouterr()
    errors = [line for line in captured.err.splitlines() if "does not vanish" in line]
    assert len(errors) == 1 and "ARR1" in errors[0] and "mode v=1" in errors[0]
    assert "1 fail" in captured.out


def test_check_verify_json_names_the_failure(slipped_derivation, capsys):
    assert main(["check", str(TANKS), "--verify", "--json", "--seed", "3"]) == 1
    captured = capsys.readouterr()
    data = json.loads(captured.out)["verification"]
    assert data["ok"] is False and data["seed"] == 3 and data["threshold"] == THRESHOLD
    failed = [(c["arr"], c["mode"]) for c in data["checks"] if c["passed"] is False]
    assert failed == [("ARR1", {"v": 1})]
    assert "ARR1" in captured.err and "mode v=1" in captured.err
