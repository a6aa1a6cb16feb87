"""The ``bgfdi`` command: a thin argparse front over bondgraph, fdi and optim.

User mistakes (bad model, scenario or data files, bad options) print one line on stderr and exit
with code 2; nothing is half-written (outputs go through fdi.output.write_atomic).
"""
from __future__ import annotations

import argparse
import sys
from collections import Counter

import sympy as sp

from bondgraph.causality import DIAGNOSIS, SIMULATION, Causality, assign
from bondgraph.errors import CausalityError, ModelError
from bondgraph.loader import load_model
from bondgraph.model import Model

from .cli_errors import UsageError
from .data import DataError
from .output import write_atomic


USER_ERRORS = (ModelError, CausalityError, DataError, UsageError)
CAUSALITY_CHOICES = ("derivative", "mixed")


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
    if out:
        write_atomic(out, text)
    else:
        sys.stdout.write(text)


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
    model = load_model(args.model)
    kinds = Counter(e.kind for e in model.elements.values())
    jkinds = Counter(j.kind for j in model.junctions.values())
    print(f"model {model.name} ({args.model})")
    if model.reference:
        print(f"  reference: {model.reference}")
    print(f"  elements   {len(model.elements)}: " + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))
    ctrl = [f"{j.name} ({j.kind}, mode {j.mode})" for j in model.junctions.values() if j.controlled]
    print(f"  junctions  {len(model.junctions)}: " + ", ".join(f"{k}: {v}" for k, v in sorted(jkinds.items()))
          + (f"; controlled: {', '.join(ctrl)}" if ctrl else ""))
    print(f"  bonds      {len(model.bonds)}")
    print(f"  sensors    {len(model.sensors)}: " + ", ".join(
        f"{s.name} ({s.kind} on {s.junction}, {s.measures})" for s in model.sensors.values()))
    print(f"  modes      {len(model.modes)}: " + (", ".join(model.modes) or "none")
          + f" -> {2 ** len(model.modes)} mode(s)")
    print(f"  faults     {len(model.faults)}: " + ", ".join(
        f"{f.name} ({f.kind}: {', '.join(f.targets)})" for f in model.faults.values()))
    diag = assign(model, DIAGNOSIS)
    print()
    print("causality for diagnosis (SCAPH: sources fixed, sensors inverted, storage in derivative causality)")
    from .arrs import select_arrs
    from .signatures import all_modes

    chosen = select_arrs(model, args.causality)
    if not diag.ok:
        for p in list(diag.problems) + list(diag.loops):
            print(f"  SCAPH: {p}")
        if not chosen.arrs:
            raise CausalityError(list(diag.problems) + list(diag.loops)
                                 + [f"and no residual exists in {args.causality} causality (bgfdi isolability "
                                    f"{args.model} proposes sensors)"])
        print(f"  SCAPH leaves storage out of derivative causality or closes a loop: the residuals come from "
              f"structural analysis ({chosen.msos} MSO sets, {chosen.candidates} computable in "
              f"{args.causality} causality)")
    arrs = list(chosen.arrs)
    bad = []
    for mode in all_modes(model):
        for a in arrs:
            e = a.expr.xreplace({model.symbols[m]: v for m, v in mode.items()})
            if e.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
                bad.append(f"{a.name} undefined in mode {mode}")
    if bad:
        raise CausalityError(bad)
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
    print()
    print(f"residuals ({args.causality} causality): " + ", ".join(
        f"{a.name} ({'SCAPH, ' + str(a.sensor) if a.origin == 'SCAPH' else 'MSO at ' + a.junction})" for a in arrs))
    for note in chosen.notes:
        print(f"  note: {note}")
    sim = assign(model, SIMULATION)
    print()
    print("causality for simulation (SCAP, integral causality preferred)")
    print("  storage: " + (", ".join(f"{k} {v}" for k, v in sim.storage.items()) or "none"))
    for p in list(sim.problems) + list(sim.loops):
        print(f"  note: {p}")
    return 0


def cmd_graph(args: argparse.Namespace) -> int:
    from bondgraph.dot import to_dot

    model = load_model(args.model)
    _emit(to_dot(model, assign(model, args.purpose)), args.output)
    return 0


# ------------------------------------------------------------------ tables

