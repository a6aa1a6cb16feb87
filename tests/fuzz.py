"""Property-based fuzzing of everything bgfdi reads and writes: model files, scenario files,
measurement files, measurement streams, Unicode names, the notebook API's data, command-line
options and output paths (issues 12 and 23).

The invariant: every input ends as a result or as the project's own error (one line for the
user), never as another exception, never in more than a few seconds, never with more than 1 GB of
memory (the process's peak resident size, checked after each case); an output never replaces an
input or leaves a partial file; a model that loads has no two names that are one once
Unicode-normalised. ``tests/test_fuzz.py`` runs a bounded number of examples per target in the
test suite; run this module for the counts::

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
import os
import resource
import signal
import sys
import tempfile
import time
import unicodedata
from pathlib import Path
from typing import Callable

import numpy as np

import yaml
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.errors import CausalityError, ModelError
from bondgraph.loader import load_model, load_model_text
from fdi.app.cli import main
from fdi.errors import UsageError
from fdi.data import DataError, blocks, check_against_model, checked, read_csv
from fdi.app.scenario import ScenarioError, load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parent.parent
TANK_TEXT = (ROOT / "models" / "two_tank_valve.yaml").read_text(encoding="utf-8")
TANK = yaml.safe_load(TANK_TEXT)
CYCAB = load_model(ROOT / "models" / "cycab_steering.yaml")
NOMINAL = (ROOT / "models" / "data" / "cycab" / "nominal.csv").read_text(encoding="utf-8").splitlines()
OWN_ERRORS = (ModelError, CausalityError, DataError, ScenarioError, UsageError)
SLOW_S = 5.0                 # "never more than a few seconds"
ALARM_S = 20                 # a case still running then is a hang
MEMORY_KB = 1 << 20          # 1 GB more peak resident memory than before the first case: a blow-up

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
                                 "ARR1=1e-3", "ARR9=1", "beta_theta2=0.5", "x=", "=1", "a1=1,a2=1", "a1=7",
                                 "AHDE", "SHADE", "1e6", "1e7", "7", "\u00b5", "-"])
OPTIONS = ["--pop", "--generations", "--wait", "--persistence", "--threshold", "--samples", "--seed", "--workers",
           "--failure", "--engine", "--max-set", "--jobs"]
FLAGS = ["--json", "--timings", "--no-exoneration", "--fail-on-fault", "-q", "-v"]


@st.composite
def diagnose_argv(draw) -> list[str]:
    """``bgfdi diagnose`` of 12 s of nominal CyCab data (nothing to detect: fast) with drawn options
    of the current command line and flags."""
    argv = ["diagnose", str(ROOT / "models" / "cycab_steering.yaml"), "{data}", "--workers", "1"]
    for _ in range(draw(st.integers(1, 3))):
        option = draw(st.sampled_from(OPTIONS))
        value = draw(OPTION_VALUES)
        if option == "--jobs" and value not in ("0", "-1", "abc", "", "nan"):
            value = "1"                                 # one file: more jobs would start processes for nothing
        argv += [option, value]
    argv += draw(st.lists(st.sampled_from(FLAGS), max_size=2, unique=True))
    return argv


# ------------------------------------------------------------------ streams, Unicode, the API, outputs

HEADER = NOMINAL[0].split(",")
CONFUSABLE = {"u": ["\u00b5", "\u03bc", "u"], "f": ["\ufb01", "f"], "A": ["\uff21", "A"], "1": ["\uff11", "1"],
              "p": ["p", "\u1d56", "\uff50"], "t": ["t", "\u209c", "\uff54"], "C": ["C", "\uff23"], "R": ["R", "\u211b"]}
# each an identifier character (or one after the first) whose NFKC form is the plain letter


@st.composite
def stream_texts(draw) -> str:
    """A measurement stream as ``monitor -`` reads it: a header (sometimes with a name twice or in
    another Unicode form), nominal rows, then lines of drawn length (up to 1.5 MiB, no end), NULs
    or a row cut mid-way."""
    header = list(HEADER)
    kind = draw(st.sampled_from(["plain", "twice", "unicode", "long", "nul", "cut", "wide"]))
    if kind == "twice":
        header.append(draw(st.sampled_from(HEADER)))
    if kind == "unicode":
        header += ["\u00b5", draw(st.sampled_from(["\u03bc", "\u00b5x", "mu"]))]
    if kind == "wide":
        header += [f"c{i}" for i in range(draw(st.integers(1, 12_000)))]
    start = draw(st.integers(1, len(NOMINAL) - 60))
    rows = [NOMINAL[start + i] + ",0" * (len(header) - len(HEADER)) for i in range(draw(st.integers(0, 50)))]
    text = ",".join(header) + "\n" + "".join(r + "\n" for r in rows)
    if kind == "long":
        text += "1," * draw(st.integers(1, 800_000))
    if kind == "nul":
        text += "\x00" * draw(st.integers(1, 1_500_000))
    if kind == "cut" and rows:
        text += rows[-1][:draw(st.integers(0, len(rows[-1])))]
    return text


def check_stream(text: str) -> None:
    """The monitor's reader (as ``bgfdi monitor M -`` uses it: blocks of 50 rows, a cut last row
    dropped), each block checked as the stream checks it."""
    for header, block in blocks(io.StringIO(text), "fuzz stream", 50, cut=lambda message: None):
        if len(block) >= 2:
            checked("fuzz stream", header, block)


@st.composite
def unicode_models(draw) -> str:
    """The two-tank model with some of its names rewritten in look-alike Unicode forms (micro sign,
    Greek mu, ligatures, full-width and super/subscript letters), sometimes a second parameter
    named like the first once normalised."""
    text = TANK_TEXT
    for name in draw(st.lists(st.sampled_from(["R12", "Cd", "A1", "A2", "Qin", "p1", "J1", "tank1"]), max_size=3)):
        spelled = "".join(draw(st.sampled_from(CONFUSABLE.get(c, [c]))) for c in name)
        if spelled[0].isidentifier():
            text = text.replace(name, spelled)
    if draw(st.booleans()):                        # two parameters, one name once normalised: must be refused
        one, other = draw(st.sampled_from([("\u00b5x", "\u03bcx"), ("\ufb01x", "fix"), ("\uff213", "A3"),
                                           ("\uff509", "p9"), ("\u211bq", "Rq")]))
        text = text.replace("  Cd:  {value", f"  {one}: {{value: 1.0, unit: Pa}}\n  {other}: {{value: 2.0, unit: Pa}}\n"
                                             "  Cd:  {value", 1)
    return text


def check_unicode_model(text: str) -> None:
    """Loads, or the project's error; a model that loads has no two names equal once normalised."""
    model = load_model_text(text, "fuzz.yaml")
    names = [*model.parameters, *model.modes, *model.inputs, *model.sensors, *model.elements, *model.junctions]
    normal = [unicodedata.normalize("NFKC", n) for n in names]
    if len(set(normal)) != len(set(names)):
        raise AssertionError(f"names equal once normalised were accepted: {names}")
    assign(model, DIAGNOSIS)


