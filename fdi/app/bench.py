"""Benchmarks printed as tables: ``bgfdi bench derive`` (symbolic derivation time: ARRs and
state equations; ``bgfdi tables`` on chains of measured tanks, where residual selection must
scale), ``bgfdi bench simulate`` (the CyCab scenario 2 by stage), ``optim``, ``diagnose``."""
from __future__ import annotations

import math
import time
from pathlib import Path

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.chains import chain_yaml, tank_chain_yaml
from bondgraph.loader import load_model, load_model_text
from bondgraph.simulation import build_system

from ..arrs import derive_arrs
from ..signatures import all_modes, fault_signature_matrix, mode_change_signature_matrix

CHAIN_SIZES = (10, 20, 50, 100, 200)
TANK_SIZES = (10, 30, 100)      # tanks in series, a pressure sensor and a fault on every one


def _best_of(fn, repeat: int = 3) -> float:
    from sympy.core.cache import clear_cache

    best = float("inf")
    for _ in range(repeat):
        clear_cache()
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def derive_rows(models: list[Path], sizes=CHAIN_SIZES, echo=None, tanks: tuple[int, ...] | None = None) -> list[dict]:
    """Time causality + AGARRs (+ signature matrices for shipped models), best of three cold runs
    (sympy's cache cleared before each, so nothing derived earlier is reused); chains also their
    state equations (:func:`chain_row`, ``echo`` told each stage as it is measured); tank chains
    ``bgfdi tables`` (:func:`tank_row`)."""
    rows = []
    for path in models:
        model = load_model(path)

        def job(model=model):
            from ..arrs import select_arrs
            arrs = list(select_arrs(model).arrs)          # SCAPH, completed by MSO residuals where needed
            for mode in all_modes(model):
                fault_signature_matrix(model, arrs, mode)
            mode_change_signature_matrix(model, arrs)
            return arrs
        n = len(model.elements) + len(model.junctions)
        rows.append({"case": model.name, "elements": n, "arrs": len(job()), "seconds": _best_of(job)})
    if rows:
        from bondgraph.structure import mso_search

        from ..arrs import select_arrs, structural_system
        largest = max(rows, key=lambda r: r["elements"])
        model = load_model(next(p for p in models if load_model(p).name == largest["case"]))
        system = structural_system(model)
        search = mso_search(system)
        largest.update(mso_seconds=_best_of(lambda: mso_search(system)), msos=len(search.sets),
                       equations=len(system.equations), select_seconds=_best_of(lambda: select_arrs(model), 1))
    for size in sizes:
        rows.append(chain_row(size, echo))
    for n in TANK_SIZES if tanks is None else tanks:
        rows.append(tank_row(n, echo))
    return rows


def tables_job(model) -> str:
    """What ``bgfdi tables`` does after loading: residual selection, the signature matrices of
    every mode and the mode change matrix, the text tables."""
    from ..arrs import select_arrs
    from ..tables import render

    arrs = list(select_arrs(model).arrs)
    modes = all_modes(model)
    return render("text", arrs, [fault_signature_matrix(model, arrs, m) for m in modes],
                  mode_change_signature_matrix(model, arrs))


def tank_row(n: int, echo=None) -> dict:
    """``bgfdi tables`` (loading included) on a chain of ``n`` tanks with a pressure sensor and a
    sensor fault on each (:func:`bondgraph.chains.tank_chain_yaml`): SCAPH gives the n tank
    balances, and the first and last sensor faults need one more residual each, found near them
    (about 3^n MSO sets in all). One cold run (sympy's cache cleared first)."""
    text = tank_chain_yaml(n)

    def job():
        model = load_model_text(text, f"tank_chain_{n}")
        return model, tables_job(model)
    model, _ = job()
    from ..arrs import select_arrs
    row = {"case": f"tanks N={n}", "tanks": n, "elements": len(model.elements) + len(model.junctions),
           "faults": len(model.faults), "arrs": len(select_arrs(model).arrs), "seconds": _best_of(job, 1)}
    if echo:
        echo(f"tank chain N={n}: tables {row['seconds']:.3f} s")
    return row


