"""Hostile inputs of issue 12, one case each: a model, scenario, data file or option a careless or
malicious user might give. Shared by ``tests/test_hostile.py`` (every case) and ``tests/fuzz.py``.

A case is ``(id, files, argv, expect)``: ``files`` maps a file name to its text or bytes (written
into a fresh folder), a :class:`Fifo` (a named pipe nobody writes to) or a :class:`Link` (a
symbolic link to another of the files), ``argv`` the command with ``{name}`` standing for that
file's path, and ``expect`` is ``"error"`` (exit 2, one line naming the file or option; warnings
aside) or ``"ok"`` (valid but unusual: exit 0). Every input file must be the same bytes after the
command (nothing the command reads is replaced).

Issue 23 added the kinds that were still misbehaving: names given twice or equal once
Unicode-normalised (data headers, model names and columns, scenario keys), two sensors on one
column, constant calibration data, outputs that are inputs, unbounded lines (``/dev/zero``), a
FIFO in a suite folder, a ``--plot`` folder that cannot be created; its second round a FIFO
with no writer given directly (scenario, data, stream, calibration run, model), a stream whose
header is for another model, and line ends and encodings the reader sizes its arrays from; its
third round file names and option values with line ends and terminal escapes (shown escaped, on
one line) and ``diagnose M -``.
"""
from __future__ import annotations

import gzip
import os
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TANK = (ROOT / "models" / "two_tank_valve.yaml").read_text(encoding="utf-8")
CYCAB = str(ROOT / "models" / "cycab_steering.yaml")
NOMINAL = (Path(__file__).resolve().parent.parent / "models" / "data" / "cycab" / "nominal.csv").read_text(encoding="utf-8")


@dataclass(frozen=True)
class Fifo:
    """A named pipe that nobody writes to: reading it would wait forever."""


@dataclass(frozen=True)
class Link:
    """A symbolic link to another file of the case."""
    target: str


def tank(old: str, new: str) -> str:
    """The two-tank model with one piece of text replaced (the piece must be there)."""
    assert old in TANK, old
    return TANK.replace(old, new, 1)


def check(text: str | bytes, name: str = "m.yaml") -> tuple[dict, list[str]]:
    return {name: text}, ["check", "{" + name + "}"]


def tables(text: str | bytes) -> tuple[dict, list[str]]:
    return {"m.yaml": text}, ["tables", "{m.yaml}", "--mode", "v=1"]


def data(text: str | bytes, *options: str) -> tuple[dict, list[str]]:
    return {"d.csv": text}, ["diagnose", CYCAB, "{d.csv}", "--workers", "1", *options]


def scenario(text: str, *options: str) -> tuple[dict, list[str]]:
    return {"s.json": text}, ["simulate", CYCAB, "{s.json}", "-o", "{out}/o.csv", *options]


LAUGHS = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))
_NOMINAL_LINES = NOMINAL.splitlines(keepends=True)
SHORT = "".join(_NOMINAL_LINES[:1200])            # 12 s of nominal data: no detection, fast
SHORT_ROWS = "".join(_NOMINAL_LINES[1:1200])
UNWRITABLE = "/proc/bgfdi-plots" if hasattr(os, "geteuid") and os.geteuid() == 0 else "/proc/self/bgfdi-plots"

