"""Each residual's noise predicted from the measurement model, mode by mode, before any data.

The sensors' noise (``noise:`` in the model file, a standard deviation per data column) reaches a
residual through its expression and the derivative filter. A residual whose form changes with the
modes (a controlled junction's outputs multiplied by its mode variable) may divide a noisy
difference by a small parameter in one mode and read a sensor directly in another: an EV
precharge circuit's link balance reads the main contactor's current as (Vb - vdc)/Rm with its
contact resistance Rm = 2 mOhm, 100 A of noise for the link voltage's 0.2 V, where the precharge
mode reads the pack current's 0.3 A. One threshold per residual is set by its noisiest mode, so a
fault seen only in the quiet modes must move the residual by the noisy mode's noise before it is
detected (measured on that circuit: the precharge resistor's loss, seen only while precharging,
was reported as the current sensor's gain). ``bgfdi check`` names such residuals
(:func:`noise_notes`) and ``check --json`` gives every prediction.

The prediction simulates the measurement alone: every sensor held at its operating value (the
file's ``initial`` reading of it, else 0) and every input at its expression, the modes held, each
sensor's columns made with its noise (:func:`fdi.measure.sensor_columns`, as ``bgfdi simulate``
makes them; a resolution as its uniform quantisation noise, step^2/12, which a varying signal
meets), the residuals evaluated as a diagnosis evaluates them (:func:`fdi.residuals.evaluate`:
the same derivative filter and window), less their values on the noise-free record: what remains
is the noise's response at that operating point, linear or not. Each sensor's share of the variance: the same with its noise alone.

>>> from bondgraph.loader import load_model
>>> from fdi.arrs import select_arrs
>>> from fdi.residuals import compile_residuals
>>> m = load_model("models/boost_converter.yaml")      # the switch s: two operating modes
>>> pred = predicted_noise(m, compile_residuals(m, list(select_arrs(m).arrs)), window=1e-5, ts=1e-6)
>>> [(x.mode["s"], x.std > 0) for x in pred["ARR1"]]
[(1, True), (0, True)]
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from bondgraph.model import Model

from . import derivatives
from .measure import SeveralColumns, sensor_columns
from .mode_thresholds import key_text

SPREAD = 10.0            # a residual whose noise differs this much between modes of one unit is named
WINDOWS = 40             # the simulated record: this many derivative windows ...
MIN_SAMPLES = 4000       # ... and at least this many samples (the std within a few per cent)
SEED = 0


@dataclass(frozen=True)
class ModeNoise:
    """A residual's predicted noise in one mode: its standard deviation (the residual's unit;
    None where the residual is not finite at the operating point) and each noisy sensor's share of
    its variance."""
    mode: Mapping[str, int]
    std: float | None
    shares: Mapping[str, float]


def _operating_record(model: Model, n: int, ts: float) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Each sensor's operating value and each input's values on ``n`` samples."""
    from .data import input_values
    t = np.arange(n) * ts
    level = {s: float(model.initial.get(s, 0.0)) for s in model.sensors}
    inputs = {name: input_values(model, name, t) if inp.expr is not None else np.zeros(n)
              for name, inp in model.inputs.items()}
    return level, inputs


def _signals(model: Model, level: Mapping[str, float], noisy: set[str], n: int, rng: np.random.Generator,
             ) -> dict[str, np.ndarray]:
    """Each sensor's signal read back from its columns: with its noise where in ``noisy``."""
    from .data import _signal_functions
    functions = _signal_functions(model)
    out = {}
    for s in model.sensors.values():
        columns = set(s.noise) | set(s.resolution)
        # quantisation as its additive model (uniform, step^2/12: Widrow's), which a varying signal
        # meets; held at one level, rounding alone would give a constant error
        noise = {c: math.hypot(s.noise.get(c, 0.0), s.resolution.get(c, 0.0) / math.sqrt(12.0)) if s.name in noisy
                 else 0.0 for c in columns}
        cols = sensor_columns(model, s, np.full(n, level[s.name]), rng, noise=noise,
                              resolution=dict.fromkeys(s.resolution, 0.0))
        names, fn = functions[s.name]
        out[s.name] = np.asarray(fn(*[cols[c] for c in names]), dtype=float) * np.ones(n)
    return out


