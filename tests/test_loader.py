"""The model loader: the shipped models load; each kind of bad input gives one clear error."""
from __future__ import annotations

import math
import subprocess
import sys

import pytest

from bondgraph.errors import ModelError
from bondgraph.loader import load_model, load_model_text
from fdi.app.cli import main

from .conftest import CYCAB, MODELS, SHIPPED

BASE = """\
name: rc
parameters:
  R: {value: 100.0, unit: Ohm}
  C1: {value: 1.0e-3, unit: F}
data: {columns: [t, u, v]}
inputs:
  u: {column: u, unit: V}
elements:
  src: {type: MSe, input: u}
  res: {type: R, parameter: R}
  cap: {type: C, parameter: C1}
junctions:
  j1: {type: "1"}
  j0: {type: "0"}
sensors:
  v: {type: De, junction: j0, column: v, unit: V}
bonds:
  1: [src, j1]
  2: [j1, res]
  3: [j1, j0]
  4: [j0, cap]
"""


def test_cycab_loads_with_the_fixed_names(cycab):
    for p in ["k1", "k2", "k3", "k4", "k5", "J1", "J2", "J3", "kf2", "Fu2", "kf3", "Fu3", "kf5", "Fu5",
              "A", "R1", "R4", "r_a", "L", "w"]:
        assert p in cycab.parameters
    assert math.isinf(cycab.parameters["R4"].value)
    assert list(cycab.sensors) == ["theta1", "dp", "theta2"]
    assert list(cycab.inputs) == ["u_in"]
    assert list(cycab.modes) == ["a1", "a2"]
    assert set(cycab.faults) == {"R4", "R5", "beta_theta1", "beta_theta2", "beta_dp", "a1", "a2"}
    assert cycab.faults["R5"].targets == ("kf5", "Fu5")
    assert cycab.parameters["k1"].value == 5.0 and cycab.parameters["kf5"].value == 300.0
    assert str(cycab.sensors["dp"].signal) == "p1 - p2"


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_model_loads(path):
    m = load_model(path)
    assert m.elements and m.bonds and m.sensors and m.faults


def test_base_fixture_is_valid():
    m = load_model_text(BASE, "rc.yaml")
    assert len(m.bonds) == 4


def _err(text: str) -> ModelError:
    with pytest.raises(ModelError) as info:
        load_model_text(text, "bad.yaml")
    return info.value