def cmd_tables(args: argparse.Namespace) -> int:
    from .arrs import select_arrs
    from .signatures import all_modes, fault_signature_matrix, mode_change_signature_matrix
    from .tables import render

    model = load_model(args.model)
    arrs = list(select_arrs(model, args.causality).arrs)
    if not arrs:
        raise CausalityError([f"{model.name} has no residual in {args.causality} causality; "
                              f"bgfdi isolability {args.model} proposes sensors"])
    modes = [parse_mode(args.mode, model)] if args.mode else all_modes(model)
    fsms = [fault_signature_matrix(model, arrs, m) for m in modes]
    mcsm = mode_change_signature_matrix(model, arrs, modes[0] if args.mode else None)
    _emit(render(args.format, arrs, fsms, mcsm), args.output)
    return 0


# ------------------------------------------------------------------ isolability

def cmd_isolability(args: argparse.Namespace) -> int:
    from .isolability_report import analyse, to_json, to_text

    model = load_model(args.model)
    if args.max_sensors < 0 or args.max_sensors > 6:
        raise UsageError("--max-sensors must be between 0 and 6")
    modes = [parse_mode(args.mode, model)] if args.mode else None
    result = analyse(model, args.causality, modes, args.max_sensors)
    _emit(to_json(result) if args.json else to_text(result), args.output)
    return 0


# ------------------------------------------------------------------ simulate

class Progress:
    """A one-line progress bar on stderr (only on a terminal, so logs stay clean)."""

    def __init__(self, total: float, label: str) -> None:
        self.total, self.label = total, label
        self.on = sys.stderr.isatty()

    def __call__(self, done: float) -> None:
        if self.on:
            frac = min(1.0, done / self.total) if self.total else 1.0
            bar = "#" * int(30 * frac)
            sys.stderr.write(f"\r{self.label} [{bar:<30}] {100 * frac:5.1f}%")
            if frac >= 1.0:
                sys.stderr.write("\n")
            sys.stderr.flush()


def cmd_simulate(args: argparse.Namespace) -> int:
    from .scenario import ScenarioError, load_scenario, run, to_csv

    model = load_model(args.model)
    try:
        scenario = load_scenario(args.scenario, model)
        if args.seed is not None:
            from dataclasses import replace
            scenario = replace(scenario, seed=args.seed)
        columns = run(model, scenario, progress=Progress(scenario.T, "simulating"), method=args.method)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    write_atomic(args.output, to_csv(columns))
    print(f"wrote {args.output}: {len(columns['t'])} samples of {', '.join(columns)}")
    if args.plot:
        from .plots import plot_signals
        plot_signals(columns, args.plot)
        print(f"plot: {args.plot}")
    return 0


# ------------------------------------------------------------------ diagnose / demo

def _pairs(items: list[str] | None, what: str, cast=float) -> dict:
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep:
            raise UsageError(f"--{what} takes NAME=VALUE, got '{item}'")
        try:
            out[name.strip()] = cast(value)
        except ValueError:
            raise UsageError(f"--{what} {name}: '{value}' is not a number") from None
    return out


def _options(args: argparse.Namespace, model: Model):
    from optim import ENGINES

    from .diagnose import Options
    from .identify import compiled
    names = [a.name for a in compiled(model.path)[1]]
    thresholds = _pairs(args.threshold, "threshold")
    for k in thresholds:
        if k not in names:
            raise UsageError(f"--threshold: '{k}' is no residual of {model.name} (use {', '.join(names)})")
    failures = _pairs(args.failure, "failure")
    for k in failures:
        if k not in model.faults:
            raise UsageError(f"--failure: '{k}' is no fault of {model.name}")
    if args.engine not in ENGINES:
        raise UsageError(f"--engine: unknown engine '{args.engine}' (use {', '.join(ENGINES)})")
    return Options(thresholds=thresholds, waiting_time=args.wait, exoneration=not args.no_exoneration,
                   engine=args.engine, pop=args.pop, generations=args.generations, samples=args.samples,
                   seed=args.seed, workers=args.workers, failures=failures)


def _diagnose_and_print(model_path: str, data, options, args, data_name: str) -> int:
    import json

    from .diagnose import diagnose, public
    from .identify import compiled
    from .report import to_text
    model = compiled(str(model_path))[0]
    bar = Progress(1.0, "estimators")
    report = diagnose(model_path, data, options, progress=lambda done, total: bar(done / total))
    if args.json:
        text = json.dumps(public(report), indent=1) + "\n"
    else:
        text = to_text(public(report), model.name, data_name)
    _emit(text, getattr(args, "output", None))
    if getattr(args, "plot", None):
        from .plots import plot_diagnosis
        for p in plot_diagnosis(report, args.plot, model):
            print(f"plot: {p}", file=sys.stderr)
    return 0


