"""Structural analysis of the three-tank benchmark by the Fault Diagnosis Toolbox, kept as a fixture.

Why this exists: ``models/three_tank.yaml`` is the three-tank system exactly as the Fault
Diagnosis Toolbox (FDT, Python package ``faultdiagnosistoolbox``, models/three_tank; Frisk et al.,
"Diagnosability analysis considering causal interpretations for differential constraints", IEEE
TSMC-A 42(5), 2012) ships it. FDT's own answers (MSOs, their fault signature matrix, isolability
and detectability under mixed, derivative and integral causality, sensor placement for full
isolability) are stored in ``three_tank.json`` next to this script, so that the tests can compare
bgfdi with FDT without FDT installed. The project does not depend on FDT; only this script does.

Regenerate (FDT 0.12.5 in a separate environment, never in the project's venv)::

    python -m venv /tmp/fdtenv && /tmp/fdtenv/bin/pip install faultdiagnosistoolbox==0.12.5
    /tmp/fdtenv/bin/python tests/data/fdt/make_three_tank.py

JSON keys:
  faults       model.f, the order of every fault axis below
  variables    model.x (unknowns), model.z (measurements), model.parameters
  equations    one readable string per equation e1..e12 (indices below are 0-based into this list)
  msos         the MSO sets, each as sorted 0-based equation indices, the list sorted
  fsm          fault signature matrix of those MSOs: rows = msos (same order), columns = faults
  isolability  {causality: IM} from model.IsolabilityAnalysis(causality=...), causality in
               mixed, der, int. NOTE: FDT's matrix has im[i][j] = 1 where fault i is NOT
               isolable from fault j (the docstring says otherwise); it need not be symmetric
  classes      {causality: isolability classes}: groups of mutually non-isolable faults
               (i ~ j when im[i][j] = im[j][i] = 1, closed transitively), each in model.f order,
               the classes ordered by their first fault
  detectable   {causality: faults} from model.DetectabilityAnalysis(causality=...)[0]
  not_detectable  {causality: faults}, the second list of DetectabilityAnalysis
  sensor_placement_isolability  model.SensorPlacementIsolability()[0] with all variables as
               possible sensor locations (model.PossibleSensorLocations()): the minimal sets of
               extra sensors giving full isolability
  fdt_version  faultdiagnosistoolbox.__version__
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import faultdiagnosistoolbox as fdt
from faultdiagnosistoolbox.models import three_tank

CAUSALITIES = ("mixed", "der", "int")


def equation_text(rel) -> str:
    if isinstance(rel, (list, tuple)):          # FDT's differential constraint [dx, x, 'diff']
        dx, x, _ = rel
        return f"{dx} = d({x})/dt"
    return f"{rel.lhs} = {rel.rhs}"


def classes(im, faults: list[str]) -> list[list[str]]:
    n = len(faults)
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in range(n):
            if i != j and im[i][j] == 1 and im[j][i] == 1:
                parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    return [[faults[i] for i in g] for g in sorted(groups.values(), key=min)]


def main() -> None:
    model = three_tank.copy()
    faults = [str(f) for f in model.f]
    msos = sorted(sorted(int(i) for i in mso) for mso in model.MSO())
    fsm = model.FSM(msos)
    isolability, cls, det, nondet = {}, {}, {}, {}
    for c in CAUSALITIES:
        im = [[int(v) for v in row] for row in model.IsolabilityAnalysis(causality=c)]
        isolability[c] = im
        cls[c] = classes(im, faults)
        d, nd = model.DetectabilityAnalysis(causality=c)
        det[c] = [str(f) for f in d]
        nondet[c] = [str(f) for f in nd]
    placement_model = three_tank.copy()
    placement_model.PossibleSensorLocations()
    sensor_sets = placement_model.SensorPlacementIsolability()[0]
    out = {
        "model": model.name,
        "faults": faults,
        "variables": {"x": [str(v) for v in model.x], "z": [str(v) for v in model.z],
                      "parameters": [str(v) for v in model.parameters]},
        "equations": [equation_text(r) for r in model.syme],
        "msos": msos,
        "fsm": [[int(v) for v in row] for row in fsm],
        "isolability": isolability,
        "classes": cls,
        "detectable": det,
        "not_detectable": nondet,
        "sensor_placement_isolability": sorted(sorted(str(s) for s in group) for group in sensor_sets),
        "fdt_version": fdt.__version__,
    }
    path = Path(__file__).with_name("three_tank.json")
    text = json.dumps(out, indent=1)
    # one line per innermost list (a matrix row, an MSO, a class) for readable diffs
    text = re.sub(r"\[\s*([^\[\]{}]*?)\s*\]", lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text)
    path.write_text(text + "\n", encoding="utf-8")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
