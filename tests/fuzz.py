"""Property-based fuzzing of everything bgfdi reads: model files, scenario files, measurement
files and command-line options (issue 12).

The invariant: every input ends as a result or as the project's own error (one line for the
user), never as another exception, never in more than a few seconds. ``tests/test_fuzz.py`` runs
a bounded number of examples per target in the test suite; run this module for the counts::

    python -m tests.fuzz --cases 10000            # every target, 10 000 cases each
    python -m tests.fuzz --cases 2000 models csv  # some targets

It prints, per target, how many inputs gave a result, how many the project's error, and how many
crashed or took too long (with the first few, to reproduce).
"""
from __future__ import annotations

import argparse
import collections
import contextlib
import gzip
import io
import json
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

import yaml
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.errors import CausalityError, ModelError
from bondgraph.loader import load_model, load_model_text
from fdi.app.cli import main
from fdi.errors import UsageError
from fdi.data import DataError, check_against_model, read_csv
from fdi.app.scenario import ScenarioError, parse_scenario

ROOT = Path(__file__).resolve().parent.parent
TANK_TEXT = (ROOT / "models" / "two_tank_valve.yaml").read_text(encoding="utf-8")
TANK = yaml.safe_load(TANK_TEXT)
CYCAB = load_model(ROOT / "models" / "cycab_steering.yaml")
NOMINAL = (ROOT / "models" / "data" / "cycab" / "nominal.csv").read_text(encoding="utf-8").splitlines()
OWN_ERRORS = (ModelError, CausalityError, DataError, ScenarioError, UsageError)
SLOW_S = 5.0                 # "never more than a few seconds"
ALARM_S = 20                 # a case still running then is a hang

# ------------------------------------------------------------------ what the strategies draw

NAMES = ["t", "u_in", "theta1", "theta2", "p1", "p2", "R12", "Cd", "v", "J1", "Jv", "pump", "tank1", "x", "", "0x7"]
SCALARS = (st.none() | st.booleans() | st.integers(-10**20, 10**20)
           | st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from(NAMES)
           | st.text(max_size=12)
           | st.sampled_from(["1e999999", ".nan", "-.inf", "e**9**9", "!!python/name:os.system", "*a", "&a x",
                              "sign(e)*sqrt(abs(e))", "(" * 50, "-" * 300 + "e", "Cd/(A1-A1)"]))
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(st.sampled_from(NAMES) | st.text(max_size=6), inner, max_size=4),
                      max_leaves=12)


def _paths(node, prefix=()) -> list[tuple]:
    """Every key path of a parsed YAML document (where a mutation may land)."""
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, prefix + (i,))
    return out


TANK_PATHS = _paths(TANK)[1:]


@st.composite
def model_texts(draw) -> str:
    """The two-tank model with one to three of its values replaced, keys removed or added (as YAML
    text), or its text with a random fragment spliced in."""
    if draw(st.booleans()):
        doc = json.loads(json.dumps(TANK))                     # a deep copy
        for _ in range(draw(st.integers(1, 3))):
            path = draw(st.sampled_from(TANK_PATHS))
            parent = doc
            try:
                for k in path[:-1]:
                    parent = parent[k]
                action = draw(st.sampled_from(["set", "set", "delete", "add"]))
                if action == "set":
                    parent[path[-1]] = draw(VALUES)
                elif action == "delete":
                    del parent[path[-1]]
                elif isinstance(parent, dict):
                    parent[draw(st.sampled_from(NAMES) | st.integers(-5, 99))] = draw(VALUES)
            except (KeyError, IndexError, TypeError):
                pass                                            # an earlier mutation moved the path
        return yaml.safe_dump(doc, allow_unicode=True)
    at = draw(st.integers(0, len(TANK_TEXT)))
    cut = draw(st.integers(0, 40))
    fragment = draw(st.text(max_size=40) | st.sampled_from(["&a [1, *a]", "? [a, b]\n: 1\n", "!!binary AAAA",
                                                            "\t", "\x00", "{", "- - - -", "a: *nope"]))
    return TANK_TEXT[:at] + fragment + TANK_TEXT[at + cut:]