def chain_row(size: int, echo=None) -> dict:
    """Time the ARRs (causality + AGARRs) and the state equations (``build_system``: simulation
    causality, reduction, compiled functions) of the generated chain of ``size`` elements, best
    of three cold runs each; ``echo(line)`` is told each stage's time as it is measured."""
    model = load_model_text(chain_yaml(size), f"chain_{size}")
    n = len(model.elements) + len(model.junctions)
    row = {"case": f"chain N={size}", "elements": n, "arrs": len(model.sensors)}
    row["seconds"] = _best_of(lambda: derive_arrs(model, assign(model, DIAGNOSIS)))
    if echo:
        echo(f"chain N={size}: ARRs {row['seconds']:.3f} s")
    values = dict(model.nominal_by_name())
    row["state_seconds"] = _best_of(lambda: build_system(model, values))
    if echo:
        echo(f"chain N={size}: state equations {row['state_seconds']:.3f} s")
    return row


def format_derive(rows: list[dict]) -> str:
    out = ["Derivation of AGARRs (causality + elimination; shipped models also all MD-FSMs and the MCSM); "
           "chains also their state equations for simulation (build_system)",
           f"{'case':<32}{'elements':>9}{'ARRs':>6}{'time [s]':>11}{'s/element':>12}{'ratio':>8}{'state eqs [s]':>15}"]
    chains = [r for r in rows if r["case"].startswith("chain")]
    base = chains[0] if chains else None
    for r in rows:
        if r["case"].startswith("tanks"):
            continue
        ratio = ""
        if base and r in chains:
            ratio = f"{r['seconds'] / base['seconds']:.1f}x"
        state = f"{r['state_seconds']:.4f}" if "state_seconds" in r else ""
        out.append(f"{r['case']:<32}{r['elements']:>9}{r['arrs']:>6}{r['seconds']:>11.4f}"
                   f"{r['seconds'] / r['elements']:>12.2e}{ratio:>8}{state:>15}")
    for r in rows:
        if "mso_seconds" in r:
            out.append(f"MSO search, largest shipped model ({r['case']}, {r['equations']} equations): "
                       f"{r['msos']} MSO sets in {r['mso_seconds']:.4f} s; residual selection {r['select_seconds']:.3f} s")
    if len(chains) >= 2:
        a, b = chains[0], chains[-1]
        growth = (b["seconds"] / a["seconds"]) / (b["elements"] / a["elements"])
        out.append(f"chain growth: time x{b['seconds'] / a['seconds']:.1f} for elements x"
                   f"{b['elements'] / a['elements']:.1f} (1.0 per unit = linear; measured {growth:.2f})")
    tanks = [r for r in rows if r["case"].startswith("tanks")]
    if tanks:
        out += ["", "bgfdi tables on tanks in series, a pressure sensor and a sensor fault on every tank "
                "(load, residual selection, signature matrices, text; one cold run)",
                f"{'case':<32}{'elements':>9}{'faults':>8}{'ARRs':>6}{'time [s]':>11}{'s/tank':>10}"]
        for r in tanks:
            out.append(f"{r['case']:<32}{r['elements']:>9}{r['faults']:>8}{r['arrs']:>6}{r['seconds']:>11.3f}"
                       f"{r['seconds'] / r['tanks']:>10.4f}")
    if len(tanks) >= 2:
        a, b = tanks[0], tanks[-1]
        exponent = math.log(b["seconds"] / a["seconds"]) / math.log(b["tanks"] / a["tanks"])
        out.append(f"tank growth: time x{b['seconds'] / a['seconds']:.1f} for tanks x{b['tanks'] / a['tanks']:.1f}: "
                   f"time ~ n^{exponent:.2f} (1 = linear)")
    return "\n".join(out) + "\n"


