"""The ``bgfdi`` command: a thin argparse front over bondgraph, fdi and optim.

User mistakes (bad model, scenario or data files, bad options) print one line on stderr and exit
with code 2, before any work where they can be seen before it; nothing is half-written (outputs go
through fdi.app.output.write_atomic, ``-o -`` is standard output). A reader that goes away (``| head``)
ends the command quietly. See docs/cli.md.
"""
from __future__ import annotations

import argparse
import contextlib
import errno
import io
import logging
import math
import os
import sys
import warnings
from collections import Counter
from typing import Callable


from typing import TYPE_CHECKING

from bondgraph.deep import LIMIT, run_deep
from bondgraph.errors import CausalityError, ModelError

if TYPE_CHECKING:                      # networkx (causality) and sympy (model) only where a command derives
    from bondgraph.causality import Causality
    from bondgraph.model import Mode, Model

    from ..monitor import Monitor

from ..errors import UsageError
from ..data import DataError
from ..options import DEFAULT_WORKERS, MAX_GENERATIONS, MAX_POP, MIN_POP, MIN_SAMPLES
from ..atomic import on_signals
from .output import (Terminated, check_folder, check_folder_not_input, check_not_input, check_output, is_stdout,
                     write_atomic)
from .sources import Sources, said
from .sources import shown as source_name
from .progress import LOG, NORMAL, QUIET, VERBOSE, Progress, Steps, configure, stage
from .progress import shown as escaped


DIAGNOSIS, SIMULATION = "diagnosis", "simulation"     # bondgraph.causality's purposes (tests/test_cli checks)


def assign(model: "Model", purpose: str) -> "Causality":
    """:func:`bondgraph.causality.assign`, imported when a command assigns causality (networkx)."""
    from bondgraph.causality import assign as assign_causality
    return assign_causality(model, purpose)


def load_model(path):
    """:func:`bondgraph.loader.load_model`, imported when a command reads a model (sympy, yaml)."""
    from bondgraph.loader import load_model as load
    return load(path)


def shown(path: object) -> str:
    """A path or name as a message shows it: the copy of ``-`` as "standard input", control
    characters escaped (a name read from a file can neither start a second line nor drive the
    terminal)."""
    return escaped(source_name(path))


USER_ERRORS = (ModelError, CausalityError, DataError, UsageError)
CAUSALITY_CHOICES = ("derivative", "mixed")
MAX_WORKERS = 256          # processes; more is a typo (and on a forkserver platform, that many processes)
MAX_WAIT = 1e6             # s, as for the model's waiting_time
SIGNALS_PNG = "signals.png"        # simulate --plot DIR: the figure's name in DIR
RUL_CONE_PNG = "rul_cone.png"      # evaluate --plot DIR
MAX_CHAIN = 10_000         # bench derive, bench chain: bgfdi check of 10 000 elements takes about 10 s CPU


# ------------------------------------------------------------------ option values

class Parser(argparse.ArgumentParser):
    """argparse with its errors as one line (``bgfdi: error: --pop: must be ...``), exit code 2:
    the usage text would make a second line, and the option's help is one ``--help`` away."""

    def error(self, message: str) -> None:  # type: ignore[override]
        message = message.removeprefix("argument ")
        hint = "" if "must be" in message else f" (see {self.prog} --help)"
        self.exit(2, f"bgfdi: error: {shown(message)}{hint}\n")


def _bad(expected: str, text: str) -> argparse.ArgumentTypeError:
    return argparse.ArgumentTypeError(f"must be {expected}, got {text if text.strip() else repr(text)}")


def whole(low: int, high: int | None = None) -> Callable[[str], int]:
    """An argparse type: an integer in [low, high] (no upper bound when ``high`` is None)."""
    span = f">= {low}" if high is None else f"from {low} to {high}"

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise _bad(f"an integer {span}", text) from None
        if value < low or (high is not None and value > high):
            raise _bad(f"an integer {span}", text)
        return value
    return parse


def _real_value(text: str, low: float | None, strict: bool, high: float | None) -> float | None:
    """``text`` as a finite float within the bounds, or None."""
    try:
        value = float(text)
    except ValueError:
        return None
    if not math.isfinite(value) or (high is not None and value > high):
        return None
    if low is not None and (value < low or (strict and value == low)):
        return None
    return value


def _real_span(low: float | None, strict: bool, high: float | None) -> str:
    span = "a finite number"
    if low is not None:
        span += f" {'>' if strict else '>='} {low:g}"
    if high is not None:
        span += f"{' and' if low is not None else ''} <= {high:g}"
    return span


def real(low: float | None = None, strict: bool = False, high: float | None = None) -> Callable[[str], float]:
    """An argparse type: a finite float, >= ``low`` (> with ``strict``), <= ``high``."""
    def parse(text: str) -> float:
        value = _real_value(text, low, strict, high)
        if value is None:
            raise _bad(_real_span(low, strict, high), text)
        return value
    return parse


def pair(low: float | None = None, strict: bool = False) -> Callable[[str], tuple[str, float]]:
    """An argparse type: NAME=VALUE with a finite VALUE (> ``low`` with ``strict``); the name is
    checked against the model once it is loaded."""
    def parse(text: str) -> tuple[str, float]:
        name, sep, value = text.partition("=")
        if not sep or not name.strip():
            raise argparse.ArgumentTypeError(f"must be NAME=VALUE, got {text!r}")
        number = _real_value(value, low, strict, None)
        if number is None:
            raise argparse.ArgumentTypeError(f"{name.strip()}: must be {_real_span(low, strict, None)}, got {value!r}")
        return name.strip(), number
    return parse


def method(text: str) -> str:
    """An argparse type: the integrator of ``simulate`` (fdi.app.scenario.METHODS, any case)."""
    from .scenario import METHODS, ScenarioError, check_method
    try:
        return check_method(text)
    except ScenarioError:
        raise argparse.ArgumentTypeError(f"must be one of {', '.join(METHODS)}, got {text!r}") from None


def chain_sizes(text: str) -> tuple[int, ...]:
    """An argparse type: comma-separated chain sizes for ``bench derive``, each 1 to MAX_CHAIN."""
    parse = whole(1, MAX_CHAIN)
    try:
        sizes = tuple(parse(x.strip()) for x in text.split(","))
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"must be comma-separated chain sizes from 1 to {MAX_CHAIN}, such as "
                                         f"1000,2000, got {text!r}") from None
    return sizes


