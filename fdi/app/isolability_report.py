"""``bgfdi isolability``: what a model's residuals can tell apart, what the best residuals could,
per mode and causal interpretation, and which added sensors would make every fault isolable.

Mode faults (a valve stuck open or closed) are read from the chosen residuals' MCSM: in each mode,
a mode fault that switches its variable out of the mode's value has the signature of that switch,
and is told apart from the component faults (or not) as they are from one another. A trial's surge
tank relief valve stuck open reads in mode v = 0 as the tank's leak does, [0 1 0]; the command said
every fault isolable, leaving mode faults out unsaid. A mode fault holding the value the mode
already has (stuck closed while closed) has nothing to show in it, and is listed as such. The
structural best and the sensor placement are of the component faults: a mode fault has no
equation of its own in a mode's structure (the mode is substituted), and the text says so."""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.model import Model
from bondgraph.structure import DERIVATIVE, MIXED

from ..arrs import select_arrs, structural_system
from ..identifiability import coinciding
from ..results import Coincidence
from ..isolability import Isolability, sensor_placement, signature_isolability, structural_isolability
from ..signatures import all_modes, fault_signature_matrix, mode_change_signature_matrix, nominal_mode


@dataclass(frozen=True)
class ModeAnalysis:
    mode: dict
    best: dict[str, Isolability]        # by causality (component faults)
    chosen: Isolability                 # the component faults and the mode faults a switch out of ``mode`` makes
    mode_faults: dict = field(default_factory=dict)     # those mode faults: their MCSM signatures
    held: tuple[str, ...] = ()          # mode faults holding the value ``mode`` already has: nothing to see in it

    def reaches_best(self, causality: str) -> bool:
        """The chosen residuals tell apart, among the component faults, what the best can."""
        best = self.best[causality]
        return self.chosen.restricted(best.faults).covers(best)


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
        switched, held = mode_fault_signatures(model, chosen.arrs, mode)
        names = faults + list(switched)
        if chosen.arrs:
            fsm = fault_signature_matrix(model, list(chosen.arrs), mode)
            iso = signature_isolability(names, {**{r.fault: r.structural for r in fsm.rows}, **switched})
        else:
            iso = signature_isolability(names, {f: () for f in names})
        out.append(ModeAnalysis(dict(mode), best, iso, switched, held))
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


def mode_fault_signatures(model: Model, arrs, mode: dict) -> tuple[dict[str, tuple[int, ...]], tuple[str, ...]]:
    """The model's mode faults in ``mode``: those that switch their variable out of the mode's
    value, with the signature of that switch (its MCSM row: which residuals differ between the
    two modes), and those holding the value the mode already has (a valve stuck closed while
    commanded closed: no residual can see it in this mode)."""
    here = {**nominal_mode(model), **mode}
    rows = {r.variable: r.signature for r in mode_change_signature_matrix(model, list(arrs), here).rows} \
        if arrs else {}
    switched: dict[str, tuple[int, ...]] = {}
    held: list[str] = []
    for name, f in model.faults.items():
        if f.kind != "mode":
            continue
        variable, value = f.targets[0], 0 if f.value is None else int(f.value)
        if int(here[variable]) == value:
            held.append(name)
        else:
            switched[name] = tuple(rows.get(variable, (0,) * len(arrs)))
    return switched, tuple(held)


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
    moded = any(m.mode_faults or m.held for m in a.modes)
    if moded:
        lines.append("  mode faults: in the chosen residuals' classes by their MCSM signatures (a switch out of "
                     "each mode); the best and the sensor placement are of the component faults only (a mode "
                     "fault has no equation of its own in a mode's structure)")
    for m in a.modes:
        label = " ".join(f"{k}={v}" for k, v in m.mode.items()) or "(no modes)"
        lines += ["", f"mode {label}"]
        for c, iso in m.best.items():
            lines.append(f"  best, {c} causality:".ljust(34) + _classes(iso))
        reach = "reaches" if m.reaches_best(a.causality) else "falls short of"
        lines.append("  chosen residuals:".ljust(34) + _classes(m.chosen) + f"   ({reach} the best in {a.causality} causality"
                     + (", component faults)" if moded else ")"))
        if moded:
            lines.append("  mode faults (MCSM):".ljust(34) + _mode_faults(m))
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


def _mode_faults(m: ModeAnalysis) -> str:
    """The mode faults of a mode: each switch's signature, and those the mode already holds."""
    parts = [f"{name} [{' '.join(map(str, sig))}]" for name, sig in m.mode_faults.items()]
    if m.held:
        parts.append(f"{', '.join(m.held)}: the value this mode already has, nothing to see in it "
                     f"(seen from the other value)")
    return "; ".join(parts)


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
        "modes": [{"mode": m.mode, "best": {c: _iso_dict(i) for c, i in m.best.items()}, "chosen": _iso_dict(m.chosen),
                   "mode_faults": {name: list(sig) for name, sig in m.mode_faults.items()},
                   "mode_faults_held": list(m.held)}
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
