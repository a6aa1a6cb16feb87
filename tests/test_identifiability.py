"""Faults the residuals read only through one combination (fdi.identifiability): against hand
derivations and a designed truth on data from tests/independent/drained_tank.py (scipy, the
volume balance typed by hand, apart from bgfdi).

A gravity-drained tank measured at its inflow and outflow (tests/data/drained_tank.yaml) has no
level sensor: its balance reads the level through the valve law backwards, p = Qout^2/Kv^2, so
Qin - Qout - C dp/dt reads the capacitance C and the valve Kv only as C/Kv^2. A clog Kv x 0.7 is
then a capacitance x 1/0.49 to the last digit, and the report must say so."""
from __future__ import annotations

import json
import math
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from fdi.api import Options, diagnose
from fdi.monitor import compiled

from .independent import drained_tank, measurements, thresholds_fixture

DATA = Path(__file__).resolve().parent / "data"
TANK = str(DATA / "drained_tank.yaml")
ROOT = DATA.parent.parent

_data = partial(measurements, drained_tank.simulate)
thresholds = thresholds_fixture(TANK, drained_tank.simulate)


def _function_of(combination: str, names: tuple[str, str], of: sp.Expr) -> bool:
    """Whether the text ``combination`` of the symbols ``names`` is a function of ``of`` alone:
    written with ``of`` = s, it no longer reads the second name."""
    a, b = (sp.Symbol(n) for n in names)
    expr = sp.sympify(combination, locals={n: sp.Symbol(n) for n in names} | {"N": sp.Symbol("N")})
    s = sp.Symbol("s")
    (a_of_s,) = sp.solve(sp.Eq(of, s), a)
    return b not in sp.simplify(expr.subs(a, a_of_s)).free_symbols


def test_the_tanks_capacitance_and_valve_are_read_only_through_c_over_kv_squared():
    (pair,) = compiled(TANK).coinciding
    assert set(pair.faults) == {"Kv", "C"} and pair.residuals == ("ARR1",)
    C, Kv = sp.symbols("C Kv")
    assert _function_of(pair.combination, ("C", "Kv"), C / Kv ** 2)


def test_a_transformers_winding_resistances_are_read_as_one_referred_to_the_secondary():
    """Hughes, Electrical and Electronic Technology, ch. 31: measured at its currents only, the
    transformer's effort balance (V - R1 i1)/N - N R2 i1 - N L2 i1' reads R1 and R2 only as
    R2 + R1/N^2, the primary's resistance referred to the secondary."""
    (pair,) = compiled(str(DATA / "transformer.yaml")).coinciding
    assert set(pair.faults) == {"R1", "R2"} and pair.residuals == ("ARR2",)
    R1, R2, N = sp.symbols("R1 R2 N")
    assert _function_of(pair.combination, ("R1", "R2"), R2 + R1 / N ** 2)


def test_faults_of_one_signature_whose_fits_differ_are_not_read_together():
    """Frisk et al. (2012): with a pressure sensor on tank 1 and a flow sensor through valve 2, the
    three tanks' valves 2 and 3 and tank 3 share a signature (ARR2 only). Their fits still differ:
    by hand, d ARR2/d Rv2 = CT3 q2' + q2/Rv3 and d ARR2/d Rv3 = (p3 terms)/Rv3^2 move apart with
    the signals, as does the capacitance's derivative term; nothing is read together."""
    assert compiled(str(ROOT / "models" / "three_tank.yaml")).coinciding == ()


def test_the_pairs_travel_with_a_compiled_monitor():
    from fdi.persist import pack, restore
    m = compiled(TANK)
    assert restore(pack(m))["_matrices"]["coinciding"] == m.coinciding


def test_a_clog_is_fitted_as_either_fault_and_the_report_says_they_are_one_fit(thresholds):
    """Designed truth: Kv x 0.7 at 60 s. Whichever fault the search names (seed 0 named the
    capacitance), its fit is the design's C/Kv^2 x 1/0.49; the other is offered as nearly as good,
    with the pair the residuals read together."""
    report = diagnose(TANK, _data("clog", 7, t0=60.0, factor=0.7),
                      Options(workers=1, seed=0, thresholds=thresholds))
    d = report.to_dict()
    (found,) = d["diagnosis"]["faults"]
    ratio = (found["value"] / drained_tank.KV) ** -2 if found["name"] == "Kv" else found["value"] / drained_tank.C
    assert found["type"] == "abrupt" and ratio == pytest.approx(1 / 0.49, rel=0.01)
    (alt,) = [a for a in d["alternatives"] if a["coincides"]]
    assert {found["name"], *alt["candidate"]} == {"Kv", "C"} and set(alt["coincides"]["faults"]) == {"Kv", "C"}
    assert abs(alt["criterion"]) < 0.01
    from fdi.app.report import to_text
    text = to_text(d, "drained_tank", "clog")
    assert "(one fit: the residuals (ARR1) read Kv and C only through" in text
    partner = alt["candidate"][0]
    assert f"    or {partner}: abrupt" in text and f"(read together with {found['name']}: one fit)" in report.summary()


