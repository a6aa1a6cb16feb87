"""``bgfdi isolability``: what a model's residuals can tell apart, what the best residuals could,
per mode and causal interpretation, and which added sensors would make every fault isolable."""
from __future__ import annotations

import json
import time
from dataclasses import dataclass

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.model import Model
from bondgraph.structure import DERIVATIVE, MIXED

from ..arrs import select_arrs, structural_system
from ..identifiability import coinciding
from ..results import Coincidence
from ..isolability import Isolability, sensor_placement, signature_isolability, structural_isolability
from ..signatures import all_modes, fault_signature_matrix


@dataclass(frozen=True)
class ModeAnalysis:
    mode: dict
    best: dict[str, Isolability]        # by causality
    chosen: Isolability


@dataclass(frozen=True)
class Analysis:
    model: str
    causality: str
    residuals: tuple
    modes: tuple[ModeAnalysis, ...]
    placement: object
    mso_count: int
    mso_seconds: float
    seconds: float
    notes: tuple[str, ...]
    sensitivities: tuple = ()           # fdi.sensitivity.NominalSensitivity, on a nominal simulation
    coinciding: tuple[Coincidence, ...] = ()   # faults the residuals read only together


def analyse(model: Model, causality: str = DERIVATIVE, modes: list[dict] | None = None,
            max_sensors: int = 3, config=None) -> Analysis:
    """The isolability analysis; with the model's monitor settings (``config``: its thresholds),
    also each fault's weak residuals on a nominal simulation (:func:`fdi.sensitivity.nominal_sensitivities`)."""
    start = time.perf_counter()
    chosen = select_arrs(model, causality)
    diag = assign(model, DIAGNOSIS)
    faults = [f for f, v in model.faults.items() if v.kind != "mode"]
    out = []
    for mode in modes or all_modes(model):
        system = structural_system(model, diag, mode=mode if model.modes else None)
        best = {c: structural_isolability(model, system, c, faults) for c in (DERIVATIVE, MIXED)}
        if chosen.arrs:
            fsm = fault_signature_matrix(model, list(chosen.arrs), mode)
            iso = signature_isolability(faults, {r.fault: r.structural for r in fsm.rows})
        else:
            iso = signature_isolability(faults, {f: () for f in faults})
        out.append(ModeAnalysis(dict(mode), best, iso))
    nominal = structural_system(model, diag, mode=out[0].mode if model.modes else None)
    placement = sensor_placement(model, nominal, causality, max_sensors) if max_sensors else None
    notes = list(chosen.notes)
    sensitivities: tuple = ()
    if config is not None and chosen.arrs:
        from ..residuals import compile_residuals
        from ..sensitivity import nominal_sensitivities
        try:
            from ..residuals import divided_by_mode
            kernels = divided_by_mode(model, chosen.arrs, compile_residuals(model, list(chosen.arrs)),
                                      config.mode_thresholds)
            sensitivities = tuple(nominal_sensitivities(model, list(kernels), dict(config.thresholds),
                                                        config.derivative_window))
        except Exception as exc:                   # noqa: BLE001  the analysis stands without it; say why
            notes.append(f"weak detectability not assessed: {str(exc).splitlines()[0]}")
    together = coinciding(model, chosen.arrs)
    return Analysis(model.name, causality, chosen.arrs, tuple(out), placement, chosen.msos, chosen.mso_seconds,
                    time.perf_counter() - start, tuple(notes), sensitivities, together)


def _classes(iso: Isolability) -> str:
    text = " ".join("{" + ", ".join(c) + "}" for c in iso.classes())
    und = iso.undetectable()
    return text + (f"; not detectable: {', '.join(und)}" if und else "")


