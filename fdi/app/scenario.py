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
start from 1). A sensor fault multiplies the measurement by beta(t) (an offset fault, ``effect:
bias``, adds b(t) to it; a stuck one, type abrupt, holds the reading it had at t0); a source fault
multiplies the source (or adds b(t) to its command); a mode fault sets the mode variable to the
fault's value (default 0) from t0.

``"plant": "cycab"`` names a reference plant written apart from bgfdi (fdi/app/plant_cycab.py):
``simulate_scenario`` (used by ``bgfdi evaluate``) runs the scenario on it instead of bgfdi's
simulator; ``run`` (``bgfdi simulate``) is always bgfdi's simulator. ``"expect": "nothing"`` says
that the design's faults are too small to be seen: a correct diagnosis reports nothing.

Every key and number is checked where it enters, and the run's size is bounded (MAX_BYTES,
MAX_SAMPLES, MAX_STEPS, MAX_SWITCHES; docs/simulation.md) so that no file can hang the simulator
or exhaust memory. Problems are :class:`ScenarioError`, a UsageError: one line, exit code 2.
"""
from __future__ import annotations

import json
import math
import reprlib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import sympy as sp
import yaml

from bondgraph.errors import ModelError
from bondgraph.model import Model
from bondgraph.simulation import SimulationError, simulate
from bondgraph.timescales import model_integration_step

from .. import profiles
from ..data import input_values
from ..errors import UsageError
from ..inputs import NoWriter, open_binary
from ..measure import SeveralColumns, sensor_columns

TYPES = ("abrupt", "intermittent", "incipient", "mode")
FAULT_KEYS = {"target", "type", "t0", "failure"}          # what every fault of a scenario may give
KEYS_OF = {"abrupt": {"value"}, "intermittent": {"value", "period"}, "incipient": {"model", "b"}, "mode": set()}
METHODS = ("auto", "ros2", "LSODA", "Radau", "BDF", "RK45")
MAX_BYTES = 1 << 20           # a scenario file is a few lines; more is a mistake (or an attack)
MAX_SAMPLES = 10_000_000      # T * fs: 10 million samples, about 0.5 GB of columns
MAX_STEPS = 10_000_000        # T / step of ROS2 for ros2 and auto: about 3 min of integration at the CyCab's speed
MAX_SWITCHES = 10_000         # switching instants of intermittent faults (each starts a new piece)
PLANTS = ("cycab",)           # reference plants written apart from bgfdi (fdi/app/plant_<name>.py)
EXPECTS = ("nothing",)        # what a design may expect besides its faults


class ScenarioError(UsageError, ValueError):
    """A scenario file that cannot be run (one line: file, key, what to change). A UsageError, so
    the CLI prints it as one line with exit code 2."""


@dataclass(frozen=True)
class FaultEvent:
    target: str
    type: str
    t0: float
    value: float | None = None
    period: float | None = None
    model: int | None = None
    b: tuple[float, ...] = ()
    failure: float | None = None       # the value at which the part has failed (the truth of a RUL)


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
    step: float | None = None          # s, ROS2's step for this model and fs (None: the sampling time)
    plant: str | None = None           # a reference plant that simulates the run instead (PLANTS), None: bgfdi's simulator
    expect: str | None = None          # "nothing": the faults are too small to be seen; a report of any fault is wrong


def _short_repr() -> reprlib.Repr:
    r = reprlib.Repr()                       # keyword arguments only from Python 3.12
    r.maxlevel, r.maxlist, r.maxdict, r.maxstring, r.maxother = 1, 4, 4, 40, 40
    return r


_REPR = _short_repr()


def _show(value) -> str:
    """A short, bounded rendering of a bad value for a message (an alias bomb stays short)."""
    return _REPR.repr(value)


def _read_text(p: Path, path: str) -> str:
    """The file's text: at most MAX_BYTES, UTF-8 (a byte-order mark is allowed)."""
    try:
        with open_binary(p) as fh:                # a FIFO with no writer: refused, not waited on
            raw = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except NoWriter as exc:
        raise ScenarioError(str(exc)) from None
    if len(raw) > MAX_BYTES:
        raise ScenarioError(f"{path}: larger than {MAX_BYTES >> 20} MB; a scenario file is a few lines")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte {exc.start}); save it as UTF-8") from None