CELL_VALUES = (st.floats(allow_nan=True, allow_infinity=True) | st.integers(-10**6, 10**6) | st.none()
               | st.text(max_size=4) | st.lists(st.integers(), max_size=2) | st.sampled_from(["1.5", "nan", b"1"]))


class FrameLike:
    """What the API reads of a pandas DataFrame: names (repeatable, of any type) and a matrix of
    cells of any kind (pandas' object columns)."""

    def __init__(self, names: list, cells: np.ndarray):
        self.columns = names
        self._m = cells

    def to_numpy(self, dtype=None):
        return self._m.astype(dtype) if dtype is not None else self._m

    def __getitem__(self, name):
        return FrameLike([name], self._m[:, [list(self.columns).index(name)]])


@st.composite
def api_data(draw):
    """Data as a notebook gives it: a dict of arrays or lists, a frame of object cells, a
    structured array, with drawn names (repeated, Unicode variants, non-text) and lengths."""
    names = draw(st.lists(st.sampled_from(["t", "t", "p", "p", "\u00b5", "\u03bc", 1, "1", "", " t"]),
                          min_size=1, max_size=5))
    n = draw(st.integers(0, 6))
    columns = [draw(st.lists(CELL_VALUES, min_size=n, max_size=n)) if draw(st.integers(0, 3)) == 0
               else list(np.arange(n) * 0.1 + i) for i in range(len(names))]
    kind = draw(st.sampled_from(["dict", "frame", "structured"]))
    if kind == "dict":
        return dict(zip(names, columns))
    cells = np.empty((n, len(names)), dtype=object)
    for j, c in enumerate(columns):
        for i, v in enumerate(c):
            cells[i, j] = v
    if kind == "frame":
        return FrameLike(names, cells)
    plain = list(dict.fromkeys(str(x) or "x" for x in names))
    return np.zeros(n, dtype=[(x, float) for x in plain])