def to_text(a: Analysis) -> str:
    lines = [f"isolability of {a.model} (single faults; a class is a set of faults no residual tells apart)", ""]
    names = ", ".join(f"{r.name} ({'SCAPH' if r.origin == 'SCAPH' else 'MSO at ' + r.junction})" for r in a.residuals)
    lines.append(f"residuals ({a.causality} causality): {names or 'none'}")
    for note in a.notes:
        lines.append(f"  note: {note}")
    for m in a.modes:
        label = " ".join(f"{k}={v}" for k, v in m.mode.items()) or "(no modes)"
        lines += ["", f"mode {label}"]
        for c, iso in m.best.items():
            lines.append(f"  best, {c} causality:".ljust(34) + _classes(iso))
        reach = "reaches" if m.chosen.covers(m.best[a.causality]) else "falls short of"
        lines.append("  chosen residuals:".ljust(34) + _classes(m.chosen) + f"   ({reach} the best in {a.causality} causality)")
    weak = [(x.fault, x.weak(), x.reach) for x in a.sensitivities if x.weak()]
    if weak:
        lines += ["", "weakly detectable (a fault that just crosses its most sensitive residual's threshold moves "
                  "these by less than theirs, on a nominal simulation: their silence does not exonerate it)"]
        for fault, residuals, reach in weak:
            lines.append(f"  {fault}: " + ", ".join(f"{r} ({reach[r]:.2g} of its threshold)" for r in residuals))
    if a.coinciding:
        lines += ["", "read together (faults with one signature are told apart by their fits, but not these: the "
                  "residuals read each pair only through one combination, so a constant fault of one is fitted "
                  "as well by the other within their ranges)"]
        for c in a.coinciding:
            first, second = c.names()
            lines.append(f"  {first} and {second}: " + (c.combination or "one combination")
                         + f" ({', '.join(c.residuals)})")
    p = a.placement
    if p is not None:
        lines += ["", f"sensor placement ({a.causality} causality, first mode): smallest sets of added sensors that make "
                  + ("every fault detectable and isolable" if p.full else "the faults as isolable as any sensors can")]
        if p.sets == ((),):
            lines.append("  none needed: the sensors there already reach it structurally")
        elif not p.sets:
            lines.append("  no set within the size tried (raise --max-sensors)")
        else:
            for s in p.sets:
                lines.append("  " + " + ".join(c.label for c in s))
            lines.append("  classes then: " + _classes(p.target))
            if any(c.bond is not None for s in p.sets for c in s):
                lines.append("  (a sensor on a bond goes on a junction inserted there in the model file: a 0-junction "
                             "for an effort, De; a 1-junction for a flow, Df)")
    lines += ["", f"MSO sets: {a.mso_count} (search {a.mso_seconds:.3f} s); analysis {a.seconds:.2f} s"]
    return "\n".join(lines) + "\n"


def _iso_dict(iso: Isolability) -> dict:
    return {"faults": list(iso.faults), "detectable": [f for f, d in zip(iso.faults, iso.detectable) if d],
            "classes": [list(c) for c in iso.classes()],
            "isolable": [[int(x) for x in row] for row in iso.isolable]}


def to_dict(a: Analysis) -> dict:
    p = a.placement
    return {
        "model": a.model, "causality": a.causality,
        "residuals": [{"name": r.name, "origin": r.origin, "junction": r.junction, "equations": list(r.equations)}
                      for r in a.residuals],
        "modes": [{"mode": m.mode, "best": {c: _iso_dict(i) for c, i in m.best.items()}, "chosen": _iso_dict(m.chosen)}
                  for m in a.modes],
        "sensor_placement": None if p is None else {
            "full": p.full, "sets": [[{"kind": c.kind, "junction": c.junction, "bond": c.bond, "label": c.label}
                                      for c in s] for s in p.sets],
            "classes": [list(c) for c in p.target.classes()]},
        "mso_sets": a.mso_count, "notes": list(a.notes),
        "weakly_detectable": {x.fault: {r: x.reach[r] for r in x.weak()} for x in a.sensitivities if x.weak()},
        "read_together": [c.to_dict() for c in a.coinciding],
    }


def to_json(a: Analysis) -> str:
    return json.dumps(to_dict(a), indent=1) + "\n"
