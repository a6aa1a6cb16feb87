"""Benchmarks printed as tables: ``bgfdi bench derive`` (symbolic derivation time)."""
from __future__ import annotations

import time
from pathlib import Path

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.chains import chain_yaml
from bondgraph.loader import load_model, load_model_text

from .arrs import derive_arrs
from .signatures import all_modes, fault_signature_matrix, mode_change_signature_matrix

CHAIN_SIZES = (10, 20, 50, 100, 200)


def _best_of(fn, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def derive_rows(models: list[Path], sizes=CHAIN_SIZES) -> list[dict]:
    """Time causality + AGARRs (+ signature matrices for shipped models), best of three runs."""
    rows = []
    for path in models:
        model = load_model(path)

        def job(model=model):
            arrs = derive_arrs(model, assign(model, DIAGNOSIS))
            for mode in all_modes(model):
                fault_signature_matrix(model, arrs, mode)
            mode_change_signature_matrix(model, arrs)
        n = len(model.elements) + len(model.junctions)
        rows.append({"case": model.name, "elements": n, "arrs": len(model.sensors), "seconds": _best_of(job)})
    for size in sizes:
        model = load_model_text(chain_yaml(size), f"chain_{size}")
        n = len(model.elements) + len(model.junctions)
        rows.append({"case": f"chain N={size}", "elements": n, "arrs": len(model.sensors),
                     "seconds": _best_of(lambda m=model: derive_arrs(m, assign(m, DIAGNOSIS)))})
    return rows


def format_derive(rows: list[dict]) -> str:
    out = ["Derivation of AGARRs (causality + elimination; shipped models also all MD-FSMs and the MCSM)",
           f"{'case':<26}{'elements':>9}{'ARRs':>6}{'time [s]':>11}{'s/element':>12}{'ratio':>8}"]
    chains = [r for r in rows if r["case"].startswith("chain")]
    base = chains[0] if chains else None
    for r in rows:
        ratio = ""
        if base and r in chains:
            ratio = f"{r['seconds'] / base['seconds']:.1f}x"
        out.append(f"{r['case']:<26}{r['elements']:>9}{r['arrs']:>6}{r['seconds']:>11.4f}"
                   f"{r['seconds'] / r['elements']:>12.2e}{ratio:>8}")
    if len(chains) >= 2:
        a, b = chains[0], chains[-1]
        growth = (b["seconds"] / a["seconds"]) / (b["elements"] / a["elements"])
        out.append(f"chain growth: time x{b['seconds'] / a['seconds']:.1f} for elements x"
                   f"{b['elements'] / a['elements']:.1f} (1.0 per unit = linear; measured {growth:.2f})")
    return "\n".join(out) + "\n"