def test_bgfdi_isolability_lists_the_pair(capsys):
    from fdi.app.cli import main
    assert main(["isolability", TANK, "--json", "--max-sensors", "0"]) == 0
    (pair,) = json.loads(capsys.readouterr().out)["read_together"]
    assert set(pair["faults"]) == {"Kv", "C"} and pair["residuals"] == ["ARR1"]


def test_evaluate_grades_a_partner_read_together_on_the_reports_fit_of_the_design():
    """Designed truth: a clog Kv 1e-4 -> 7e-5. A report that names the capacitance and offers the
    valve as its partner read together (``coincides``) is isolated and typed, graded on the
    offered valve fit (7.07e-5: 1 % off); without the pair, or when the alternative is another
    set, the same report is not isolated."""
    from fdi.app.evaluate import format_scores, score, summary
    from fdi.app.scenario import FaultEvent
    design = [FaultEvent("Kv", "abrupt", 60.0, value=7.0e-5)]
    pair = {"faults": ["Kv", "C"], "combination": "Kv**2/C", "residuals": ["ARR1"]}
    offered = {"candidate": ["Kv"], "faults": [{"name": "Kv", "type": "abrupt", "value": 7.07e-5, "t0": 60.0}],
               "cost": 100.0, "criterion": 0.0, "coincides": pair}
    report = {"detection": {"time": 59.8}, "alternatives": [offered],
              "diagnosis": {"faults": [{"name": "C", "type": "abrupt", "value": 1.04e-5, "t0": 60.0}]}}
    s = score("clog", design, report, {})
    assert (s.isolated, s.typed, s.found, s.read_together) == (True, True, ["C"], ["Kv", "C"])
    assert s.errors["Kv"] == pytest.approx(0.01)
    assert "yes*" in format_scores([s], summary([s]))
    for alternatives in ([], [{**offered, "coincides": None}]):
        s = score("clog", design, {**report, "alternatives": alternatives}, {})
        assert (s.isolated, s.read_together, s.errors) == (False, [], {})


def test_laws_that_read_a_pair_together_only_while_a_signal_keeps_its_sign_are_separated():
    """Designed truths: a|x| + b x, a sign(x) x^2 + b x^2 and a max(x, 0) + b x read a and b as
    a + b only while x > 0; a flow that reverses separates them. (a + b) x and the tank's
    a sign(x) x^2 / b^2 read them together whatever the sign."""
    from fdi.identifiability import read_together
    a, b, u = sp.symbols("a b u")
    x = sp.Function("x")(sp.Symbol("t"))
    apart = [u - a * sp.Abs(x) - b * x, a * sp.sign(x) * x ** 2 + b * x ** 2, a * sp.Max(x, 0) + b * x]
    assert not any(read_together([e], a, b, {"a", "b"}) for e in apart)
    assert read_together([u - (a + b) * x], a, b, {"a", "b"})
    assert read_together([u - a * sp.sign(x) * x ** 2 / b ** 2], a, b, {"a", "b"})


def test_a_combination_is_named_from_constants_only():
    """A ratio that still reads a signal names nothing (it is not a pair read together)."""
    from fdi.identifiability import combination
    a, b = sp.symbols("a b")
    x = sp.Function("x")(sp.Symbol("t"))
    assert combination(x / sp.Abs(x), a, b) is None
    assert combination(sp.Integer(2), a, b) == a + b / 2


def test_the_three_tanks_shared_signature_is_decided_apart_pair_by_pair():
    """By hand, d ARR2/d Rv2 = CT3 q2' + q2/Rv3 and d ARR2/d Rv3 = (p3 terms)/Rv3^2: their ratio
    moves with the signals (as does the capacitance's CT3 p3' term): not read together."""
    from fdi.identifiability import _plain, read_together
    m = compiled(str(ROOT / "models" / "three_tank.yaml"))
    (arr2,) = [a for a in m.arrs if a.name == "ARR2"]
    e = _plain(arr2.expr)
    Rv2, Rv3, CT3 = sp.symbols("Rv2 Rv3 CT3")
    constants = set(m.model.nominal_by_name())
    assert read_together([e], Rv2, Rv3, constants) is False
    assert read_together([e], Rv2, CT3, constants) is False


