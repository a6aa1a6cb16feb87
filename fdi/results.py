"""What a diagnosis finds, stage by stage, as small frozen values.

:class:`Detection` (t_D and the coherence vectors), :class:`Isolation` (candidate sets, the sets
too large to identify, the relaxed sets, suspected mode changes), :class:`ModeFault` (the
fault-mode estimator's answer), :class:`Estimate` (one estimator's fit of one candidate set),
:class:`Fault` (one identified fault: type, values, onset, degradation model and its band),
:class:`Prognosis`, :class:`Episode` (a later decision) and :class:`Diagnosis`, which holds them
with the residuals it was decided on. ``Diagnosis.to_dict()`` is the JSON report ``bgfdi
diagnose --json`` prints: every key of :data:`REPORT_KEYS` always present, in that order, null
where the diagnosis did not reach it (docs/report.schema.json).

    >>> f = Fault(name="R4", type="abrupt", value=2.4e9, t0=31.88)
    >>> f.to_dict()
    {'name': 'R4', 'type': 'abrupt', 'value': 2400000000.0, 't0': 31.88}
    >>> Fault.from_dict(f.to_dict()) == f
    True
    >>> f.describe()
    'R4: abrupt, value 2.4e+09, from 31.88 s'
"""
from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from .detect import Detection

# The top-level keys of a report, in the order the JSON gives them (docs/report.schema.json).
REPORT_KEYS = ("detection", "mode", "candidates", "estimators", "diagnosis", "prognosis", "note",
               "weakly_detectable", "pruned", "suspected_mode_changes", "mode_estimate", "mode_costs",
               "mode_fault_cost", "exoneration_relaxed", "alternatives", "winner", "episodes", "window",
               "insignificant")
FAULT_TYPES = ("abrupt", "intermittent", "incipient", "stuck", "mode")
DETERMINED = 6.0     # the least criterion without a final fit minus with it (Kass & Raftery 1995: "strong")


def plain(x: Any) -> Any:
    """JSON-ready: numpy numbers as Python ones, non-finite floats as None, tuples as lists."""
    if isinstance(x, Mapping):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not np.isfinite(x) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def _vec(v) -> str:
    return "[" + " ".join(str(x) for x in v) + "]"