def check_api(data) -> None:
    from fdi.api import measurements
    measurements(data)


OUTPUT_KINDS = ["new", "existing", "model", "model-dotted", "link-to-model", "hardlink-to-model", "folder",
                "missing-folder", "under-a-file", "fifo", "devnull", "dash", "empty", "link-dangling", "proc"]


@st.composite
def output_cases(draw) -> tuple[str, str]:
    """(command, kind of -o path): graph or tables of a model copy, written to a drawn kind of path."""
    return draw(st.sampled_from(["graph", "tables"])), draw(st.sampled_from(OUTPUT_KINDS))


def check_outputs(case: tuple[str, str]) -> None:
    """The command ends in 0 or 2 with one line; the model it reads is the same bytes after; no
    partial (.part) or probe file is left in the folder."""
    command, kind = case
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        model = folder / "m.yaml"
        model.write_text(TANK_TEXT, encoding="utf-8")
        (folder / "old.txt").write_text("old\n", encoding="utf-8")
        path = {"new": folder / "out.txt", "existing": folder / "old.txt", "model": model,
                "model-dotted": folder / "." / "m.yaml", "link-to-model": folder / "l.txt",
                "hardlink-to-model": folder / "h.yaml", "folder": folder, "missing-folder": folder / "no" / "x",
                "under-a-file": model / "x", "fifo": folder / "pipe", "devnull": Path(os.devnull), "dash": "-",
                "empty": "", "link-dangling": folder / "dangling", "proc": Path("/proc/bgfdi-out.txt")}[kind]
        if kind == "link-to-model":
            path.symlink_to(model)
        if kind == "hardlink-to-model":
            os.link(model, path)
        if kind == "link-dangling":
            path.symlink_to(folder / "nowhere" / "x")
        if kind == "fifo":
            return                                  # writing into a FIFO waits for a reader: hostile.py covers it
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main([command, str(model), "-o", str(path)])
            except SystemExit as exc:
                rc = exc.code
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
        if rc not in (0, 2) or "Traceback" in err.getvalue() or (rc == 2 and len(lines) != 1):
            raise AssertionError(f"exit {rc}: {err.getvalue()[:200]}")
        if model.read_text(encoding="utf-8") != TANK_TEXT:
            raise AssertionError(f"-o {kind} replaced the model it reads")
        left = [p.name for p in folder.iterdir() if p.name.startswith(".")]
        if left:
            raise AssertionError(f"-o {kind} left {left}")
        if rc == 2:
            raise UsageError(lines[0])


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
    """As read from a file, in JSON (keys sometimes given twice: the reader must refuse them)."""
    parse_scenario(data, CYCAB, "fuzz.json")
    if isinstance(data, dict) and data:
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "s.json"
            key, value = next(iter(data.items()))
            text = json.dumps(data, default=str)
            p.write_text("{" + json.dumps(str(key)) + ": " + json.dumps(value, default=str) + ", " + text[1:],
                         encoding="utf-8")
            try:
                load_scenario(p, CYCAB)
            except ScenarioError as exc:
                if "duplicate key" in str(exc):
                    return
                raise
            raise AssertionError(f"a key given twice was accepted: {p.read_text(encoding='utf-8')[:120]}")


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
        allowed = (0, 2, 3) if "--fail-on-fault" in argv else (0, 2)      # 3: a fault found, as asked
        if rc not in allowed or "Traceback" in err.getvalue() or (rc == 2 and len(lines) != 1):
            raise AssertionError(f"exit {rc}: {err.getvalue()[:200]}")
        if rc == 2:
            raise UsageError(lines[0])


