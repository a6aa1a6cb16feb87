"""A user trial's electric hoist (tests/data/electric_hoist.yaml: DC motor, brake as a 1c, gearbox,
drum, a wire rope as a spring k beside a damper c, the hook load under gravity; current, motor
speed and rope tension measured). By hand, the rope's stiffness is read only through the tension's
second derivative (T'' + (c/m) T' + (k/m)(T - m g) - k rd wm'/N - c rd wm''/N = 0, brake released):
an equation differentiated to eliminate the rope's stretch, which derivative causality's residuals
do not do, so none reads k; without the damper, k enters the drum's balance directly. The trial's
data with the rope losing half its stiffness read "nothing detected", and only `bgfdi isolability`
said k could not be detected."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from fdi.app.cli import main

MODEL = Path(__file__).parent / "data" / "electric_hoist.yaml"


@pytest.fixture(scope="module")
def text() -> str:
    return MODEL.read_text(encoding="utf-8")


def test_check_names_a_declared_fault_no_residual_reads(capsys):
    assert main(["check", str(MODEL)]) == 0
    out = capsys.readouterr().out
    (line,) = [x for x in out.splitlines() if "no residual reads" in x]
    assert "no residual reads k in any mode" in line and "nothing detected" in line and "isolability" in line
    assert main(["check", str(MODEL), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["residuals"]["notes"]
    assert any(n.startswith("no residual reads k in any mode") for n in notes)


def test_without_the_damper_the_stiffness_is_read(tmp_path, text):
    from bondgraph.loader import load_model
    from fdi.arrs import select_arrs
    from fdi.signatures import unread_faults
    plain = text.replace("  R_rope:  {type: R, parameter: c}\n", "").replace("  15: [J_str, R_rope]\n", "")
    assert plain != text
    (tmp_path / "nodamp.yaml").write_text(plain, encoding="utf-8")
    model = load_model(tmp_path / "nodamp.yaml")
    arrs = list(select_arrs(model).arrs)
    assert unread_faults(model, arrs) == []
    assert any(model.symbols["k"] in a.expr.free_symbols for a in arrs)


def test_a_slack_mode_whose_condition_reads_the_sensor_it_switches_off_is_named(tmp_path, text, capsys):
    """The trial's slack rope: the rope's 0c is off while slack, the load cell on it then reads 0, and
    'positive: T' can never be above zero again: simulated, the load fell freely to the end."""
    slack = (text.replace('  J_T:     {type: "0", description: rope tension}',
                          '  J_T:     {type: 0c, mode: taut, description: rope tension}')
                 .replace("modes:\n", 'modes:\n  taut: {nominal: 1, positive: "T", description: "rope taut"}\n'))
    (tmp_path / "slack.yaml").write_text(slack, encoding="utf-8")
    assert main(["check", str(tmp_path / "slack.yaml")]) == 0
    out = capsys.readouterr().out
    assert "mode taut can never switch back in simulation once taut = 0" in out and "reads T, a sensor on J_T" in out
    assert main(["check", str(tmp_path / "slack.yaml"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["simulation"]["latching"][0].startswith("mode taut can never")