@dataclass(frozen=True)
class Fault:
    """One identified fault. ``type`` abrupt or stuck: ``value``; intermittent: ``value`` and
    ``period`` (s); incipient: degradation ``model`` k (the paper's eq. 15 + k), its ``eta`` bits,
    coefficients ``b`` and their 95 % bands ``b_band`` (the onset's ``t0_band``), and the other
    degradation models the window cannot tell from it (``other_models``: model, b, t0, cost; see
    :func:`fdi.estimators.other_models`), and its plausible fits along the onset (``onset_profile``:
    t0, b, cost; :func:`fdi.estimators.onset_profile`); mode: ``value`` the
    mode the variable is stuck in. ``t0``: the onset (s)."""
    name: str
    type: str
    value: float | None = None
    period: float | None = None
    model: int | None = None
    eta: tuple[int, ...] | None = None
    b: tuple[float, ...] | None = None
    t0: float | None = None
    b_band: tuple[tuple[float, float], ...] | None = None
    t0_band: tuple[float, float] | None = None
    other_models: tuple[Mapping, ...] | None = None    # degradation models the window cannot tell apart
    onset_profile: tuple[Mapping, ...] | None = None   # plausible fits along the onset: t0, b, cost

    @classmethod
    def from_dict(cls, d: Mapping) -> "Fault":
        band = d.get("b_band")
        return cls(str(d["name"]), str(d["type"]), d.get("value"), d.get("period"), d.get("model"),
                   None if d.get("eta") is None else tuple(d["eta"]), None if d.get("b") is None else tuple(d["b"]),
                   d.get("t0"), None if band is None else tuple(tuple(x) for x in band),
                   None if d.get("t0_band") is None else tuple(d["t0_band"]),
                   None if d.get("other_models") is None else tuple(dict(m) for m in d["other_models"]),
                   None if d.get("onset_profile") is None else tuple(dict(m) for m in d["onset_profile"]))

    def to_dict(self) -> dict:
        """The report's entry: name, type, the type's values, t0, then the bands."""
        out: dict = {"name": self.name, "type": self.type}
        for key in ("value", "period", "model", "eta", "b", "t0", "b_band", "t0_band", "other_models", "onset_profile"):
            v = getattr(self, key)
            if v is not None:
                out[key] = ([list(x) for x in v] if key == "b_band"
                            else [dict(m) for m in v] if key in ("other_models", "onset_profile")
                            else list(v) if isinstance(v, tuple) else v)
        return out

    def describe(self, variable: str | None = None, unit: str = "") -> str:
        """The fault in words, as the text report and the notebook table show it (with its onset:
        a trial's user found it only in the JSON); ``variable``: a mode fault's mode variable (the
        fault's name is not: a user read ``out_stuck_closed = 0``); ``unit``: its value's
        (:func:`value_unit`: a trial read an offset of 2950.3 as metres, its column's unit, where
        the sensor's signal is in Pa)."""
        since = f", from {self.t0:.6g} s" if self.t0 is not None else ""
        unit = f" {unit}" if unit else ""
        if self.type == "abrupt":
            if self.t0_band is not None and self.t0 is not None and self.t0_band[0] < self.t0:
                since += f" (or as early as {self.t0_band[0]:.6g} s: the data before it do not tell)"
            return f"{self.name}: abrupt, value {self.value:.5g}{unit}{since}"
        if self.type == "intermittent":
            return f"{self.name}: intermittent, value {self.value:.5g}{unit}, period {self.period:.4g} s{since}"
        if self.type == "incipient":
            b = ", ".join(f"{x:.5g}" for x in self.b)
            return (f"{self.name}: incipient, model {self.model} (eq. {15 + self.model}, eta {_vec(self.eta)}), "
                    f"b = [{b}]{since}")
        if self.type == "stuck":
            return f"{self.name}: stuck at {self.value:.5g}{unit} from {self.t0:.4g} s"
        if self.t0_band is not None and self.t0 is not None and self.t0_band[0] < self.t0:
            since += f" (or as early as {self.t0_band[0]:.6g} s: until then the mode was meant to be at that value, so the data do not tell when it stuck)"
        return f"{self.name}: fault mode ({variable or self.name} = {self.value if self.value is not None else 0}){since}"


NO_UNIT = ("", "-", "1")


def value_unit(model, name: str) -> str:
    """The unit of fault ``name``'s value as the report gives it: a parametric fault of one
    parameter, its parameter's; an offset or a stuck reading of a sensor, its signal's (not its
    columns': a level sensor read in m, its signal a pressure in Pa); of a source, its input's;
    '' for an efficiency factor, a group's common factor, a mode, or a unit the model leaves out."""
    f = getattr(model, "faults", {}).get(name)
    if f is None:
        return ""
    unit = ""
    if f.kind == "parametric" and len(f.targets) == 1:
        unit = model.parameters[f.targets[0]].unit
    elif f.kind == "sensor" and f.effect in ("bias", "stuck"):
        unit = model.sensors[f.targets[0]].unit
    elif f.kind == "source" and f.effect == "bias":
        element = model.elements.get(f.targets[0])
        source = model.inputs.get(element.input) if element is not None and element.input else None
        unit = source.unit if source is not None else ""
    return "" if unit in NO_UNIT else unit


def faults_of(entries) -> tuple[Fault, ...]:
    return tuple(f if isinstance(f, Fault) else Fault.from_dict(f) for f in entries)


@dataclass(frozen=True)
class Isolation:
    """The candidate sets the FSM leaves for the final coherence vector (``relaxed``: found only
    once exoneration was dropped), the sets larger than ``max_set`` that are counted but not
    identified (``pruned``: how many), the faults a quiet residual cannot exonerate (``weak``: fault ->
    residuals) and the mode changes the MCSM suspects."""
    candidates: tuple[tuple[str, ...], ...]
    suspected: tuple[str, ...] = ()
    pruned: int = 0                      # candidate sets of max_set + 1 faults, counted, not identified
    max_set: int = 3
    relaxed: bool = False
    weak: Mapping[str, tuple[str, ...]] | None = None


COMMANDED = "commanded"   # a mode variable commanded to switch that follows its command: the report's value


