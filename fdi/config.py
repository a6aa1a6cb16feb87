"""The monitor's settings, read from a model file's diagnosis sections.

The bond graph (:class:`bondgraph.model.Model`) is physics only. How it is monitored lives here:
the threshold of each residual, the waiting time T_wt, the identification window, the derivative
window, and per fault the search bounds and the failure value a prognosis runs to. The sections::

    thresholds: {ARR1: 0.012, theta2: 0.003}     # by residual name or by the sensor of its AGARR
    diagnosis: {waiting_time: 2.0, samples: 1000, derivative_window: 0.25}
    faults:
      R4_leak: {kind: parametric, parameters: [R4], bounds: [1e5, 1e9], failure: 2e6}

>>> from bondgraph.loader import read_document_text
>>> text = '''
... parameters: {C: {value: 1.0e-3, unit: F}, R: {value: 100.0, unit: Ohm}}
... data: {columns: [t, i_in, v]}
... inputs: {i_in: {unit: A, column: i_in}}
... elements: {src: {type: MSf, input: i_in}, c: {type: C, parameter: C}, r: {type: R, parameter: R}}
... junctions: {j: {type: "0"}}
... sensors: {v: {type: De, junction: j, column: v, unit: V}}
... bonds: {1: [src, j], 2: [j, c], 3: [j, r]}
... faults: {R_up: {kind: parametric, parameters: [R], bounds: [1, 1000], failure: 500}}
... thresholds: {v: 0.01}
... diagnosis: {waiting_time: 1.5}
... '''
>>> model, config = load_text(text, "rl.yaml")
>>> config.thresholds, config.waiting_time, config.bounds("R_up"), config.failure("R_up")
({'ARR1': 0.01}, 1.5, (1.0, 1000.0), 500.0)
>>> config.replace(waiting_time=3.0).waiting_time      # a variant for a notebook, the file untouched
3.0
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace as _replace
from pathlib import Path
from typing import TYPE_CHECKING, Mapping

from bondgraph.model import Model

if TYPE_CHECKING:           # the loader (sympy's parser) is imported where a file is read, not for a compiled model
    from bondgraph.loader import Document

MAX_TIME = 1.0e6             # s: a derivative window or waiting time beyond 11 days is a typing error
EXONERATIONS = ("sensitivity", "structural")   # how a quiet residual exonerates a fault
MAX_SAMPLES = 10_000_000     # samples in an identification window
DEFAULT_SAMPLES = 1000       # the paper's identification window (Section IV)
# The derivative window and the waiting time have no default in seconds: when the file gives none
# (None here), fdi.scales derives them from the data's sampling time and the model's time constants
# once the data are known (fdi.scales.resolve).


@dataclass(frozen=True)
class FaultSettings:
    """How one candidate fault is identified: search ``bounds`` [low, high] (None: the defaults of
    :func:`fdi.objective.fault_space`) and the ``failure`` value its prognosis runs to (None: none)."""
    bounds: tuple[float, float] | None = None
    failure: float | None = None


@dataclass(frozen=True)
class MonitorConfig:
    """The settings of a monitor of one model: thresholds by residual name (ARR1, ARR2, ...), the
    waiting time T_wt (s) after the first detection before isolation decides, the identification
    window in samples, the derivative window (s), and :class:`FaultSettings` by fault name.
    ``waiting_time`` and ``derivative_window`` are None when the file leaves them to the data and
    the model (:func:`fdi.scales.resolve` fills them in: one window, a window of half the fastest
    time constant and at least 9 samples)."""
    thresholds: Mapping[str, float] = field(default_factory=dict)
    waiting_time: float | None = None
    samples: int = DEFAULT_SAMPLES
    derivative_window: float | None = None
    faults: Mapping[str, FaultSettings] = field(default_factory=dict)
    exoneration: str = "sensitivity"        # or "structural": the paper's (every structural 1 exonerates)
    persistence: float | None = None        # threshold-seconds of evidence before a residual is latched
                                            # (fdi.detect); None: one derivative window
    mode_thresholds: Mapping[str, Mapping[tuple, float]] = field(default_factory=dict)
    """Thresholds by mode (:mod:`fdi.mode_thresholds`): by residual name, the threshold in each
    combination of some mode variables, keyed ((mode, 0 or 1), ...), and () for every other
    combination; such a residual is monitored divided by its mode's threshold, against 1 (its
    entry in ``thresholds``)."""

    def __post_init__(self) -> None:
        if self.mode_thresholds:            # a residual divided by its mode's threshold is judged against 1
            object.__setattr__(self, "thresholds", {**self.thresholds, **dict.fromkeys(self.mode_thresholds, 1.0)})

    def bounds(self, fault: str) -> tuple[float, float] | None:
        """The search bounds of ``fault`` given in the file, or None."""
        s = self.faults.get(fault)
        return None if s is None else s.bounds

    def failure(self, fault: str) -> float | None:
        """The failure value of ``fault`` given in the file, or None."""
        s = self.faults.get(fault)
        return None if s is None else s.failure

    def replace(self, **changes) -> "MonitorConfig":
        """A copy with some fields changed (``thresholds`` merged by name into the file's; a residual
        given one threshold there loses its thresholds by mode; a table dropped from
        ``mode_thresholds`` needs its residual's threshold in ``thresholds``, or it would be judged
        undivided against 1)."""
        if "mode_thresholds" in changes:
            dropped = set(self.mode_thresholds) - set(changes["mode_thresholds"]) - set(changes.get("thresholds", ()))
            if dropped:
                raise ValueError(f"give thresholds for {', '.join(sorted(dropped))} with their tables by mode dropped")
        if "thresholds" in changes:
            given = changes["thresholds"]
            changes["thresholds"] = {**self.thresholds, **given}
            if "mode_thresholds" not in changes:
                changes["mode_thresholds"] = {k: v for k, v in self.mode_thresholds.items() if k not in given}
        return _replace(self, **changes)


def read_config(doc: Document, model: Model) -> MonitorConfig:
    """The monitor settings of a read model file; a ModelError (file, key, line) on a bad value."""
    diag = doc.spec(doc.data.get("diagnosis") or {}, ("diagnosis",),
                    {"waiting_time", "samples", "derivative_window", "exoneration", "persistence"})
    exoneration = diag.get("exoneration", "sensitivity")
    if exoneration not in EXONERATIONS:
        raise doc.error(("diagnosis", "exoneration"), f"exoneration must be {' or '.join(EXONERATIONS)}, not "
                                                      f"{exoneration!r} (docs/diagnosis.md)")
    window = waiting = None                 # not given: from the data and the model (fdi.scales)
    if diag.get("derivative_window") is not None:
        window = doc.number(diag["derivative_window"], ("diagnosis", "derivative_window"),
                            "derivative_window (a time in s)", above=0, maximum=MAX_TIME)
    if diag.get("waiting_time") is not None:
        waiting = doc.number(diag["waiting_time"], ("diagnosis", "waiting_time"), "waiting_time (a time in s)",
                             minimum=0, maximum=MAX_TIME)
    persistence = None
    if diag.get("persistence") is not None:
        persistence = doc.number(diag["persistence"], ("diagnosis", "persistence"),
                                 "persistence (threshold-seconds: a residual's time above its threshold, "
                                 "weighted by |r|/threshold, before it is confirmed; 0 = the first crossing)", minimum=0, maximum=MAX_TIME)
    samples = int(doc.number(diag.get("samples", DEFAULT_SAMPLES), ("diagnosis", "samples"), "samples",
                             integer=True, minimum=2, maximum=MAX_SAMPLES))
    thresholds, by_mode = _thresholds(doc, model)
    return MonitorConfig(thresholds=thresholds, waiting_time=waiting, samples=samples,
                         derivative_window=window, faults=_fault_settings(doc, model), exoneration=str(exoneration),
                         persistence=persistence, mode_thresholds=by_mode)


def _thresholds(doc: Document, model: Model) -> tuple[dict[str, float], dict[str, dict[tuple, float]]]:
    """Thresholds by residual name (ARR1, ARR2, ...: which residuals exist is decided by the
    residual selection, and checked when the diagnosis starts) or by the sensor of an AGARR; a
    residual's may be a mapping by mode (``{p=1 m=0: 0.9, other: 550}``: :mod:`fdi.mode_thresholds`),
    which sets its entry to 1 (it is monitored divided by its mode's threshold)."""
    from .mode_thresholds import parse_table
    by_sensor = {s: f"ARR{i + 1}" for i, s in enumerate(model.sensors)}
    out: dict[str, float] = {}
    by_mode: dict[str, dict[tuple, float]] = {}
    for key, value in doc.mapping(doc.data.get("thresholds"), ("thresholds",)).items():
        arr = by_sensor.get(key, key)
        if not (isinstance(arr, str) and re.fullmatch(r"ARR[1-9][0-9]*", arr)):
            raise doc.error(("thresholds", key), f"'{key}' is no residual (use ARR1, ARR2, ... as `bgfdi tables` "
                                                 f"names them, or a sensor name: {', '.join(model.sensors) or 'none'})")
        if isinstance(value, dict):
            by_mode[arr] = parse_table(doc, model, value, ("thresholds", key))
            out[arr] = 1.0
        else:
            out[arr] = doc.number(value, ("thresholds", key), "threshold", above=0)
    return out, by_mode


def _fault_settings(doc: Document, model: Model) -> dict[str, FaultSettings]:
    out: dict[str, FaultSettings] = {}
    for name, spec in doc.mapping(doc.data.get("faults"), ("faults",)).items():
        where = ("faults", name)
        bounds = spec.get("bounds")
        if bounds is not None:
            if not isinstance(bounds, list) or len(bounds) != 2:
                raise doc.error(where + ("bounds",), "bounds must be [low, high]")
            if model.faults[name].kind == "mode":
                raise doc.error(where + ("bounds",), "a mode fault has no magnitude to search: remove its bounds")
            # finite: the search draws values between the bounds (a leakage resistance's healthy .inf
            # is its nominal value, not a bound; [0.01, .inf] crashed the diagnosis at the first fault)
            bounds = tuple(doc.number(b, where + ("bounds",), "bound") for b in bounds)
            if not bounds[0] < bounds[1]:
                raise doc.error(where + ("bounds",), "bounds must be [low, high] with low < high")
            _same_sign(doc, model, name, bounds, where + ("bounds",))
        failure = spec.get("failure")
        if failure is not None and model.faults[name].kind == "mode":
            raise doc.error(where + ("failure",), "a mode fault has no degradation to prognose: remove its failure value")
        if failure is not None:
            failure = doc.number(failure, where + ("failure",), "failure")
            _reachable(doc, model, name, failure, where + ("failure",))
        if bounds is not None or failure is not None:
            out[str(name)] = FaultSettings(bounds, failure)
    return out


def _same_sign(doc: Document, model: Model, name: str, bounds: tuple[float, float], where: tuple) -> None:
    """A parametric fault's bounds keep its parameters' sign (0 allowed: a friction or a heater's
    power that vanishes): a resistance searched through 0 to negative values is a passive element
    turned active, no fault of it (a trial's [-1e14, 1e14] on a valve's resistance was taken
    without a word, and half the search spent there)."""
    fault = model.faults[name]
    if fault.kind != "parametric":
        return
    for p in fault.targets:
        value = getattr(model.parameters.get(p), "value", None)
        if not isinstance(value, (int, float)) or value == 0 or not math.isfinite(value):
            continue
        if (value > 0 and bounds[0] < 0) or (value < 0 and bounds[1] > 0):
            side = "a lower bound of 0 or more" if value > 0 else "an upper bound of 0 or less"
            # bounds wholly of the other sign: the value's sign is as likely the slip (a trial's orifice
            # coefficient written -4e-6 with bounds [1e-7, 1e-5] was told to make its bounds negative)
            other = (f"; or, if {p} is {'negative' if value > 0 else 'positive'} as the bounds say, fix the sign of "
                     f"its value under parameters" if (bounds[1] <= 0 if value > 0 else bounds[0] >= 0) else "")
            raise doc.error(where, f"bounds [{bounds[0]:g}, {bounds[1]:g}] cross 0 from {p} = {value:g}: the search "
                                   f"would change the parameter's sign (a passive element turned active); give {side}"
                                   f"{other}")


def _reachable(doc: Document, model: Model, name: str, failure: float, where: tuple) -> None:
    """A failure value on the other side of 0 from its parameter (or from an efficiency factor's 1)
    is one the degradation never reaches without the element turning active (a trial's conductance
    of 500 W/K given failure: -250 was accepted, and its prognosis said EOL = inf without a word)."""
    fault = model.faults[name]
    if fault.kind == "parametric" and len(fault.targets) == 1:
        value, what = getattr(model.parameters.get(fault.targets[0]), "value", None), fault.targets[0]
    elif fault.kind in ("sensor", "source") and fault.effect == "gain":
        value, what = 1.0, f"beta_{fault.targets[0]}"
    else:
        return
    if isinstance(value, (int, float)) and math.isfinite(value) and value * failure < 0:
        kind = "parameter" if fault.kind == "parametric" else "factor"
        raise doc.error(where, f"failure {failure:g} is on the other side of 0 from {what} = {value:g}: the "
                               f"degradation never reaches it without changing the {kind}'s sign; give the value "
                               f"at which the component has failed, of {what}'s sign")


def load(path: str | Path) -> tuple[Model, MonitorConfig]:
    """The bond graph and the monitor settings of a model file, read once."""
    from bondgraph.loader import model_from_document, read_document
    doc = read_document(path)
    model = model_from_document(doc)
    return model, read_config(doc, model)


def load_text(text: str, path: str = "<model>") -> tuple[Model, MonitorConfig]:
    """As :func:`load`, from YAML text (``path`` names it in messages)."""
    from bondgraph.loader import model_from_document, read_document_text
    doc = read_document_text(text, path)
    model = model_from_document(doc)
    return model, read_config(doc, model)
