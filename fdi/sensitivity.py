"""Isolation aware of sensitivity: a quiet residual exonerates a fault only if it could have fired.

Exoneration (Sec. IV of the paper) drops every fault whose signature has a 1 where the coherence
vector has a 0: it assumes that a fault moves every residual it enters past its threshold. A
residual can be structurally sensitive and numerically deaf: a current-sensor gain fault of a DC
drive moves the armature's voltage balance by volts and the shaft's torque balance by a tenth of
its threshold, so the true fault was exonerated and two wrong ones were reported.

So before exonerating, each fault's sensitivity is measured on the data of the decision window:
the residuals with the fault's parameter moved by a small step, against the residuals at
nominal values. The residuals that fired fix the size the fault would need (their deviation over
the step's: the part of each one's peak above its own peak before the fault, when that is known,
for noise and a relay's switching spikes are not the fault's); at that size a quiet residual it
enters would move by the step's effect on it scaled alike. Where that is under the residual's
threshold, the quiet residual says nothing about the fault: its 1 is *weak* there, and the fault
is judged on the residuals it can move.

On the CyCab, a gain fault of the steering-wheel encoder beta_theta1 enters ARR1 and ARR2; if it
would move ARR1 to 0.41 of its threshold only, a quiet ARR1 no longer exonerates it, and it
becomes a candidate for the coherence vector [0 1 0], alone and with R4:

>>> from bondgraph.loader import load_model
>>> from fdi.isolate import candidate_sets
>>> from fdi.scaph import derive_arrs
>>> from fdi.signatures import fault_signature_matrix
>>> m = load_model("models/cycab_steering.yaml")
>>> fsm = fault_signature_matrix(m, derive_arrs(m))
>>> weak = [Weakness("beta_theta1", "ARR1", predicted=0.41, threshold=1.0)]
>>> fsm.row("beta_theta1").nominal, effective(fsm, weak).row("beta_theta1").nominal
((1, 1, 0), (0, 1, 0))
>>> candidate_sets(fsm, (0, 1, 0)), candidate_sets(effective(fsm, weak), (0, 1, 0))
([('R4',)], [('R4',), ('beta_theta1',), ('R4', 'beta_theta1')])
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np

from bondgraph.model import Model

from . import derivatives
from .data import input_values
from .residuals import Residual, corrects_signal, evaluate
from .signatures import FSM

STEP = 0.05          # relative change of a fault's parameter (or efficiency factor) for the sensitivity
# A quiet residual is weak for a fault when the fault, at the size the residuals that fired need,
# would move it by less than MARGIN x its threshold: it could not have crossed, so its silence says
# nothing. (The paper exonerates by structure alone; a model that reproduces it says so:
# diagnosis: {exoneration: structural}, as the CyCab's file does: there beta_theta1 would move ARR1
# to 0.41 of its threshold in scenario 2, and the paper exonerates it.)
MARGIN = 1.0


@dataclass(frozen=True)
class Weakness:
    """Fault ``fault`` would move quiet residual ``residual`` by ``predicted`` (peak, in the
    residual's unit) at the size the residuals that fired need: under ``threshold`` x MARGIN."""
    fault: str
    residual: str
    predicted: float
    threshold: float


def perturbed(model: Model, fault: str, nominal: Mapping[str, float],
               raw: Mapping[str, np.ndarray]) -> tuple[dict, dict, dict] | None:
    """(parameter values, efficiency factors, offsets) with the fault's targets moved by STEP (an
    offset by STEP x the signal's RMS); None where the fault cannot be perturbed (a mode fault, an
    infinite or zero nominal value, a signal that is zero)."""
    f = model.faults[fault]
    if f.effect == "stuck":               # no size to scale: the data show it or not (fdi.stuck)
        return None
    if f.effect == "bias":
        size = float(np.sqrt(np.mean(np.square(np.asarray(raw[f.targets[0]], dtype=float)))))
        return ({}, {}, {f.targets[0]: STEP * size}) if size > 0 else None
    if f.kind == "source" and not corrects_signal(model, f):     # a fixed-value source: a parameter
        return {f.symbols[0]: 1.0 - STEP}, {}, {}
    if f.kind in ("sensor", "source"):
        return {}, {f.targets[0]: 1.0 - STEP}, {}
    if f.kind != "parametric":
        return None
    values = {}
    for p in f.targets:
        v = nominal.get(p)
        if v is None or not np.isfinite(v) or v == 0:
            return None
        values[p] = v * (1.0 + STEP)
    return values, {}, {}


def weak_entries(model: Model, residuals: list[Residual], raw: Mapping[str, np.ndarray], ts: float, window: float,
                 fsm: FSM, coherence: tuple[int, ...], thresholds: np.ndarray, crop: slice,
                 values: Mapping[str, object] | None = None,
                 quiet_level: np.ndarray | None = None) -> list[Weakness]:
    """The (fault, quiet residual) pairs whose structural 1 the data cannot confirm (module doc).
    ``raw``: the signals of the decision window, ``crop`` the samples judged; ``values``: mode
    values (commanded modes); ``quiet_level``: each residual's peak |r| before the fault (its noise
    and spikes, e.g. at a relay's switchings), which the fault's size is read above."""
    c = [int(x) for x in coherence]
    nominal = {k: float(v) for k, v in model.nominal_by_name().items()}
    base_values = dict(values or {})
    r0 = evaluate(model, residuals, raw, ts, window=window, values=base_values)[:, crop]
    # the fault's size is read past the first derivative window: a step of a signal (an offset, a
    # gain) jumps its derivative, and the spike the filter makes of it at the onset is no effect of
    # the constant step probed here (a thermometer's 1.5 K offset read as 33 K from a zone balance's
    # 10 kW spike, its steady effect 1 kW: the wall balance it moves by 187 W "would have fired")
    lead = derivatives.window_samples(window, ts, derivatives.DEFAULT_ORDER)
    past = slice(lead if r0.shape[-1] > 2 * lead else 0, None)
    observed = np.fmax.reduce(np.abs(r0[..., past]), axis=-1)      # NaN skipped, no warning
    if quiet_level is not None:          # the part of each peak above the residual's own level is the fault's
        observed = observed - np.nan_to_num(np.asarray(quiet_level, dtype=float), nan=0.0)
    out: list[Weakness] = []
    for row in fsm.rows:
        quiet = [j for j, (s, cj) in enumerate(zip(row.nominal, c)) if s and not cj]
        fired = [j for j, (s, cj) in enumerate(zip(row.nominal, c)) if s and cj]
        if not quiet or not fired:
            continue
        moved = perturbed(model, row.fault, nominal, raw)
        if moved is None:
            continue
        params, betas, biases = moved
        r1 = evaluate(model, residuals, raw, ts, window=window, values={**base_values, **params}, betas=betas,
                      biases=biases)[:, crop]
        effect = np.fmax.reduce(np.abs(r1 - r0)[..., past], axis=-1)  # the step's peak effect on each residual
        scales = [observed[i] / effect[i] for i in fired      # a peak not above its own level reads no size
                  if effect[i] > 0 and np.isfinite(effect[i]) and np.isfinite(observed[i]) and observed[i] > 0]
        if not scales:
            continue
        k = min(scales)                 # the smallest size that explains one residual that fired
        for j in quiet:
            predicted = float(k * effect[j])
            if np.isfinite(predicted) and predicted < MARGIN * float(thresholds[j]):
                out.append(Weakness(row.fault, fsm.columns[j], predicted, float(thresholds[j])))
    return out


def effective(fsm: FSM, weak: list[Weakness]) -> FSM:
    """The FSM with each weak entry set to 0 in its fault's nominal signature."""
    if not weak:
        return fsm
    col = {name: j for j, name in enumerate(fsm.columns)}
    drop: dict[str, set[int]] = {}
    for w in weak:
        drop.setdefault(w.fault, set()).add(col[w.residual])
    rows = []
    for r in fsm.rows:
        if r.fault in drop:
            r = replace(r, nominal=tuple(0 if j in drop[r.fault] else v for j, v in enumerate(r.nominal)))
        rows.append(r)
    return replace(fsm, rows=tuple(rows))


@dataclass(frozen=True)
class NominalSensitivity:
    """How a fault that just crosses its most sensitive residual's threshold moves the others, on a
    simulated nominal run: ``reach[residual]`` as a fraction of that residual's threshold (1 for
    the residual that sets the size). Below MARGIN a structural 1 is a weak one."""
    fault: str
    reach: Mapping[str, float]

    def weak(self) -> list[str]:
        return [r for r, x in self.reach.items() if x < MARGIN]


def nominal_sensitivities(model: Model, residuals: list[Residual], thresholds: Mapping[str, float],
                          window: float | None = None) -> list[NominalSensitivity]:
    """Every candidate fault's reach in each residual it enters structurally, on a nominal run of
    bgfdi's simulator (the model's own input expressions, from its initial state, over twenty of its
    slowest time constants at most two thousand fastest ones, sampled at the data's sampling time or
    a tenth of the fastest time constant): the fault is moved by STEP, the residuals' peak change
    scaled to the size at which the first of them reaches its threshold. Raises ValueError when the
    model cannot be simulated as it is (an input without an expression, no time constant)."""
    from bondgraph.simulation import simulate
    from bondgraph.timescales import model_time_scales

    scales = model_time_scales(model)
    if not scales.known:
        raise ValueError("no time constant to set the run")
    if any(i.expr is None for i in model.inputs.values()):
        raise ValueError("an input has no expr to simulate")
    if any(m.column or m.autonomous for m in model.modes.values()):
        raise ValueError("its modes switch (commanded or autonomous): a nominal run at fixed modes would not "
                         "say how its residuals see a fault; the decision window's data do (report: weakly_detectable)")
    ts = model.sampling_time or scales.fastest / 10
    span = min(20 * scales.slowest, 2000 * scales.fastest) if np.isfinite(scales.slowest) else 2000 * scales.fastest
    t = np.arange(int(span / ts) + 1) * ts
    nominal = {k: float(v) for k, v in model.nominal_by_name().items()}
    missing = [r.name for r in residuals if r.name not in thresholds]
    if missing:
        raise ValueError(f"no threshold for {', '.join(missing)} in the model (bgfdi calibrate gives them)")
    traj = simulate(model, t, values=lambda tt: nominal)
    raw = {s: np.asarray(traj.signals[s], dtype=float) for s in model.sensors}
    raw.update({name: input_values(model, name, t) for name in model.inputs})
    w = window or max(5 * ts, scales.fastest / 2)
    edge = max(1, int(np.ceil(w / ts)))
    crop = slice(edge, t.size - edge)
    r0 = evaluate(model, residuals, raw, ts, window=w)[:, crop]
    out = []
    names = [r.name for r in residuals]
    for fault in model.faults:
        moved = perturbed(model, fault, nominal, raw)
        if moved is None:
            continue
        params, betas, biases = moved
        r1 = evaluate(model, residuals, raw, ts, window=w, values=params, betas=betas, biases=biases)[:, crop]
        effect = np.nanmax(np.abs(r1 - r0), axis=-1)
        enters = [j for j, r in enumerate(residuals) if effect[j] > 0 and np.isfinite(effect[j])]
        if not enters:
            continue
        sets = min(enters, key=lambda j: thresholds[names[j]] / effect[j])     # the residual that sets the size
        size = thresholds[names[sets]] / effect[sets]
        out.append(NominalSensitivity(fault, {names[j]: 1.0 if j == sets else float(size * effect[j] / thresholds[names[j]])
                                              for j in enters}))     # exactly 1 there, not 1 - 1e-16 (weak below 1)
    return out