@dataclass(frozen=True)
class ModeFault:
    """The fault-mode estimator's answer: the estimated ``mode``, its cost, the cost of every
    combination of the suspected variables (``table``), and the mode faults it implies."""
    mode: Mapping[str, int]
    cost: float
    table: tuple[Mapping, ...]
    faults: tuple[Fault, ...]
    following: tuple[str, ...] = ()    # variables commanded to switch estimated to follow their command (``mode``
                                       # holds their command at the window's start; the report says "commanded")
    ties: tuple[Mapping, ...] = ()     # other fault modes within 1 % of its cost (the report's note names them)


@dataclass(frozen=True)
class Estimate:
    """One estimator's answer for one candidate set: its best cost (eq. 24, weighted) and fitness
    1/(cost + eps), the best fitness per generation, the engine's margin, the faults, and its work."""
    candidate: tuple[str, ...]
    cost: float
    fitness: float
    history: tuple[float, ...]
    margin: float | None
    faults: tuple[dict, ...]
    evaluations: int
    wall_s: float
    objective_s: float = 0.0
    resume: object = field(default=None, repr=False, compare=False)
    """The engine's state when it ran without its final check (``optim.ahde.Snapshot``): what a
    second pass continues from. Not reported."""
    raced_out: bool = False
    """Stopped in the race of the candidate sets of its size, two faults or more
    (``fdi.estimators``): after its first or second rung its best fit cost over 6x the best of
    them and its race had stalled; the fit is that race leader's, not settled."""
    outdone_by: tuple[str, ...] = ()
    """Raced out for another reason: its race stalled with its leader no better than this subset of
    it (fitted before it; within ``fdi.estimators.SUBSET_GAIN``), which the criterion prefers."""
    held: tuple[str, ...] = ()
    """At a later decision, the faults of an earlier diagnosis held at their fit (each with its own
    onset) while the rest of the set was searched: the same set may also be fitted afresh, with
    nothing held, and then appears twice (``fdi.episodes.redecide``)."""

    def to_dict(self, history: bool = True) -> dict:
        out: dict = {"candidate": list(self.candidate), "fitness": self.fitness}
        if history:      # (JSON has no infinity: a cost no fit made finite is null)
            out["history"] = [h if math.isfinite(h) else None for h in self.history]
        out.update({"margin": self.margin, "cost": self.cost if math.isfinite(self.cost) else None,
                    "faults": [dict(f) for f in self.faults],
                    "raced_out": self.raced_out, "outdone_by": list(self.outdone_by) or None,
                    "held": list(self.held) or None,
                    "evaluations": self.evaluations, "wall_s": self.wall_s,
                    "objective_s": self.objective_s})
        return out