def scheduler(text: str) -> str:
    """An argparse type: ``local`` or a dask scheduler address (fdi.app.fleet.check_address)."""
    from .fleet import check_address
    try:
        return check_address(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def check_plot(path: str | None) -> None:
    """``--plot``: matplotlib present, and a folder that can be made or written into (every
    command's --plot names a folder), refused before any work as ``-o`` is."""
    if path is None:
        return
    import importlib.util
    if importlib.util.find_spec("matplotlib") is None:
        from ..errors import need_matplotlib
        raise need_matplotlib()
    if is_stdout(path):
        raise UsageError("--plot: standard output takes no plot; name a folder")
    check_folder(path, "--plot")


def command_inputs(args: argparse.Namespace) -> list[str]:
    """Every file the command reads: the model, data, scenario and run files, the scenarios of a
    suite folder (an output must be none of them)."""
    inputs = [getattr(args, "model", None), getattr(args, "scenario", None)]
    for name in ("data", "runs"):
        value = getattr(args, name, None)
        inputs += value if isinstance(value, list) else [value]
    if getattr(args, "scenarios", None):
        from .evaluate import suite_files
        inputs += [str(p) for p in suite_files(args.scenarios)] + list(args.scenarios)
    if args.command == "demo":
        from .resources import scenarios_dir, shipped_model
        inputs += [str(shipped_model("cycab_steering")), str(scenarios_dir() / f"cycab_{args.scenario}.json")]
    return [str(x) for x in inputs if isinstance(x, (str, os.PathLike))]


def check_model_input(args: argparse.Namespace) -> None:
    """A model given as a named FIFO is refused before any work: its reader would wait for a writer
    that may never come. (Data and scenario files that are FIFOs are opened without waiting and
    refused only when nothing writes into them: fdi.inputs.)"""
    from ..inputs import is_named_fifo
    model = getattr(args, "model", None)
    if isinstance(model, str) and is_named_fifo(model):
        raise UsageError(f"{model}: a named FIFO; give the model as a regular file (or as <(cat {model}))")


def check_outputs(args: argparse.Namespace) -> None:
    """Every output the command will write, checked before it starts (nothing is then computed
    only to fail at the end, and no input is replaced by an output)."""
    inputs = command_inputs(args)
    if getattr(args, "output", None) is not None:
        check_output(args.output, "-o")
        check_not_input(args.output, inputs, "-o")
    plot = getattr(args, "plot", None)               # --plot names a folder in every command
    check_plot(plot)
    if plot is None:
        return
    check_folder_not_input(plot, inputs, "--plot")
    named = {"simulate": SIGNALS_PNG, "evaluate": RUL_CONE_PNG}.get(args.command)
    output = getattr(args, "output", None)
    if named is not None and output is not None and not is_stdout(output) \
            and os.path.realpath(os.path.join(plot, named)) == os.path.realpath(output):
        raise UsageError(f"--plot: '{os.path.join(plot, named)}' is also the -o file; name another folder or file")


def parse_mode(text: str, model: Model) -> dict[str, int]:
    """``a1=1,a2=0`` -> {'a1': 1, 'a2': 0}, every other mode variable at its nominal value."""
    mode = {n: m.nominal for n, m in model.modes.items()}
    for part in filter(None, (p.strip() for p in text.split(","))):
        name, _, value = part.partition("=")
        name = name.strip()
        if name not in model.modes:
            raise UsageError(f"--mode: '{name}' is no mode variable of {model.name} (known: {', '.join(model.modes)})")
        if value.strip() not in ("0", "1"):
            raise UsageError(f"--mode: {name} must be 0 or 1, got '{value}'")
        mode[name] = int(value)
    return mode


def _emit(text: str, out: str | None) -> None:
    """``text`` to the file ``out`` (atomically), or to standard output (no -o, or -o -)."""
    write_atomic(out if out else "-", text)


def _note(text: str, out: str | None) -> None:
    """A status line: on stdout, unless the result itself goes there (-o -): then a note on
    stderr. Silenced by -q either way."""
    if is_stdout(out):
        LOG.info(text)
    elif LOG.isEnabledFor(logging.INFO):          # -q silences every note
        print(text)


def _json_text(data) -> str:
    """The --json output of a command: indented, numbers as floats (numpy's too)."""
    import json
    return json.dumps(data, indent=1, default=float) + "\n"


# ------------------------------------------------------------------ check / graph

def _causality_lines(model: Model, c: Causality) -> list[str]:
    lines = []
    for b in model.bonds:
        recv = c.effort_to.get(b.id, "?")
        lines.append(f"  {b.id:>4}  {b.source:>10} -> {b.target:<10}  stroke at {recv:<10}  "
                     f"effort into {recv}, flow into {b.other(recv) if recv != '?' else '?'}")
    for s in model.sensors.values():
        recv = c.effort_to.get(s.name, "?")
        lines.append(f"  {s.name:>4}  {s.junction:>10} -> {s.name:<10}  stroke at {recv:<10}  (signal bond, {s.kind})")
    return lines


def cmd_check(args: argparse.Namespace) -> int:
    """The model's summary, causality and residuals; with ``--verify``, the residuals checked on
    the simulated model: exit code 1 when one does not vanish (a finding, one line per ARR and
    mode on standard error), 0 otherwise."""
    if args.json:
        return _check_json(args)
    from ..config import load

    with stage("load"):
        model, config = load(args.model)         # the bond graph and the monitor settings both checked
    report = io.StringIO()                       # printed whole once made: an error half-way prints no half report
    with contextlib.redirect_stdout(report):     # (a parameter of .inf refused at the residuals, after the summary)
        _print_summary(model, shown(args.model))
        arrs = _print_diagnostic_causality(model, args, config)
        from bondgraph.timescales import growth_notes, model_time_scales
        sim = assign(model, SIMULATION)
        with stage("time scales"):
            growing = growth_notes(model_time_scales(model))
        print()
        print("causality for simulation (SCAP, integral causality preferred)")
        print("  storage: " + (", ".join(f"{k} {v}" for k, v in sim.storage.items()) or "none"))
        for p in list(sim.problems) + list(sim.loops) + growing:
            print(f"  note: {p}")
        code = _print_verification(model, arrs, args) if args.verify else 0
    sys.stdout.write(report.getvalue())
    return code


def _check_json(args: argparse.Namespace) -> int:
    """``check --json``: the analysis as one object; 1 when a verified residual does not vanish, or
    none could be verified."""
    from .check_report import analyse
    report = analyse(args.model, args.causality, args.seed if args.verify else None)
    report["file"] = shown(report["file"])
    _emit(_json_text(report), None)
    verification = report["verification"]
    from .verify_report import verified_nothing
    if verification is not None and (not verification["ok"] or verified_nothing(verification)):
        from .verify_report import failures
        for line in failures(verification, args.model):
            LOG.error(line)
        return 1
    return 0


def _print_summary(model: Model, path: str) -> None:
    """The model's elements, junctions, bonds, sensors, modes and faults, one line each."""
    kinds = Counter(e.kind for e in model.elements.values())
    jkinds = Counter(j.kind for j in model.junctions.values())
    print(f"model {model.name} ({path})")
    if model.reference:
        import textwrap
        print(textwrap.fill(model.reference, width=100, initial_indent="  reference: ", subsequent_indent=" " * 13,
                            break_on_hyphens=False, break_long_words=False))
    print(f"  elements   {len(model.elements)}: " + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))
    ctrl = [f"{j.name} ({j.kind}, mode {j.mode})" for j in model.junctions.values() if j.controlled]
    print(f"  junctions  {len(model.junctions)}: " + ", ".join(f"{k}: {v}" for k, v in sorted(jkinds.items()))
          + (f"; controlled: {', '.join(ctrl)}" if ctrl else ""))
    from bondgraph.modes import held_still, latching
    for note in held_still(model) + latching(model):
        print(f"    note: {note}")
    print(f"  bonds      {len(model.bonds)}")
    print(f"  sensors    {len(model.sensors)}: " + ", ".join(
        f"{s.name} ({s.kind} on {s.junction}, {s.measures})" for s in model.sensors.values()))
    print(f"  modes      {len(model.modes)}: " + (", ".join(f"{m.name} ({_driven(m)})" for m in model.modes.values())
                                                   or "none") + f" -> {2 ** len(model.modes)} mode(s)")
    from ..data import unread_columns
    for c in unread_columns(model):
        print(f"  note: data column {c} is read by nothing: a sensor's, an input's or a commanded mode's "
              f"column (modes: <name>: {{column: {c}}})?")
    print(f"  faults     {len(model.faults)}: " + ", ".join(
        f"{f.name} ({f.kind}: {', '.join(f.targets)})" for f in model.faults.values()))
    from .two_ports import laws
    ports = laws(model)
    if ports:            # a TF's modulus is read from its first bond to its second: the laws show which way
        print(f"  two-ports  {len(ports)} (bond variables e[k], f[k]; power from the first node to the second):")
        for p in ports:
            print(f"    {p['name']} ({p['kind']}, {p['from']} -> {p['to']}): {', '.join(p['laws'])}")


def _driven(mode: Mode) -> str:
    """What sets a mode variable, as `check` lists it: its command column, its condition, or only a
    fault (held at its nominal value otherwise)."""
    if mode.column:
        return f"commanded: {mode.column}"
    if mode.autonomous:
        return "autonomous"
    return f"{mode.nominal} unless a fault"


def _print_diagnostic_causality(model: Model, args: argparse.Namespace, config) -> list:
    """SCAPH's assignment, the residuals chosen (SCAPH's, or MSO residuals where it falls short),
    checked defined in every mode, with notes on units and noise that differ by mode; returns the
    residuals."""
    from ..arrs import mixed_unit_notes, select_arrs, undefined_in_modes, unit_clash_notes
    from ..noise import noise_notes, predicted_for
    from ..signatures import all_modes

    with stage("diagnostic causality (SCAPH)"):
        diag = assign(model, DIAGNOSIS)
    print()
    print("causality for diagnosis (SCAPH: sources fixed, sensors inverted, storage in derivative causality)")
    with stage(f"residual selection ({args.causality} causality)"):
        chosen = select_arrs(model, args.causality)
    if not diag.ok:
        for p in list(diag.problems) + list(diag.loops):
            print(f"  SCAPH: {p}")
        if not chosen.arrs:
            from .check_report import no_residual
            raise CausalityError(list(diag.problems) + list(diag.loops) + [no_residual(model, args.model, args.causality)])
        print(f"  SCAPH leaves storage out of derivative causality or closes a loop: the residuals come from "
              f"structural analysis ({chosen.msos} MSO sets, {chosen.candidates} computable in "
              f"{args.causality} causality)")
    arrs = list(chosen.arrs)
    bad = undefined_in_modes(model, arrs, all_modes(model))
    if bad:
        raise CausalityError(bad)
    _print_assignment(model, diag)
    print()
    print(f"residuals ({args.causality} causality): " + ", ".join(f"{a.name} ({_origin(a)})" for a in arrs))
    for note in chosen.notes:
        print(f"  note: {note}")
    from ..signatures import unread_fault_note
    for note in unit_clash_notes(model, arrs) + mixed_unit_notes(model, arrs) + unread_fault_note(model, arrs,
                                                                                                   args.causality):
        print(f"  note: {note}")
    if args.causality == "derivative":
        from ..detect import checked_thresholds
        if (missing := checked_thresholds(model, config.thresholds, [a.name for a in arrs])) is not None:
            print(f"  note: {missing}")
        with stage("noise predicted by mode"):
            window, predicted = predicted_for(model, config, arrs)
        for note in noise_notes(model, arrs, predicted, window):
            print(f"  note: {note}")
    return arrs