@pytest.mark.parametrize("old, new, fragments", [
    ("res: {type: R, parameter: R}", "res: {type: Resistor, parameter: R}", ["unknown element type 'Resistor'", "elements.res.type"]),
    ("  4: [j0, cap]", "  4: [j0, capp]", ["dangling", "'capp'"]),
    ("  4: [j0, cap]", "  4: [j0, cap]\n  5: [cap, j0]", ["duplicate bond", "bond 4"]),
    ("  4: [j0, cap]", "  4: [j0, cap]\n  4: [j0, cap]", ["duplicate key '4'"]),
    ("  R: {value: 100.0, unit: Ohm}", "  R: {unit: Ohm}", ["has no value"]),
    ("  R: {value: 100.0, unit: Ohm}", "  R: {value: 100.0, unit: Ohms}", ["unknown unit 'Ohms'"]),
    ("  R: {value: 100.0, unit: Ohm}", "  R: {value: 100.0, unit: 'N**x'}", ["cannot read unit"]),
    ("res: {type: R, parameter: R}", "res: {type: R, effort: 'Rr*f'}", ["undefined symbol 'Rr'", "did you mean 'R'"]),
    ("res: {type: R, parameter: R}", "res: {type: R, effort: 'R*tanh(e)'}",
     ["elements.res.effort", "effort law is written in f (its flow), not e", "under 'flow'"]),
    ("cap: {type: C, parameter: C1}", "cap: {type: C, effort: 'e/C1'}", ["effort law is written in q", "not e"]),
    ("res: {type: R, parameter: R}", "res: {type: R, effort: \"__import__('os').getcwd()\"}", ["not allowed"]),
    ("res: {type: R, parameter: R}", "res: {type: R, effort: 'R.real'}", ["not allowed"]),
    ("v: {type: De, junction: j0, column: v, unit: V}", "v: {type: De, column: v, unit: V}", ["on no junction"]),
    ("v: {type: De, junction: j0, column: v, unit: V}", "v: {type: De, junction: jx, column: v, unit: V}", ["no junction"]),
    ("v: {type: De, junction: j0, column: v, unit: V}", "v: {type: De, junction: j1, column: v, unit: V}", ["0-junction"]),
    ("  j0: {type: \"0\"}", "  j0: {type: \"0c\"}", ["needs mode"]),
    ("src: {type: MSe, input: u}", "src: {type: MSe, input: uu}", ["undefined input 'uu'"]),
    # a trial's battery pack: value "-Iinv" and input: Iinv, the sign dropped with no word
    ("src: {type: MSe, input: u}", "src: {type: MSe, input: u, value: '-u'}",
     ["elements.src", "both input and value", "keep one"]),
    # a trial's cell charged while it discharged: its storage's bond drawn outwards (q' = f regardless)
    ("  4: [j0, cap]", "  4: [cap, j0]", ["bonds.4", "points away from C 'cap'", "write it [j0, cap]"]),
    # a trial's orifice law read a Greek capital kappa's 'Κpa', another parameter, for 'Kpa'
    ("  R: {value: 100.0, unit: Ohm}", "  R: {value: 100.0, unit: Ohm}\n  \u04211: {value: 1.0, unit: F}",
     ["'C1' and '\u04211' (a parameter) look alike", "U+0421 CYRILLIC CAPITAL LETTER ES", "rename one"]),
    ("cap: {type: C, parameter: C1}", "cap: {type: C, parameter: \u04211}",
     ["undefined parameter '\u04211'", "did you mean 'C1'? '\u0421' is U+0421 CYRILLIC CAPITAL LETTER ES"]),
    ("cap: {type: C, parameter: C1}", "cap: {type: C, parameter: C2}", ["undefined parameter 'C2'"]),
    ("  C1: {value: 1.0e-3, unit: F}", "  C1: {value: -1.0e-3, unit: F}",
     ["elements.cap.parameter", "'C1' = -0.001", "only when positive", "give its positive value"]),
    ("  C1: {value: 1.0e-3, unit: F}", "  C1: {value: 0, unit: F}", ["elements.cap.parameter", "'C1' = 0"]),
    ("  R: {value: 100.0, unit: Ohm}", "  R: {value: 1.0e308, unit: Ohm}", ["parameters.R.value", "beyond 1e300", ".inf"]),
    ("res: {type: R, parameter: R}", "off: {type: R, parameter: R}",       # YAML 1.1 read it as False (my own trial)
     ["elements", "a name reads as False in YAML (no, off or false unquoted)", "quote it"]),
    ("  C1: {value: 1.0e-3, unit: F}", "  C1: {value: 1.0e-320, unit: F}",      # a user trial: q/C1 overflowed in simulate
     ["parameters.C1.value", "below 1e-300", "dividing by it overflows"]),
    ("  R: {value: 100.0, unit: Ohm}", "  R: {value: 100.0, unit: Ohm, description: leak (wet, aged)}",
     ["unknown key 'aged)'", "quote the text"]),
    ("  R: {value: 100.0, unit: Ohm}", "  R: {value: 100.0, unti: Ohm}", ["unknown key 'unti'", "allowed: "]),
    ("  4: [j0, cap]", "  4: [j0, cap]\nfaults:\n  fR: {kind: parametric, parameters: [R, R]}",
     ["faults.fR.parameters", "R listed twice", "name each parameter once"]),
    ("  4: [j0, cap]", "  4: [j0, cap]\ninitial: {vv: 1.0}",
     ["initial.vv", "'vv' is no storage element or sensor", "storage element's name", ": cap, v"]),
])
def test_bad_input_is_one_clear_error(old, new, fragments):
    assert old in BASE
    err = _err(BASE.replace(old, new))
    text = str(err)
    assert text.startswith("bad.yaml")
    assert "\n" not in text
    for f in fragments:
        assert f in text


def test_errors_carry_the_line_number():
    err = _err(BASE.replace("res: {type: R, parameter: R}", "res: {type: Resistor, parameter: R}"))
    assert err.line == BASE.splitlines().index("  res: {type: R, parameter: R}") + 1


def test_tf_needs_exactly_two_bonds():
    text = BASE.replace("  cap: {type: C, parameter: C1}", "  cap: {type: C, parameter: C1}\n  tf: {type: TF, modulus: R}")
    text += "  5: [j0, tf]\n"
    assert "needs exactly two" in str(_err(text))