class _Duplicate(Exception):
    """A key given twice in one mapping of a scenario file (``line`` and ``first``: YAML only)."""

    def __init__(self, key: str, line: int | None = None, first: int | None = None) -> None:
        super().__init__(key)
        self.key, self.line, self.first = key, line, first


class _UniqueKeyLoader(yaml.SafeLoader):
    """The safe loader, refusing a key given twice in one mapping (plain ``safe_load`` keeps the
    last silently: ``T: 2 ... T: 3`` would run 3 s with nothing said)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):              # the mapping's own keys (a merged << may be overridden)
            seen: dict[tuple, int] = {}
            for key_node, _ in node.value:
                if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                    key = (key_node.tag, key_node.value)
                    line = key_node.start_mark.line + 1
                    if key in seen:
                        raise _Duplicate(key_node.value, line, seen[key])
                    seen[key] = line
        return super().construct_mapping(node, deep)


def _unique_pairs(pairs: list[tuple[str, object]]) -> dict:
    """json.loads' object hook refusing a key given twice in one object (json keeps the last)."""
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise _Duplicate(key)
        out[key] = value
    return out


def load_scenario(path: str | Path, model: Model) -> Scenario:
    """Read and check a scenario file (JSON by its .json suffix, YAML otherwise); a key given
    twice in one mapping is refused."""
    p = Path(path)
    text = _read_text(p, str(path))
    kind = "JSON" if p.suffix.lower() == ".json" else "YAML"
    try:
        data = (json.loads(text, object_pairs_hook=_unique_pairs) if kind == "JSON"
                else yaml.load(text, Loader=_UniqueKeyLoader))  # noqa: S506 - a SafeLoader subclass
    except _Duplicate as exc:
        where = f" at line {exc.line} (first at line {exc.first})" if exc.line else ""
        raise ScenarioError(f"{path}: duplicate key '{str(exc.key)[:40]}'{where}; give each key once") from None
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise ScenarioError(f"{path}: not valid {kind}: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    except ValueError:                              # an integer of more than 4300 digits
        raise ScenarioError(f"{path}: a number has too many digits to read; write it with an exponent (1.0e+7)") from None
    except RecursionError:
        raise ScenarioError(f"{path}: not valid {kind}: nested too deeply") from None
    return parse_scenario(data, model, str(path))


def _num(path: str, where: str, value, what: str, *, low: float | None = None, strict: bool = False) -> float:
    """``value`` as a finite float, at least ``low`` (above it if ``strict``); else one line that
    names the file and key."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            pass
        else:
            raise ScenarioError(f"{path}: {where}: {what} is the text {value!r}; write it as a number "
                                "(YAML reads 1e7 as text: write 1.0e+7)")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{path}: {where}: {what} must be a number, got {_show(value)}")
    try:
        x = float(value)
    except OverflowError:
        x = float("inf")
    if not math.isfinite(x):
        raise ScenarioError(f"{path}: {where}: {what} must be a finite number, got {_show(value)}")
    if low is not None and (x < low or (strict and x == low)):
        raise ScenarioError(f"{path}: {where}: {what} must be {'>' if strict else '>='} {low:g}, got {x:g}")
    return x


def _mapping(path: str, where: str, value) -> dict:
    """A mapping whose keys are all text (YAML also makes numbers, dates and lists keys)."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ScenarioError(f"{path}: {where} must be a mapping of names to values, got {_show(value)}")
    for k in value:
        if not isinstance(k, str):
            raise ScenarioError(f"{path}: {where}: the key {_show(k)} is no name; keys are names (quote them)")
    return value


def _run_length(path: str, data: dict) -> tuple[float, float]:
    """T and fs: finite, positive, at least two and at most MAX_SAMPLES samples."""
    T = _num(path, "T", data.get("T", 60), "the run's length (s)", low=0, strict=True)
    fs = _num(path, "fs", data.get("fs", 100), "the sampling rate (Hz)", low=0, strict=True)
    n = T * fs
    if n < 1:
        raise ScenarioError(f"{path}: T * fs = {n:g}: the run must have at least 2 samples; raise T or fs")
    if n > MAX_SAMPLES:
        raise ScenarioError(f"{path}: T * fs = {n:g} samples, more than the limit of {MAX_SAMPLES:,}; "
                            "lower T or fs")
    return T, fs


def _seed(path: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ScenarioError(f"{path}: seed must be an integer >= 0, got {_show(value)}")
    return value


WHAT = {"noise": "a standard deviation", "resolution": "a quantisation step"}


def _column_values(path: str, key: str, data: dict, model: Model) -> dict[str, float]:
    """``noise`` or ``resolution``: data column -> finite number >= 0."""
    out = {}
    for k, v in _mapping(path, key, data.get(key)).items():
        if model.columns and k not in model.columns:
            raise ScenarioError(f"{path}: {key}: '{k}' is no data column of {model.name} "
                                f"(use {', '.join(c for c in model.columns if c != 't')})")
        out[k] = _num(path, f"{key}.{k}", v, WHAT[key], low=0)
    return out


def parse_scenario(data, model: Model, path: str = "<scenario>") -> Scenario:
    """Check every key and number of a scenario (as read from its file) against ``model``."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: the scenario must be a mapping with T, fs and faults, got {_show(data)}")
    _mapping(path, "the scenario", data)
    known = {"seed", "T", "fs", "faults", "noise", "resolution", "plant", "expect"}
    initial = {}
    for key, value in data.items():
        if key.endswith("_0") and key not in known:
            name = key[:-2]
            if name not in model.sensors and name not in model.elements:
                raise ScenarioError(f"{path}: {key}: '{name}' is no state or signal of {model.name} "
                                    f"(sensors: {', '.join(model.sensors)})")
            initial[name] = _num(path, key, value, "an initial value")
        elif key not in known:
            raise ScenarioError(f"{path}: unknown key '{key}' (use seed, T, fs, faults, noise, resolution, plant, expect, "
                                "<name>_0)")
    T, fs = _run_length(path, data)
    seed = _seed(path, data.get("seed", 0))
    raw = data.get("faults") or []
    if not isinstance(raw, list):
        raise ScenarioError(f"{path}: faults must be a list of mappings, got {_show(raw)}")
    faults = [_event(path, i, f, model, T, fs) for i, f in enumerate(raw)]
    switches = sum(2 * (T - e.t0) / e.period for e in faults if e.type == "intermittent")
    if switches > MAX_SWITCHES:
        raise ScenarioError(f"{path}: the intermittent faults switch {switches:.0f} times, more than the limit "
                            f"of {MAX_SWITCHES:,}; lengthen their period")
    noise = _column_values(path, "noise", data, model)
    resolution = _column_values(path, "resolution", data, model)
    plant, expect = data.get("plant"), data.get("expect")
    if plant is not None and plant not in PLANTS:
        raise ScenarioError(f"{path}: plant: unknown plant {_show(plant)} (use {', '.join(PLANTS)}, or leave it out for bgfdi's simulator)")
    if expect is not None and expect not in EXPECTS:
        raise ScenarioError(f"{path}: expect: {_show(expect)} is not understood (use {', '.join(EXPECTS)}, or leave it out)")
    return Scenario(path, seed, T, fs, initial, tuple(faults), noise, resolution, model_integration_step(model, 1.0 / fs),
                    plant, expect)


def _target(path: str, where: str, f: dict, model: Model) -> str:
    target = f.get("target")
    if not isinstance(target, str) or target not in model.faults:
        shown = f"'{target}'" if isinstance(target, str) else _show(target)
        raise ScenarioError(f"{path}: {where}.target: unknown target {shown}; name one fault of {model.name} "
                            f"({', '.join(model.faults)})")
    return target


def _event(path: str, i: int, f, model: Model, T: float, fs: float) -> FaultEvent:
    """One fault of the scenario, every field checked."""
    where = f"faults[{i}]"
    if not isinstance(f, dict):
        raise ScenarioError(f"{path}: {where}: a fault is a mapping with target, type, t0, got {_show(f)}")
    _mapping(path, where, f)
    target = _target(path, where, f, model)
    fault = model.faults[target]
    kind = f.get("type")
    if not isinstance(kind, str) or kind not in TYPES:
        raise ScenarioError(f"{path}: {where}: unknown type {_show(kind)} (use {', '.join(TYPES)})")
    if (kind == "mode") != (fault.kind == "mode"):
        raise ScenarioError(f"{path}: {where}: target '{target}' is a {fault.kind} fault; "
                            + ("use type mode" if fault.kind == "mode" else "type mode is for mode variables"))
    unread = sorted(k for k in set(f) - FAULT_KEYS - KEYS_OF[kind] if f[k] not in (None, []))   # (simulate
    # --json echoes every key, the unused ones null or empty: such a fault reads back as it was written)
    if unread:
        # a trial's valve stuck with "value": 0.5 was simulated stuck at the model's value, without a word
        held = f" (a mode fault holds its variable at the value the model's fault gives: {fault.value:g})" \
            if kind == "mode" and fault.value is not None else ""
        raise ScenarioError(f"{path}: {where}: {', '.join(unread)} not read for a fault of type {kind}{held}; "
                            f"remove {'it' if len(unread) == 1 else 'them'}")
    if "t0" not in f:
        raise ScenarioError(f"{path}: {where}: missing t0 (the fault's start time in s)")
    t0 = _num(path, f"{where}.t0", f["t0"], "the start time (s)")
    if not 0 <= t0 < T:
        raise ScenarioError(f"{path}: {where}: t0 = {t0:g} s is outside the run (0 to T = {T:g} s)")
    value = period = model_no = None
    b: tuple[float, ...] = ()
    if fault.effect == "stuck" and kind != "abrupt":
        raise ScenarioError(f"{path}: {where}: target '{target}' is a stuck sensor: use type abrupt (it freezes "
                            "at t0, holding the reading it had)")
    if kind in ("abrupt", "intermittent") and not (fault.effect == "stuck" and "value" not in f):
        if "value" not in f:
            raise ScenarioError(f"{path}: {where}: missing value (the faulty value of {target})")
        value = _num(path, f"{where}.value", f["value"], "the faulty value")
        if fault.kind == "parametric" and len(fault.targets) == 1 and not value > 0 and \
                model.parameters[fault.targets[0]].value > 0:
            # a parameter with a positive nominal value is a positive symbol in the derivation (its signs
            # simplified on that): a value through zero is no physics the equations hold for
            raise ScenarioError(f"{path}: {where}.value: {value:g} for {target}, whose parameter "
                                f"{fault.targets[0]} is positive ({model.parameters[fault.targets[0]].value:g}); "
                                "give a positive faulty value")
    if kind == "intermittent":
        period = _period(path, where, f, fs)
    if kind == "incipient":
        model_no, b = _incipient(path, where, f)
    if kind == "mode":
        value = fault.value if fault.value is not None else 0.0
    failure = None if f.get("failure") is None else _num(path, f"{where}.failure", f["failure"], "the failure value")
    event = FaultEvent(target, kind, t0, value, period, model_no, b, failure)
    if kind == "incipient" and math.isfinite(base := nominal_of(model, fault)):   # (R4 = inf drifts from inf)
        # a trial's friction drift at b = 1e5 /s reached inf within the run, and the run went on frozen
        grid = np.linspace(t0, T, 1001)
        with np.errstate(all="ignore"):
            bad = ~np.isfinite(np.asarray(fault_profile(event, base, T)(grid), dtype=float))
        if bad.any():
            raise ScenarioError(f"{path}: {where}.b: {target}'s drift leaves the floats by t = {grid[bad][0]:.4g} s "
                                f"(the run ends at {T:g} s); give a smaller rate")
    return event


def _period(path: str, where: str, f: dict, fs: float) -> float:
    """The period of an intermittent fault: at least two samples, so that both halves are seen."""
    if "period" not in f:
        raise ScenarioError(f"{path}: {where}: missing period (s) of the intermittent fault")
    period = _num(path, f"{where}.period", f["period"], "the period (s)", low=0, strict=True)
    if period < 2 / fs:
        raise ScenarioError(f"{path}: {where}.period: {period:g} s is shorter than two samples (2/fs = {2 / fs:g} s); "
                            "lengthen it")
    return period


def _incipient(path: str, where: str, f: dict) -> tuple[int, tuple[float, ...]]:
    """Degradation model 1-4 (eqs. 16-19) and its coefficients b."""
    model_no = f.get("model")
    if isinstance(model_no, bool) or model_no not in (1, 2, 3, 4) or not isinstance(model_no, int):
        raise ScenarioError(f"{path}: {where}.model: must be 1, 2, 3 or 4 (eqs. 16-19), got {_show(model_no)}")
    raw = f.get("b") or []
    if not isinstance(raw, list):
        raise ScenarioError(f"{path}: {where}.b: must be a list of numbers, got {_show(raw)}")
    b = tuple(_num(path, f"{where}.b[{k}]", x, "a coefficient") for k, x in enumerate(raw))
    need = profiles.N_COEFFICIENTS[model_no]
    if len(b) != need:
        raise ScenarioError(f"{path}: {where}: model {model_no} needs b with {need} coefficient(s)")
    return model_no, b


def fault_profile(event: FaultEvent, nominal: float, t_end: float | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """P(t) of one injected fault, as a function of a time array; its ``at`` attribute gives it at
    one instant (:func:`fdi.profiles.at`, the same numbers; the array function where that has none).
    ``t_end``, the run's end: eq. (19) read at one instant from one integration to it."""
    if event.type in ("abrupt", "mode"):
        kind, kw = "abrupt", {"value": event.value}
        fn = lambda t: profiles.abrupt(t, event.t0, nominal, event.value)[0]        # noqa: E731
    elif event.type == "intermittent":
        kind, kw = "intermittent", {"value": event.value}
        fn = lambda t: profiles.intermittent(t, event.t0, nominal, event.value, event.period)[0]   # noqa: E731
    else:
        kind, kw = "incipient", {"model": event.model, "b": list(event.b),
                                 "span": None if t_end is None else t_end - event.t0}
        fn = lambda t: profiles.incipient(t, event.t0, nominal, event.model, [list(event.b)])[0]   # noqa: E731

    def at(t: float) -> float:
        v = profiles.at(kind, t, event.t0, nominal, **kw)
        return float(fn(np.array([t]))[0]) if v is None else v
    fn.at = at
    return fn


def breakpoints(scenario: Scenario) -> list[float]:
    out = set()
    for e in scenario.faults:
        out.add(e.t0)
        if e.type == "intermittent":
            out.update(e.t0 + k * e.period / 2 for k in range(1, int((scenario.T - e.t0) / (e.period / 2)) + 1))
    return sorted(x for x in out if 0 < x < scenario.T)


def nominal_of(model: Model, fault) -> float:
    """What a fault's profile P(t) starts from: an offset's 0, a parameter's nominal value, a mode's
    nominal value, else 1 (an efficiency factor, or the multiplier of a group of parameters)."""
    if fault.effect == "bias":
        return 0.0
    if fault.kind == "parametric" and len(fault.targets) == 1:
        return float(dict(model.nominal_by_name())[fault.targets[0]])
    if fault.kind == "mode":
        return float(model.modes[fault.targets[0]].nominal)
    return 1.0


def time_functions(model: Model, scenario: Scenario):
    """values(t) for the simulator (vectorised: t may be an array), each sensor's beta(t) for the
    measurement (its offset b(t) under ``~bias_<sensor>``), and the onset of each stuck sensor."""
    nominal = dict(model.nominal_by_name())
    param_fns: dict[str, Callable] = {}
    beta_sensors: dict[str, Callable] = {}
    stuck: dict[str, float] = {}
    for e in scenario.faults:
        fault = model.faults[e.target]
        if fault.effect == "stuck":              # the reading frozen from t0 (applied to the measurement)
            stuck[fault.targets[0]] = e.t0
            continue
        profile = fault_profile(e, nominal_of(model, fault), scenario.T)
        if fault.effect == "bias":               # an offset added to the measurement, or to the command
            name = f"bias_{fault.targets[0]}" if fault.kind == "source" else f"~bias_{fault.targets[0]}"
            (param_fns if fault.kind == "source" else beta_sensors)[name] = profile
            continue
        if fault.kind == "parametric" and len(fault.targets) == 1:
            param_fns[fault.targets[0]] = profile
        elif fault.kind == "parametric":
            for p in fault.targets:
                param_fns[p] = (lambda m, base: (lambda t: base * m(t)))(profile, nominal[p])
        elif fault.kind == "sensor":
            beta_sensors[fault.targets[0]] = profile
        elif fault.kind == "source":
            param_fns[f"beta_{fault.targets[0]}"] = profile
        else:
            param_fns[fault.targets[0]] = profile
    for m in model.modes.values():                 # a commanded mode follows its command, unless stuck
        if m.column and m.expr is not None:
            command = command_function(model, m.name)
            stuck = [e for e in scenario.faults if model.faults[e.target].kind == "mode"
                     and model.faults[e.target].targets[0] == m.name]
            if stuck:
                e = stuck[0]
                param_fns[m.name] = (lambda cmd, t0, v: (lambda t: np.where(np.asarray(t) >= t0, v, cmd(t))))(
                    command, e.t0, float(e.value))
            else:
                param_fns[m.name] = command

    def values(t: float | np.ndarray) -> dict[str, float | np.ndarray]:
        """Every parameter at time t (a float), or at every time of an array (arrays for faulted ones)."""
        v = dict(nominal)
        if param_fns:
            arr = np.atleast_1d(np.asarray(t, dtype=float))
            for k, fn in param_fns.items():
                v[k] = (np.asarray(fn(arr), dtype=float) if np.ndim(t) else
                        float(fn.at(float(t))) if hasattr(fn, "at") else float(fn(arr)[0]))
        return v
    return values, beta_sensors, stuck


def command_function(model: Model, mode: str) -> Callable[[np.ndarray], np.ndarray]:
    """A commanded mode's command as 0/1 at times t (its expression read as 1 from 0.5 up)."""
    nominal = {s: v for s, v in model.nominal_values().items()}
    fn = sp.lambdify([sp.Symbol("t", real=True)], model.modes[mode].expr.xreplace(nominal), modules="numpy")
    return lambda t: (np.asarray(fn(np.asarray(t, dtype=float)), dtype=float) * np.ones_like(t, dtype=float)
                      >= 0.5).astype(float)


def check_method(method: str) -> str:
    """The integrator's canonical name (any case: ``lsoda`` is LSODA), or one line naming the choices."""
    for m in METHODS:
        if str(method).lower() == m.lower():
            return m
    raise ScenarioError(f"--method: unknown integrator '{method}' (use {', '.join(METHODS)})")


def check_steps(scenario: Scenario, method: str) -> None:
    """Refuse a run the fixed-step integrator would take hours over: ROS2 (chosen by ``auto`` for
    discontinuous models) steps once a sample or 20 times per fastest time constant of the model,
    whichever is shorter (``scenario.step``, :func:`bondgraph.timescales.integration_step`), so it
    takes T / step steps."""
    if method not in ("auto", "ros2"):
        return
    step = scenario.step or 1.0 / scenario.fs
    steps = scenario.T / step
    if steps > MAX_STEPS:
        raise ScenarioError(f"{scenario.path}: T = {scenario.T:g} s takes {steps:.3g} steps of ROS2 ({step:.3g} s "
                            f"each: the sampling time or a twentieth of the model's fastest time constant), more "
                            f"than the limit of {MAX_STEPS:,}; shorten T (at most {MAX_STEPS * step:.3g} s), or "
                            "for a smooth model choose --method LSODA")


def run(model: Model, scenario: Scenario, *, progress=None, method: str = "auto",
        stages: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """Simulate a scenario and return the data columns (t, inputs, measured columns), SI units.
    ``stages``: CPU seconds per stage of the simulation are added to it (see ``simulate``).
    A run whose numbers leave the floats (a fault value that divides by zero) is a ScenarioError
    naming the first column and time, never a CSV of NaN."""
    method = check_method(method)
    check_steps(scenario, method)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")           # numpy's overflow, scipy's LSODA: reported once, below
        try:
            cols = _run(model, scenario, progress, method, stages)
        except SimulationError as exc:
            if exc.where is not None:            # the model, not the run: name its file and key
                raise ModelError(str(exc), file=model.path, where=exc.where) from None
            hint = " (try --method ros2: a fixed step)" if exc.stalled and method != "ros2" else ""
            raise ScenarioError(f"{scenario.path}: {exc}{hint}") from None
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
            if isinstance(exc, UsageError):
                raise
            raise ScenarioError(f"{scenario.path}: the simulation failed ({type(exc).__name__}: "
                                f"{str(exc).splitlines()[0] if str(exc) else 'no message'}); check the fault values") from None
    _check_finite(scenario, cols)
    return cols


def simulate_scenario(model: Model, scenario: Scenario, **kwargs) -> dict[str, np.ndarray]:
    """The scenario's data from the plant it names (``"plant": "cycab"``: the independent reference
    plant of fdi/app/plant_cycab.py, which reads no model), else from bgfdi's simulator (``run``)."""
    if scenario.plant is None:
        return run(model, scenario, **kwargs)
    from . import plant_cycab
    try:
        cols = plant_cycab.run_scenario(scenario)
    except plant_cycab.PlantError as exc:
        raise ScenarioError(f"{scenario.path}: plant {scenario.plant}: {exc}") from None
    _check_finite(scenario, cols)
    return cols


def _check_finite(scenario: Scenario, cols: dict[str, np.ndarray]) -> None:
    for name, x in cols.items():
        bad = np.flatnonzero(~np.isfinite(x))
        if bad.size:
            raise ScenarioError(f"{scenario.path}: the simulated {name} is not finite from t = "
                                f"{cols['t'][bad[0]]:g} s; check the fault values and initial values")


def _run(model: Model, scenario: Scenario, progress, method: str,
         stages: dict[str, float] | None) -> dict[str, np.ndarray]:
    n = int(round(scenario.T * scenario.fs))
    t = np.arange(n + 1) / scenario.fs
    values, beta_sensors, stuck = time_functions(model, scenario)
    driven = _with_offsets(model, [model.faults[e.target] for e in scenario.faults])   # the simulator's only:
    initial = dict(model.initial)                                                        # the logged command has no offset
    initial.update(scenario.initial)
    switches = [float(t[k + 1]) for m in model.modes.values() if m.column and m.expr is not None
                for k in np.flatnonzero(np.diff(command_function(model, m.name)(t)))]
    traj = simulate(driven, t, values=values, breakpoints=sorted(set(breakpoints(scenario)) | set(switches)), initial=initial,
                    progress=progress, method=method, vectorised=True, stages=stages)
    rng = np.random.default_rng(scenario.seed)
    cols: dict[str, np.ndarray] = {"t": traj.t}
    for name, inp in model.inputs.items():
        cols[inp.column or name] = input_values(model, name, traj.t)
    for m in model.modes.values():                 # the command, as the controller logged it
        if m.column:
            if m.expr is None:
                raise ScenarioError(f"{model.path}: modes.{m.name}: a commanded mode needs expr: <command as a "
                                    "function of t> to be simulated")
            cols[m.column] = command_function(model, m.name)(traj.t)
    for s in model.sensors.values():
        measured = traj.signals[s.name] * (beta_sensors[s.name](traj.t) if s.name in beta_sensors else 1.0)
        if f"~bias_{s.name}" in beta_sensors:
            measured = measured + beta_sensors[f"~bias_{s.name}"](traj.t)
        if s.name in stuck:
            k = min(int(np.searchsorted(traj.t, stuck[s.name])), traj.t.size - 1)
            measured = np.where(traj.t >= stuck[s.name], measured[k], measured)
        try:
            cols.update(sensor_columns(model, s, measured, rng, scenario.noise, scenario.resolution))
        except SeveralColumns as exc:
            raise ScenarioError(str(exc)) from None
    order = [c for c in model.columns if c in cols] or list(cols)
    return {c: cols[c] for c in order + [c for c in cols if c not in order]}


def _with_offsets(model: Model, faults: list) -> Model:
    """The model with an offset symbol ``bias_<source>`` added to each source a bias fault acts on
    (its input's expression, or its value), for the simulator to read from ``values(t)``."""
    from dataclasses import replace as _replace
    sources = {f.targets[0] for f in faults if f.kind == "source" and f.effect == "bias"}
    if not sources:
        return model
    symbols = dict(model.symbols)
    inputs = dict(model.inputs)
    elements = dict(model.elements)
    for name in sources:
        b = sp.Symbol(f"bias_{name}", real=True)
        symbols[b.name] = b
        if name in inputs and inputs[name].expr is not None:
            inputs[name] = _replace(inputs[name], expr=inputs[name].expr + b)
        elif name in elements and elements[name].value is not None:
            elements[name] = _replace(elements[name], value=elements[name].value + b)
    return _replace(model, symbols=symbols, inputs=inputs, elements=elements)


def csv_chunks(columns: dict[str, np.ndarray], rows: int = 10_000) -> Iterator[str]:
    """The CSV text in pieces of ``rows`` lines, so that 10 million samples never make one string
    (nor one table of them: each piece's rows are gathered from the columns as it is written)."""
    names = list(columns)
    yield ",".join(names) + "\n"
    samples = len(columns[names[0]]) if names else 0
    for a in range(0, samples, rows):
        table = np.column_stack([columns[n][a:a + rows] for n in names])
        yield "".join(",".join(f"{v:.10g}" for v in row) + "\n" for row in table)


def to_csv(columns: dict[str, np.ndarray]) -> str:
    """The columns as one CSV text (header, then one line per sample)."""
    return "".join(csv_chunks(columns))