def cmd_diagnose(args: argparse.Namespace) -> int:
    from .data import read_csv
    from .identify import compiled

    model = compiled(args.model)[0]
    options = _options(args, model)
    data = read_csv(args.data)
    return _diagnose_and_print(args.model, data, options, args, args.data)


def cmd_demo(args: argparse.Namespace) -> int:
    """Simulate CyCab scenario 2 with bgfdi's own simulator, diagnose it, print the report."""
    from .data import Measurements
    from .resources import scenarios_dir, shipped_model
    from .scenario import load_scenario, run

    from .identify import compiled
    path = str(shipped_model("cycab_steering"))
    model = compiled(path)[0]
    scenario = load_scenario(scenarios_dir() / f"cycab_{args.scenario}.json", model)
    print(f"simulating CyCab {args.scenario} ({scenario.T:g} s; faults: "
          + (", ".join(f"{f.target} {f.type} from {f.t0:g} s" for f in scenario.faults) or "none") + ")",
          file=sys.stderr)
    cols = run(model, scenario, progress=Progress(scenario.T, "simulating"))
    data = Measurements(f"simulated {args.scenario}", cols["t"], cols)
    print("diagnosing ...", file=sys.stderr)
    return _diagnose_and_print(path, data, _options(args, model), args, f"simulated CyCab {args.scenario}")


# ------------------------------------------------------------------ bench

def cmd_bench(args: argparse.Namespace) -> int:
    from . import bench
    from .resources import shipped_models

    if args.what == "derive":
        sizes = bench.CHAIN_SIZES
        if args.sizes:
            try:
                sizes = tuple(int(x) for x in args.sizes.split(","))
            except ValueError:
                raise UsageError(f"--sizes: expected comma-separated chain sizes such as 1000,2000, got '{args.sizes}'") from None
        sys.stdout.write(bench.format_derive(bench.derive_rows(shipped_models(), sizes, echo=print)))
        return 0
    if args.what == "simulate":
        from .resources import scenarios_dir
        sys.stdout.write(bench.format_simulate(bench.simulate_rows(scenarios_dir() / "cycab_scenario2.json")))
        return 0
    if args.what == "optim":
        import json

        from optim import ENGINES

        from . import synthetic
        if args.problem not in synthetic.GROUPS and args.problem not in synthetic.CASES and args.problem != "scenario2":
            raise UsageError(f"--problem: unknown '{args.problem}' (synthetic, synthetic-all, scenario2, "
                             f"or one of {', '.join(synthetic.CASES)})")
        methods = args.methods.split(",") if args.methods else list(ENGINES)
        for m in methods:
            if m not in ENGINES:
                raise UsageError(f"--methods: unknown engine '{m}' (use {', '.join(ENGINES)})")
        rows = bench.optim_rows(args.problem, args.runs, methods, workers=args.workers)
        summary = bench.summarise_optim(args.problem, args.runs, rows)
        sys.stdout.write(json.dumps(summary, indent=1) + "\n" if args.json else bench.format_optim(summary))
        return 0
    if args.what == "diagnose":
        from .resources import reference_data
        sys.stdout.write(bench.format_diagnose(bench.diagnose_rows(reference_data("scenario2.csv"), args.workers)))
        return 0
    raise UsageError(f"unknown benchmark '{args.what}'")


# ------------------------------------------------------------------ main

