"""A controlled junction switched off imposes its constraint on every bond (Mosterman & Biswas
1998): a 1c carries no flow, a 0c no effort. Joined to a plain junction of its own kind it holds
that junction's common variable at 0. A user trial's elevator wrote its holding brake as a 1c on
the sheave's 1-junction: released (brk = 0), the brake locked the sheave, and the only hint was a
residual "summing different units by mode". `check` now says it, with the fix. Designed models:
a shaft (1-junction: motor torque, inertia, bearing) with a brake branch switched by a 1c (held
still while off) or by a 0c (only the brake's torque cut), and without its inertia (nothing held:
not named); a node (0-junction) with a capacitance and a shorting 0c (its voltage held at 0)."""
from __future__ import annotations

from bondgraph.loader import load_model_text
from bondgraph.modes import held_still
from fdi.app.cli import main

SHAFT = """\
name: braked_shaft
parameters:
  J: {value: 0.5, unit: kg*m^2}
  b: {value: 0.1, unit: N*m*s/rad}
  Rb: {value: 100.0, unit: N*m*s/rad}
data: {columns: [t, tau, brk, w]}
inputs:
  tau: {column: tau, unit: N*m}
modes:
  brk: {nominal: 0, column: brk}
elements:
  motor: {type: MSe, input: tau}
  inertia: {type: I, parameter: J}
  bearing: {type: R, parameter: b}
  brake: {type: R, parameter: Rb}
junctions:
  shaft: {type: "1"}
  sw: {type: KIND, mode: brk}
sensors:
  w: {type: Df, junction: shaft, column: w, unit: rad/s}
bonds:
  1: [motor, shaft]
  2: [shaft, inertia]
  3: [shaft, bearing]
  4: [shaft, sw]
  5: [sw, brake]
"""


def test_a_switch_that_holds_its_neighbour_still_is_named_with_its_fix(tmp_path, capsys):
    (note,) = held_still(load_model_text(SHAFT.replace("KIND", "1c"), "shaft.yaml"))
    assert note.startswith("with brk = 0, sw (1c) carries no flow on any bond, so it holds shaft's flow at 0: "
                           "inertia stand(s) still in that mode (with bearing, inertia, motor)")
    assert "not for a brake or a clutch that should only cut its branch's effort" in note and "a 0c on the branch" in note
    # the same switch on a junction with no inertia (a valve between two lines of no inertance) is not named
    no_mass = SHAFT.replace("KIND", "1c").replace("  2: [shaft, inertia]\n", "").replace(
        "  inertia: {type: I, parameter: J}\n", "")
    assert held_still(load_model_text(no_mass, "shaft.yaml")) == []
    assert held_still(load_model_text(SHAFT.replace("KIND", "0c"), "shaft.yaml")) == []
    assert held_still(load_model_text(SHAFT.replace("KIND", "1c").replace(
        "sw: {type: 1c, mode: brk}", "sw: {type: 1c, mode: brk, switched_off: outputs}"), "shaft.yaml")) == []
    node = SHAFT.replace("KIND", "0c").replace('shaft: {type: "1"}', 'shaft: {type: "0"}').replace(
        "w: {type: Df", "w: {type: De").replace("inertia: {type: I, parameter: J}", "inertia: {type: C, parameter: J}")
    (dual,) = held_still(load_model_text(node, "node.yaml"))
    assert "sw (0c) carries no effort on any bond, so it holds shaft's effort at 0: inertia discharge(s) to 0" in dual
    assert "that is a 1c on the branch" in dual
    path = tmp_path / "shaft.yaml"
    path.write_text(SHAFT.replace("KIND", "1c"), encoding="utf-8")
    main(["check", str(path)])
    assert "    note: with brk = 0, sw (1c) carries no flow on any bond" in capsys.readouterr().out


def test_verify_draws_a_mode_s_random_states_from_its_own_states():
    """A trial's drone motor: its winding's inductance hangs on a 1c alone, so disarmed (mode 0) the
    winding is gone; `check --verify` drew the random initial states of every mode from the states
    all modes visit, and the disarmed runs 2 and 3 were left out ("initial value(s) for L_wind: no
    state or sensor of that name"). That model (tests/data/drone_propulsion.yaml): every run of
    both modes is simulated now, and the disarmed mode's two residuals that read the rotor pass."""
    from pathlib import Path

    from bondgraph.loader import load_model
    from fdi.arrs import select_arrs
    from fdi.verify import verify
    model = load_model(Path(__file__).parent / "data" / "drone_propulsion.yaml")
    v = verify(model, list(select_arrs(model).arrs), seed=0)
    assert v.settings is not None and not [r for r in v.settings.left_out if "initial value" in r.why]
    disarmed = [c for c in v.checks if dict(c.mode) == {"arm": 0} and c.passed]
    assert len(disarmed) == 2 and all(c.runs == 3 for c in disarmed)