def predicted_noise(model: Model, residuals: Sequence, window: float, ts: float,
                    modes: list[dict[str, int]] | None = None, seed: int = SEED) -> dict[str, list[ModeNoise]]:
    """Each residual's :class:`ModeNoise` in each of ``modes`` (default: the modes the plant runs
    in, :func:`fdi.signatures.operating_modes`), on data sampled every ``ts`` s with derivatives
    over ``window`` s. Empty when no sensor declares noise or resolution, or a sensor's columns
    cannot be made (several columns without ``columns:``)."""
    from .residuals import evaluate
    from .signatures import operating_modes

    noisy = [s.name for s in model.sensors.values() if any(s.noise.values()) or any(s.resolution.values())]
    if not noisy or not residuals:
        return {}
    modes = modes if modes is not None else operating_modes(model)
    width = derivatives.window_samples(window, ts, derivatives.DEFAULT_ORDER)
    n = max(MIN_SAMPLES, WINDOWS * width)
    level, inputs = _operating_record(model, n, ts)
    keep = slice(width, n - width)                 # the filter's edge samples are noisier: the interior only
    try:
        records = {"": _signals(model, level, set(), n, np.random.default_rng(seed))}
        records["*"] = _signals(model, level, set(noisy), n, np.random.default_rng(seed))
        for s in noisy if len(noisy) > 1 else ():
            records[s] = _signals(model, level, {s}, n, np.random.default_rng(seed))
    except SeveralColumns:
        return {}
    out: dict[str, list[ModeNoise]] = {r.name: [] for r in residuals}
    for mode in modes:
        values = {k: float(v) for k, v in mode.items()}
        with np.errstate(all="ignore"):
            r = {key: np.asarray(evaluate(model, list(residuals), {**sig, **inputs}, ts, window=window,
                                          values=values))[:, keep] for key, sig in records.items()}
            spread = {key: np.std(r[key] - r[""], axis=1) for key in r if key}
        for i, res in enumerate(residuals):
            total = float(spread["*"][i])
            if not math.isfinite(total):
                out[res.name].append(ModeNoise(dict(mode), None, {}))
                continue
            parts = {s: float(spread[s][i]) ** 2 for s in noisy if s in spread} or {noisy[0]: total ** 2}
            whole = sum(v for v in parts.values() if math.isfinite(v))
            shares = {s: v / whole for s, v in parts.items() if whole > 0 and math.isfinite(v) and v > 0}
            out[res.name].append(ModeNoise(dict(mode), total, shares))
    return out


def mode_text(mode: Mapping[str, int]) -> str:
    """``p=1 m=0`` (the MD-FSM tables' spelling, :func:`fdi.mode_thresholds.key_text`'s)."""
    return key_text(tuple(mode.items()))


def spreads(model: Model, arrs: Sequence, predicted: Mapping[str, list[ModeNoise]]) -> list[tuple]:
    """Per residual and per unit its modes sum (a residual of mixed units: each apart,
    :func:`fdi.arrs.units_by_mode`), its quietest and noisiest predicted modes where they are
    :data:`SPREAD` times apart or more: (arr, unit, quietest, noisiest)."""
    from .arrs import units_by_mode

    out = []
    for a in arrs:
        rows = [x for x in predicted.get(a.name, ()) if x.std is not None and x.std > 0]
        if len(rows) < 2:
            continue
        units = units_by_mode(model, a, [dict(x.mode) for x in rows]) or {"": [dict(x.mode) for x in rows]}
        for unit, modes in units.items():
            group = [x for x in rows if dict(x.mode) in modes]
            lo, hi = min(group, key=lambda x: x.std), max(group, key=lambda x: x.std)
            if len(group) >= 2 and hi.std >= SPREAD * lo.std:
                out.append((a, unit, lo, hi))
    return out


def noise_notes(model: Model, arrs: Sequence, predicted: Mapping[str, list[ModeNoise]], window: float) -> list[str]:
    """One note per residual whose predicted noise differs by :data:`SPREAD` or more between two
    modes that sum the same unit (a residual of mixed units has its own note,
    :func:`fdi.arrs.mixed_unit_notes`), naming the quietest and noisiest modes and the sensor that
    dominates the noisiest."""
    notes = []
    for a, unit, lo, hi in spreads(model, arrs, predicted):
        ratio = hi.std / lo.std
        top = max(hi.shares, key=hi.shares.get) if hi.shares else None
        cause = f" ({top} {100 * hi.shares[top]:.0f} %)" if top else ""
        u = f" {unit}" if unit else ""
        notes.append(f"{a.name}'s noise predicted from the sensors' declared noise (derivative window "
                     f"{window:.3g} s): {hi.std:.3g}{u} in {mode_text(hi.mode)}{cause}, {lo.std:.3g}{u} in "
                     f"{mode_text(lo.mode)}, {ratio:.0f}x apart: one threshold, set by the noisiest mode, needs "
                     f"a fault {ratio:.0f}x larger in the quietest (bgfdi calibrate gives it thresholds by "
                     f"mode; or look in the noisy mode's form, `bgfdi tables`, for a small parameter dividing "
                     f"a measured difference)")
    return notes


def predicted_for(model: Model, config, arrs: Sequence) -> tuple[float | None, dict[str, list[ModeNoise]]]:
    """The derivative window a diagnosis of data sampled at the file's ``data: sampling_time`` uses
    (``diagnosis.derivative_window``, else the rule's: :func:`fdi.scales.resolve`) and the
    predictions for the AGARRs ``arrs`` there; (None, {}) for a file without a sampling time,
    residuals that integrate states (mixed causality: not evaluated on data), or a measurement the
    prediction cannot simulate (check stands without it)."""
    from .residuals import compile_residuals
    from .scales import resolve
    ts = model.sampling_time
    if not ts or not arrs or any(a.states for a in arrs):
        return None, {}
    window = float(resolve(config, model, ts).derivative_window)
    try:
        return window, predicted_noise(model, compile_residuals(model, list(arrs)), window, ts)
    except Exception:                       # noqa: BLE001 - a prediction beside check's analysis: none, not a failure
        return None, {}


def to_json(predicted: Mapping[str, list[ModeNoise]]) -> dict:
    """The predictions as plain data: by residual, a list of {mode, std, shares}."""
    return {name: [{"mode": dict(x.mode), "std": x.std, "shares": dict(x.shares)} for x in rows]
            for name, rows in predicted.items()}