TARGETS = {"models": (model_texts(), check_model), "csv": (csv_files(), check_csv),
           "scenarios": (SCENARIOS, check_scenario), "options": (diagnose_argv(), check_options),
           "streams": (stream_texts(), check_stream), "unicode": (unicode_models(), check_unicode_model),
           "api": (api_data(), check_api), "outputs": (output_cases(), check_outputs)}


class OutOfTime(Exception):
    """The target's time budget is spent: the cases run so far are its count."""


def run(target: str, cases: int, seed: int = 0, seconds: float | None = None) -> collections.Counter:
    """``cases`` examples of one target, counted by outcome (the first crashes kept to reproduce);
    with ``seconds``, stop at the first case that would start after that budget (the counts are
    then of the cases actually run)."""
    strategy, fn = TARGETS[target]
    counts: collections.Counter = collections.Counter()
    examples: list[tuple[str, object]] = []
    deadline = None if seconds is None else time.perf_counter() + seconds
    worst: list = [0, None]                        # [kB the peak rose during one case, that case]

    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss      # kB on Linux

    @settings(max_examples=cases, database=None, deadline=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck), derandomize=True)
    @given(strategy)
    def body(case):
        if deadline is not None and time.perf_counter() > deadline:
            raise OutOfTime()
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        outcome, _ = judge(lambda: fn(case))
        rise = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
        if rise > worst[0]:                        # the case that raised the peak most (the peak only grows)
            worst[:] = [rise, case]
        if resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base > MEMORY_KB and not counts["memory"]:
            outcome = "memory"                     # the peak only grows: the first case past 1 GB is counted
        counts[outcome.split(":")[0]] += 1
        kinds = {o.split(":")[1] if ":" in o else o for o, _ in examples}
        kind = outcome.split(":")[1] if ":" in outcome else outcome
        if outcome not in ("ok", "error") and len(examples) < 8 and kind not in kinds:
            examples.append((outcome, case))       # the first of each kind of failure

    try:
        body()
    except OutOfTime:
        counts["_out_of_time"] = 1  # type: ignore[assignment]
    counts["_peak_mb"] = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) // 1024  # type: ignore[assignment]
    counts["_examples"] = examples  # type: ignore[assignment]
    counts["_worst"] = (worst[0] // 1024, worst[1])  # type: ignore[assignment]
    return counts


def main_fuzz(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("targets", nargs="*", help=f"some of {', '.join(TARGETS)} (default: all)")
    ap.add_argument("--cases", type=int, default=10000)
    ap.add_argument("--seconds", type=float, default=None,
                    help="stop each target after this many seconds (the counts say how many cases ran)")
    args = ap.parse_args(argv)
    unknown = [t for t in args.targets if t not in TARGETS]
    if unknown:
        ap.error(f"unknown target(s) {', '.join(unknown)}; use {', '.join(TARGETS)}")
    bad = 0
    for target in args.targets or list(TARGETS):
        t0 = time.perf_counter()
        c = run(target, args.cases, seconds=args.seconds)
        examples = c.pop("_examples")
        peak = c.pop("_peak_mb")
        stopped = c.pop("_out_of_time", 0)
        worst_mb, worst_case = c.pop("_worst")
        broken = c["crash"] + c["slow"] + c["hang"] + c["memory"]
        bad += broken
        print(f"{target:10s} {sum(c.values()):6d} cases: {c['ok']} ok, {c['error']} refused with one line, "
              f"{c['crash']} crashes, {c['slow']} slower than {SLOW_S:g} s, {c['hang']} hangs, "
              f"{c['memory']} past 1 GB (peak +{peak} MB) ({time.perf_counter() - t0:.0f} s"
              f"{'; stopped by --seconds' if stopped else ''})", flush=True)
        print(f"    largest rise of the peak in one case: +{worst_mb} MB, input: {worst_case!r:.160}")
        for outcome, case in examples:
            print(f"    {outcome}\n      input: {case!r:.300}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main_fuzz())