@dataclass(frozen=True)
class Coincidence:
    """Two faults every residual reads only through one combination (:mod:`fdi.identifiability`): a
    constant fault of one is fitted as well by the other. ``combination`` names it (sympy's text)
    where it is a product of powers or a weighted sum, else it is empty; ``residuals`` read them."""
    faults: tuple[str, str]
    combination: str
    residuals: tuple[str, ...]
    symbols: tuple[str, str] = ()        # the symbol each fault acts through (the combination's names)

    def to_dict(self) -> dict:
        return {"faults": list(self.faults), "combination": self.combination or None,
                "residuals": list(self.residuals), "symbols": list(self.symbols)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Coincidence":
        return cls(tuple(d["faults"]), d.get("combination") or "", tuple(d.get("residuals") or ()),
                   tuple(d.get("symbols") or ()))

    def names(self) -> tuple[str, str]:
        """The two faults, each with its symbol where it is named apart from it (``fV2 (Rv2)``)."""
        a, b = (f if s in ("", f) else f"{f} ({s})" for f, s in zip(self.faults, self.symbols or ("", "")))
        return a, b

    def describe(self) -> str:
        """One line: ``the residuals (ARR1) read Kv and C only through Kv**2/C``; a fault named
        apart from its symbol is given with it (``fV2 (Rv2)``).

        >>> Coincidence(("fV2", "fV3"), "Rv2 + Rv3", ("ARR2",), ("Rv2", "Rv3")).describe()
        'the residuals (ARR2) read fV2 (Rv2) and fV3 (Rv3) only through Rv2 + Rv3'
        """
        a, b = self.names()
        how = f"through {self.combination}" if self.combination else "through one combination"
        return f"the residuals ({', '.join(self.residuals)}) read {a} and {b} only {how}"


def partners(alternatives, name: str, final: set[str], winner) -> list[dict]:
    """The fits the report's ``alternatives`` (dicts) offer of the faults read together with final
    fault ``name`` (their ``coincides``), while the final faults are still the first decision's
    winner's (a later decision's faults were fitted on other data)."""
    if winner is None or final != set(winner):
        return []
    return [g for a in alternatives or () if a.get("coincides") and name in a["coincides"]["faults"]
            for g in a["faults"] if g["name"] in a["coincides"]["faults"] and g["name"] != name]


@dataclass(frozen=True)
class Alternative:
    """An explanation the data hardly separate from the winner (information criterion within 2).
    ``coincides``: where it is the winner with one fault swapped for another that the residuals
    read only through one combination with it, that pair: then no data can separate them."""
    candidate: tuple[str, ...]
    faults: tuple[dict, ...]
    cost: float
    criterion: float
    coincides: Coincidence | None = None

    def to_dict(self) -> dict:
        return {"candidate": list(self.candidate), "faults": [dict(f) for f in self.faults], "cost": self.cost,
                "criterion": self.criterion, "coincides": None if self.coincides is None else self.coincides.to_dict()}


@dataclass(frozen=True)
class Dropped:
    """A fault of the final fit that does not earn its parameters: the criterion's change without it;
    ``unseen``: left out as its own effect on the residuals stays within their noise floor by the
    detector's rule (:func:`fdi.decide.unseen`), whatever the criterion says; ``before``: as it
    fits the fault-free data before the onset better than the model does (a mismatch of the model
    or of the filter that was there before any fault, :func:`fdi.decide.before_onset`)."""
    fault: dict
    criterion_without: float
    unseen: bool = False
    before: bool = False        # left out as it fits the data before the onset too (:func:`fdi.decide.before_onset`)

    def to_dict(self) -> dict:
        return {**self.fault, "criterion_without": self.criterion_without, "unseen": self.unseen,
                "before": self.before}


@dataclass(frozen=True)
class Prognosis:
    """The end of life of an incipient fault (when it reaches ``failure``), its RUL at ``at`` and
    the RUL band from the coefficients' 95 % intervals."""
    name: str
    failure: float
    eol: float
    rul: float
    at: float
    rul_low: float
    rul_high: float

    @classmethod
    def from_dict(cls, d: Mapping) -> "Prognosis":
        return cls(d["name"], d["failure"], d["eol"], d["rul"], d["at"], d["rul_low"], d["rul_high"])

    def to_dict(self) -> dict:
        return {"name": self.name, "failure": self.failure, "eol": self.eol, "rul": self.rul, "at": self.at,
                "rul_low": self.rul_low, "rul_high": self.rul_high}

    @property
    def passed(self) -> bool:
        """The fitted degradation reached its failure value before ``at`` (``eol`` then dates it;
        RUL 0): a failure already past, not one at this very sample (:mod:`fdi.prognose`)."""
        return eol_passed(self.eol, self.at)

    def said(self) -> str:
        """The RUL and its band as the summary says them, a passed end of life dated."""
        when = f" (failure value reached at EOL {self.eol:.4g} s: passed)" if self.passed else ""
        return f"{self.rul:.4g} s at {self.at:.4g} s{when} (band {self.rul_low:.4g} to {self.rul_high:.4g} s)"


def eol_passed(eol, at) -> bool:
    """An end of life before ``at`` (numbers, or None/inf as a report's JSON gives them)."""
    return isinstance(eol, (int, float)) and isinstance(at, (int, float)) and math.isfinite(eol) and eol < at


@dataclass(frozen=True)
class Episode:
    """A later decision: at ``time`` the coherence vector gained a residual (``cause``
    "coherence"), or the residuals with the known fit held left their thresholds ("misfit": the fit
    stopped explaining the data, :func:`fdi.pipeline.misfit_at`); decided at ``decision_time``
    from the diagnosis ``previous``."""
    time: float
    decision_time: float
    coherence: tuple[int, ...]
    previous: tuple[dict, ...]
    estimates: tuple[Estimate, ...]
    winner: tuple[str, ...]
    faults: tuple[dict, ...]
    cause: str = "coherence"

    def to_dict(self) -> dict:
        return {"time": self.time, "decision_time": self.decision_time, "cause": self.cause,
                "coherence": list(self.coherence),
                "previous": [dict(f) for f in self.previous],
                "candidates": [list(e.candidate) for e in self.estimates],
                "estimators": [e.to_dict(history=False) for e in self.estimates],
                "winner": list(self.winner), "faults": [dict(f) for f in self.faults]}


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """A diagnosis: its stages as typed values, and the residuals it was decided on (``t``,
    ``residuals`` (residuals x samples), ``thresholds``, ``names``: for plots). ``to_dict()`` is
    the JSON report (every key of :data:`REPORT_KEYS`, null where absent); ``summary()`` says it
    in a few lines."""
    model: str                                   # the model's name
    mode: Mapping[str, int]
    detection: Detection | None = None
    isolation: Isolation | None = None
    mode_fault: ModeFault | None = None
    estimates: tuple[Estimate, ...] = ()
    faults: tuple[Fault, ...] = ()
    winner: tuple[str, ...] | None = None
    alternatives: tuple[Alternative, ...] | None = None
    episodes: tuple[Episode, ...] | None = None
    window: tuple[float, float] | None = None
    insignificant: tuple[Dropped, ...] | None = None
    criterion_without: float | None = None       # the criterion without the final faults minus with them
    prognosis: tuple[Prognosis, ...] = ()
    note: str | None = None
    t: np.ndarray = field(default=None, repr=False)
    residuals: np.ndarray = field(default=None, repr=False)
    thresholds: np.ndarray = field(default=None, repr=False)
    names: tuple[str, ...] = ()
    units: tuple[str, ...] = ()                  # each residual's unit (fdi.arrs.arr_unit)
    timings: Mapping[str, float] = field(default_factory=dict, repr=False)
    bond_graph: Any = field(default=None, repr=False)     # the Model diagnosed (for plots)

    @property
    def determined(self) -> bool | None:
        """Whether the data since t_D determine the final fit: the fault-free model's Schwarz criterion
        exceeds the fit's strongly, ``DETERMINED`` or more
        (:func:`fdi.decide.significant`); None without a fit."""
        return None if self.criterion_without is None else self.criterion_without >= DETERMINED

    @property
    def candidates(self) -> list[tuple[str, ...]]:
        return [] if self.isolation is None else list(self.isolation.candidates)

    def to_dict(self, timings: bool = False) -> dict:
        """The report (JSON-ready); wall-clock entries only with ``timings``, so that two runs of
        one diagnosis give identical reports."""
        iso, mf = self.isolation, self.mode_fault
        report = {
            "detection": None if self.detection is None else self.detection.to_dict(),
            "mode": dict(self.mode),
            "candidates": [list(c) for c in self.candidates],
            "estimators": [e.to_dict() for e in self.estimates],
            "diagnosis": {"faults": [f.to_dict() for f in self.faults], "criterion_without": self.criterion_without},
            "prognosis": [p.to_dict() for p in self.prognosis],
            "note": self.note,
            "weakly_detectable": None if iso is None or not iso.weak else {k: list(v) for k, v in iso.weak.items()},
            "pruned": None if iso is None or not iso.pruned else {"max_set": iso.max_set, "sets": iso.pruned},
            "suspected_mode_changes": None if iso is None else list(iso.suspected),
            "mode_estimate": None if mf is None else {k: COMMANDED if k in mf.following else v
                                                      for k, v in mf.mode.items()},
            "mode_costs": None if mf is None or not mf.table else [dict(r) for r in mf.table],
            "mode_fault_cost": None if mf is None or not mf.faults else mf.cost,
            "exoneration_relaxed": None if iso is None or not iso.relaxed else True,
            "alternatives": None if self.alternatives is None else [a.to_dict() for a in self.alternatives],
            "winner": None if self.winner is None else list(self.winner),
            "episodes": None if self.episodes is None else [e.to_dict() for e in self.episodes],
            "window": None if self.window is None else list(self.window),
            "insignificant": None if self.insignificant is None else [d.to_dict() for d in self.insignificant],
        }
        out = plain(report)
        if timings:
            out["timings"] = plain(dict(self.timings))
            return out
        return deterministic(out)

    def to_json(self, indent: int | None = 1) -> str:
        """``bgfdi diagnose --json``, character for character."""
        return json.dumps(self.to_dict(), indent=indent, default=float) + "\n"

    def plot(self) -> dict:
        """matplotlib Figures by name: residuals with thresholds, estimator fitness, fault profiles,
        RUL (needs the plot extra)."""
        from .plots import diagnosis_figures
        return diagnosis_figures(self, self.bond_graph)

    def rows(self) -> list[dict]:
        """One row per fault (one row with ``fault`` None when there is none): :func:`fault_rows`."""
        return fault_rows([self])

    def to_frame(self):
        """:meth:`rows` as a pandas DataFrame (the pandas extra)."""
        return to_frame([self])

    def faults_frame(self):
        """One row per fault identified (none: no rows) with its type, values, onset and RUL band:
        :data:`FAULT_COLUMNS` (the pandas extra)."""
        pd = need_pandas("faults_frame")
        rows = [{k: r[k] for k in FAULT_COLUMNS} for r in fault_rows([self]) if r["fault"] is not None]
        return pd.DataFrame(rows, columns=list(FAULT_COLUMNS))

    def residuals_frame(self):
        """One row per sample: ``t`` [s], each residual by name (in its unit, ``attrs["units"]``),
        then ``NAME_threshold`` (the threshold it is compared with) and ``NAME_above`` (True where
        |r| exceeds it; the persistence rule then decides the coherence vector). The pandas extra."""
        pd = need_pandas("residuals_frame")
        if self.t is None or self.residuals is None:
            raise ValueError("this Diagnosis carries no residuals (it was read from a report); diagnose the data")
        r = np.asarray(self.residuals, dtype=float)
        thresholds = np.broadcast_to(np.asarray(self.thresholds, dtype=float).reshape(len(self.names), -1), r.shape)
        columns: dict = {"t": np.asarray(self.t, dtype=float)}
        columns.update({name: r[i] for i, name in enumerate(self.names)})
        columns.update({f"{name}_threshold": thresholds[i] for i, name in enumerate(self.names)})
        with np.errstate(invalid="ignore"):
            columns.update({f"{name}_above": np.abs(r[i]) > thresholds[i] for i, name in enumerate(self.names)})
        frame = pd.DataFrame(columns)
        frame.attrs.update({"model": self.model, "units": {"t": "s", **dict(zip(self.names, self.units))}})
        return frame

    def _variable(self, fault: str) -> str | None:
        """The mode variable of mode fault ``fault`` (None for another fault or without the model)."""
        f = getattr(self.bond_graph, "faults", {}).get(fault)
        return f.targets[0] if f is not None and f.kind == "mode" else None

    def summary(self) -> str:
        """The diagnosis in a few lines: detection, faults, RULs."""
        d = self.detection
        lines = [f"{self.model}: " + ("nothing detected" if d is None else
                                       f"detected at t_D = {d.time:.4g} s, coherence {_vec(d.coherence)}; "
                                       f"at {d.decision_time:.4g} s: {_vec(d.final_coherence)}")]
        offered = [a.to_dict() for a in self.alternatives or ()]
        for f in self.faults:
            lines.append(f"  {f.describe(self._variable(f.name), value_unit(self.bond_graph, f.name))}")  # (its onset in it)
            lines += [f"    or {Fault.from_dict(g).describe(None, value_unit(self.bond_graph, g['name']))} "
                      f"(read together with {f.name}: one fit)"
                      for g in partners(offered, f.name, {g.name for g in self.faults}, self.winner)]
        if d is not None and not self.faults:
            lines.append("  no fault identified" + (f" ({self.note})" if self.note else ""))
        elif self.determined is False:
            lines.append(f"  not determined by these data (criterion {self.criterion_without:+.2f}: the note says why)")
        lines += [f"  RUL of {p.name}: {p.said()}" for p in self.prognosis if math.isfinite(p.rul)]
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        d = self.detection
        rows = [("detection", "none" if d is None else
                 f"t<sub>D</sub> = {d.time:.2f} s, coherence {list(d.coherence)}; at {d.decision_time:.2f} s: "
                 f"{list(d.final_coherence)}")]
        rows += [(f.name, f.describe(self._variable(f.name), value_unit(self.bond_graph, f.name)).split(": ", 1)[1])
                 for f in self.faults] or [
            ("diagnosis", "no fault" if d is None else "no fault identified")]
        rows += [(f"RUL of {p.name}", f"{p.rul:.2f} s at {p.at:.2f} s (EOL {p.eol:.2f} s{', passed' * p.passed})")
                 for p in self.prognosis if math.isfinite(p.rul)]
        body = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th><td style='text-align:left'>"
                       f"{html.escape(str(v)) if '<sub>' not in str(v) else v}</td></tr>" for k, v in rows)
        return f"<table><caption>bgfdi diagnosis</caption>{body}</table>"

    def __repr__(self) -> str:
        found = ", ".join(f"{f.name} {f.type}" for f in self.faults) or "no fault"
        when = "nothing detected" if self.detection is None else f"t_D = {self.detection.time:.4g} s"
        return f"<Diagnosis of {self.model}: {when}; {found}>"