def test_an_offset_or_a_frozen_sensor_is_never_read_together_with_a_parameter(tmp_path):
    """By hand: a resistor across a source with its current measured, u - R i/beta_i, reads R and
    the current sensor's gain only as R/beta_i (Ohm's law through a mis-scaled ammeter). The same
    sensor's offset (i + b) or frozen reading acts on no gain symbol: paired with nothing."""
    path = tmp_path / "resistor.yaml"
    path.write_text(RESISTOR)
    (pair,) = compiled(str(path)).coinciding
    assert set(pair.faults) == {"R", "gain"}
    assert _function_of(pair.combination.replace("beta_i", "B"), ("R", "B"), sp.Symbol("R") / sp.Symbol("B"))


RESISTOR = """name: resistor
parameters:
  R: {value: 10.0, unit: Ohm}
data: {columns: [t, u, i], sampling_time: 0.001}
inputs:
  u: {column: u, unit: V, expr: "sin(t)"}
elements:
  supply: {type: MSe, input: u}
  load: {type: R, parameter: R}
junctions:
  J: {type: "1"}
sensors:
  i: {type: Df, junction: J, column: i, unit: A, noise: 0.001}
bonds:
  1: [supply, J]
  2: [J, load]
faults:
  R: {kind: parametric, parameters: [R]}
  gain: {kind: sensor, sensor: i}
  offset: {kind: sensor, sensor: i, effect: bias}
  frozen: {kind: sensor, sensor: i, effect: stuck}
"""


def test_evaluate_does_not_hide_an_extra_final_fault_behind_a_pair():
    """Designed: truth {Kv}; the report's final faults are {C, X} (a later decision added X) and
    its first decision offered {Kv} as C's partner. The pair does not turn {C, X} into {Kv}."""
    from fdi.app.evaluate import score
    from fdi.app.scenario import FaultEvent
    pair = {"faults": ["Kv", "C"], "combination": "Kv**2/C", "residuals": ["ARR1"]}
    offered = {"candidate": ["Kv"], "faults": [{"name": "Kv", "type": "abrupt", "value": 7.0e-5, "t0": 60.0}],
               "cost": 1.0, "criterion": 0.0, "coincides": pair}
    report = {"detection": {"time": 59.8}, "alternatives": [offered],
              "diagnosis": {"faults": [{"name": "C", "type": "abrupt", "value": 1e-5, "t0": 60.0},
                                       {"name": "X", "type": "abrupt", "value": 1.0, "t0": 70.0}]}}
    s = score("clog", [FaultEvent("Kv", "abrupt", 60.0, value=7.0e-5)], report, {})
    assert not s.isolated and s.read_together == []


def test_a_rul_checkpoint_refits_the_design_where_the_report_named_its_partner(monkeypatch):
    """Designed: the valve clogs by eq. (16), Kv = 1e-4 exp(-0.005 (t - 20)), failing at 6e-5:
    EOL = 20 + ln(0.6) / -0.005 = 122.2 s. At each checkpoint the diagnosis names the capacitance,
    its partner read only through C/Kv^2, and offers the valve's fit beside it; the refit starts
    from that fit of the design (not C's), and the checkpoint is graded on the valve's prognosis,
    marked read together. Without the pair, the same report is no prediction of the valve."""
    from fdi.app import evaluate
    from fdi.app.scenario import FaultEvent, Scenario
    from fdi.config import load
    from fdi.data import Measurements
    from fdi.detect import Detection
    from fdi.options import Options
    from fdi.prognose import end_of_life
    from fdi.results import Alternative, Coincidence, Diagnosis, Fault, Prognosis
    model, config = load(TANK)
    b, failure, t0 = -0.005, 6.0e-5, 20.0
    eol = t0 + math.log(failure / 1.0e-4) / b
    design = FaultEvent("Kv", "incipient", t0, model=1, b=(b,), failure=failure)
    scenario = Scenario("clog.json", 0, 130.0, 20.0, {}, (design,), {}, {})
    t = np.arange(0.0, 130.0, 0.05)
    meas = Measurements("clog", t, {"t": t, "Qin": np.zeros_like(t), "Qout": np.zeros_like(t)})
    valve = Fault("Kv", "incipient", model=1, eta=(0, 0), b=(b,), t0=t0)
    pair = Coincidence(("Kv", "C"), "C/Kv**2", ("ARR1",), ("Kv", "C"))

    def report(coincides):
        return Diagnosis("drained_tank", {}, Detection(25.0, (1,), 26.0, (1,), 500),
                         faults=(Fault("C", "incipient", model=1, eta=(0, 0), b=(-2 * b,), t0=t0),),
                         alternatives=(Alternative(("Kv",), (valve.to_dict(),), 1.0, 0.0, coincides),))
    refitted = []

    def refresh(monitor, prefix, d, o, memo):
        refitted.append([f.name for f in d.faults])
        now = float(prefix.t[-1])
        ends = {f.name: end_of_life(1, list(f.b), 1.0e-4, failure, f.t0, now) for f in d.faults if f.name == "Kv"}
        return tuple(f.to_dict() for f in d.faults), tuple(
            Prognosis(n, failure, e, e - now, now, 0.0, 1e9) for n, e in ends.items())
    monkeypatch.setattr(evaluate, "refresh_prognosis", refresh)
    for coincides, graded in ((pair, True), (None, False)):
        monkeypatch.setattr(evaluate, "compiled", lambda path, r=report(coincides): type(
            "M", (), {"diagnose": lambda self, *a: r})())
        refitted.clear()
        points = evaluate.rul_checkpoints(TANK, model, config, scenario, meas, {}, Options(workers=1))
        assert [p["t"] for p in points] == pytest.approx([t0 + f * (eol - t0) for f in (0.5, 0.9)])
        if graded:
            assert refitted == [["Kv"], ["Kv"]]
            assert all(p["read_together"] == ["Kv", "C"] for p in points)
            assert all(abs(p["rul"] - p["true_rul"]) <= 0.05 for p in points)    # from the last sample before
        else:
            assert refitted == [] and all(p["rul"] is None for p in points)
            assert all(p["note"] == "the fault is not diagnosed incipient at this point" for p in points)