def derive_json(rows: list[dict]) -> dict:
    """``bench derive --json``: every case with the same keys (null where not measured), seconds
    best of three cold runs; the MSO search of the largest shipped model apart; ``bgfdi tables``
    on each tank chain (one cold run) in ``tank_chains``."""
    cases, mso, tanks = [], None, []
    for r in rows:
        if r["case"].startswith("tanks"):
            tanks.append({"tanks": r["tanks"], "elements": r["elements"], "faults": r["faults"], "arrs": r["arrs"],
                          "tables_s": r["seconds"]})
            continue
        cases.append({"case": r["case"], "chain": r["case"].startswith("chain"), "elements": r["elements"],
                      "arrs": r["arrs"], "arrs_s": r["seconds"], "state_equations_s": r.get("state_seconds")})
        if "mso_seconds" in r:
            mso = {"case": r["case"], "equations": r["equations"], "msos": r["msos"], "search_s": r["mso_seconds"],
                   "selection_s": r["select_seconds"]}
    return {"benchmark": "derive", "cases": cases, "mso": mso, "tank_chains": tanks}


# ---------------------------------------------------------------- simulation

def simulate_rows(scenario_path: Path, repeat: int = 3) -> dict:
    """CPU seconds of simulating a CyCab scenario (60 s of scenario 2) by stage: state equations,
    integration, outputs, and the rest (sensor sampling: noise, quantisation); best of ``repeat``
    cold runs (sympy's cache cleared before each). Beside it, in the same run, the same scenario on
    the independent reference plant (:mod:`fdi.app.plant_cycab`: the rig's physics with scipy's
    LSODA, no bond graph), best of ``repeat`` too: a ratio measured on this machine now, never
    against a stored figure."""
    from sympy.core.cache import clear_cache

    from . import plant_cycab
    from .resources import shipped_model
    from .scenario import load_scenario, run

    model = load_model(shipped_model("cycab_steering"))
    scenario = load_scenario(scenario_path, model)
    best: dict | None = None
    for _ in range(repeat):
        clear_cache()
        stages: dict[str, float] = {}
        start = time.process_time()
        run(model, scenario, stages=stages)
        total = time.process_time() - start
        if best is None or total < best["total_s"]:
            best = {"stages": stages, "total_s": total}
    assert best is not None
    best["stages"]["sampling"] = best["total_s"] - sum(best["stages"].values())
    reference = math.inf
    for _ in range(repeat):
        start = time.process_time()
        plant_cycab.run_scenario(scenario)
        reference = min(reference, time.process_time() - start)
    best.update(scenario=Path(scenario_path).name, T=scenario.T, reference_s=reference)
    return best


def format_simulate(row: dict) -> str:
    out = [f"Simulation of the CyCab, {row['T']:g} s of {row['scenario']} (CPU seconds, one process, best of 3)",
           f"{'stage':<20}{'CPU [s]':>10}"]
    for stage, secs in row["stages"].items():
        out.append(f"{stage:<20}{secs:>10.3f}")
    out.append(f"{'total':<20}{row['total_s']:>10.3f}")
    out.append(f"reference: {row['reference_s']:.3f} s CPU for the same scenario on the independent reference plant "
               f"(fdi.app.plant_cycab: scipy LSODA, no bond graph), best of 3 in this run; ratio "
               f"{row['reference_s'] / row['total_s']:.2f}x (above 1: faster than the reference)")
    return "\n".join(out) + "\n"


def simulate_json(row: dict) -> dict:
    """``bench simulate --json``: CPU seconds by stage (best of three), the simulated span in s."""
    return {"benchmark": "simulate", "scenario": row["scenario"], "duration": row["T"],
            "stages_cpu_s": dict(row["stages"]), "total_cpu_s": row["total_s"], "reference_cpu_s": row["reference_s"]}


# ---------------------------------------------------------------- optimisers (Table VI protocol)

TABLE_VI = {"pop": 150, "generations": 300}     # pc 0.55, pm 0.08: the defaults of optim.GAOptions