def test_tf_modulus_must_be_constant():
    text = BASE.replace("  cap: {type: C, parameter: C1}", "  cap: {type: C, parameter: C1}\n  tf: {type: TF, modulus: v*R}")
    text += "  5: [j0, tf]\n  6: [tf, j1]\n"
    assert "use MTF" in str(_err(text))


def test_not_yaml_and_not_a_mapping():
    assert "not valid YAML" in str(_err("a: [1, 2"))
    assert "top level must be a mapping" in str(_err("- 1\n- 2\n"))


def test_cli_bad_model_exits_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BASE.replace("  4: [j0, cap]", "  4: [j0, capp]"))
    assert main(["check", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "dangling" in err and "bad.yaml" in err


def test_console_script_prints_no_traceback(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BASE.replace("  R: {value: 100.0, unit: Ohm}", "  R: {unit: Ohm}"))
    proc = subprocess.run([sys.executable, "-m", "fdi.app.cli", "check", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "has no value" in proc.stderr


def test_missing_file(capsys):
    assert main(["check", "no/such/model.yaml"]) == 2
    assert "cannot read model file" in capsys.readouterr().err


def test_check_cycab(capsys):
    assert main(["check", str(CYCAB)]) == 0
    out = capsys.readouterr().out
    assert "one assignment, valid in all 4 mode(s)" in out
    assert "all storage elements in derivative causality" in out


def test_monitor_settings_are_read_apart_from_the_bond_graph():
    """The bond graph is physics only; the file's thresholds, diagnosis section and each fault's
    bounds and failure value are the monitor's (fdi.config), as the CyCab file writes them."""
    from fdi.config import load
    model, config = load(CYCAB)
    assert not hasattr(model, "thresholds") and not hasattr(model.faults["R4"], "bounds")
    assert dict(config.thresholds) == {"ARR1": 1.0, "ARR2": 5.5e-6, "ARR3": 15.0}
    assert (config.waiting_time, config.samples, config.derivative_window) == (5.0, 1000, 0.25)
    assert config.failure("beta_theta2") is not None and config.bounds("R4") is not None
    assert config.replace(thresholds={"ARR2": 1e-5}).thresholds == {"ARR1": 1.0, "ARR2": 1e-5, "ARR3": 15.0}


def test_monitor_settings_errors_name_file_key_and_line():
    from fdi.config import load_text
    bad = BASE + "diagnosis:\n  waiting_time: -1\n"
    with pytest.raises(ModelError, match=r"rc.yaml:\d+: diagnosis.waiting_time: .*at least 0"):
        load_text(bad, "rc.yaml")
    with pytest.raises(ModelError, match="thresholds.nope: 'nope' is no residual"):
        load_text(BASE + "thresholds: {nope: 1}\n", "rc.yaml")


# The loader constructs a document without anchors in one walk of its own (bondgraph.loader._plain);
# PyYAML's safe_load is the reference it must equal, and the limits _measure enforces must hold.
PLAIN_DOCS = [
    "a: 1\nb: 0x1f\nc: 1_000\nd: 1.5e3\ne: .inf\nf: -.Inf\ng: yes\nh: No\ni: ~\nj: null\nk: 'x: y'\n",
    "t: 2001-12-14t21:59:43.10-05:00\nd: 2002-12-14\nb: !!binary aGVsbG8=\ns: !!str 12\nf: !!float 3\n",
    "list: [1, [2, {x: 3}], 'four', 5.0]\nmap: {1: one, 2.5: two, true: three, null: four}\n",
    "nested:\n  - a: {b: [c, d]}\n  - - 1\n    - 2\nempty: {}\nnone: []\nblank:\n",
    "é: ünïcödé\n\"quoted key\": \"tab\\tand newline\\n\"\nfolded: >\n  one\n  two\nliteral: |\n  one\n  two\n",
]
GENERAL_DOCS = [            # left to PyYAML's constructor: anchors, merge keys, sets, ordered maps
    "base: &b {x: 1, y: 2}\nderived:\n  <<: *b\n  y: 3\n",
    "derived:\n  <<: {x: 1}\n  y: 3\n",
    "s: !!set {a, b}\no: !!omap [{a: 1}, {b: 2}]\n",
    "a: &x [1, 2]\nb: *x\n",
]


@pytest.mark.parametrize("text", PLAIN_DOCS + GENERAL_DOCS)
def test_documents_read_as_safe_load_reads_them(text):
    import yaml

    from bondgraph.loader import read_document_text
    assert read_document_text(text, "m.yaml").data == yaml.safe_load(text)


@pytest.mark.parametrize("text", PLAIN_DOCS)
def test_a_document_without_anchors_is_built_in_one_walk(text):
    import yaml

    from bondgraph.loader import _GENERAL, _compose, _plain
    loader, node = _compose(text)
    got = _plain(loader, node, "m.yaml")
    loader.dispose()
    assert got is not _GENERAL and got == yaml.safe_load(text)


def test_nesting_and_size_limits_hold_without_anchors():
    from bondgraph.loader import MAX_NESTING, MAX_NODES, read_document_text
    deep = "".join("  " * i + f"k{i}:\n" for i in range(MAX_NESTING + 5)) + "  " * (MAX_NESTING + 5) + "v: 1\n"
    with pytest.raises(ModelError, match=f"nested more than {MAX_NESTING} levels") as exc:
        read_document_text(deep, "deep.yaml")
    assert exc.value.line == MAX_NESTING + 1          # the first line past the limit
    wide = "x: [" + ", ".join(["1"] * (MAX_NODES + 10)) + "]\n"
    with pytest.raises(ModelError, match=f"more than {MAX_NODES} values"):
        read_document_text(wide, "wide.yaml")


@pytest.mark.parametrize("text", ["x:\n" + "- 0\n" * 12 + "y: 1\n",                       # a long list
                                  "a:\n  b:\n    c:\n      - 1\n      - 2\n      - 3\n      - [4, 5, 6, 7]\n"])
def test_a_limit_names_the_node_pyyaml_s_measure_names(text, monkeypatch):
    """The size limit (lowered here) and the nesting limit are met at the same node, with the same
    message, whether the loader's one walk or PyYAML's measured construction reads the text (an
    anchor's '&' in a comment sends it to the latter)."""
    from bondgraph import loader
    for nodes, nesting in ((10, 64), (6, 3), (1000, 1)):
        monkeypatch.setattr(loader, "MAX_NODES", nodes)
        monkeypatch.setattr(loader, "MAX_NESTING", nesting)
        got = []
        for t in (text, "# &\n" + text):
            with pytest.raises(ModelError) as exc:
                loader.read_document_text(t, "m.yaml")
            got.append((str(exc.value).split(": ", 1)[1], exc.value.line - (1 if t.startswith("#") else 0)))
        assert got[0] == got[1]


@pytest.mark.parametrize("value, kind", [("!!int x", "int"), ("!!float 'x'", "float"), ("!!timestamp 'x'", "timestamp")])
def test_a_value_its_tag_does_not_fit_is_one_line_and_a_duplicate_key_comes_first(value, kind):
    from bondgraph.loader import read_document_text
    with pytest.raises(ModelError, match=f"is no {kind}; write one or remove its !!{kind} tag") as exc:
        read_document_text(f"a: 1\nb: {value}\n", "m.yaml")
    assert exc.value.line == 2
    with pytest.raises(ModelError, match="duplicate key 'a'"):
        read_document_text(f"a: 1\na: 2\nb: {value}\n", "m.yaml")


def test_an_integer_too_long_for_python_is_one_line_that_names_no_tag():
    """A value of 5 000 digits (Python converts at most 4 300: a hostile file's, and no tag was
    written): the line said "is no int; write one or remove its !!int tag"."""
    from bondgraph.loader import read_document_text
    with pytest.raises(ModelError, match="an integer of 5000 digits; a model's numbers are floats") as exc:
        read_document_text("a: 1\nb: " + "9" * 5000 + "\n", "m.yaml")
    assert exc.value.line == 2 and "!!" not in str(exc.value)


@pytest.mark.parametrize("kind", ["TF", "GY"])
@pytest.mark.parametrize("modulus, value", [("n", "0.0"), ("2*n", "0.0"), ("n", ".inf"), ("0", "1.0"), ("1/n", "0.0"),
                                            ("n - n", "1.0")])
def test_a_two_port_of_modulus_zero_or_infinite_is_refused_with_its_value(kind, modulus, value):
    """A TF (or GY) of modulus 0 couples nothing and the derivation divides by it (a loudspeaker's
    cone area typed as 0 gave the voice-coil residual inf); a modulus of n = 0.5 loads."""
    text = (BASE.replace("  C1: {value: 1.0e-3, unit: F}\n", f"  C1: {{value: 1.0e-3, unit: F}}\n  n: {{value: {value}}}\n")
            .replace("  cap: {type: C, parameter: C1}\n", f"  cap: {{type: C, parameter: C1}}\n  tf: {{type: {kind}, modulus: '{modulus}'}}\n")
            .replace("  j0: {type: \"0\"}\n", "  j0: {type: \"0\"}\n  j2: {type: \"0\"}\n")
            .replace("  3: [j1, j0]\n", "  3: [j1, tf]\n  5: [tf, j2]\n  6: [j2, j0]\n"))
    err = _err(text)
    assert "elements.tf.modulus" in str(err) and "couples nothing" in str(err)
    if modulus == "1/n":        # (a trial read "1/N = nan": the value that makes it so is named)
        assert "modulus 1/n, not finite at the parameters' values (n = 0)" in str(err)
    load_model_text(text.replace(f"n: {{value: {value}}}", "n: {value: 0.5}").replace("modulus: '0'", "modulus: '0.5'")
                    .replace("modulus: 'n - n'", "modulus: 'n'"))


def test_check_names_a_command_column_no_mode_reads(tmp_path, capsys):
    """A mode meant to follow its command but given no ``column:`` is held at its nominal value
    (a user's EV precharge model: the main contactor's m_cmd beside a mode m without column, and
    every closing of the contactor was diagnosed as a fault). It is legal (a mode only a fault
    changes, as the CyCab's), so check says what drives each mode and names the column nothing reads."""
    text = (MODELS / "two_tank_commanded.yaml").read_text(encoding="utf-8")
    given = ', column: v_cmd, expr: "heaviside(300 - t)"'
    assert given in text
    model = tmp_path / "forgot.yaml"
    model.write_text(text.replace(given, ""), encoding="utf-8")
    assert main(["check", str(model)]) == 0
    out = capsys.readouterr().out
    assert "v (1 unless a fault" in out and "data column v_cmd is read by nothing" in out
    assert main(["check", str(MODELS / "two_tank_commanded.yaml")]) == 0
    out = capsys.readouterr().out
    assert "v (commanded: v_cmd)" in out and "read by nothing" not in out


def test_the_time_column_may_stand_anywhere_but_must_be_there():
    """Records need a t column, not in first place (fdi.data finds it by name): a model listing it
    second loads; one without it is refused naming data.columns (a trial's model passed check)."""
    assert load_model_text(BASE.replace("columns: [t, u, v]", "columns: [u, t, v]"), "rc.yaml").columns == ("u", "t", "v")
    err = _err(BASE.replace("columns: [t, u, v]", "columns: [u, v]"))
    assert "data.columns" in str(err) and "no time column t" in str(err)


def _check_line(tmp_path, capsys, text: str) -> tuple[int, str]:
    path = tmp_path / "m.yaml"
    path.write_text(text, encoding="utf-8")
    code = main(["check", str(path)])
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return code, err


def test_an_infinite_parameter_a_residual_multiplies_by_is_refused_with_its_key(tmp_path, capsys):
    """A capacitance of .inf (a user trial: an inertia J1 of .inf) makes the RC's residual, which
    reads C1 dv/dt, infinite on every sample: the diagnosis said "nothing detected". Refused as a
    divisor of 0 is; the CyCab's leakage resistance R4 of .inf, which its residuals divide by, loads."""
    code, err = _check_line(tmp_path, capsys, BASE.replace("C1: {value: 1.0e-3", "C1: {value: .inf"))
    assert code == 2
    assert "parameters.C1.value: parameter 'C1' is infinite, and ARR1 multiplies by it" in err
    assert main(["check", str(CYCAB)]) == 0


def test_search_bounds_must_be_finite(tmp_path, capsys):
    """A fault's bounds of [0.01, .inf] passed the loader and crashed the diagnosis at the first fault
    (a user trial): the search draws values between the bounds."""
    text = BASE + "faults:\n  R_up: {kind: parametric, parameters: [R], bounds: [1.0, .inf]}\n"
    code, err = _check_line(tmp_path, capsys, text)
    assert code == 2 and "faults.R_up.bounds: bound must be finite" in err


def test_search_bounds_keep_the_parameter_s_sign(tmp_path, capsys):
    """A trial's [-1e14, 1e14] on a valve's resistance was taken without a word (half the search spent on
    negative resistances); down to 0 stays allowed (a friction or a heater's power that vanishes)."""
    text = BASE + "faults:\n  R_up: {kind: parametric, parameters: [R], bounds: [-100.0, 1000.0]}\n"
    code, err = _check_line(tmp_path, capsys, text)
    assert code == 2 and "faults.R_up.bounds: bounds [-100, 1000] cross 0 from R = 100" in err
    assert "lower bound of 0 or more" in err and "fix the sign" not in err
    # bounds wholly of the other sign: the value's sign may be the slip (a trial's -4e-6 orifice coefficient)
    text = BASE + "faults:\n  R_up: {kind: parametric, parameters: [R], bounds: [-1000.0, -10.0]}\n"
    code, err = _check_line(tmp_path, capsys, text)
    assert code == 2 and "or, if R is negative as the bounds say, fix the sign of its value under parameters" in err
    path = tmp_path / "zero.yaml"
    path.write_text(BASE + "faults:\n  R_up: {kind: parametric, parameters: [R], bounds: [0.0, 1000.0]}\n",
                    encoding="utf-8")
    assert main(["check", str(path)]) == 0


@pytest.mark.parametrize("old, new, words", [
    ("  cap: {type: C, parameter: C1}", "  cap: {parameter: C1}", ["elements.cap: has no type", "type: R"]),
    ("  j0: {type: \"0\"}", "  j0: {type: \"0c\", mode: s}", ["junctions.j0.mode: undefined symbol 's'", "modes"]),
    ("name: rc", "name: " + "r" * 201, ["name: the model's name is 201 characters long", "description"]),
])
def test_a_model_mistake_says_what_to_change(tmp_path, capsys, old, new, words):
    """What a user trial met: a missing element type was "unknown element type 'None'", an undefined
    mode variable was to be defined "under parameters, inputs or sensors", and a name of 100 000
    characters was echoed in every report."""
    assert old in BASE
    code, err = _check_line(tmp_path, capsys, BASE.replace(old, new))
    assert code == 2
    for w in words:
        assert w in err, (w, err)


def test_a_zero_divisor_in_a_residual_of_one_mode_is_refused(tmp_path, capsys):
    """The driveline's clutch residual (added from the engaged mode's own bond graph) divides by
    k_c: a stiffness of 0 was checked fine, then calibrated and diagnosed blind (a review)."""
    from .conftest import ROOT
    text = (ROOT / "tests" / "data" / "driveline_clutch.yaml").read_text(encoding="utf-8")
    assert "  k_c: {value: 500.0," in text
    code, err = _check_line(tmp_path, capsys, text.replace("  k_c: {value: 500.0,", "  k_c: {value: 0.0,"))
    assert code == 2 and "parameter 'k_c' is 0, and ARR3 divides by it" in err


def test_thresholds_by_mode_take_a_mode_named_in_unicode():
    """calibrate --by-mode wrote {κ=0: ..., κ=1: ...} for a mode named κ, and the file it wrote was
    then refused ("'κ=0' is no mode combination": the keys took ASCII names only; a user trial)."""
    from fdi.config import load_text

    from .conftest import ROOT
    text = (ROOT / "tests" / "data" / "driveline_clutch.yaml").read_text(encoding="utf-8")
    text = text.replace("  c: {nominal: 1, column: c_cmd", "  \u03ba: {nominal: 1, column: c_cmd")
    text = text.replace("mode: c,", "mode: \u03ba,")
    text = text.replace("ARR3: 0.453}", "ARR3: {\u03ba=0: 0.4, \u03ba=1: 0.453}}")
    _, config = load_text(text, "k.yaml")
    assert config.mode_thresholds["ARR3"] == {(("\u03ba", 0),): 0.4, (("\u03ba", 1),): 0.453}


def test_a_mode_fault_takes_no_bounds_and_no_failure(tmp_path, capsys):
    """A mode fault's bounds and failure value were accepted and ignored (a user trial)."""
    text = CYCAB.read_text(encoding="utf-8")
    line = "  a1:          {kind: mode, mode: a1, value: 0, description: burnt driver or motor}"
    assert line in text
    for extra, words in (("bounds: [0.0, 1.0]", "faults.a1.bounds: a mode fault has no magnitude to search"),
                         ("failure: 1.0", "faults.a1.failure: a mode fault has no degradation to prognose")):
        code, err = _check_line(tmp_path, capsys, text.replace(line, line.replace("value: 0,", f"value: 0, {extra},")))
        assert code == 2 and words in err, err


def test_a_sensor_computed_from_other_sensors_columns_is_refused():
    """A trial's 'twist' sensor, theta_m/10 - theta_L beside both encoders: its residual against them
    is zero by construction (calibrated to 7e-11 and said to detect both encoders' faults). A signal
    computed only from columns other sensors read is refused, naming them; one that reads a column
    of its own (a differential transducer's p1 - p2 where only p1 is a sensor) is a measurement."""
    from pathlib import Path
    text = (Path(__file__).resolve().parent / "data" / "servo_gearbox.yaml").read_text()
    derived = text.replace("sensors:\n", 'sensors:\n  twist: {type: Df, junction: J_tw, measures: displacement, '
                                         'expr: "theta_m/10 - theta_L", unit: rad}\n', 1)
    with pytest.raises(ModelError, match=r"sensors\.twist\.expr: sensor 'twist' computes .* from columns other "
                                         r"sensors read \(theta_L by theta_L, theta_m by theta_m\)"):
        load_model_text(derived, "servo_twist.yaml")
    own = derived.replace('"theta_m/10 - theta_L"', '"theta_m/10 - theta_s"').replace(
        "columns: [t, u, i, theta_m, theta_L]", "columns: [t, u, i, theta_m, theta_L, theta_s]")
    assert "twist" in load_model_text(own, "servo_twist_own.yaml").sensors


@pytest.mark.parametrize("fault, said", [
    ("R_up: {kind: parametric, parameters: [R], failure: -50.0}", "faults.R_up.failure: failure -50 is on the other "
                                                                  "side of 0 from R = 100"),
    ("gain_v: {kind: sensor, sensor: v, failure: -0.5}", "failure -0.5 is on the other side of 0 from beta_v = 1")])
def test_a_failure_value_on_the_other_side_of_zero_is_refused(tmp_path, capsys, fault, said):
    """A conductance of 500 W/K given failure: -250 (a trial) was accepted and prognosed EOL = inf:
    no degradation reaches it without the element turning active. 0 stays allowed (a heater's power
    that vanishes)."""
    code, err = _check_line(tmp_path, capsys, BASE + "faults:\n  " + fault + "\n")
    assert code == 2 and said in err
    path = tmp_path / "zero.yaml"
    path.write_text(BASE + "faults:\n  R_up: {kind: parametric, parameters: [R], failure: 0.0}\n", encoding="utf-8")
    assert main(["check", str(path)]) == 0


@pytest.mark.parametrize("law, part", [
    ('effort: "R*f*log(-R)"', "log(-R)"),                 # a trial's rope: k*q*log(-k), complex at k = 1e6
    ('effort: "f*sqrt(R - 200)"', "sqrt(R - 200)"),       # a root of a negative value at R = 100
    ('effort: "R*f*asin(R/50)"', "asin(R/50)")])          # asin(2)
def test_a_law_that_is_not_real_at_the_parameters_values_is_refused_where_it_is_written(tmp_path, capsys, law, part):
    """A law's part that reads parameters only and leaves its function's domain at their values makes
    every residual that reads it NaN on every sample: `check` passed it and the diagnosis read the
    residual as silent (exit 0, a wrong fault). Refused at the law's key and line, with the value; a
    law in the domain there (log(R), sqrt(R)) and a parameter of .inf a law divides by still load."""
    code, err = _check_line(tmp_path, capsys, BASE.replace("res: {type: R, parameter: R}", "res: {type: R, " + law + "}"))
    assert code == 2 and ":10: elements.res.effort:" in err
    assert f"'{part}' in " in err and "is not a finite real number at the parameters' values (R = 100)" in err
    ok = tmp_path / "ok.yaml"
    ok.write_text(BASE.replace("res: {type: R, parameter: R}", 'res: {type: R, effort: "f*sqrt(R)*log(R)", flow: "e/(sqrt(R)*log(R))"}'),
                  encoding="utf-8")
    assert main(["check", str(ok)]) == 0
    assert load_model(MODELS / "cycab_steering.yaml").parameters["R4"].value == math.inf
