"""``bgfdi check --json``: the model's summary, both causality assignments and its residuals as
one JSON object (shape in docs/cli.md). The text report is cli.cmd_check; the two say the same."""
from __future__ import annotations

import math

from bondgraph.causality import DIAGNOSIS, SIMULATION, Causality, assign
from bondgraph.errors import CausalityError
from bondgraph.model import Model
from bondgraph.modes import held_still, latching
from bondgraph.timescales import growth_notes, model_time_scales

from ..data import unread_columns
from .progress import stage


def no_residual(model: Model, path, causality: str) -> str:
    """What ``check`` says when no residual exists in ``causality``: in derivative causality, that
    mixed causality may give some where the model's structure is redundant (a trial's Thevenin
    cell measured by its voltage and current: its residual integrates the charge, and the message
    only proposed sensors). Decided on the structure, in polynomial time: the residual selection
    in mixed causality took 16 GB on a 500-element chain."""
    text = f"and no residual exists in {causality} causality"
    if causality == "derivative" and model.faults:
        from bondgraph.structure import redundancy_of, structure_of
        from ..scaph import structural_system
        if redundancy_of(structure_of(structural_system(model))) > 0:
            return (f"{text}: the model is structurally redundant, so --causality mixed may give residuals (they "
                    f"integrate a storage element's state: they need its initial value and drift with an "
                    f"offset); or add a sensor (bgfdi isolability {path} proposes them)")
    return f"{text} (bgfdi isolability {path} proposes sensors)"


def _bonds(model: Model, c: Causality) -> list[dict]:
    """Every bond with its causal stroke: which end receives the effort (the stroke's end) and which
    the flow; the sensors' signal bonds after the power bonds."""
    out = []
    for b in model.bonds:
        recv = c.effort_to.get(b.id)
        out.append({"bond": b.id, "from": b.source, "to": b.target, "effort_to": recv,
                    "flow_to": b.other(recv) if recv is not None else None, "signal": False})
    for s in model.sensors.values():
        recv = c.effort_to.get(s.name)
        out.append({"bond": s.name, "from": s.junction, "to": s.name, "effort_to": recv,
                    "flow_to": (s.name if recv == s.junction else s.junction) if recv is not None else None,
                    "signal": True})
    return out


def _causality(model: Model, c: Causality) -> dict:
    return {"ok": c.ok, "problems": list(c.problems), "loops": list(c.loops),
            "modes_checked": len(c.modes_checked), "storage": dict(c.storage), "resistors": dict(c.resistors),
            "strong": dict(c.strong), "detectors": sorted(c.detectors), "bonds": _bonds(model, c)}


def analyse(path: str, causality: str = "derivative", verify_seed: int | None = None) -> dict:
    """What ``bgfdi check`` reports, as plain data. A model without any residual, or with one
    undefined in some mode, is a CausalityError as for the text report. With ``verify_seed``
    (``--verify``), the residuals are also verified on the simulated model (``verification``,
    :mod:`fdi.app.verify_report`; null otherwise)."""
    from ..arrs import mixed_unit_notes, select_arrs, undefined_in_modes, unit_clash_notes
    from ..noise import noise_notes, predicted_for, to_json as noise_json
    from ..signatures import all_modes, unread_fault_note

    from ..config import load
    from .two_ports import laws as two_port_laws

    with stage("load"):
        model, config = load(path)               # the bond graph and the monitor settings both checked
    with stage("diagnostic causality (SCAPH)"):
        diag = assign(model, DIAGNOSIS)
    with stage(f"residual selection ({causality} causality)"):
        chosen = select_arrs(model, causality)
    if not diag.ok and not chosen.arrs:
        raise CausalityError(list(diag.problems) + list(diag.loops) + [no_residual(model, path, causality)])
    arrs = list(chosen.arrs)
    bad = undefined_in_modes(model, arrs, all_modes(model))
    if bad:
        raise CausalityError(bad)
    with stage("simulation causality (SCAP)"):
        sim = assign(model, SIMULATION)
    window, predicted, missing = None, {}, None
    if causality == "derivative":
        from ..detect import checked_thresholds
        missing = checked_thresholds(model, config.thresholds, [a.name for a in arrs])
        with stage("noise predicted by mode"):
            window, predicted = predicted_for(model, config, arrs)
    verification = None
    if verify_seed is not None:
        from ..verify import verify
        from .verify_report import to_json

        with stage("verification on the simulated model"):
            verification = to_json(verify(model, arrs, seed=verify_seed))
    return {
        "model": model.name,
        "file": str(path),
        "reference": model.reference or None,
        "elements": [{"name": e.name, "kind": e.kind} for e in model.elements.values()],
        "junctions": [{"name": j.name, "kind": j.kind, "mode": j.mode} for j in model.junctions.values()],
        "sensors": [{"name": s.name, "kind": s.kind, "junction": s.junction, "measures": s.measures, "unit": s.unit}
                    for s in model.sensors.values()],
        "modes": [{"name": m.name, "nominal": m.nominal, "column": m.column, "autonomous": bool(m.autonomous)}
                  for m in model.modes.values()],
        "unread_columns": unread_columns(model),
        "faults": [{"name": f.name, "kind": f.kind, "targets": list(f.targets)} for f in model.faults.values()],
        "two_ports": two_port_laws(model),
        "diagnosis": _causality(model, diag),
        "residuals": {
            "causality": causality,
            "from_structure": not diag.ok,
            "msos": chosen.msos if not diag.ok else None,
            "arrs": [{"name": a.name, "origin": a.origin, "sensor": a.sensor, "junction": a.junction} for a in arrs],
            "notes": (list(chosen.notes) + unit_clash_notes(model, arrs) + mixed_unit_notes(model, arrs)
                      + unread_fault_note(model, arrs, causality)
                      + noise_notes(model, arrs, predicted, window) + ([missing] if missing else [])),
            "noise": {"derivative_window": window, "by_residual": noise_json(predicted)} if predicted else None,
        },
        "simulation": {**_causality(model, sim), "growing": growth_notes(model_time_scales(model)),
                       "held_still": held_still(model), "latching": latching(model)},
        "monitor": _monitor(config),
        "verification": verification,
    }


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _monitor(config) -> dict:
    """The monitor settings of the file (SI: times in s; thresholds in each residual's unit, 1 for a
    residual with thresholds by mode, whose table is in mode_thresholds; an unbounded end of a
    fault's search bounds is null)."""
    from ..mode_thresholds import key_text
    return {"thresholds": dict(config.thresholds),
            "mode_thresholds": {name: {key_text(k): v for k, v in table.items()}
                                for name, table in config.mode_thresholds.items()},
            "waiting_time": config.waiting_time, "samples": config.samples,
            "derivative_window": config.derivative_window,
            "faults": {name: {"bounds": None if f.bounds is None else [_finite(b) for b in f.bounds],
                              "failure": _finite(f.failure)} for name, f in config.faults.items()}}