def _origin(a) -> str:
    """Where a residual comes from, as `check` lists it: SCAPH at a sensor, an MSO set's residual at a
    junction, and whether it was rebuilt mode by mode (fdi.modewise: "SCAPH by mode" is one SCAPH ARR
    per sensor joined by mode indicators; "+modes" the mode's own ARRs joined in place of one).

    >>> from types import SimpleNamespace as A
    >>> [_origin(A(origin=o, sensor="T1", junction="J1")) for o in ("SCAPH", "SCAPH by mode", "MSO", "MSO+modes",
    ...                                                               "MSO in mode c=1")]
    ['SCAPH, T1', 'SCAPH by mode, T1', 'MSO at J1', 'MSO at J1, rebuilt mode by mode', 'MSO at J1, mode c=1 only']
    >>> _origin(A(origin="SCAPH+zero", sensor="I", junction="Je"))
    "SCAPH, I, its sensor's zero where switched off"
    """
    base, _, mode = a.origin.removesuffix("+modes").removesuffix("+zero").partition(" in mode ")
    text = f"{base}, {a.sensor}" if base.startswith("SCAPH") else f"MSO at {a.junction}"
    return (text + (", rebuilt mode by mode" if a.origin.endswith("+modes") else "")
            + (", its sensor's zero where switched off" if a.origin.endswith("+zero") else "")
            + (f", mode {mode} only" if mode else ""))


def _print_assignment(model: Model, diag: Causality) -> None:
    """One assignment valid in every mode, storage causalities, strong bonds, detectors, strokes."""
    n_modes = len(diag.modes_checked)
    print(f"  one assignment, valid in all {n_modes} mode(s)"
          + (f" ({', '.join(model.modes)} in {{0, 1}}; checked: every residual is defined in each): controlled "
             "junction outputs are multiplied by their mode variable, so no causality is reassigned at a switch"
             if model.modes else ""))
    print("  storage: " + (", ".join(f"{k} {v}" for k, v in diag.storage.items()) or "none"))
    if diag.ok and all(v == "derivative" for v in diag.storage.values()):
        print("  all storage elements in derivative causality")
    for j in model.junctions.values():
        if j.controlled and j.name in diag.strong:
            print(f"  controlled junction {j.name}: strong bond {diag.strong[j.name]} (preferred causality), "
                  f"outputs x {j.mode}")
    for s in sorted(diag.detectors):
        print(f"  sensor {s}: a second sensor on junction {model.sensors[s].junction}, a detector (its own residual)")
    print("  bond  from -> to  causal stroke:")
    for line in _causality_lines(model, diag):
        print(line)


def _print_verification(model: Model, arrs: list, args: argparse.Namespace) -> int:
    """``--verify``: every residual on the model's own simulation; 1 when one does not vanish, or
    none could be verified."""
    from ..verify import verify
    from .verify_report import failures, to_json, to_lines, verified_nothing

    with stage("verification on the simulated model"):
        verification = verify(model, arrs, seed=args.seed)
    print()
    for line in to_lines(verification):
        print(line)
    data = to_json(verification)
    for line in failures(data, args.model):
        LOG.error(line)
    return 0 if verification.ok and not verified_nothing(data) else 1


GRAPH_FORMATS = ("dot", "svg", "png", "pdf")
GRAPH_SUFFIXES = {".dot": "dot", ".gv": "dot", ".svg": "svg", ".png": "png", ".pdf": "pdf"}


def graph_format(fmt: str | None, output: str | None) -> str:
    """The format of ``graph``: ``--format``, else the -o file's suffix, else DOT; a --format that
    contradicts a known suffix (DOT text in ``g.png``) is refused."""
    from pathlib import Path

    implied = None if output is None or is_stdout(output) else GRAPH_SUFFIXES.get(Path(output).suffix.lower())
    if fmt is not None and implied is not None and fmt != implied:
        raise UsageError(f"--format {fmt}: contradicts -o {output} ({implied}); give a file ending in .{fmt} or "
                         f"--format {implied}")
    return fmt or implied or "dot"


def cmd_graph(args: argparse.Namespace) -> int:
    """The model as Graphviz DOT text, or rendered by Graphviz's ``dot`` (svg, png, pdf)."""
    import shutil
    import subprocess

    from bondgraph.dot import to_dot

    fmt = graph_format(args.format, args.output)
    dot = shutil.which("dot") if fmt != "dot" else None
    if fmt != "dot" and dot is None:
        given = f"--format {fmt}" if args.format else f"-o {args.output} ({fmt})"
        raise UsageError(f"{given}: needs Graphviz's dot program on PATH (install Graphviz: apt install "
                         "graphviz, brew install graphviz or conda install graphviz), or write --format dot")
    model = load_model(args.model)
    text = to_dot(model, assign(model, args.purpose))
    if fmt == "dot":
        _emit(text, args.output)
        return 0
    with stage(f"dot -T{fmt}"):
        done = subprocess.run([dot, f"-T{fmt}"], input=text.encode("utf-8"), capture_output=True, timeout=600)
    if done.returncode != 0:
        problem = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise UsageError(f"dot -T{fmt} failed (exit {done.returncode}): {problem[0] if problem else 'no message'}")
    write_atomic(args.output if args.output else "-", done.stdout)
    return 0


# ------------------------------------------------------------------ tables

def cmd_tables(args: argparse.Namespace) -> int:
    from ..arrs import select_arrs, undefined_in_modes
    from ..signatures import all_modes, fault_signature_matrix, mode_change_signature_matrix
    from ..tables import render

    fmt = _tables_format(args)
    with stage("load"):
        model = load_model(args.model)
    modes = [parse_mode(args.mode, model)] if args.mode else all_modes(model)    # a bad --mode before the derivation
    with stage(f"residuals ({args.causality} causality)"):
        arrs = list(select_arrs(model, args.causality).arrs)
    if not arrs:
        raise CausalityError([f"{model.name} has no residual in {args.causality} causality; "
                              f"bgfdi isolability {args.model} proposes sensors"])
    bad = undefined_in_modes(model, arrs, modes)
    if bad:
        raise CausalityError(bad)
    with stage(f"signature matrices ({len(modes)} mode(s))"):
        fsms = [fault_signature_matrix(model, arrs, m) for m in modes]
        mcsm = mode_change_signature_matrix(model, arrs, modes[0] if args.mode else None)
    _emit(render(fmt, arrs, fsms, mcsm), args.output)
    return 0


def _tables_format(args: argparse.Namespace) -> str:
    """--json is --format json; with another --format it is a contradiction, refused."""
    if args.json and args.format not in (None, "json"):
        raise UsageError(f"--json: contradicts --format {args.format}; give one of them")
    return "json" if args.json else args.format or "text"


# ------------------------------------------------------------------ isolability

def cmd_isolability(args: argparse.Namespace) -> int:
    from .isolability_report import analyse, to_json, to_text

    from ..config import load as load_config
    model, config = load_config(args.model)
    modes = [parse_mode(args.mode, model)] if args.mode else None
    result = analyse(model, args.causality, modes, args.max_sensors, config)
    _emit(to_json(result) if args.json else to_text(result), args.output)
    return 0


# ------------------------------------------------------------------ simulate