def _optim_job(job: tuple) -> dict:
    """One run of one method on one problem instance (in a worker process)."""
    import numpy as np

    import optim

    from . import synthetic
    method, case, seed, settings = job
    if case in synthetic.CASES:
        p = synthetic.problem(case, seed)
    else:
        p = benchmark_problem(case, seed)
    r = optim.minimize(p, engine=method, seed=seed, **settings)      # the problem carries its hooks
    ok = synthetic.recovered(p.spaces, p.truth, p.finish(r.real, r.bits), r.bits, p.t, p.t0)
    return {"method": method, "case": case, "seed": seed, "cost": r.cost, "fitness": float(r.fitness),
            "success": bool(ok), "evaluations": r.evaluations, "wall_s": r.wall_s, "overhead_s": r.overhead_s,
            "margin": r.extra.get("margin"), "history": [float(h) for h in np.asarray(r.history)[:: max(1, len(r.history) // 50)]]}


def optim_rows(problem: str, runs: int, methods: list[str], workers: int = 2, settings: dict | None = None,
               progress=None) -> list[dict]:
    """Every run of every method on every case of ``problem``, in ``workers`` processes;
    ``progress(done, total)`` told as runs finish."""
    from . import synthetic
    from .parallel import map_in_order
    cases = synthetic.GROUPS.get(problem, (problem,))
    settings = settings or TABLE_VI
    jobs = [(m, c, s, settings) for m in methods for c in cases for s in range(runs)]
    return map_in_order(_optim_job, jobs, workers, progress)


def summarise_optim(problem: str, runs: int, rows: list[dict]) -> dict:
    import numpy as np

    out: dict = {"problem": problem, "runs": runs, "methods": {}}
    for method in dict.fromkeys(r["method"] for r in rows):
        rs = [r for r in rows if r["method"] == method]
        fit = np.array([r["fitness"] for r in rs])
        out["methods"][method] = {
            "min": float(fit.min()), "max": float(fit.max()), "mean": float(fit.mean()), "std": float(fit.std()),
            "success": float(np.mean([r["success"] for r in rs])),
            "evaluations": int(np.mean([r["evaluations"] for r in rs])),
            "wall_s": float(np.mean([r["wall_s"] for r in rs])),
            "overhead_s": float(np.mean([r["overhead_s"] for r in rs])),
            "runs": len(rs),
        }
    return out


def format_optim(summary: dict) -> str:
    out = [f"Identification benchmark '{summary['problem']}' (Table VI protocol: population 150, 300 iterations, "
           f"pc 0.55, pm 0.08; {summary['runs']} runs per case)",
           "fitness = 1/(sum|G| + eps), higher is better; success = true types and values within 2 %",
           f"{'method':<12}{'min':>11}{'max':>11}{'mean':>11}{'std':>11}{'success':>9}{'evals':>8}"
           f"{'wall [s]':>10}{'outside obj [s]':>16}"]
    for name, m in summary["methods"].items():
        out.append(f"{name:<12}{m['min']:>11.4g}{m['max']:>11.4g}{m['mean']:>11.4g}{m['std']:>11.3g}"
                   f"{m['success'] * 100:>8.0f}%{m['evaluations']:>8d}{m['wall_s']:>10.2f}{m['overhead_s']:>16.3f}")
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------- the diagnosis pipeline

REPEAT = 5      # bench diagnose: the least of this many runs, in the process and as whole processes (this
                # machine's speed drifts by 30-40 % within minutes: of three, the least still moved 0.96-1.10 s)


def diagnose_rows(data_path: Path, workers: int = 1) -> dict:
    """Stage times of one diagnosis of scenario 2 at the paper's settings (population 100,
    150 generations, five estimators), and the share of identification spent in the objective."""
    from ..api import diagnose
    from ..options import Options
    from .resources import shipped_model

    from .. import kernels

    model, options = shipped_model("cycab_steering"), Options(pop=100, generations=150, workers=workers)
    t0, cpu0 = time.perf_counter(), time.process_time()
    d = diagnose(model, data_path, options)
    total, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    est = d.estimates
    from .. import hints
    later = math.inf
    for _ in range(REPEAT):              # again in this process: what a notebook or a monitor pays per decision;
        hints.forget()                   # the least of REPEAT (this machine's speed drifts); the answers kept by
        cpu1 = time.process_time()       # content forgotten first: a new record would find none
        diagnose(model, data_path, options)
        later = min(later, time.process_time() - cpu1)
    return {"stages": dict(d.timings), "total_s": total, "cpu_s": cpu, "later_cpu_s": later, "estimators": len(est),
            "workers": workers,
            "objective_s": sum(e.objective_s for e in est), "estimator_s": sum(e.wall_s for e in est),
            "evaluations": sum(e.evaluations for e in est), "kernels": kernels.path(),
            "objective": objective_costs(), "jit": {p: jit_costs(p) for p in kernels.available()} or None,
            "process": process_costs(model, data_path, workers)}


def process_costs(model: Path, data_path: Path, workers: int, repeat: int = REPEAT, fill: bool = True) -> dict | None:
    """A whole ``bgfdi diagnose MODEL DATA --workers N -q`` process as a user runs it: after one run
    that fills the caches (the compiled model and the C kernels, where the disk cache is on; not
    with ``fill`` off), the least wall and CPU seconds (user + system of the child, ``getrusage``)
    of ``repeat`` runs; and whether the cache was on. None if a run fails."""
    import sys

    from .. import diskcache
    from .bench_startup import process_times
    cmd = [sys.executable, "-m", "fdi", "diagnose", str(model), str(data_path), "--workers", str(workers), "-q"]
    try:
        if fill:
            process_times(cmd)
        runs = [process_times(cmd) for _ in range(repeat)]
    except RuntimeError:
        return None
    return {"wall_s": min(w for w, _ in runs), "cpu_s": min(c for _, c in runs), "runs": repeat,
            "cache": diskcache.enabled()}


def jit_costs(path: str, probes: int = 2) -> dict | None:
    """CPU seconds a fresh process pays for the compiled kernels of ``path`` (``c``: the library
    built once and kept in the disk cache; ``numba``: numba's disk cache), warm: loading them (for
    numba its import), then the first objective call (numba loads every kernel it runs there), then
    a second (:func:`jit_probe` in a subprocess, run ``probes`` times: the first may build; the last
    is reported). None if it fails."""
    import json
    import os
    import subprocess
    import sys
    env = {**os.environ, "BGFDI_KERNELS": path}
    for _ in range(max(1, probes)):
        out = subprocess.run([sys.executable, "-c", "from fdi.app.bench import jit_probe; jit_probe()"],
                             capture_output=True, text=True, env=env)
    try:
        got = json.loads(out.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return None
    return got if got.get("path") == path else None


def jit_probe() -> None:
    """Print (JSON) this process's CPU seconds to load the compiled kernels (numba's import and its
    kernels' module, or the C library), for the first compiled calls (the filter, then an objective
    call on scenario 2's problem: numba loads every kernel from its cache there) and for a second
    objective call; and the path that ran."""
    import json

    import numpy as np

    from .. import derivatives, kernels
    from ..encoding import N_BITS
    clock = time.process_time
    t0 = clock()
    kernels.jit()
    t1 = clock()
    derivatives.fir(np.zeros(30), derivatives.centred(5, 3, 2, 0.01), 0, 26)
    t2 = clock()
    obj = benchmark_problem("scenario2", 0).objective
    b = obj.bounds()
    real = np.tile(b.mean(axis=1), (3, 1))
    bits = np.zeros((3, N_BITS * len(obj.spaces)), dtype=bool)
    bits[np.arange(3), np.arange(3)] = True
    t3 = clock()
    obj.coarse(real, bits)
    t4 = clock()
    obj.coarse(real, bits)
    t5 = clock()
    print(json.dumps({"import_s": t1 - t0, "first_call_s": (t2 - t1) + (t4 - t3), "second_call_s": t5 - t4,
                      "path": kernels.path()}))


def objective_costs(rows: int = 100, repeat: int = 5, seed: int = 0) -> dict:
    """CPU time of one objective call on scenario 2's identification (R4 & beta_theta2, the
    bench problem), full and coarse, for 1 and ``rows`` random individuals of every structure
    (min of ``repeat``): the per-row cost is the slope, the per-call overhead the intercept
    (what a call costs before its rows)."""
    import numpy as np

    from ..encoding import N_BITS
    obj = benchmark_problem("scenario2", seed).objective
    rng = np.random.default_rng(seed)
    b = obj.bounds()
    real = b[:, 0] + rng.random((rows, b.shape[0])) * (b[:, 1] - b[:, 0])
    bits = np.zeros((rows, N_BITS * len(obj.spaces)), dtype=bool)
    for j in range(len(obj.spaces)):
        bits[np.arange(rows), N_BITS * j + rng.integers(0, 3, rows)] = True
        bits[:, N_BITS * j + 3:N_BITS * j + 5] = rng.random((rows, 2)) < 0.5

    def cpu(fn, n: int) -> float:
        fn(real[:n], bits[:n])
        best = math.inf
        for _ in range(repeat):
            start = time.process_time()
            fn(real[:n], bits[:n])
            best = min(best, time.process_time() - start)
        return best
    out = {"rows": rows}
    for name, fn in (("full", obj), ("coarse", obj.coarse)):
        one, many = cpu(fn, 1), cpu(fn, rows)
        per_row = (many - one) / (rows - 1)
        out[name] = {"call_1_s": one, f"call_{rows}_s": many, "per_row_s": per_row, "overhead_s": one - per_row}
    return out


def format_diagnose(row: dict) -> str:
    out = [f"Diagnosis of CyCab scenario 2 (paper settings: population 100, 150 generations, "
           f"{row['estimators']} estimators, {row['workers']} worker process(es))",
           f"{'stage':<20}{'wall [s]':>10}"]
    for stage, secs in row["stages"].items():
        out.append(f"{stage:<20}{secs:>10.2f}")
    out.append(f"{'total':<20}{row['total_s']:>10.2f}")
    share = row["objective_s"] / row["estimator_s"] if row["estimator_s"] else 0.0
    out.append(f"{'total CPU':<20}{row['cpu_s']:>10.2f}")
    out.append(f"the same diagnosis again in this process: {row['later_cpu_s']:.2f} s CPU, least of {REPEAT} (kernels loaded, "
               f"model derived)")
    out.append(f"identification: {row['evaluations']} evaluations; {100 * share:.0f} % of estimator time in residual "
               f"evaluation (the objective), {row['estimator_s'] - row['objective_s']:.2f} s in the engines; "
               f"{1e6 * row['objective_s'] / max(1, row['evaluations']):.0f} us per evaluated row")
    p = row.get("process")
    if p:
        out.append(f"a whole `bgfdi diagnose` process ({'warm caches' if p['cache'] else 'the cache off'}, least of "
                   f"{p['runs']}): {p['wall_s']:.2f} s wall, {p['cpu_s']:.2f} s CPU (target: <= 1 s warm)")
    o = row["objective"]
    out.append(f"objective ({row['kernels']} kernels; R4 & beta_theta2, random rows of every structure, CPU, "
               f"min of 5):")
    for path, j in (row.get("jit") or {}).items():
        if j:
            what = "the C library kept in the disk cache" if path == "c" else "numba's disk cache warm"
            out.insert(len(out) - 1, f"{path} kernels in a fresh process ({what}, CPU): load "
                                     f"{j['import_s']:.2f} s, first objective call {j['first_call_s']:.2f} s, "
                                     f"second {1e3 * j['second_call_s']:.1f} ms")
    for name in ("full", "coarse"):
        c, key = o[name], f"call_{o['rows']}_s"
        out.append(f"  {name:<7} 1 row {1e6 * c['call_1_s']:>7.0f} us, {o['rows']} rows {1e3 * c[key]:>6.2f} ms: "
                   f"{1e6 * c['per_row_s']:>6.1f} us/row + {1e6 * c['overhead_s']:>6.0f} us per call")
    return "\n".join(out) + "\n"


def diagnose_json(row: dict) -> dict:
    """``bench diagnose --json``: wall seconds by stage of one diagnosis of scenario 2."""
    return {"benchmark": "diagnose", "data": "scenario2.csv", "pop": 100, "generations": 150,
            "workers": row["workers"], "estimators": row["estimators"], "stages_s": dict(row["stages"]),
            "total_s": row["total_s"], "cpu_s": row["cpu_s"], "later_cpu_s": row["later_cpu_s"],
            "estimator_s": row["estimator_s"],
            "objective_s": row["objective_s"], "evaluations": row["evaluations"], "kernels": row["kernels"],
            "objective": row["objective"], "jit": row.get("jit"), "process": row.get("process")}


def benchmark_problem(name: str, seed: int):
    """The scenario-2 identification (beta_theta2 & R4 on the shipped reference data) for the bench."""
    import numpy as np
    from .resources import reference_data, shipped_model
    from .synthetic import Problem
    from ..data import read_csv, signals_from_data
    from ..objective import Objective, window
    from ..monitor import compiled
    if name != "scenario2":
        raise ValueError(f"unknown problem '{name}' (synthetic, synthetic-all, a synthetic case, or scenario2)")
    path = str(shipped_model("cycab_steering"))
    c = compiled(path)
    model, config = c.model, c.config
    data = read_csv(reference_data("scenario2.csv"))
    raw = signals_from_data(model, data)
    win = window(data.t, raw, 32.0, config.samples, config.derivative_window)
    weights = 1.0 / np.array([config.thresholds[a.name] for a in c.arrs])
    obj = Objective(model, c.residuals, win, ("R4", "beta_theta2"), weights, config.derivative_window, config=config)
    truth = [{"type": "abrupt", "value": 2.5221e7}, {"type": "incipient", "model": 2, "b": [-0.03]}]
    t_win = win.t[win.crop]
    fixed_onset = lambda real, bits: obj(np.hstack([real, np.full((real.shape[0], 1), 32.0)]), bits)
    return Problem("scenario2", obj.spaces, truth, t_win, 32.0, fixed_onset, "scenario-2 identification, beta_theta2 & R4",
                   objective=obj)


# ---------------------------------------------------------------- chains: cost against model size

CHECK_CHAINS = (10, 100, 1000)          # elements of the drivetrain chain (chain_yaml) checked
DIAGNOSE_CHAINS = (10, 100, 250)        # tanks of fault_chain_yaml diagnosed (one capacitance fault; 250: 1000 elements)


def _cpu(fn) -> float:
    """CPU seconds of ``fn()`` (process time: what the machine's other load does not inflate much)."""
    start = time.process_time()
    fn()
    return time.process_time() - start


def check_chain_row(size: int) -> dict:
    """``bgfdi check --json`` of the drivetrain chain of ``size`` elements (:func:`chain_yaml`: one
    residual along the whole chain), loading included, on a deep-stack thread as the command does;
    one cold run (a fresh model object; sympy's cache cleared)."""
    import tempfile

    from sympy.core.cache import clear_cache

    from bondgraph.deep import run_deep

    from .check_report import analyse

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"chain_{size}.yaml"
        path.write_text(chain_yaml(size))
        clear_cache()
        seconds = run_deep(_cpu, lambda: analyse(str(path)))
    return {"case": f"check chain N={size}", "elements": size, "seconds": seconds}


def diagnose_chain_row(tanks: int, workers: int = 1) -> dict:
    """``bgfdi diagnose`` (monitor compiled from the text, detection, isolation, identification) of
    ``tanks`` tanks in series (:func:`bondgraph.chains.fault_chain_yaml`) with the capacitance of
    the middle tank dropped to 0.8 of its value at 100 s; the data simulated by bgfdi's own
    simulator beforehand (not timed: the benchmark times the diagnosis, and
    tests/test_chain_diagnosis.py checks it against an independent simulator)."""
    from bondgraph.chains import fault_chain_yaml

    from ..api import diagnose
    from ..data import Measurements
    from ..options import Options
    from .scenario import parse_scenario, run

    text = fault_chain_yaml(tanks)
    model = load_model_text(text, f"fault_chain_{tanks}")
    middle = (tanks + 1) // 2
    scenario = parse_scenario({"seed": 1, "T": 300.0, "fs": 2.0,
                               "faults": [{"target": f"fT{middle}", "type": "abrupt", "t0": 100.0, "value": 0.8e-5}]},
                              model, "<bench chain>")
    cols = run(model, scenario)
    data = Measurements(f"fault_chain_{tanks}", cols["t"], cols)
    result: dict = {}

    def job():
        result["report"] = diagnose(text, data,
                                    Options(workers=workers, seed=0)).to_dict()
    seconds = _cpu(job)
    faults = result["report"]["diagnosis"]["faults"]
    return {"case": f"diagnose tanks N={tanks}", "elements": len(model.elements) + len(model.junctions),
            "tanks": tanks, "seconds": seconds, "found": [f.get("name") for f in faults],
            "ratios": [f["value"] / 1.0e-5 if f.get("type") == "abrupt" else None for f in faults],
            "expected": f"fT{middle}", "expected_ratio": 0.8}


def chain_rows(check_sizes=CHECK_CHAINS, tank_sizes=DIAGNOSE_CHAINS, echo=None) -> list[dict]:
    rows = []
    for n in check_sizes:
        rows.append(check_chain_row(n))
        if echo:
            echo(f"check chain N={n}: {rows[-1]['seconds']:.2f} s CPU")
    for n in tank_sizes:
        rows.append(diagnose_chain_row(n))
        if echo:
            echo(f"diagnose tanks N={n}: {rows[-1]['seconds']:.2f} s CPU")
    return rows


def growth_exponent(rows: list[dict], size_key: str = "elements") -> float | None:
    """The exponent k of time ~ size^k from the first to the last row (1 = linear)."""
    if len(rows) < 2 or rows[0]["seconds"] <= 0:
        return None
    a, b = rows[0], rows[-1]
    return math.log(b["seconds"] / a["seconds"]) / math.log(b[size_key] / a[size_key])


def format_chain(rows: list[dict]) -> str:
    out = ["Cost against model size (CPU seconds, one cold run each)",
           f"{'case':<28}{'elements':>9}{'CPU [s]':>10}{'s/element':>12}  result"]
    for r in rows:
        result = ""
        if "found" in r:
            found = [name if ratio is None else f"{name} x{ratio:.3f}"
                     for name, ratio in zip(r["found"], r.get("ratios") or [None] * len(r["found"]))]
            result = f"found {', '.join(found) or 'nothing'} (designed {r['expected']} x{r.get('expected_ratio', 0.8):g})"
        out.append(f"{r['case']:<28}{r['elements']:>9}{r['seconds']:>10.2f}{r['seconds'] / r['elements']:>12.2e}  {result}")
    for label, group, key in (("check", [r for r in rows if r["case"].startswith("check")], "elements"),
                              ("diagnose", [r for r in rows if r["case"].startswith("diagnose")], "tanks")):
        k = growth_exponent(group, key)
        if k is not None:
            out.append(f"{label} growth: time ~ n^{k:.2f} from n = {group[0][key]} to {group[-1][key]} (1 = linear)")
    return "\n".join(out) + "\n"


def chain_json(rows: list[dict]) -> dict:
    check = [r for r in rows if r["case"].startswith("check")]
    diag = [r for r in rows if r["case"].startswith("diagnose")]
    return {"benchmark": "chain",
            "check": [{"elements": r["elements"], "cpu_s": r["seconds"]} for r in check],
            "check_exponent": growth_exponent(check),
            "diagnose": [{"tanks": r["tanks"], "elements": r["elements"], "cpu_s": r["seconds"], "found": r["found"],
                          "ratios": r["ratios"], "expected": r["expected"], "expected_ratio": r["expected_ratio"]}
                         for r in diag],
            "diagnose_exponent": growth_exponent(diag, "tanks")}