CELLS = (st.floats(allow_nan=True, allow_infinity=True).map(repr) | st.integers().map(str)
         | st.sampled_from(["", " ", "nan", "inf", "1e400", "-0", "1,5", "0x10", "\"1\"", "abc", "1e-320"])
         | st.text(max_size=6))


@st.composite
def csv_files(draw) -> bytes:
    """A measurement file: the CyCab's header (sometimes broken) and rows of nominal data or drawn
    cells, in a drawn separator, encoding and compression."""
    header = NOMINAL[0].split(",")
    if draw(st.booleans()):
        header = draw(st.lists(st.sampled_from(header + ["", "x", "T", " t"]), min_size=0, max_size=8))
    n = draw(st.integers(0, 30))
    start = draw(st.integers(1, len(NOMINAL) - 40))
    rows = [NOMINAL[start + i].split(",") for i in range(n)]
    for _ in range(draw(st.integers(0, 6))):
        if rows:
            r = draw(st.integers(0, len(rows) - 1))
            row = list(rows[r])
            if row and draw(st.booleans()):
                row[draw(st.integers(0, len(row) - 1))] = draw(CELLS)
            else:
                row = draw(st.lists(CELLS, max_size=8))
            rows[r] = row
    sep = draw(st.sampled_from([",", ",", ";", "\t"]))
    end = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    text = end.join(sep.join(r) for r in [header] + rows) + draw(st.sampled_from(["", end, end * 2]))
    encoding = draw(st.sampled_from(["utf-8", "utf-8", "utf-8-sig", "utf-16", "latin-1", "utf-32"]))
    data = text.encode(encoding, errors="replace")
    if draw(st.booleans()) and draw(st.booleans()):
        data = gzip.compress(data)
    if draw(st.integers(0, 9)) == 0:
        data = draw(st.binary(max_size=200))
    return data


FAULT = st.fixed_dictionaries({}, optional={
    "target": VALUES | st.sampled_from(["R4", "R5", "beta_theta2", "a1", "k2"]),
    "type": VALUES | st.sampled_from(["abrupt", "intermittent", "incipient"]),
    "t0": VALUES | st.floats(0, 2), "value": VALUES | st.floats(0, 2), "period": VALUES,
    "model": VALUES | st.integers(0, 5), "b": VALUES, "eta": VALUES})
SCENARIOS = st.fixed_dictionaries({}, optional={
    "T": VALUES | st.floats(0, 3), "fs": VALUES | st.floats(0, 200), "seed": VALUES,
    "faults": st.lists(FAULT, max_size=3) | VALUES, "noise": VALUES, "theta2_0": VALUES,
    "initial": VALUES, "x": VALUES}) | VALUES

OPTION_VALUES = st.sampled_from(["0", "1", "-1", "4", "nan", "inf", "-inf", "1e9", "abc", "", "2.5", "ARR1=-1",
                                 "ARR1=1e-3", "ARR9=1", "beta_theta2=0.5", "x=", "=1", "a1=1,a2=1", "a1=7"])
OPTIONS = ["--pop", "--generations", "--wait", "--threshold", "--samples", "--seed", "--workers", "--failure",
           "--engine", "--mode"]


@st.composite
def diagnose_argv(draw) -> list[str]:
    """``bgfdi diagnose`` of 12 s of nominal CyCab data (nothing to detect: fast) with drawn options."""
    argv = ["diagnose", str(ROOT / "models" / "cycab_steering.yaml"), "{data}", "--workers", "1"]
    for _ in range(draw(st.integers(1, 3))):
        argv += [draw(st.sampled_from(OPTIONS)), draw(OPTION_VALUES)]
    return argv