def cmd_simulate(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from .scenario import check_steps, csv_chunks, load_scenario, run

    model = load_model(args.model)
    scenario = load_scenario(args.scenario, model)          # ScenarioError is a UsageError: one line
    if args.seed is not None:
        scenario = replace(scenario, seed=args.seed)
    check_steps(scenario, args.method)
    if args.json and is_stdout(args.output):
        raise UsageError("--json: standard output carries the CSV (-o -); write the CSV to a file or drop --json")
    stages: dict[str, float] = {}
    with Progress(scenario.T, "simulating", "s") as bar:
        columns = run(model, scenario, progress=bar, method=args.method, stages=stages)
    for name, seconds in stages.items():
        LOG.debug("simulation stage %s: %.3f s CPU", name, seconds)
    with stage("writing the CSV"):
        write_atomic(args.output, csv_chunks(columns))
    where = "standard output" if is_stdout(args.output) else args.output
    if not args.json:
        _note(f"wrote {where}: {len(columns['t'])} samples of {', '.join(columns)}", args.output)
    if args.plot:
        from pathlib import Path

        from ..plots import column_units, plot_signals
        Path(args.plot).mkdir(parents=True, exist_ok=True)
        written = Path(args.plot) / SIGNALS_PNG
        plot_signals(columns, written, column_units(model), [(f.target, f.t0) for f in scenario.faults])
        if not args.json:
            _note(f"plot: {written}", args.output)
    if args.json:
        sys.stdout.write(_json_text(_simulation_summary(model, scenario, columns, args)))
    return 0


def _simulation_summary(model: Model, scenario, columns: dict, args: argparse.Namespace) -> dict:
    """simulate --json: what was simulated and written (times in s)."""
    from dataclasses import asdict
    t = columns["t"]
    return {"model": model.name, "scenario": shown(args.scenario), "output": args.output, "plot": args.plot,
            "samples": int(len(t)), "columns": list(columns), "t_start": float(t[0]), "t_end": float(t[-1]),
            "sampling_time": 1.0 / scenario.fs, "seed": scenario.seed, "method": args.method,
            "faults": [{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(f).items()}
                       for f in scenario.faults]}


# ------------------------------------------------------------------ diagnose / demo

def _named(pairs: list[tuple[str, float]] | None, option: str, known: list[str], what: str) -> dict[str, float]:
    """NAME=VALUE pairs (values checked while parsing) whose names must be in ``known``."""
    out = dict(pairs or [])
    for k in out:
        if k not in known:
            raise UsageError(f"{option}: '{k}' is no {what} (use {', '.join(known)})")
    return out


def _options(args: argparse.Namespace, monitor: "Monitor"):
    """The diagnosis Options from the command line; the names in --threshold and --failure are
    checked against the model here, every value was checked while parsing."""
    from optim import ENGINES

    from ..options import Options
    if args.engine not in ENGINES:
        raise UsageError(f"--engine: unknown engine '{args.engine}' (use {', '.join(ENGINES)})")
    model = monitor.model
    names = list(monitor.names)
    thresholds = _named(args.threshold, "--threshold", names, f"residual of {model.name}")
    failures = _named(args.failure, "--failure", list(model.faults), f"fault of {model.name}")
    options = Options(thresholds=thresholds, waiting_time=args.wait, persistence=args.persistence,
                      exoneration=not args.no_exoneration,
                      engine=args.engine, pop=args.pop, generations=args.generations, samples=args.samples,
                      seed=args.seed, workers=args.workers, failures=failures, max_set=args.max_set,
                      keep_spikes=getattr(args, "keep_spikes", False))
    options.check()
    return options


def _timings_line(d) -> str:
    stages = d.timings
    return "timings: " + ", ".join(f"{k} {v:.2f} s" for k, v in stages.items()) + "\n"


def _diagnose_and_print(model_path: str, data, options, args, data_name: str) -> int:
    """Diagnose, print (text or --json), plot; 3 with --fail-on-fault when a fault was found, else 0."""

    from ..monitor import compiled, persist
    from .report import to_text
    monitor = compiled(str(model_path))
    model = monitor.model
    with Steps("estimators") as tick:
        d = monitor.diagnose(data, options, progress=tick)
    persist(monitor)                      # what this diagnosis derived (time scales, FSMs) for the next process
    for name, seconds in d.timings.items():
        LOG.debug("diagnosis stage %s: %.3f s", name, seconds)
    public = d.to_dict(args.timings)      # wall-clock times only with --timings: two runs are byte-identical
    if args.json:
        text = _json_text(public)
    else:
        from ..objective import nominal
        from ..results import value_unit
        text = to_text(public, model.name, data_name, {n: f.targets[0] for n, f in model.faults.items()
                                                         if f.kind == "mode"},
                       {n: value_unit(model, n) for n in model.faults},
                       {m for m, mode in model.modes.items() if mode.autonomous},
                       {n: nominal(model, n) for n, f in model.faults.items() if f.kind != "mode"}) \
            + (_timings_line(d) if args.timings else "")
    _emit(text, getattr(args, "output", None))
    if getattr(args, "plot", None):
        from ..plots import plot_diagnosis
        for p in plot_diagnosis(d, args.plot, model):
            LOG.info(f"plot: {p}")
    return 3 if getattr(args, "fail_on_fault", False) and public["diagnosis"]["faults"] else 0


def cmd_diagnose(args: argparse.Namespace) -> int:
    from ..data import read_csv
    from ..options import check_samples
    from ..monitor import compiled

    _check_fleet_options(args)
    monitor = compiled(args.model)
    options = _options(args, monitor)
    if len(args.data) > 1 or (args.jobs or 1) > 1 or args.scheduler or is_parquet(args.output):
        return _diagnose_batch(args, options)
    data = read_csv(args.data[0])
    check_samples(options.samples, data.ts, "--samples", monitor.min_period(options, data.ts))
    return _diagnose_and_print(args.model, data, options, args, shown(args.data[0]))


def is_parquet(path: str | None) -> bool:
    """An -o file whose suffix asks for a Parquet table (``diagnose``)."""
    return path is not None and not is_stdout(path) and str(path).lower().endswith(".parquet")


def check_parquet(args: argparse.Namespace) -> None:
    """``diagnose -o X.parquet``: the parquet extra installed and no --json, checked before any work."""
    from .fleet import have_parquet, need_parquet
    if not is_parquet(getattr(args, "output", None)):
        return
    if args.json or args.plot:
        raise UsageError(f"{'--json' if args.json else '--plot'}: -o {args.output} writes a Parquet table, one "
                         "row per fault; drop it, or write the report to a .json file")
    if not have_parquet():
        raise need_parquet(f"-o {args.output}")


def _check_fleet_options(args: argparse.Namespace) -> None:
    """--plot: one file only; --scheduler: the dask extra installed; --jobs only with a
    LocalCluster (a running cluster has its own workers). Checked before any work."""
    if args.plot and (len(args.data) > 1 or (args.jobs or 1) > 1 or args.scheduler):
        raise UsageError("--plot: a fleet of files draws no plots; diagnose one file with --plot DIR")
    if not args.scheduler:
        return
    from .fleet import have_dask, need_dask
    if not have_dask():
        raise need_dask()
    if args.scheduler != "local" and args.jobs is not None:
        raise UsageError(f"--jobs: the cluster at {args.scheduler} runs as many files at once as it has workers; "
                         "drop --jobs, or give --scheduler local --jobs N for a LocalCluster of N processes")


def _diagnose_batch(args: argparse.Namespace, options) -> int:
    """Several files: one JSON line each, in the order given; ``--jobs`` processes, or a dask
    cluster (``--scheduler``), through fdi.app.fleet.diagnose_many. A bad file gives its line with
    an ``error`` and the others go on; the exit status is 2 if any was bad, else 3 with
    ``--fail-on-fault`` when any has a fault, else 0."""
    import json
    from contextlib import nullcontext

    from .fleet import Cluster, diagnose_many, workers_of
    jobs = args.jobs or 1
    local = max(1, min(args.jobs or os.cpu_count() or 1, len(args.data)))    # no more workers than files
    where = (f"dask scheduler {args.scheduler}" if args.scheduler and args.scheduler != "local"
             else f"a dask LocalCluster of {local} worker(s)" if args.scheduler
             else f"{min(jobs, len(args.data))} process(es)")
    with (Cluster(args.scheduler, args.jobs, len(args.data)) if args.scheduler else nullcontext()) as client:
        if client is not None:
            LOG.debug("dask scheduler %s: %d worker(s)", client.scheduler.address, workers_of(client))
        LOG.info(f"diagnosing {len(args.data)} file(s) on {where}")
        with Steps("diagnosed", "files") as tick, stage("fleet"):
            lines = diagnose_many(args.model, args.data, options, client=client, jobs=jobs, timings=args.timings,
                                  progress=tick)
    for line in lines:
        line["file"] = shown(line["file"])
        line["error"] = None if line["error"] is None else said(line["error"])
    if is_parquet(args.output):
        from .fleet import parquet_bytes
        write_atomic(args.output, parquet_bytes(lines))
        _note(f"wrote {args.output}: {len(lines)} file(s), one row per fault", args.output)
    else:
        _emit("".join(json.dumps(line, default=float) + "\n" for line in lines), getattr(args, "output", None))
    if any(line["error"] is not None for line in lines):
        for line in lines:
            if line["error"] is not None:
                LOG.error(line["error"])
        return 2
    if args.fail_on_fault and any(line["diagnosis"]["faults"] for line in lines):
        return 3
    return 0


class _VersionAction(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata costs
    every other command 30 ms of imports and a scan of the installed distributions)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0,
                         help=help or "show the program's version number and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        sys.stdout.write(f"bgfdi {_version()}\n")
        parser.exit()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("bgfdi")
    except PackageNotFoundError:
        return "unknown (not installed)"


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Thresholds from nominal runs; printed, or written into a copy of the model (-o)."""
    from pathlib import Path

    from ..calibrate import calibrate, format_calibration, with_thresholds
    from ..monitor import compiled

    compiled(args.model)                                   # the model checked before the runs are read
    c = calibrate(args.model, args.runs, args.margin, args.quantile, window=args.window, by_mode=args.by_mode)
    text = _json_text(c.to_dict()) if args.json else format_calibration(c)
    if args.output:
        try:
            edited = with_thresholds(Path(args.model).read_text(encoding="utf-8"), c)
        except ValueError as e:              # a diagnosis key laid out in a way the window cannot be added to
            raise DataError(f"{args.model}: the chosen derivative window ({c.window:.4g} s) cannot be written into a "
                            f"copy: {e}; add diagnosis: {{derivative_window: {c.window:.4g}}} by hand") from None
        write_atomic(args.output, edited)
        # (with --json, the note goes to standard error: standard output is one JSON document)
        _note(f"wrote {args.output} with the calibrated thresholds", "-" if args.json else args.output)
    sys.stdout.write(text)
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Each scenario simulated, diagnosed and scored (fdi.app.evaluate); a table or --json."""

    from .evaluate import format_scores, scenario_cost, suite_files, summary
    from ..monitor import compiled
    from .scenario import load_scenario

    monitor = compiled(args.model)
    model = monitor.model
    options = _options(args, monitor)
    files = suite_files(args.scenarios, skipped=LOG.warning)
    if not files:
        raise UsageError(f"no scenario files in {', '.join(args.scenarios)}")
    # every file checked before the first simulation; each weighs its samples in the ETA
    costs = [scenario_cost(load_scenario(f, model)) for f in files]
    scores = _evaluate_files(args.model, files, options, costs, args.jobs)
    totals = summary(scores)
    if args.json:
        text = _json_text({"model": model.name, "summary": totals, "scenarios": [s.to_dict() for s in scores]})
    else:
        text = format_scores(scores, totals)
    _emit(text, args.output)
    if args.plot:
        from pathlib import Path

        from ..plots import plot_rul_cone
        Path(args.plot).mkdir(parents=True, exist_ok=True)
        LOG.info(f"plot: {plot_rul_cone(scores, Path(args.plot) / RUL_CONE_PNG)}")
    return 0


def _evaluate_files(model_path: str, files: list, options, costs: list[float] | None = None, jobs: int = 1) -> list:
    """Each scenario simulated, diagnosed and scored, with progress (one line each with -v). The
    progress counts each scenario's samples (``costs``, :func:`fdi.app.evaluate.scenario_cost`):
    simulating and diagnosing take time in proportion to them, so the ETA of a suite of unequal
    scenarios is not the optimistic one of a uniform rate per scenario. ``jobs`` > 1: that many
    scenarios at once, one process each, their estimators in that process (the scores are the
    same: each scenario is seeded by its own file, and results do not depend on workers)."""
    import time

    from .evaluate import evaluate_scenario, scenario_cost
    if costs is None:
        from .scenario import load_scenario
        model = load_model(model_path)
        costs = [scenario_cost(load_scenario(f, model)) for f in files]
    if jobs > 1 and len(files) > 1:
        from dataclasses import replace
        from functools import partial

        from .parallel import map_in_order
        with Progress(sum(costs), f"evaluating {model_path} ({len(files)} scenarios, {jobs} at once)",
                      "samples") as bar:
            return map_in_order(partial(evaluate_scenario, model_path, options=replace(options, workers=1)), files,
                                jobs, progress=lambda done, total: bar(sum(costs) * done / total))
    scores = []
    with Progress(sum(costs), f"evaluating {model_path} ({len(files)} scenarios)", "samples") as bar:
        for f, cost in zip(files, costs):
            start = time.perf_counter()
            scores.append(evaluate_scenario(model_path, f, options))
            LOG.debug("scenario %s: %.2f s", f.name, time.perf_counter() - start)
            bar.advance(cost)
    return scores


def check_monitor_options(args: argparse.Namespace) -> None:
    """The diagnosis options monitor takes but could not honour are refused, not ignored."""
    if args.json:
        raise UsageError("--json: monitor always writes JSON lines, one event each; drop --json")
    if args.plot:
        raise UsageError("--plot: monitor draws no plots; diagnose the recorded file with bgfdi diagnose --plot DIR")


def cmd_monitor(args: argparse.Namespace) -> int:
    """Feed the stream to a Monitor block by block; each event is one JSON line on standard output
    (or in the -o file, written when the stream ends)."""
    import json

    import numpy as np

    from ..chunks import chunks, gathered
    from ..data import Measurements, blocks, check_against_model, open_text
    from ..monitor import compiled
    from ..results import deterministic

    compiled_monitor = compiled(args.model)
    model = compiled_monitor.model
    options = _options(args, compiled_monitor)
    lines: list[str] = []
    held: list[dict] | None = []            # events before the header is read and checked: held

    def emit(event: dict) -> None:
        if held is not None:
            held.append(event)
            return
        if not args.timings:
            event = deterministic(event)
        line = json.dumps(event, sort_keys=False, default=float)
        if args.output and not is_stdout(args.output):
            lines.append(line)
        else:
            print(line, flush=True)

    def header_read(header: list[str]) -> None:
        """The header is one the model can read: the held events (``start``) go out."""
        nonlocal held
        check_against_model(model, Measurements(source, np.zeros(2), dict.fromkeys(header)))
        events, held = held or [], None
        for event in events:
            emit(event)
    source = "standard input" if args.data == "-" else args.data
    if args.data == "-" and (sys.stdin is None or sys.stdin.closed):
        raise UsageError("monitor: standard input is closed; pipe the CSV stream in (header first), or give a file")
    if args.data != "-":
        fh = open_text(args.data)
    elif hasattr(sys.stdin, "buffer") and hasattr(sys.stdin.buffer, "peek"):
        from ..data import text_of         # as a file is read: a byte-order mark, UTF-16, gzip
        try:
            fh = text_of(sys.stdin.buffer)
        except OSError as exc:              # a descriptor not open for reading (0>file)
            raise UsageError(f"monitor: cannot read standard input ({exc.strerror or exc}); pipe the CSV stream "
                             "in (header first), or give a file") from None
    else:
        fh = sys.stdin                      # a text stream given as such (a test's capture)
    monitor = None
    try:
        with _terminated_raises():
            live = _live(fh)
            monitor = compiled_monitor.stream(emit, options, source=source, refresh=args.refresh,
                                              history=args.history, live=live)
            # a live source block by block as its rows arrive; a recording a megabyte at a time,
            # parsed in C (fdi.chunks) and fed as blocks of --block rows: the same events
            if live:                        # joined while more rows are already waiting
                rows = gathered(blocks(fh, source, args.block, cut=LOG.warning, on_header=header_read), fh)
            else:
                rows = chunks(fh, source, args.block, cut=LOG.warning, on_header=header_read)
            for header, block in rows:      # a stream cut mid-row: its last row dropped with a warning
                monitor.feed(header, block, rows=args.block)
            monitor.close()
        from ..monitor import persist
        persist(compiled_monitor)
    finally:
        if monitor is not None:
            monitor.stop(now=True)          # after an error, Ctrl-C or SIGTERM: no worker left running
        if args.data != "-":
            fh.close()
        elif fh is not sys.stdin:
            fh.detach()                     # the wrapper made here: standard input itself stays open
    if lines:
        write_atomic(args.output, "\n".join(lines) + "\n")
    return 0


def _live(fh) -> bool:
    """A stream read as it arrives (a pipe, a terminal, a socket): identifications run while it is
    read on. A regular file is a recording, replayed: each identification waited for, as if it took
    no stream time, so its events are the same on every run."""
    import stat
    try:
        return not stat.S_ISREG(os.fstat(fh.fileno()).st_mode)
    except (AttributeError, OSError, ValueError):     # no descriptor (a test's StringIO): a recording
        return False


class Stopped(Terminated):
    """SIGTERM or SIGHUP while the monitor read its stream (no partial output to remove)."""


def _terminated_raises():
    """SIGTERM (and SIGHUP) raise :class:`Stopped` while the monitor runs, so that its worker is
    ended (``finally``) instead of outliving a killed reader; the handlers are put back after."""
    def handler(signum, frame):
        raise Stopped(signum)
    return on_signals(handler)


def _removed_on_signal(sources: Sources):
    """SIGTERM and SIGHUP remove the copy of standard input, then end the process by the signal's
    default action (a process pool's workers, forked with the handler, only end); the handlers are
    put back after."""
    import signal
    owner = os.getpid()

    def handler(signum, frame):
        if os.getpid() == owner:        # not a forked worker the parent may end while it reads on
            sources.close()
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
    return on_signals(handler)


def cmd_demo(args: argparse.Namespace) -> int:
    """Simulate CyCab scenario 2 with bgfdi's own simulator, diagnose it, print the report."""
    from ..data import Measurements
    from ..options import check_samples
    from ..monitor import compiled
    from .resources import scenarios_dir, shipped_model
    from .scenario import load_scenario, run

    path = str(shipped_model("cycab_steering"))
    monitor = compiled(path)
    model = monitor.model
    options = _options(args, monitor)                 # bad options refused before simulating
    scenario = load_scenario(scenarios_dir() / f"cycab_{args.scenario}.json", model)
    check_samples(options.samples, 1.0 / scenario.fs, "--samples")
    LOG.info(f"simulating CyCab {args.scenario} ({scenario.T:g} s; faults: "
             + (", ".join(f"{f.target} {f.type} from {f.t0:g} s" for f in scenario.faults) or "none") + ")")
    with Progress(scenario.T, "simulating", "s") as bar, stage("simulation"):
        cols = run(model, scenario, progress=bar)
    data = Measurements(f"simulated {args.scenario}", cols["t"], cols)
    LOG.info("diagnosing ...")
    return _diagnose_and_print(path, data, options, args, f"simulated CyCab {args.scenario}")


# ------------------------------------------------------------------ bench

def cmd_bench(args: argparse.Namespace) -> int:
    from . import bench
    from .resources import shipped_models

    if args.what == "derive":
        sizes = args.sizes or bench.CHAIN_SIZES
        rows = bench.derive_rows(shipped_models(), sizes, echo=LOG.info if args.json else lambda line: _note(line, None))
        sys.stdout.write(_json_text(bench.derive_json(rows)) if args.json else bench.format_derive(rows))
        return 0
    if args.what == "chain":
        echo = LOG.info if args.json else (lambda line: _note(line, None))
        rows = bench.chain_rows(args.sizes or bench.CHECK_CHAINS, echo=echo)
        sys.stdout.write(_json_text(bench.chain_json(rows)) if args.json else bench.format_chain(rows))
        return 0
    if args.what == "simulate":
        from .resources import scenarios_dir
        row = bench.simulate_rows(scenarios_dir() / "cycab_scenario2.json")
        sys.stdout.write(_json_text(bench.simulate_json(row)) if args.json else bench.format_simulate(row))
        return 0
    if args.what == "optim":

        from optim import ENGINES

        from . import synthetic
        if args.problem not in synthetic.GROUPS and args.problem not in synthetic.CASES and args.problem != "scenario2":
            raise UsageError(f"--problem: unknown '{args.problem}' (synthetic, synthetic-all, scenario2, "
                             f"or one of {', '.join(synthetic.CASES)})")
        methods = args.methods.split(",") if args.methods else list(ENGINES)
        for m in methods:
            if m not in ENGINES:
                raise UsageError(f"--methods: unknown engine '{m}' (use {', '.join(ENGINES)})")
        with Steps("optimiser runs", "runs") as tick:
            rows = bench.optim_rows(args.problem, args.runs, methods, workers=args.workers, progress=tick)
        summary = bench.summarise_optim(args.problem, args.runs, rows)
        sys.stdout.write(_json_text({"benchmark": "optim", **summary}) if args.json
                         else bench.format_optim(summary))
        return 0
    if args.what == "accuracy":
        from ..options import Options
        from .evaluate import format_scores, suite_files, summary
        from .resources import scenarios_dir, shipped_model
        suites = []
        for suite in sorted(p for p in scenarios_dir().iterdir() if p.is_dir() and p.name.startswith("suite_")):
            model = str(shipped_model(suite.name.removeprefix("suite_")))
            scores = _evaluate_files(model, suite_files([str(suite)]), Options(workers=args.workers, seed=args.seed))
            if args.json:
                suites.append({"suite": suite.name, "model": load_model(model).name, "summary": summary(scores),
                               "scenarios": [s.to_dict() for s in scores]})
            else:
                sys.stdout.write(f"{suite.name} ({model})\n" + format_scores(scores, summary(scores)) + "\n")
        if args.json:
            sys.stdout.write(_json_text({"benchmark": "accuracy", "seed": args.seed, "suites": suites}))
        return 0
    if args.what == "monitor":
        from .bench_monitor import format_monitor, monitor_json, monitor_rows
        row = monitor_rows(args.hours, args.block, echo=LOG.info if args.json else lambda line: _note(line, None))
        sys.stdout.write(_json_text(monitor_json(row)) if args.json else format_monitor(row))
        return 0
    if args.what == "fleet":
        from .bench_fleet import fleet_json, fleet_rows, format_fleet
        from .resources import reference_data, shipped_model
        row = fleet_rows(reference_data("nominal.csv").parent, str(shipped_model("cycab_steering")),
                         workers=args.workers, echo=LOG.info if args.json else lambda line: _note(line, None))
        sys.stdout.write(_json_text(fleet_json(row)) if args.json else format_fleet(row))
        return 0
    if args.what == "startup":
        from .bench_startup import format_startup, startup_json, startup_row
        from .resources import reference_data, shipped_model
        row = startup_row(shipped_model("cycab_steering"), reference_data("scenario3.csv"))
        sys.stdout.write(_json_text(startup_json(row)) if args.json else format_startup(row))
        return 0
    if args.what == "csv":
        from .bench_csv import csv_json, csv_rows, format_csv
        row = csv_rows(args.megabytes, echo=LOG.info if args.json else lambda line: _note(line, None))
        sys.stdout.write(_json_text(csv_json(row)) if args.json else format_csv(row))
        return 0
    if args.what == "diagnose":
        from .resources import reference_data
        row = bench.diagnose_rows(reference_data("scenario2.csv"), args.workers)
        sys.stdout.write(_json_text(bench.diagnose_json(row)) if args.json else bench.format_diagnose(row))
        return 0
    raise UsageError(f"unknown benchmark '{args.what}'")


# ------------------------------------------------------------------ codegen

def cmd_codegen(args: argparse.Namespace) -> int:
    """A self-contained C99 residual monitor of the model, written into a folder (docs/deploy.md)."""
    from pathlib import Path

    from ..codegen import generate, write_folder
    from ..monitor import compiled
    from ..options import Options
    _check_codegen_folder(args.folder, [args.model])
    with stage("load"):
        monitor = compiled(args.model)
    thresholds = _named(args.threshold, "--threshold", list(monitor.names), f"residual of {monitor.model.name}")
    options = Options(thresholds=thresholds, waiting_time=args.wait, persistence=args.persistence)
    with stage("code generation"):
        files = generate(monitor, args.sampling_time, options, args.prefix, args.lang)
    _check_codegen_folder(args.folder, [args.model], files)
    write_folder(files, args.folder)
    _note(f"wrote {', '.join(str(Path(args.folder) / n) for n in files)}; build and run: make -C {args.folder} "
          f"&& {Path(args.folder) / 'monitor'} DATA.csv", None)
    return 0


def _check_codegen_folder(folder: str, inputs: list[str], files: dict[str, str] | None = None) -> None:
    """Refuse, before any work, an output folder that is standard output, a file, cannot be made
    or written into, or holds an input under a generated file's name (``files``, once known)."""
    from pathlib import Path

    from .output import OutputError
    if is_stdout(folder):
        raise OutputError("-o: standard output cannot take a folder of files; name a folder")
    if str(folder).strip() == "":
        raise OutputError("-o: the path is empty; name a folder")
    for source in inputs:
        if Path(folder).exists() and Path(source).exists() and os.path.samefile(folder, source):
            raise OutputError(f"-o: '{folder}' is the input {source} of this command; name a folder")
    parent = Path(folder).parent
    if parent.exists() and not parent.is_dir():
        raise OutputError(f"-o: '{parent}' is a file, not a folder; name a folder in a folder")
    check_folder(folder, "-o")
    for name in files or ():
        check_not_input(Path(folder) / name, inputs, "-o")


# ------------------------------------------------------------------ main

def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="bgfdi", description="Fault diagnosis and prognosis with hybrid bond graphs.")
    p.add_argument("--version", action=_VersionAction)
    _verbosity_options(p, suppress=False)
    sub = p.add_subparsers(dest="command", required=True)

    c = sub.add_parser("check", help="validate a model and show its causality")
    c.add_argument("model")
    c.add_argument("--causality", choices=CAUSALITY_CHOICES, default="derivative",
                   help="residuals that differentiate only (default) or may integrate (mixed)")
    c.add_argument("--json", action="store_true", help="print the summary, causality and residuals as JSON")
    c.add_argument("--verify", action="store_true",
                   help="also simulate the model in every mode from random states and inputs and check that every "
                        "residual vanishes on it (exit code 1 when one does not)")
    c.add_argument("--seed", type=whole(0), default=0,
                   help="--verify: the seed of its random states and inputs, an integer >= 0 (default 0)")
    c.set_defaults(func=cmd_check)

    g = sub.add_parser("graph", help="the bond graph with causal strokes: Graphviz DOT, or SVG, PNG, PDF by dot")
    g.add_argument("model")
    g.add_argument("-o", "--output", help="file to write (default, or -: standard output); its suffix (.dot, .gv, "
                   ".svg, .png, .pdf) sets the format when --format is not given")
    g.add_argument("--format", choices=GRAPH_FORMATS,
                   help="dot (the default: DOT text), or svg, png, pdf rendered by Graphviz's dot (on PATH)")
    g.add_argument("--purpose", choices=(DIAGNOSIS, SIMULATION), default=DIAGNOSIS)
    g.set_defaults(func=cmd_graph)

    t = sub.add_parser("tables", help="AGARRs, MD-FSM and MCSM")
    t.add_argument("model")
    t.add_argument("--mode", help="one mode, e.g. a1=1,a2=1 (default: every mode)")
    t.add_argument("--format", choices=("text", "markdown", "latex", "json", "csv"),
                   help="text (default), markdown, latex, json or csv")
    t.add_argument("--json", action="store_true", help="the same as --format json")
    t.add_argument("--causality", choices=CAUSALITY_CHOICES, default="derivative",
                   help="residuals that differentiate only (default) or may integrate (mixed)")
    t.add_argument("-o", "--output", help="file to write (default, or -: standard output)")
    t.set_defaults(func=cmd_tables)

    iso = sub.add_parser("isolability", help="detectability and isolability per mode; sensor placement")
    iso.add_argument("model")
    iso.add_argument("--causality", choices=CAUSALITY_CHOICES, default="derivative",
                     help="causal interpretation of differential constraints (default derivative)")
    iso.add_argument("--mode", help="one mode, e.g. v=0 (default: every mode)")
    iso.add_argument("--max-sensors", type=whole(0, 6), default=3, help="largest sensor set tried for placement (0 to 6)")
    iso.add_argument("--json", action="store_true", help="print the analysis as JSON")
    iso.add_argument("-o", "--output", help="file to write (default, or -: standard output)")
    iso.set_defaults(func=cmd_isolability)

    s = sub.add_parser("simulate", help="simulate a scenario with faults injected; write a measurement CSV")
    s.add_argument("model")
    s.add_argument("scenario", help="scenario file (JSON or YAML), - for standard input, or a shipped scenario's "
                   "name (cycab_scenario2)")
    s.add_argument("-o", "--output", required=True, help="CSV file to write (-: standard output)")
    s.add_argument("--seed", type=whole(0), help="override the scenario's noise seed (an integer >= 0)")
    s.add_argument("--method", type=method, default="auto", help="auto (default), ros2, LSODA, Radau, BDF or RK45")
    s.add_argument("--plot", metavar="DIR", help=f"also plot the signals into DIR/{SIGNALS_PNG} (DIR made when "
                   "missing; needs the plot extra)")
    s.add_argument("--json", action="store_true",
                   help="print a JSON summary of the run on standard output (the CSV goes to -o FILE)")
    s.set_defaults(func=cmd_simulate)

    def keep_spikes_option(p: argparse.ArgumentParser) -> None:      # diagnose and evaluate (not the stream)
        p.add_argument("--keep-spikes", action="store_true",
                       help="read one-sample spikes of the sensor columns as recorded (default: each read as the "
                            "mean of its neighbours, and named in the note; fdi.spikes)")

    def diagnosis_options(p: argparse.ArgumentParser, stream: bool = False) -> None:
        p.add_argument("--threshold", action="append", type=pair(0, strict=True), metavar="ARRk=VALUE",
                       help="override a threshold (VALUE > 0)")
        p.add_argument("--wait", type=real(0, high=MAX_WAIT), help="waiting time T_wt in s, >= 0 (default: the model's)")
        p.add_argument("--persistence", type=real(0, high=MAX_WAIT),
                       help="threshold-seconds of evidence before a residual joins the coherence vector: its time "
                            "above the threshold weighted by |r|/threshold, within max(T_wt, 4 derivative windows) "
                            "(0: the first crossing, the paper's rule; default: the model's, else one derivative "
                            "window)")
        p.add_argument("--no-exoneration", action="store_true", help="also admit sets whose union covers the coherence vector")
        p.add_argument("--max-set", type=whole(1, 6), default=3,
                       help="largest candidate set identified, 1 to 6 (default 3); larger ones are counted in the report")
        p.add_argument("--engine", default="AHDE", help="identification engine (AHDE, AHDE-joint, AHDE-paper, SHADE, scipy-DE, GA, AGA)")
        p.add_argument("--pop", type=whole(MIN_POP, MAX_POP), default=100,
                       help=f"population per estimator, {MIN_POP} to {MAX_POP} (paper: 100)")
        p.add_argument("--generations", type=whole(1, MAX_GENERATIONS), default=150,
                       help="generations per estimator, >= 1 (paper: 150)")
        p.add_argument("--samples", type=whole(MIN_SAMPLES),
                       help=f"N samples from t_D for identification, >= {MIN_SAMPLES} (default: the model's)")
        p.add_argument("--seed", type=whole(0), default=0, help="random seed, an integer >= 0")
        p.add_argument("--workers", type=whole(1, MAX_WORKERS), default=DEFAULT_WORKERS,
                       help=f"estimator processes at most, 1 to {MAX_WORKERS} (default {DEFAULT_WORKERS}: up to 2, "
                            "one per core; the pool opens when the estimators left are worth it; results do not "
                            "depend on it)")
        p.add_argument("--failure", action="append", type=pair(), metavar="FAULT=VALUE", help="failure value for prognosis")
        # (monitor refuses --json and --plot with a line saying why: not listed in its help)
        p.add_argument("--json", action="store_true",
                       help=argparse.SUPPRESS if stream else "print the report as JSON")
        p.add_argument("--timings", action="store_true",
                       help="add wall-clock times to the report (without them two runs give identical reports)")
        p.add_argument("--plot", metavar="DIR", help=argparse.SUPPRESS if stream else
                       "write the plots into the folder DIR, made when missing (needs the plot extra)")
        p.add_argument("-o", "--output", help="write the report to a file instead of standard output (-)")

    d = sub.add_parser("diagnose", help="detect, isolate, identify and prognose faults in a measurement file")
    d.add_argument("model")
    d.add_argument("data", nargs="+", help="measurement CSV file(s) (t first, SI units), - for standard input, or "
                   "shipped data by name (scenario2); several: one JSON line each (-o X.parquet: one table)")
    d.add_argument("--jobs", type=whole(1, MAX_WORKERS),
                   help="files diagnosed at once (each job one process that keeps the derived model; default 1); "
                        "with --scheduler local, the LocalCluster's worker processes (default: one per core)")
    d.add_argument("--scheduler", type=scheduler, metavar="local|ADDRESS",
                   help="run the files on dask (the dask extra): local for a LocalCluster, or the address of a "
                        "running scheduler such as tcp://10.0.0.5:8786 (docs/cli.md, Fleets)")
    d.add_argument("--fail-on-fault", action="store_true",
                   help="exit with status 3 when a fault is diagnosed in any file (for scripts and CI)")
    diagnosis_options(d)
    keep_spikes_option(d)
    d.set_defaults(func=cmd_diagnose)

    cal = sub.add_parser("calibrate", help="thresholds from fault-free runs, each residual with its unit")
    cal.add_argument("model")
    cal.add_argument("runs", nargs="+", help="nominal measurement CSV files (one may be -: standard input)")
    cal.add_argument("--margin", type=real(1.0, high=1e6), default=1.5, help="factor on the level (default 1.5)")
    cal.add_argument("--quantile", type=real(0.5, high=1.0), help="use this quantile of |r| instead of its peak")
    cal.add_argument("--window", choices=["auto"],
                     help="auto: also choose the derivative window (a quarter of the rule's up to 16 times it, at most a tenth of the shortest run) where the faults "
                          "need the smallest changes to be detected, and calibrate at it (written with -o)")
    cal.add_argument("--by-mode", action="store_true",
                     help="thresholds by mode for every residual whose form switches with a commanded or autonomous "
                          "mode (default: those whose unit, or predicted noise tenfold, differs between modes)")
    cal.add_argument("--json", action="store_true", help="print the calibration as JSON")
    cal.add_argument("-o", "--output", help="write a copy of the model with the calibrated thresholds")
    cal.set_defaults(func=cmd_calibrate)

    ev = sub.add_parser("evaluate", help="simulate, diagnose and score a suite of scenarios against their designs")
    ev.add_argument("model")
    ev.add_argument("scenarios", nargs="+", help="scenario files or folders of them (a suite), - for standard "
                    "input, or a shipped suite's name (suite_cycab_steering)")
    ev.add_argument("--jobs", type=whole(1, MAX_WORKERS), default=1,
                    help="scenarios evaluated at once, one process each, their estimators in it (default 1); "
                         "the scores are the same")
    diagnosis_options(ev)
    keep_spikes_option(ev)
    ev.set_defaults(func=cmd_evaluate)

    mon = sub.add_parser("monitor", help="watch a measurement stream: JSON-lines events as the samples arrive")
    mon.add_argument("model")
    mon.add_argument("data", help="measurement CSV file, or - for a CSV stream on standard input (header first)")
    mon.add_argument("--block", type=whole(1, 1_000_000), default=50,
                     help="rows read before the residuals are brought up to date (default 50)")
    mon.add_argument("--refresh", type=real(0.1, high=1e6), default=None,
                     help="seconds between refreshed prognoses of a growing fault (default: an "
                          "identification window, N ts: 10 s for the CyCab)")
    mon.add_argument("--history", type=real(1.0, high=1e9), default=None,
                     help="seconds of samples kept before a detection: memory stays bounded on an endless "
                          "stream (default: 360 000 samples, an hour at 100 Hz, 36 s at 10 kHz; at least the "
                          "settling time and four derivative windows)")
    diagnosis_options(mon, stream=True)
    mon.set_defaults(func=cmd_monitor)

    demo = sub.add_parser("demo", help="simulate CyCab scenario 2 and diagnose it (the main job)")
    demo.add_argument("--scenario", default="scenario2", choices=("nominal", "scenario1", "scenario2", "scenario3"))
    diagnosis_options(demo)
    demo.set_defaults(func=cmd_demo)

    cg = sub.add_parser("codegen", help="generate a self-contained C99 residual monitor of a model (docs/deploy.md)")
    cg.add_argument("model")
    cg.add_argument("--lang", choices=("c",), default="c", help="the language: c (C99 and libm; the default)")
    cg.add_argument("-o", "--output", dest="folder", metavar="DIR", required=True,
                    help="folder to write the monitor into (made when missing; its files replaced when present)")
    cg.add_argument("--sampling-time", type=real(0, strict=True, high=MAX_WAIT), metavar="S",
                    help="the data's sampling time in s, > 0 (default: the model's data.sampling_time); the "
                         "filter's coefficients are made for it")
    cg.add_argument("--threshold", action="append", type=pair(0, strict=True), metavar="ARRk=VALUE",
                    help="override a threshold (VALUE > 0)")
    cg.add_argument("--wait", type=real(0, high=MAX_WAIT), help="waiting time T_wt in s, >= 0 (default: the model's)")
    cg.add_argument("--persistence", type=real(0, high=MAX_WAIT),
                    help="threshold-seconds of evidence before a residual joins the coherence vector (default: the "
                         "model's, else one derivative window; 0: the first crossing)")
    cg.add_argument("--prefix", help="C prefix of the generated names and files (default: bgfdi_ and the model's name)")
    cg.set_defaults(func=cmd_codegen)

    b = sub.add_parser("bench", help="benchmarks, printed as tables")
    b.add_argument("what", choices=("derive", "chain", "simulate", "optim", "diagnose", "accuracy", "monitor", "fleet",
                                          "startup", "csv"))
    b.add_argument("--megabytes", type=real(1.0, high=4000.0), default=250.0,
                   help="csv: size of the file written and read (default 250)")
    b.add_argument("--hours", type=real(0.05, high=24.0), default=1.0,
                   help="monitor: hours of 100 Hz data streamed (default 1; 4 reads the memory at 4 h too)")
    b.add_argument("--block", type=whole(1, 1_000_000), default=50, help="monitor: rows per block (default 50)")
    b.add_argument("--sizes", type=chain_sizes,
                   help=f"derive, chain: comma-separated chain sizes, 1 to {MAX_CHAIN} (derive: default "
                        "10,20,50,100,200; chain: elements checked, default 10,100,1000)")
    b.add_argument("--problem", default="synthetic", help="optim: synthetic (3 cases), synthetic-all, scenario2 or one case")
    b.add_argument("--runs", type=whole(1), default=20, help="optim: independent runs per case, >= 1 (Table VI: 20)")
    b.add_argument("--methods", help="optim: comma-separated engines (default: all)")
    b.add_argument("--workers", type=whole(1, MAX_WORKERS), default=2,
                   help="processes (diagnose: default 1 core is measured with 1)")
    b.add_argument("--seed", type=whole(0), default=0,
                   help="accuracy: the diagnoses' random seed (default 0); a difference between two trees that "
                        "one seed shows and others do not is the search's noise")
    b.add_argument("--json", action="store_true", help="print the measurements as JSON (docs/cli.md)")
    b.set_defaults(func=cmd_bench)
    for command in sub.choices.values():
        _verbosity_options(command, suppress=True)
        for action in command._actions:               # every model positional says what it may be
            if action.dest == "model" and action.help is None:
                action.help = "model YAML file, - for standard input, or a shipped model's name (cycab_steering)"
    return p