ROW_KEYS = ("file", "error", "detection_time", "fault", "type", "value", "period", "model", "b", "t0", "rul", "rul_low",
            "rul_high", "criterion_without")


def fault_rows(reports) -> list[dict]:
    """One row per fault of each report (a :class:`Diagnosis`, or a report dict as a fleet returns
    it, with its ``file``), every row with the keys of :data:`ROW_KEYS` (None where absent): a
    report without a fault gives one row with ``fault`` None, so every file of a fleet shows.

    >>> fault_rows([{"file": "a.csv", "detection": None, "diagnosis": {"faults": []}, "prognosis": []}])
    [{'file': 'a.csv', 'error': None, 'detection_time': None, 'fault': None, 'type': None, 'value': None, 'period': None, 'model': None, 'b': None, 't0': None, 'rul': None, 'rul_low': None, 'rul_high': None, 'criterion_without': None}]
    """
    out = []
    for r in reports:
        report = r.to_dict() if isinstance(r, Diagnosis) else r
        det = report.get("detection")
        life = {p["name"]: p for p in report.get("prognosis") or []}
        base = {"file": report.get("file"), "error": report.get("error"),
                "detection_time": None if det is None else det["time"],
                "criterion_without": (report.get("diagnosis") or {}).get("criterion_without")}
        faults = (report.get("diagnosis") or {}).get("faults") or [None]
        for f in faults:
            row = dict.fromkeys(ROW_KEYS)
            row.update(base)
            if f is not None:
                p = life.get(f["name"], {})
                row.update({"fault": f["name"], "type": f["type"], "value": f.get("value"), "period": f.get("period"),
                            "model": f.get("model"), "b": f.get("b"), "t0": f.get("t0"), "rul": p.get("rul"),
                            "rul_low": p.get("rul_low"), "rul_high": p.get("rul_high")})
            out.append(row)
    return out


FAULT_COLUMNS = ROW_KEYS[3:]            # a Diagnosis's faults_frame: no file, error or detection time


def need_pandas(what: str):
    """pandas, or an ImportError in one line naming the extra."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(f"{what} needs pandas: pip install 'bgfdi[pandas]' (fault_rows gives the fault rows "
                          "as plain dicts)") from None
    return pd


def to_frame(reports):
    """:func:`fault_rows` as a pandas DataFrame, one row per fault of each report (a fleet's
    reports: one DataFrame; ``pip install 'bgfdi[pandas]'``); without pandas, :func:`fault_rows`
    gives the same rows as dicts."""
    pd = need_pandas("to_frame")
    return pd.DataFrame(fault_rows(reports), columns=list(ROW_KEYS))


def deterministic(x):
    """A report (or any part of it) without wall-clock entries, so that two runs of one diagnosis
    compare equal (``--timings`` keeps them)."""
    if isinstance(x, dict):
        return {k: deterministic(v) for k, v in x.items() if k not in ("wall_s", "objective_s", "timings")}
    if isinstance(x, list):
        return [deterministic(v) for v in x]
    return x