CASES: list[tuple[str, dict, list[str], str]] = [
    # ------------------------------------------------------------------ model files
    ("yaml-python-tag", *check(tank("name: two_tank_valve", 'name: !!python/object/apply:os.system ["echo hi"]')), "error"),
    ("model-latin1", *check(tank("Pump into tank 1", "Pompe \u00e0 l'entr\u00e9e").encode("latin-1")), "error"),
    ("model-binary", *check(b"\x00\x01\x02\xff\xfe" * 20), "error"),
    ("recursive-alias", *check(TANK + "extra: &x [1, *x]\n"), "error"),
    ("complex-key", *check(TANK + "? [a, b]\n: 1\n"), "error"),
    ("bond-id-hex", *check(tank("  1: [pump, J1]", "  0x9: [pump, J1]")), "error"),
    ("bond-id-sexagesimal", *check(tank("  1: [pump, J1]", "  1:30: [pump, J1]")), "error"),
    ("samples-inf", *check(tank("samples: 1000", "samples: .inf")), "error"),
    ("samples-nan", *check(tank("samples: 1000", "samples: .nan")), "error"),
    ("samples-zero", *check(tank("samples: 1000", "samples: 0")), "error"),
    ("sensor-list", *check(tank("beta_p1:  {kind: sensor, sensor: p1}", "beta_p1:  {kind: sensor, sensor: [p1]}")), "error"),
    ("mode-list", *check(tank("v:        {kind: mode, mode: v,", "v:        {kind: mode, mode: [v],")), "error"),
    ("parameter-list", *check(tank("valve:  {type: R, parameter: R12}", "valve:  {type: R, parameter: [R12]}")), "error"),
    ("parameter-mapping", *check(tank("valve:  {type: R, parameter: R12}", "valve:  {type: R, parameter: {a: 1}}")), "error"),
    ("input-list", *check(tank("pump:   {type: MSf, input: Qin}", "pump:   {type: MSf, input: [Qin]}")), "error"),
    ("parameters-number", *check("name: x\nparameters: 1.5\n"), "error"),
    ("columns-number", *check(tank("columns: [t, Qin, p1, p2]", "columns: 5")), "error"),
    ("columns-without-time", *check(tank("columns: [t, Qin, p1, p2]", "columns: [Qin, p1, p2]")), "error"),
    ("c-without-law", *check(tank('tank2:  {type: C, effort: "rho*g*q/A2", displacement: "A2*e/(rho*g)"}',
                                  "tank2:  {type: C}")), "error"),
    ("controlled-junction-one-bond", *check(tank("  5: [Jv, J2]\n", "").replace("  4: [Jv, valve]\n", "")
                                            .replace("  valve:  {type: R, parameter: R12}\n", "")), "error"),
    ("value-overflow", *check(tank("value: 1.0e7,", "value: 1e999999,")), "error"),
    ("value-integer-overflow", *check(tank("value: 1.0e7,", "value: 1" + "0" * 400 + ",")), "error"),
    ("value-nan", *check(tank("value: 1.0e7,", "value: .nan,")), "error"),
    ("value-string", *check(tank("value: 1.0e7,", "value: big,")), "error"),
    ("window-huge", *check(tank("derivative_window: 5.0", "derivative_window: 1e300")), "error"),
    ("window-negative", *check(tank("derivative_window: 5.0", "derivative_window: -1")), "error"),
    ("waiting-nan", *check(tank("waiting_time: 10.0", "waiting_time: .nan")), "error"),
    ("threshold-inf", *check(tank("ARR1: 1.0e-4,", "ARR1: .inf,")), "error"),
    ("threshold-negative", *check(tank("ARR1: 1.0e-4,", "ARR1: -1,")), "error"),
    ("threshold-string", *check(tank("ARR1: 1.0e-4,", "ARR1: high,")), "error"),
    ("sampling-zero", *check(tank("sampling_time: 0.1", "sampling_time: 0")), "error"),
    ("noise-negative", *check(tank("noise: 20.0}\n  p2", "noise: -20.0}\n  p2")), "error"),
    ("initial-list", *check(tank("p1: 3000.0", "p1: [3000.0]")), "error"),
    ("tables-division-by-zero", *tables(tank('effort: "rho*g*q/A1"', 'effort: "rho*g*q/(A1 - A1)"')), "error"),
    # a constant part beyond a double (exp(exp(exp(100))) held `tables` for minutes; 1e300 * 1e300 made
    # every residual inf, blind without an error) and an integer no float holds (a traceback)
    ("tables-tower-of-exponentials", *tables(tank('effort: "rho*g*q/A1"', 'effort: "rho*g*q/A1*exp(exp(exp(100)))"')),
     "error"),
    ("constant-overflow", *check(tank('effort: "rho*g*q/A1"', 'effort: "rho*g*q/A1*1e300*1e300"')), "error"),
    ("integer-beyond-a-float", *check(tank('effort: "rho*g*q/A1"', 'effort: "rho*g*q/A1*' + "9" * 400 + '"')), "error"),
    ("model-name-too-long", {}, ["check", "a" * 300 + ".yaml"], "error"),
    ("model-name-escapes", *check(tank("name: two_tank_valve", 'name: "tank\\e[31mRED\\e[0m\\nfake: line"')), "error"),
    ("window-below-a-sample", {"m.yaml": (ROOT / "models" / "cycab_steering.yaml").read_text(encoding="utf-8")
                               .replace("derivative_window: 0.25", "derivative_window: 1.0e-300"), "d.csv": SHORT},
     ["diagnose", "{m.yaml}", "{d.csv}", "--workers", "1"], "error"),
    ("window-below-a-sample-calibrate", {"m.yaml": (ROOT / "models" / "cycab_steering.yaml").read_text(encoding="utf-8")
                                         .replace("derivative_window: 0.25", "derivative_window: 1.0e-300"),
                                         "d.csv": SHORT},
     ["calibrate", "{m.yaml}", "{d.csv}", "-o", "{out}/c.yaml"], "error"),
    ("name-keyword", *check(tank("  R12: {value", "  lambda: {value").replace("parameter: R12", "parameter: lambda")), "error"),
    ("top-level-list", *check("- a\n- b\n"), "error"),
    ("empty-file", *check(""), "error"),
    ("crlf-model", *check(TANK.replace("\n", "\r\n")), "ok"),
    ("bom-model", *check("\ufeff" + TANK), "ok"),
    # ------------------------------------------------------------------ denial of service
    ("power-tower", *check(tank('flow: "Cd*sign(e)*sqrt(abs(e))"', 'flow: "Cd*e**9**9**9"')), "error"),
    ("huge-exponent", *check(tank('flow: "Cd*sign(e)*sqrt(abs(e))"', 'flow: "Cd*e**123456789"')), "error"),
    ("billion-laughs", *check(LAUGHS + TANK), "error"),
    ("chained-plus", *check(tank('flow: "Cd*sign(e)*sqrt(abs(e))"', 'flow: "' + "e+" * 990 + 'e"')), "error"),
    ("unary-minus", *check(tank('flow: "Cd*sign(e)*sqrt(abs(e))"', 'flow: "' + "-" * 1990 + 'e"')), "error"),
    ("nested-parentheses", *check(tank('flow: "Cd*sign(e)*sqrt(abs(e))"', 'flow: "' + "(" * 600 + "e" + ")" * 600 + '"')), "error"),
    ("long-expression", *check(tank('flow: "Cd*sign(e)*sqrt(abs(e))"', 'flow: "' + "+".join(["e"] * 3000) + '"')), "error"),
    ("big-document", *check(TANK + "#" + "x" * (11 << 20) + "\n"), "error"),
    ("deep-nesting", *check(TANK + "extra: " + "[" * 5000 + "]" * 5000 + "\n"), "error"),
    # ------------------------------------------------------------------ data files
    ("data-gzip", *data(gzip.compress(SHORT.encode())), "ok"),
    ("data-binary", *data(b"\x00\x9f\x92\x96" * 300), "error"),
    ("data-utf16", *data(SHORT.encode("utf-16")), "ok"),
    ("data-latin1", *data(SHORT.replace("t,u_in", "t,u_in").encode("latin-1") + b"# \xe9\n"), "error"),
    ("data-bom", *data("\ufeff" + SHORT), "ok"),
    ("data-crlf", *data(SHORT.replace("\n", "\r\n")), "ok"),
    ("data-semicolon", *data(SHORT.replace(",", ";")), "ok"),
    ("data-blank-last-line", *data(SHORT + "\n\n"), "ok"),
    ("data-header-only", *data(_NOMINAL_LINES[0]), "error"),
    ("data-empty", *data(""), "error"),
    ("data-time-huge", *data(_NOMINAL_LINES[0] + "".join(f"{1e301 * (i + 1)},0,0,0,1e5,1e5\n" for i in range(600))), "error"),
    ("data-time-backwards", *data(_NOMINAL_LINES[0] + "".join(f"{-0.01 * i},0,0,0,1e5,1e5\n" for i in range(600))), "error"),
    ("data-nan", *data(SHORT + "12.0,nan,0,0,1e5,1e5\n"), "error"),
    ("data-ragged", *data(SHORT + "12.0,0,0\n"), "error"),
    ("data-text-cell", *data(SHORT + "12.0,zero,0,0,1e5,1e5\n"), "error"),
    ("data-missing-file", {}, ["diagnose", CYCAB, "{out}/nothing.csv"], "error"),
    ("monitor-binary", {"d.csv": b"\x00\x9f\x92\x96" * 300}, ["monitor", CYCAB, "{d.csv}", "--workers", "1"], "error"),
    ("monitor-time-jump", {"d.csv": _NOMINAL_LINES[0] + "0,0,0,0,1,1\n0.01,0,0,0,1,1\n0.05,0,0,0,1,1\n"},
     ["monitor", CYCAB, "{d.csv}", "--workers", "1"], "error"),
    ("monitor-block-zero", {"d.csv": SHORT}, ["monitor", CYCAB, "{d.csv}", "--block", "0"], "error"),
    ("monitor-ok", {"d.csv": SHORT}, ["monitor", CYCAB, "{d.csv}", "--workers", "1"], "ok"),
    ("evaluate-missing", {}, ["evaluate", CYCAB, "{out}/none.json"], "error"),
    ("evaluate-empty-folder", {}, ["evaluate", CYCAB, "{out}"], "error"),
    # ------------------------------------------------------------------ scenario files
    ("scenario-T-nan", *scenario('{"T": NaN, "fs": 100}'), "error"),
    ("scenario-T-inf", *scenario('{"T": Infinity, "fs": 100}'), "error"),
    ("scenario-T-huge", *scenario('{"T": 1e7, "fs": 100}'), "error"),
    ("scenario-fs-tiny", *scenario('{"T": 10, "fs": 1e-9}'), "error"),
    ("scenario-target-list", *scenario('{"T": 1, "fs": 100, "faults": [{"target": ["R4"], "type": "abrupt", "value": 1e7, "t0": 0.5}]}'), "error"),
    ("scenario-noise-list", *scenario('{"T": 1, "fs": 100, "noise": [1, 2]}'), "error"),
    ("scenario-int-key", *scenario('{"T": 1, "fs": 100, "noise": {"1": 2}}'), "error"),
    ("scenario-not-json", *scenario("{T: [}"), "error"),
    ("scenario-list", *scenario("[1, 2]"), "error"),
    ("scenario-method-bogus", *scenario('{"T": 1, "fs": 100}', "--method", "bogus"), "error"),
    # ------------------------------------------------------------------ options
    ("option-pop-zero", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--pop", "0"], "error"),
    ("option-generations-zero", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--generations", "0"], "error"),
    ("option-wait-negative", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--wait", "-5"], "error"),
    ("option-wait-nan", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--wait", "nan"], "error"),
    ("option-threshold-negative", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--threshold", "ARR1=-1"], "error"),
    ("option-threshold-unknown", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--threshold", "ARR9=1"], "error"),
    ("option-samples-zero", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--samples", "0"], "error"),
    ("option-workers-zero", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--workers", "0"], "error"),
    ("option-failure-bad", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--failure", "beta_theta2=abc"], "error"),
    ("option-engine-bogus", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/scenario2.csv"), "--engine", "bogus"], "error"),
    ("option-mode-bad", {}, ["tables", CYCAB, "--mode", "a1=7"], "error"),
    ("option-sizes-bad", {}, ["bench", "derive", "--sizes", "10,-3"], "error"),
    # ------------------------------------------------------------------ outputs
    ("output-directory", {}, ["tables", CYCAB, "-o", "{out}"], "error"),
    ("output-missing-folder", {}, ["tables", CYCAB, "-o", "{out}/no/such/folder/t.txt"], "error"),
    ("output-dash", {}, ["tables", CYCAB, "--mode", "a1=1,a2=1", "-o", "-"], "ok"),
    ("output-name-too-long", {}, ["tables", CYCAB, "-o", "{out}/" + "t" * 300 + ".txt"], "error"),
    # ------------------------------------------------------------------ issue 23: names that cannot be meant
    ("data-column-twice", *data("t,u_in,theta1,theta2,p1,p1\n" + SHORT_ROWS), "error"),
    ("data-column-twice-extra", *data("t,u_in,theta1,theta2,p1,p2,p1\n"
                                      + "".join(r.rstrip("\n") + ",0\n" for r in SHORT_ROWS.splitlines(True))), "error"),
    ("data-columns-nfkc", *data("t,u_in,theta1,theta2,p1,p2,\u00b5,\u03bc\n"
                                + "".join(r.rstrip("\n") + ",0,0\n" for r in SHORT_ROWS.splitlines(True))), "error"),
    ("monitor-column-twice", {"d.csv": "t,u_in,theta1,theta2,p1,p1\n" + SHORT_ROWS},
     ["monitor", CYCAB, "{d.csv}", "--workers", "1"], "error"),
    ("model-names-nfkc", *check(tank("  Cd:  {value", "  \u00b5: {value: 1.0, unit: Pa}\n  \u03bc: {value: 2.0, unit: Pa}\n"
                                     "  Cd:  {value")), "error"),
    ("model-names-ligature", *check(tank("  Cd:  {value", "  \ufb01x: {value: 1.0, unit: Pa}\n  fix: {value: 2.0, unit: Pa}\n"
                                         "  Cd:  {value")), "error"),
    ("model-name-micro-alone", *check(TANK.replace("R12", "\u00b5")), "ok"),
    ("model-columns-twice", *check(tank("columns: [t, Qin, p1, p2]", "columns: [t, Qin, p1, p2, p2]")), "error"),
    ("model-duplicate-key", *check(tank("  A2:  {value", "  A1:  {value")), "error"),
    ("model-two-sensors-one-column", *check(tank("p2: {type: De, junction: J2, column: p2",
                                                 "p2: {type: De, junction: J2, column: p1")), "error"),
    ("scenario-key-twice-json", *scenario('{"T": 1, "fs": 100, "T": 2}'), "error"),
    ("scenario-key-twice-yaml", {"s.yaml": "T: 1\nfs: 100\nT: 2\n"},
     ["simulate", CYCAB, "{s.yaml}", "-o", "{out}/o.csv"], "error"),
    ("calibrate-constant", {"c.csv": "t,Qin,p1,p2\n" + "".join(f"{i / 10:.1f},0,0,0\n" for i in range(600))},
     ["calibrate", str(ROOT / "models" / "two_tank_valve.yaml"), "{c.csv}"], "error"),
    # ------------------------------------------------------------------ issue 23: sizes without bounds
    ("data-dev-zero", {}, ["diagnose", CYCAB, "/dev/zero"], "error"),
    ("monitor-dev-zero", {}, ["monitor", CYCAB, "/dev/zero", "--workers", "1"], "error"),
    ("data-long-row", *data(_NOMINAL_LINES[0] + "0," + "1," * 600_000 + "1\n"), "error"),
    ("data-wide-header", *data("t," + ",".join(f"c{i}" for i in range(10_001)) + "\n"), "error"),
    ("data-gzip-no-line-end", *data(gzip.compress(b"\x00" * 3_000_000)), "error"),
    ("data-gzip-magic-only", *data(b"\x1f\x8b"), "error"),            # found by the csv fuzzer (EOFError)
    ("data-gzip-cut", *data(gzip.compress(SHORT.encode())[:300]), "error"),
    # ------------------------------------------------------------------ issue 23: never lose an input
    ("output-is-the-data", {"d.csv": SHORT}, ["diagnose", CYCAB, "{d.csv}", "--workers", "1", "-o", "{d.csv}"], "error"),
    ("output-is-the-scenario", {"s.json": '{"T": 1, "fs": 100}'}, ["simulate", CYCAB, "{s.json}", "-o", "{s.json}"],
     "error"),
    ("output-link-to-the-scenario", {"s.json": '{"T": 1, "fs": 100}', "l.csv": Link("s.json")},
     ["simulate", CYCAB, "{s.json}", "-o", "{l.csv}"], "error"),
    ("output-is-the-model", {"m.yaml": TANK}, ["tables", "{m.yaml}", "-o", "{m.yaml}"], "error"),
    ("output-dotted-model", {"m.yaml": TANK}, ["graph", "{m.yaml}", "-o", "{out}/./m.yaml"], "error"),
    ("plot-folder-unwritable", {}, ["diagnose", CYCAB, str(ROOT / "models/data/cycab/nominal.csv"), "--plot",
                                    UNWRITABLE], "error"),
    ("evaluate-fifo-in-suite", {"suite/x.json": Fifo()}, ["evaluate", CYCAB, "{out}/suite"], "error"),
    # ------------------------------------------------------------------ issue 23, second round
    ("scenario-fifo", {"s.json": Fifo()}, ["simulate", CYCAB, "{s.json}", "-o", "{out}/o.csv"], "error"),
    ("data-fifo", {"d.csv": Fifo()}, ["diagnose", CYCAB, "{d.csv}", "--workers", "1"], "error"),
    ("monitor-fifo", {"d.csv": Fifo()}, ["monitor", CYCAB, "{d.csv}"], "error"),
    ("calibrate-fifo", {"c.csv": Fifo()}, ["calibrate", CYCAB, "{c.csv}"], "error"),
    ("model-fifo", {"m.yaml": Fifo()}, ["check", "{m.yaml}"], "error"),
    ("evaluate-fifo-scenario", {"s.json": Fifo()}, ["evaluate", CYCAB, "{s.json}"], "error"),
    ("monitor-other-model-header", {"d.csv": "t,a,b\n0,1,2\n0.01,1,2\n"}, ["monitor", CYCAB, "{d.csv}"], "error"),
    ("data-cr-line-ends", *data(SHORT.replace("\n", "\r")), "ok"),
    # ------------------------------------------------------------------ issue 23, third round
    ("file-name-line-end-and-escape", {"a\nb\x1b[2J.csv": SHORT},
     ["diagnose", CYCAB, "{a\nb\x1b[2J.csv}", "--workers", "1", "-o", "{a\nb\x1b[2J.csv}"], "error"),
    ("option-value-line-end", {}, ["diagnose", CYCAB, "{out}/d.csv", "--engine", "a\nb"], "error"),
    ("diagnose-dash", {}, ["diagnose", CYCAB, "-"], "error"),
    ("model-sensor-reads-time", *check(tank("p2: {type: De, junction: J2, column: p2",
                                            "p2: {type: De, junction: J2, column: t")), "error"),
]