def _verbosity_options(p: argparse.ArgumentParser, suppress: bool) -> None:
    """-q/-v, before the command (``bgfdi -q simulate ...``) or after it (``bgfdi simulate -q``)."""
    default = {"default": argparse.SUPPRESS} if suppress else {}
    group = p.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true", **default,
                       help="no progress or notes on standard error (warnings and errors still print)")
    group.add_argument("-v", "--verbose", action="store_true", **default,
                       help="also stage timings and details on standard error")
    p.add_argument("--no-cache", action="store_true", **default,
                   help="derive the model afresh, without the compiled-model cache on disk (also BGFDI_CACHE=off)")


def main(argv: list[str] | None = None) -> int:
    """Run one command; its exit code. A closed standard output (``| head``) ends it quietly with
    code 1, as the Python documentation recommends (SIGPIPE is not restored: a worker process
    could die of it)."""
    if sys.stdout is None:                     # started with standard output closed (``>&-``)
        sys.stdout = _ClosedOutput()
    if sys.stderr is None:                     # standard error closed (``2>&-``): nothing can be told,
        sys.stderr = open(os.devnull, "w", encoding="utf-8")     # but the exit code still says it
    try:
        code = _run(argv)
        sys.stdout.flush()
        return code
    except BrokenPipeError:
        _silence_stdout()
        return 1
    except UnicodeEncodeError as exc:          # standard output in an encoding that cannot hold the text
        encoding = getattr(sys.stdout, "encoding", None) or exc.encoding
        if (encoding or "").lower().replace("-", "") != (exc.encoding or "").lower().replace("-", ""):
            raise                              # not standard output's: a bug, shown as one
        _silence_stdout()
        LOG.error(f"standard output: its encoding {encoding} (from the locale or PYTHONIOENCODING) cannot hold "
                  f"{exc.object[exc.start:exc.end]!r}; set PYTHONIOENCODING=utf-8 or a UTF-8 locale "
                  "(LC_ALL=C.UTF-8), or write to a file with -o (always UTF-8)")
        return 2
    except OSError as exc:                     # a write to standard output failed: a full disk, /dev/full
        if not (_stdout_failed() or isinstance(sys.stdout, _ClosedOutput)
                or (exc.filename is None and exc.errno in WRITE_ERRORS)):
            raise                              # files' errors are one-line errors where they are opened
        _silence_stdout()
        if exc.errno == errno.EBADF:
            LOG.error(CLOSED_STDOUT)
        else:
            LOG.error(f"standard output: cannot write ({exc.strerror or exc}); free space or write to a file with -o")
        return 2