def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bgfdi", description="Fault diagnosis and prognosis with hybrid bond graphs.")
    sub = p.add_subparsers(dest="command", required=True)

    c = sub.add_parser("check", help="validate a model and show its causality")
    c.add_argument("model")
    c.add_argument("--causality", choices=CAUSALITY_CHOICES, default="derivative",
                   help="residuals that differentiate only (default) or may integrate (mixed)")
    c.set_defaults(func=cmd_check)

    g = sub.add_parser("graph", help="write Graphviz DOT with causal strokes")
    g.add_argument("model")
    g.add_argument("-o", "--output", help="file to write (default: standard output)")
    g.add_argument("--purpose", choices=(DIAGNOSIS, SIMULATION), default=DIAGNOSIS)
    g.set_defaults(func=cmd_graph)

    t = sub.add_parser("tables", help="AGARRs, MD-FSM and MCSM")
    t.add_argument("model")
    t.add_argument("--mode", help="one mode, e.g. a1=1,a2=1 (default: every mode)")
    t.add_argument("--format", choices=("text", "markdown", "latex", "json", "csv"), default="text")
    t.add_argument("--causality", choices=CAUSALITY_CHOICES, default="derivative",
                   help="residuals that differentiate only (default) or may integrate (mixed)")
    t.add_argument("-o", "--output", help="file to write (default: standard output)")
    t.set_defaults(func=cmd_tables)

    iso = sub.add_parser("isolability", help="detectability and isolability per mode; sensor placement")
    iso.add_argument("model")
    iso.add_argument("--causality", choices=CAUSALITY_CHOICES, default="derivative",
                     help="causal interpretation of differential constraints (default derivative)")
    iso.add_argument("--mode", help="one mode, e.g. v=0 (default: every mode)")
    iso.add_argument("--max-sensors", type=int, default=3, help="largest sensor set tried for placement")
    iso.add_argument("--json", action="store_true", help="print the analysis as JSON")
    iso.add_argument("-o", "--output", help="file to write (default: standard output)")
    iso.set_defaults(func=cmd_isolability)

    s = sub.add_parser("simulate", help="simulate a scenario with faults injected; write a measurement CSV")
    s.add_argument("model")
    s.add_argument("scenario", help="scenario file (JSON or YAML)")
    s.add_argument("-o", "--output", required=True, help="CSV file to write")
    s.add_argument("--seed", type=int, help="override the scenario's noise seed")
    s.add_argument("--method", default="auto", help="auto (default), ros2, LSODA, Radau, BDF or RK45")
    s.add_argument("--plot", metavar="PNG", help="also plot the signals (needs the plot extra)")
    s.set_defaults(func=cmd_simulate)

    def diagnosis_options(p: argparse.ArgumentParser) -> None:
        p.add_argument("--threshold", action="append", metavar="ARRk=VALUE", help="override a threshold")
        p.add_argument("--wait", type=float, help="waiting time T_wt in s (default: the model's)")
        p.add_argument("--no-exoneration", action="store_true", help="also admit sets whose union covers the coherence vector")
        p.add_argument("--engine", default="AHDE", help="identification engine (AHDE, AHDE-joint, AHDE-paper, SHADE, scipy-DE, GA, AGA)")
        p.add_argument("--pop", type=int, default=100, help="population per estimator (paper: 100)")
        p.add_argument("--generations", type=int, default=150, help="generations per estimator (paper: 150)")
        p.add_argument("--samples", type=int, help="N samples from t_D for identification (default: the model's)")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--workers", type=int, default=2, help="estimator processes (results do not depend on it)")
        p.add_argument("--failure", action="append", metavar="FAULT=VALUE", help="failure value for prognosis")
        p.add_argument("--json", action="store_true", help="print the report as JSON")
        p.add_argument("--plot", metavar="DIR", help="write plots into DIR (needs the plot extra)")
        p.add_argument("-o", "--output", help="write the report to a file instead of standard output")

    d = sub.add_parser("diagnose", help="detect, isolate, identify and prognose faults in a measurement file")
    d.add_argument("model")
    d.add_argument("data", help="measurement CSV (t first, SI units)")
    diagnosis_options(d)
    d.set_defaults(func=cmd_diagnose)

    demo = sub.add_parser("demo", help="simulate CyCab scenario 2 and diagnose it (the main job)")
    demo.add_argument("--scenario", default="scenario2", choices=("nominal", "scenario1", "scenario2", "scenario3"))
    diagnosis_options(demo)
    demo.set_defaults(func=cmd_demo)

    b = sub.add_parser("bench", help="benchmarks, printed as tables")
    b.add_argument("what", choices=("derive", "simulate", "optim", "diagnose"))
    b.add_argument("--sizes", help="derive: comma-separated chain sizes (default 10,20,50,100,200)")
    b.add_argument("--problem", default="synthetic", help="optim: synthetic (3 cases), synthetic-all, scenario2 or one case")
    b.add_argument("--runs", type=int, default=20, help="optim: independent runs per case (Table VI: 20)")
    b.add_argument("--methods", help="optim: comma-separated engines (default: all)")
    b.add_argument("--workers", type=int, default=2, help="processes (diagnose: default 1 core is measured with 1)")
    b.add_argument("--json", action="store_true", help="optim: print the summary as JSON")
    b.set_defaults(func=cmd_bench)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except CausalityError as exc:
        print(f"bgfdi: error: {getattr(args, 'model', '')}: causality: {'; '.join(exc.problems)}", file=sys.stderr)
        return 2
    except USER_ERRORS as exc:
        print(f"bgfdi: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bgfdi: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
