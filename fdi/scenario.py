"""Scenario files and simulated measurements: faults injected, sensors sampled (``bgfdi simulate``).

A scenario (JSON or YAML) has the shape of the CyCab reference scenarios::

    {"seed": 0, "T": 60, "fs": 100, "theta2_0": -0.15,
     "faults": [{"target": "R4", "type": "abrupt", "t0": 32, "value": 2.5221e7},
                {"target": "beta_theta1", "type": "intermittent", "t0": 32, "value": 0.62, "period": 5.3},
                {"target": "beta_theta2", "type": "incipient", "t0": 32, "model": 2, "b": [-0.03]},
                {"target": "a1", "type": "mode", "t0": 32}]}

``<name>_0`` sets an initial value by state or signal name; optional ``noise`` and ``resolution``
mappings (by data column) override the model's measurement model. A target is a fault of the
model: a parametric fault on one parameter takes ``value`` as the parameter's faulty value; on a
group (R5 = kf5, Fu5) ``value`` multiplies every parameter of the group (incipient profiles then
start from 1). A sensor fault multiplies the measurement by beta(t); a source fault multiplies the
source; a mode fault sets the mode variable to the fault's value (default 0) from t0.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import sympy as sp
import yaml

from bondgraph.model import Model
from bondgraph.simulation import SimulationError, simulate

from . import profiles

TYPES = ("abrupt", "intermittent", "incipient", "mode")


class ScenarioError(ValueError):
    """A scenario file that cannot be run (one line: file, fault, what to change)."""


@dataclass(frozen=True)
class FaultEvent:
    target: str
    type: str
    t0: float
    value: float | None = None
    period: float | None = None
    model: int | None = None
    b: tuple[float, ...] = ()


@dataclass(frozen=True)
class Scenario:
    path: str
    seed: int
    T: float
    fs: float
    initial: dict
    faults: tuple[FaultEvent, ...]
    noise: dict
    resolution: dict


def load_scenario(path: str | Path, model: Model) -> Scenario:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        data = json.loads(text) if p.suffix.lower() == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise ScenarioError(f"{path}: not valid {'JSON' if p.suffix.lower() == '.json' else 'YAML'}: "
                            f"{str(exc).splitlines()[0]}") from None
    return parse_scenario(data, model, str(path))


def _num(path: str, where: str, value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{path}: {where}: {what} must be a number, got {value!r}")
    return float(value)


def parse_scenario(data, model: Model, path: str = "<scenario>") -> Scenario:
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: the scenario must be a mapping with T, fs and faults")
    known = {"seed", "T", "fs", "faults", "noise", "resolution"}
    initial = {}
    for key, value in data.items():
        if key.endswith("_0") and key not in known:
            name = key[:-2]
            if name not in model.sensors and name not in model.elements:
                raise ScenarioError(f"{path}: {key}: '{name}' is no state or signal of {model.name} "
                                    f"(sensors: {', '.join(model.sensors)})")
            initial[name] = _num(path, key, value, "an initial value")
        elif key not in known:
            raise ScenarioError(f"{path}: unknown key '{key}' (use seed, T, fs, faults, noise, resolution, <name>_0)")
    T = _num(path, "T", data.get("T", 60), "T")
    fs = _num(path, "fs", data.get("fs", 100), "fs")
    if T <= 0 or fs <= 0:
        raise ScenarioError(f"{path}: T and fs must be positive")
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ScenarioError(f"{path}: seed must be an integer")
    faults = []
    raw = data.get("faults") or []
    if not isinstance(raw, list):
        raise ScenarioError(f"{path}: faults must be a list")
    for i, f in enumerate(raw):
        faults.append(_event(path, i, f, model, T))
    noise = {str(k): _num(path, f"noise.{k}", v, "noise") for k, v in (data.get("noise") or {}).items()}
    resolution = {str(k): _num(path, f"resolution.{k}", v, "resolution") for k, v in (data.get("resolution") or {}).items()}
    for k in list(noise) + list(resolution):
        if model.columns and k not in model.columns:
            raise ScenarioError(f"{path}: noise/resolution: '{k}' is no data column of {model.name}")
    return Scenario(path, seed, T, fs, initial, tuple(faults), noise, resolution)


def _event(path: str, i: int, f, model: Model, T: float) -> FaultEvent:
    where = f"faults[{i}]"
    if not isinstance(f, dict):
        raise ScenarioError(f"{path}: {where}: a fault is a mapping with target, type, t0")
    target = f.get("target")
    if target not in model.faults:
        raise ScenarioError(f"{path}: {where}: unknown target '{target}' (faults of {model.name}: "
                            f"{', '.join(model.faults)})")
    fault = model.faults[target]
    kind = f.get("type")
    if kind not in TYPES:
        raise ScenarioError(f"{path}: {where}: unknown type '{kind}' (use {', '.join(TYPES)})")
    if (kind == "mode") != (fault.kind == "mode"):
        raise ScenarioError(f"{path}: {where}: target '{target}' is a {fault.kind} fault; "
                            + ("use type mode" if fault.kind == "mode" else "type mode is for mode variables"))
    if "t0" not in f:
        raise ScenarioError(f"{path}: {where}: missing t0 (the fault's start time in s)")
    t0 = _num(path, f"{where}.t0", f["t0"], "t0")
    if not 0 <= t0 < T:
        raise ScenarioError(f"{path}: {where}: t0 = {t0:g} s is outside the run (0 to T = {T:g} s)")
    value = period = model_no = None
    b: tuple[float, ...] = ()
    if kind in ("abrupt", "intermittent"):
        if "value" not in f:
            raise ScenarioError(f"{path}: {where}: missing value (the faulty value of {target})")
        value = _num(path, f"{where}.value", f["value"], "value")
    if kind == "intermittent":
        if "period" not in f:
            raise ScenarioError(f"{path}: {where}: missing period (s) of the intermittent fault")
        period = _num(path, f"{where}.period", f["period"], "period")
        if period <= 0:
            raise ScenarioError(f"{path}: {where}: period must be positive")
    if kind == "incipient":
        model_no = f.get("model")
        if model_no not in (1, 2, 3, 4):
            raise ScenarioError(f"{path}: {where}: model must be 1, 2, 3 or 4 (eqs. 16-19)")
        b = tuple(_num(path, f"{where}.b", x, "a coefficient") for x in (f.get("b") or []))
        need = profiles.N_COEFFICIENTS[model_no]
        if len(b) != need:
            raise ScenarioError(f"{path}: {where}: model {model_no} needs b with {need} coefficient(s)")
    if kind == "mode":
        value = fault.value if fault.value is not None else 0.0
    return FaultEvent(target, kind, t0, value, period, model_no, b)


def fault_profile(event: FaultEvent, nominal: float) -> Callable[[np.ndarray], np.ndarray]:
    """P(t) of one injected fault, as a function of a time array."""
    if event.type in ("abrupt", "mode"):
        return lambda t: profiles.abrupt(t, event.t0, nominal, event.value)[0]
    if event.type == "intermittent":
        return lambda t: profiles.intermittent(t, event.t0, nominal, event.value, event.period)[0]
    return lambda t: profiles.incipient(t, event.t0, nominal, event.model, [list(event.b)])[0]


def breakpoints(scenario: Scenario) -> list[float]:
    out = set()
    for e in scenario.faults:
        out.add(e.t0)
        if e.type == "intermittent":
            out.update(e.t0 + k * e.period / 2 for k in range(1, int((scenario.T - e.t0) / (e.period / 2)) + 1))
    return sorted(x for x in out if 0 < x < scenario.T)


def time_functions(model: Model, scenario: Scenario):
    """values(t) for the simulator (vectorised: t may be an array), and each sensor's beta(t) for
    the measurement."""
    nominal = {s.name: v for s, v in model.nominal_values().items()}
    param_fns: dict[str, Callable] = {}
    beta_sensors: dict[str, Callable] = {}
    for e in scenario.faults:
        fault = model.faults[e.target]
        if fault.kind == "parametric" and len(fault.targets) == 1:
            param_fns[fault.targets[0]] = fault_profile(e, nominal[fault.targets[0]])
        elif fault.kind == "parametric":
            mult = fault_profile(e, 1.0)
            for p in fault.targets:
                param_fns[p] = (lambda m, base: (lambda t: base * m(t)))(mult, nominal[p])
        elif fault.kind == "sensor":
            beta_sensors[fault.targets[0]] = fault_profile(e, 1.0)
        elif fault.kind == "source":
            param_fns[f"beta_{fault.targets[0]}"] = fault_profile(e, 1.0)
        else:
            param_fns[fault.targets[0]] = fault_profile(e, float(model.modes[fault.targets[0]].nominal))

    def values(t: float | np.ndarray) -> dict[str, float | np.ndarray]:
        """Every parameter at time t (a float), or at every time of an array (arrays for faulted ones)."""
        v = dict(nominal)
        if param_fns:
            arr = np.atleast_1d(np.asarray(t, dtype=float))
            for k, fn in param_fns.items():
                v[k] = np.asarray(fn(arr), dtype=float) if np.ndim(t) else float(fn(arr)[0])
        return v
    return values, beta_sensors


def run(model: Model, scenario: Scenario, *, progress=None, method: str = "auto",
        stages: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """Simulate a scenario and return the data columns (t, inputs, measured columns), SI units.
    ``stages``: CPU seconds per stage of the simulation are added to it (see ``simulate``)."""
    n = int(round(scenario.T * scenario.fs))
    t = np.arange(n + 1) / scenario.fs
    values, beta_sensors = time_functions(model, scenario)
    initial = dict(model.initial)
    initial.update(scenario.initial)
    try:
        traj = simulate(model, t, values=values, breakpoints=breakpoints(scenario), initial=initial,
                        progress=progress, method=method, vectorised=True, stages=stages)
    except SimulationError as exc:
        raise ScenarioError(f"{scenario.path}: {exc}") from None
    rng = np.random.default_rng(scenario.seed)
    cols: dict[str, np.ndarray] = {"t": traj.t}
    nominal = {s: v for s, v in model.nominal_values().items()}
    for name, inp in model.inputs.items():
        fn = sp.lambdify([sp.Symbol("t", real=True)], inp.expr.xreplace(nominal), modules="numpy")
        cols[inp.column or name] = np.asarray(fn(traj.t), dtype=float) * np.ones_like(traj.t)
    for s in model.sensors.values():
        measured = traj.signals[s.name] * (beta_sensors[s.name](traj.t) if s.name in beta_sensors else 1.0)
        mapping = s.column_values(None)
        if mapping is None:
            raise ScenarioError(f"{model.path}: sensors.{s.name}: it reads several columns; add columns: "
                                "{<column>: <expression of " + s.name + ">} to say how simulation makes them")
        for col, expr in mapping.items():
            fn = sp.lambdify([sp.Symbol(s.name, real=True)], expr.xreplace(nominal), modules="numpy")
            x = np.asarray(fn(measured), dtype=float) * np.ones_like(traj.t)
            sigma = scenario.noise.get(col, s.noise.get(col, 0.0))
            if sigma:
                x = x + sigma * rng.standard_normal(x.shape)
            res = scenario.resolution.get(col, s.resolution.get(col, 0.0))
            if res:
                x = np.round(x / res) * res
            cols[col] = x
    order = [c for c in model.columns if c in cols] or list(cols)
    return {c: cols[c] for c in order + [c for c in cols if c not in order]}


def to_csv(columns: dict[str, np.ndarray]) -> str:
    names = list(columns)
    rows = np.column_stack([columns[n] for n in names])
    lines = [",".join(names)] + [",".join(f"{v:.10g}" for v in row) for row in rows]
    return "\n".join(lines) + "\n"