CLOSED_STDOUT = "standard output is closed; give the command somewhere to write (no '>&-'), or write to a file with -o"


class _ClosedOutput:
    """What ``sys.stdout`` is when the process started without one (Python gives None): every write
    fails as a closed descriptor's would (EBADF), so a command that prints says so in one line,
    and one that writes only its ``-o`` file runs."""

    encoding = "utf-8"

    def write(self, text: str) -> int:
        raise OSError(errno.EBADF, "standard output is closed")

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        raise OSError(errno.EBADF, "standard output is closed")


WRITE_ERRORS = {getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EFBIG", "EIO") if hasattr(errno, name)}


def _stdout_failed() -> bool:
    """True when standard output cannot take what it holds (flushing it fails again)."""
    try:
        if sys.stdout is not None:
            sys.stdout.flush()
    except (OSError, ValueError):
        return True
    return False


def _silence_stdout() -> None:
    """Point standard output at /dev/null, so that the interpreter's last flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):     # no real file behind sys.stdout (tests)
        pass


def _run(argv: list[str] | None) -> int:
    parser = build_parser()
    if not (sys.argv[1:] if argv is None else argv):     # ``bgfdi`` alone: the help, as ``pip`` does
        parser.print_help()
        return 0
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:                  # a bad option (one line printed) or --help: its code, returned
        return 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 2
    configure(QUIET if args.quiet else VERBOSE if args.verbose else NORMAL)
    with warnings.catch_warnings():
        if not args.verbose:     # numpy's floating-point warnings (an overflowing record or model) are not for a
            warnings.filterwarnings("ignore", r".*( encountered|Mean of empty slice|Degrees of freedom)",
                                    RuntimeWarning)                                     # user: the report says it
        return _run_parsed(args)


def _run_parsed(args: argparse.Namespace) -> int:
    """The command of ``args`` run, its exit code (:func:`_run` around it: the warnings' filter)."""
    sources = Sources()
    try:
        if args.quiet and args.verbose:
            raise UsageError("-q and -v: give one of them")
        check_kernels_setting()
        if args.command == "monitor":
            check_monitor_options(args)
        if args.command == "diagnose":
            check_parquet(args)
        with _terminated_raises():             # killed while standard input is copied: the copy is removed
            sources.resolve(args)              # - for standard input, shipped files by name
        # a command that reads a copy of standard input removes it when SIGTERM or SIGHUP ends it too
        # (a 1.5 GB copy outlived `timeout`), then ends by the signal's default action as every command
        # does (unwinding would wait for a pool's queued jobs)
        with _removed_on_signal(sources) if sources.folder is not None else contextlib.nullcontext():
            check_model_input(args)
            check_outputs(args)
            if isinstance(sys.stdout, _ClosedOutput):
                if getattr(args, "output", None) in (None, "-") and not hasattr(args, "folder"):
                    # the answer would be lost after the work: said first (-o named only where there is one)
                    raise UsageError(CLOSED_STDOUT if hasattr(args, "output") else CLOSED_STDOUT.split(", or")[0])
                sys.stdout = open(os.devnull, "w", encoding="utf-8")   # the answer goes to its file: what
                # the command says of it beside ("wrote ...") has nowhere to go, and that is no error
            if getattr(args, "no_cache", False):
                from .. import diskcache
                diskcache.disable()
            if args.func in DEEP_COMMANDS:     # derivation only: room for the residuals of long chains
                return run_deep(args.func, args)
            return args.func(args)
    except CausalityError as exc:
        LOG.error(sources.message(f"{getattr(args, 'model', '')}: causality: {'; '.join(exc.problems)}"))
        return 2
    except USER_ERRORS as exc:
        LOG.error(sources.message(str(exc)))
        return 2
    except RecursionError:                    # a model that loads, but whose derived equations nest too deep
        model = getattr(args, "model", None)
        limit = LIMIT if args.func in DEEP_COMMANDS else sys.getrecursionlimit()
        LOG.error(f"{model or args.command}: the derived equations nest deeper than Python follows (recursion "
                  f"limit {limit:,}): the model is too large for one residual; measure more "
                  "signals along it (each sensor starts a shorter residual) or split it")
        return 2
    except KeyboardInterrupt:
        LOG.critical("interrupted")
        return 130
    except Terminated as exc:                 # SIGTERM or SIGHUP while an output was written: it was removed
        LOG.critical(f"terminated by signal {exc.signum}"
                     + ("" if isinstance(exc, Stopped) else "; the partial output was removed"))
        return 128 + exc.signum
    finally:
        sources.close()
        _cache_notes()


def check_kernels_setting() -> None:
    """``BGFDI_KERNELS``, when set, names a path (:func:`optim.kernels.environment_problem`): a typo
    would otherwise run another path than the one asked for, silently."""
    import os
    if "BGFDI_KERNELS" in os.environ:
        from optim.kernels import environment_problem
        problem = environment_problem()
        if problem:
            raise UsageError(escaped(problem))


def _cache_notes() -> None:
    """Why the compiled-model cache is off, or the C kernels could not be built, if so: one line
    each under -v."""
    for name in ("fdi.diskcache", "optim.native"):
        module = sys.modules.get(name)
        for note in getattr(module, "notes", ()):
            LOG.debug(escaped(note))       # a note names a path: control characters escaped
        if module is not None:
            module.notes.clear()           # said once: a second command in this process says its own


# Commands that only derive and print: run on a deep-stack thread (bondgraph.deep), so that the
# residual of a chain of 10 000 elements (about 6 000 levels of sympy) is derived, not refused.
# The others (simulate, diagnose, monitor...) keep the main thread: their worker pools and signal
# handling are made there.
DEEP_COMMANDS = (cmd_check, cmd_graph, cmd_tables, cmd_isolability)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