# ------------------------------------------------------------------ how a case is judged

class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang()


def judge(fn: Callable[[], object]) -> tuple[str, float]:
    """("ok" | "error" | "crash: <exception>" | "slow" | "hang", seconds) of one call."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(ALARM_S)
    t0 = time.perf_counter()
    try:
        fn()
        outcome = "ok"
    except OWN_ERRORS:
        outcome = "error"
    except Hang:
        outcome = "hang"
    except Exception as exc:                      # noqa: BLE001 - what the fuzzing looks for
        outcome = f"crash: {type(exc).__name__}: {str(exc)[:120]}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    secs = time.perf_counter() - t0
    if outcome in ("ok", "error") and secs > SLOW_S:
        outcome = "slow"
    return outcome, secs


def check_model(text: str) -> None:
    model = load_model_text(text, "fuzz.yaml")
    assign(model, DIAGNOSIS)


def check_csv(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "fuzz.csv"
        p.write_bytes(data)
        check_against_model(CYCAB, read_csv(p))


def check_scenario(data) -> None:
    parse_scenario(data, CYCAB, "fuzz.json")


def check_options(argv: list[str]) -> None:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "d.csv"
        p.write_text("\n".join(NOMINAL[:1200]) + "\n", encoding="utf-8")
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main([a.replace("{data}", str(p)) for a in argv])
            except SystemExit as exc:            # argparse's own refusal of a malformed value
                rc = exc.code
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip() and not ln.startswith("usage:")]
        if rc not in (0, 2) or "Traceback" in err.getvalue() or (rc == 2 and len(lines) != 1):
            raise AssertionError(f"exit {rc}: {err.getvalue()[:200]}")
        if rc == 2:
            raise UsageError(lines[0])


TARGETS = {"models": (model_texts(), check_model), "csv": (csv_files(), check_csv),
           "scenarios": (SCENARIOS, check_scenario), "options": (diagnose_argv(), check_options)}


def run(target: str, cases: int, seed: int = 0) -> collections.Counter:
    """``cases`` examples of one target, counted by outcome (the first crashes kept to reproduce)."""
    strategy, fn = TARGETS[target]
    counts: collections.Counter = collections.Counter()
    examples: list[tuple[str, object]] = []

    @settings(max_examples=cases, database=None, deadline=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck), derandomize=True)
    @given(strategy)
    def body(case):
        outcome, _ = judge(lambda: fn(case))
        counts[outcome.split(":")[0]] += 1
        kinds = {o.split(":")[1] if ":" in o else o for o, _ in examples}
        kind = outcome.split(":")[1] if ":" in outcome else outcome
        if outcome not in ("ok", "error") and len(examples) < 8 and kind not in kinds:
            examples.append((outcome, case))       # the first of each kind of failure

    body()
    counts["_examples"] = examples  # type: ignore[assignment]
    return counts


def main_fuzz(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("targets", nargs="*", help=f"some of {', '.join(TARGETS)} (default: all)")
    ap.add_argument("--cases", type=int, default=10000)
    args = ap.parse_args(argv)
    unknown = [t for t in args.targets if t not in TARGETS]
    if unknown:
        ap.error(f"unknown target(s) {', '.join(unknown)}; use {', '.join(TARGETS)}")
    bad = 0
    for target in args.targets or list(TARGETS):
        t0 = time.perf_counter()
        c = run(target, args.cases)
        examples = c.pop("_examples")
        broken = c["crash"] + c["slow"] + c["hang"]
        bad += broken
        print(f"{target:10s} {sum(c.values()):6d} cases: {c['ok']} ok, {c['error']} refused with one line, "
              f"{c['crash']} crashes, {c['slow']} slower than {SLOW_S:g} s, {c['hang']} hangs "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
        for outcome, case in examples:
            print(f"    {outcome}\n      input: {case!r:.300}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main_fuzz())
