"""Mode faults in ``bgfdi isolability``: read from the chosen residuals' MCSM, mode by mode, and
told apart from the component faults (or not) by the physics. A user trial's surge tank
(tests/data/hydro_surge.yaml) has a relief valve on the tank's junction, commanded closed (v = 0)
and open (v = 1), with mode faults v_open and v_closed beside a tank leak Rleak: a valve stuck open
while closed drains the junction by h/Rr as the leak does by h/Rleak, both in the tank's balance
alone, so no residual tells them apart there; stuck closed while closed shows nothing. The command
said every fault isolable (mode faults were left out, unsaid)."""
from __future__ import annotations

import json

from bondgraph.loader import load_model
from fdi.app.cli import main
from fdi.app.isolability_report import analyse

from .conftest import MODELS, ROOT

HYDRO = ROOT / "tests" / "data" / "hydro_surge.yaml"


def _by_mode(analysis) -> dict:
    return {tuple(sorted(m.mode.items())): m for m in analysis.modes}


def test_a_valve_stuck_open_is_in_one_class_with_the_leak_it_drains_as():
    modes = _by_mode(analyse(load_model(str(HYDRO)), max_sensors=0))
    closed, opened = modes[(("v", 0),)], modes[(("v", 1),)]
    # closed: stuck open is the switch to v = 1, read as the leak; stuck closed holds v = 0: nothing to see
    assert ("Rleak", "v_open") in closed.chosen.classes() and closed.held == ("v_closed",)
    assert "v_closed" not in closed.chosen.faults and not closed.chosen.full()
    # open: stuck closed is the switch to v = 0, again only the tank's balance (the valve's flow gone)
    assert ("Rleak", "v_closed") in opened.chosen.classes() and opened.held == ("v_open",)
    # the component faults alone are still isolable and reach the structural best
    assert closed.reaches_best("derivative") and {len(c) for c in closed.best["derivative"].classes()} == {1}


def test_the_command_shows_the_mode_faults_and_says_what_the_best_covers(capsys):
    assert main(["isolability", str(HYDRO), "--max-sensors", "0"]) == 0
    out = capsys.readouterr().out
    assert "{Rleak, v_open}" in out and "{Rleak, v_closed}" in out
    assert "mode faults (MCSM):             v_open [0 1 0]; v_closed: the value this mode already has" in out
    assert "the best and the sensor placement are of the component faults only" in out
    assert main(["isolability", str(HYDRO), "--max-sensors", "0", "--json"]) == 0
    (closed, opened) = json.loads(capsys.readouterr().out)["modes"]
    assert closed["mode"] == {"v": 0} and closed["mode_faults"] == {"v_open": [0, 1, 0]}
    assert closed["mode_faults_held"] == ["v_closed"] and ["Rleak", "v_open"] in closed["chosen"]["classes"]


def test_a_mode_fault_with_a_signature_of_its_own_is_its_own_class():
    """The commanded two-tank system (models/two_tank_commanded.yaml): its valve between the tanks
    closed (v = 0), the pipe resistance R12 carries no flow and no residual sees it; opening the
    valve moves flow from one tank to the other, both balances at once, which no single component
    fault does in that mode: v_open is a class of its own there."""
    modes = _by_mode(analyse(load_model(str(MODELS / "two_tank_commanded.yaml")), max_sensors=0))
    closed = modes[(("v", 0),)]
    assert ("v_open",) in closed.chosen.classes() and closed.mode_faults["v_open"][:2] == (1, 1)
    assert "R12" in closed.chosen.undetectable()