def test_a_source_gain_and_a_sensor_gain_read_as_a_product_where_the_residual_vanishes():
    """By hand (tests/data/cstr.yaml): the reactor's balance beta_F F = (V c' + c/Rrx + c/Rout)/beta_c
    holds on the data for every pair with the same beta_F beta_c (a feed 10 % high makes the
    concentration 10 % high in this linear plant, which a 10 % high analyser also shows): only the
    product is read. Compared at free points of the signals, the ratio of the partial derivatives,
    -F beta_c^2 / (V c' + c/Rrx + c/Rout), moves with them, and the pair was not named."""
    pairs = {frozenset(c.faults): c for c in compiled(str(DATA / "cstr.yaml")).coinciding}
    pair = pairs[frozenset({"feed_meter", "analyser"})]
    names = dict(zip(pair.faults, pair.symbols))
    feed, analyser = names["feed_meter"], names["analyser"]
    assert _function_of(pair.combination, (feed, analyser), sp.Symbol(feed) * sp.Symbol(analyser))
    assert frozenset({"catalyst", "holdup"}) not in pairs          # Rrx and V: separated by c' (by hand)


def test_the_zero_set_is_used_only_where_it_is_free_and_real():
    """By hand: a motor's loop u - k1 k2 w - R i - L i' reads its torque constant's two factors only
    as k1 k2 (solving i from r = 0 would also change i': that signal is not free there); an
    orifice Q - Cd A sqrt(2 p / rho) reads Cd A only (its zero set is complex for p < 0: compared at
    free points); an RL loop reads R and L apart (i and i' are independent at an instant)."""
    from fdi.identifiability import ratio, read_together
    t = sp.Symbol("t")
    u, w, i, Q, p = (sp.Function(n)(t) for n in ("u", "w", "i", "Q", "p"))
    k1, k2, R, L, Cd, A, rho = sp.symbols("k1 k2 R L Cd A rho")
    motor = [u - k1 * k2 * w - R * i - L * i.diff(t)]
    orifice = [Q - Cd * A * sp.sqrt(2 * p / rho)]
    assert read_together(motor, k1, k2, {"k1", "k2", "R", "L"}) and sp.simplify(ratio(motor, k1, k2) - k2 / k1) == 0
    assert read_together(orifice, Cd, A, {"Cd", "A", "rho"})
    assert not read_together([u - R * i - L * i.diff(t)], R, L, {"R", "L"})


def test_a_final_fault_read_together_with_one_left_out_is_noted_unless_an_alternative_says_so():
    """The drained tank's C and Kv are read only through C/Kv**2 (the derivation above): a diagnosis
    naming one of them says the other fits as well, unless its alternatives already offer that
    pair (fdi.pipeline.read_together). A trial's hoist, decided again twice, reported its drum
    bearing drifting, the motor bearing's friction being the truth, with nothing said."""
    from types import SimpleNamespace

    from fdi.pipeline import read_together
    from fdi.results import Alternative, Diagnosis, Fault
    p = SimpleNamespace(monitor=compiled(TANK))
    (pair,) = p.monitor.coinciding
    d = Diagnosis("drained_tank", {}, faults=(Fault("Kv", "abrupt", value=1e-3, t0=5.0),))
    note = read_together(p, d)
    assert note.startswith(pair.describe()) and "a change of C fits these data as well as one of Kv" in note
    offered = Alternative(("C",), ({"name": "C", "type": "abrupt", "value": 2.0, "t0": 5.0},), 1.0, 0.1, pair)
    assert read_together(p, replace(d, alternatives=(offered,))) is None
    assert read_together(p, replace(d, faults=d.faults + (Fault("C", "abrupt", value=2.0, t0=5.0),))) is None
