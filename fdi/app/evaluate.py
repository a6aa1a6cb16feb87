"""How well the toolkit diagnoses: a suite of scenarios simulated, diagnosed and scored against
their designs (``bgfdi evaluate``, ``bgfdi bench accuracy``).

Per scenario, with the measures of the diagnosis competitions (DXC: detection delay, false alarms,
isolation accuracy) and of prognostics (Saxena et al., "Metrics for offline evaluation of
prognostic performance", IJPHM 2010: relative accuracy and alpha-lambda accuracy):

- **detection delay**: t_D minus the first fault's onset; a **false alarm** is a detection in a
  run without faults or before the first onset (less half a derivative window: the centred
  filter lets a residual cross that much before the fault starts);
- **isolated**: the diagnosed faults are exactly the scenario's (a mode fault by its mode);
- **typed**: every scenario fault found with its type at the decision, and an incipient one with
  its degradation model; an incipient fault with a failure value has its degradation model and
  coefficients graded on the refit at 90 % of its life (below: what the monitor reports by then,
  on the data since detection), since at the decision seconds of a drift often cannot tell the
  models apart (the design's cost within Schwarz's criterion of the answer's: ``design_check``);
  the decision's own grade is kept beside it (``typed_at_decision``, ``models_at_decision``);
- **identification error**: relative error of each found fault's value (abrupt, intermittent),
  period, and degradation coefficients (the largest, for an incipient fault; from the same fit
  its model is graded on);
- **RUL at 50 % and 90 % of life**: for an incipient fault with a failure value, its true end of
  life from the design; at the times when 50 % and 90 % of the life from its onset have passed,
  the data up to then are diagnosed and the incipient fit refreshed on them
  (``fdi.pipeline.refresh_prognosis``); the relative error of the RUL there, and alpha-lambda
  accuracy: the prediction within alpha = 20 % of the true RUL (lambda measured from the onset);
  and the **RUL band's coverage**: whether the true RUL lies inside the prognosis' 95 % band
  (``Prognosis.rul_low``-``rul_high``); a checkpoint without a prediction is not covered;
- **prognostic horizon, relative accuracy, convergence** of each incipient fault's RUL trajectory
  (its checkpoints, :func:`prognostic_metrics`), as Saxena et al. (2010) define them;
- **sub-threshold designs** (``"expect": "nothing"``): faults too small to cross the thresholds;
  right when nothing is detected, a false alarm otherwise.

The truth is the scenario's design. The data are the reference plant's run of it when the design
names one (``"plant": "cycab"``: fdi/app/plant_cycab.py, a simulator written apart from bgfdi, so
the suite does not grade bgfdi against itself; the true end of life then comes from that plant's
own fault profile), else bgfdi's own simulation; with the scenario's noise seed.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import UsageError
from ..data import DataError, Measurements
from ..results import Fault
from ..options import Options
from ..episodes import since_detection
from ..pipeline import MAX_REFIT, refresh_prognosis
from ..monitor import compiled
from ..objective import nominal
from ..prognose import HORIZON_SAMPLES, end_of_life
from ..criterion import effective_samples
from ..scales import for_model
from .scenario import FaultEvent, Scenario, load_scenario, simulate_scenario

ALPHA = 0.2
LIFE_POINTS = (0.5, 0.9)
RUL_TOLERANCE = 0.125          # the RUL's relative error allowed at 90 % of life (the suite's goal)
COVERAGE_GOAL = 0.9            # the fraction of checkpoints whose true RUL the 95 % band should hold
VALUE_TOLERANCE = 0.05         # identified values within 5 %


@dataclass
class Score:
    """One scenario against its design."""
    name: str
    truth: list[str]
    found: list[str]
    detection: float | None
    delay: float | None
    false_alarm: bool
    isolated: bool
    typed: bool
    errors: dict[str, float] = field(default_factory=dict)
    rul: list[dict] = field(default_factory=list)
    expect_nothing: bool = False          # a sub-threshold design: right when nothing is reported
    diagnosed: list[dict] = field(default_factory=list)   # the faults found: name, type, model and fitted values
    duration: float | None = None         # s, the run's length
    prognostics: list[dict] = field(default_factory=list)  # per incipient fault: PH, CRA, convergence
    design_check: dict | None = None      # a miss: the design's cost and the answer's on the same data
    refit_check: dict | None = None       # a degradation model graded wrong on its refit: the same check there
    typed_at_decision: bool | None = None  # the types and degradation models of the decision itself
    models_at_decision: dict[str, int | None] = field(default_factory=dict)   # incipient fault -> model then
    design_models: dict[str, int | None] = field(default_factory=dict)        # incipient fault -> the design's
    coefficient_errors: dict[str, float] = field(default_factory=dict)   # as errors, an incipient fault's coefficients
    read_together: list[str] = field(default_factory=list)   # a design fault named by its partner: graded on its fit

    def to_dict(self) -> dict:
        return asdict(self)


def profile_error(e: FaultEvent, f: dict, nominal_value: float, end: float, samples: int = 2001) -> float:
    """How far a fitted degradation is from the design's over the data it was fitted on: the largest
    |P_fit(t) - P_design(t)| from the design's onset to ``end``, over the design's largest
    excursion from the nominal value there (in the reciprocal scale when the nominal value is
    infinite, a leak resistance). Why not the coefficients: the second-order models' coefficients
    trade off (a sloppy model), the data fix the trajectory, not each coefficient; measured on the
    plant: an eq. (19) pressure drift designed [10.4, 0.002, -0.0034] from 15 s, refitted at 90 % of
    its life as [19.8, 0.0047, -0.0071] from 16.8 s: coefficients 137 % apart, profiles 1.1 % of
    the excursion apart, the RUL 3 % off.

    >>> e = FaultEvent("beta", "incipient", 10.0, model=1, b=(-0.02,))
    >>> round(profile_error(e, {"model": 1, "b": [-0.021], "t0": 10.0}, 1.0, 20.0), 4)  # (e^-0.2 - e^-0.21) / (1 - e^-0.2)
    0.0449
    """
    from ..profiles import incipient
    t = np.linspace(e.t0, max(end, e.t0), samples)
    design = incipient(t, e.t0, nominal_value, e.model, [list(e.b)])[0]
    fitted = incipient(t, float(f["t0"]), nominal_value, int(f["model"]), [list(f["b"])])[0]
    if not math.isfinite(nominal_value):
        design, fitted, nominal_value = 1.0 / design, 1.0 / fitted, 0.0
    span = float(np.max(np.abs(design - nominal_value)))
    gap = float(np.max(np.abs(fitted - design)))
    return gap / span if span > 0 else gap


def _relative(found: float, true: float) -> float:
    return abs(found - true) / abs(true) if true else abs(found - true)


def identification_errors(events: list[FaultEvent], faults: list[dict], nominals: dict[str, float] | None = None,
                          ends: dict[str, float] | None = None) -> dict[str, float]:
    """The largest relative error of each found fault's identified magnitudes against the design:
    value, period; an incipient fault's coefficients, or with its nominal value (``nominals``)
    and the end of the data it was fitted on (``ends``) its degradation profile
    (:func:`profile_error`)."""
    out = {}
    by_name = {f["name"]: f for f in faults}
    for e in events:
        f = by_name.get(e.target)
        if f is None or f["type"] != e.type or e.type == "mode":
            continue
        errs = []
        if e.type in ("abrupt", "intermittent") and e.value is not None:
            errs.append(_relative(f["value"], e.value))
        if e.type == "intermittent" and e.period is not None:
            errs.append(_relative(f["period"], e.period))
        if e.type == "incipient" and f.get("model") == e.model and e.b:
            if nominals is not None and e.target in nominals and e.target in ends and f.get("t0") is not None:
                errs.append(profile_error(e, f, nominals[e.target], ends[e.target]))
            else:
                errs += [_relative(x, y) for x, y in zip(f["b"], e.b)]
        if errs:
            out[e.target] = max(errs)
    return out


def graded_faults(report: dict, truth: list[str]) -> tuple[list[dict], list[str]]:
    """The faults a report is graded on, and the pair read together when that decided it. The
    report's own diagnosis; but where its winner is the design with one fault swapped for a fault
    every residual reads only together with it (an alternative whose ``coincides`` names the
    pair, :mod:`fdi.identifiability`), that alternative's fit of the design's faults: no data
    could have chosen between the two, and the report offers both."""
    faults = report["diagnosis"]["faults"]
    said = {f["name"] for f in faults}
    if said == set(truth):
        return faults, []
    for a in report.get("alternatives") or []:           # the final faults the design with one swapped
        if a.get("coincides") and set(a["candidate"]) == set(truth) and len(a["candidate"]) == len(truth) \
                and set(a["coincides"]["faults"]) == said ^ set(truth):
            return list(a["faults"]), list(a["coincides"]["faults"])
    return faults, []


def score(name: str, events: list[FaultEvent], report: dict, mode_names: dict[str, str], early: float = 0.0,
          expect_nothing: bool = False) -> Score:
    """A diagnosis report against the scenario's fault events. ``early``: how long before a fault's
    onset a detection still counts as its detection (the centred derivative filter lets a residual
    cross up to half a window before the fault starts). ``expect_nothing``: the faults are designed
    below the thresholds, so any detection is a false alarm and a silent report is right. A
    design fault named by its partner read together is graded on the partner's fit
    (:func:`graded_faults`, ``Score.read_together``)."""
    truth = sorted({e.target for e in events})
    faults, together = graded_faults(report, truth)
    found = sorted({f["name"] for f in faults})
    det = report["detection"]
    onset = min((e.t0 for e in events), default=None)
    t_d = det["time"] if det else None
    if expect_nothing:
        quiet = t_d is None and not found
        return Score(name, truth, found, t_d, None, not quiet, quiet, quiet, {}, expect_nothing=True)
    false_alarm = t_d is not None and (onset is None or t_d < onset - early)
    delay = t_d - onset if t_d is not None and onset is not None and not false_alarm else None
    by_name = {f["name"]: f for f in faults}
    for f in faults:                       # a mode fault is reported by its mode variable
        if f["type"] == "mode":
            by_name.setdefault(mode_names.get(f["name"], f["name"]), f)
    found_named = sorted({mode_names.get(n, n) for n in found} | set(found))
    isolated = set(truth) == {n for n in found_named if n in set(truth)} and len(found) == len(truth)
    typed = all(e.target in by_name and by_name[e.target]["type"] == e.type
                and (e.type != "incipient" or by_name[e.target].get("model") == e.model) for e in events)
    said = sorted({f["name"] for f in report["diagnosis"]["faults"]})
    return Score(name, truth, said, t_d, delay, false_alarm, isolated, typed,
                 identification_errors(events, faults), read_together=together)


def evaluate_scenario(model_path: str, scenario_path: str | Path, options: Options | None = None,
                      life_points: tuple[float, ...] = LIFE_POINTS) -> Score:
    """Simulate one scenario, diagnose it, score it; RUL checkpoints for its incipient faults at the
    fractions ``life_points`` of their lives (each costs a diagnosis: more points give the
    prognostic horizon and convergence a finer trajectory, 50 % and 90 % by default)."""
    o = options or Options()
    c = compiled(model_path)
    model, config = c.model, c.config
    scenario = load_scenario(scenario_path, model)
    designed = {e.target: e.failure for e in scenario.faults if e.failure is not None}
    if designed:                       # the design's failure values, where the options give none
        o = replace(o, failures={**designed, **o.failures})
    cols = simulate_scenario(model, scenario)
    meas = Measurements(str(scenario_path), cols["t"], cols)
    # one memo for the scenario's diagnoses: a checkpoint diagnoses a prefix of the same record, and
    # an estimator whose window and settings its full diagnosis already saw is not run again
    # (fdi.estimators.Estimators._key; the tutorial's ageing capacitor: 29.3 -> 22.1 s CPU)
    o.check()
    memo: dict = {}
    report = c.diagnose(meas, o, None, memo).to_dict()
    mode_names = {f.name: f.targets[0] for f in model.faults.values() if f.kind == "mode"}
    mode_names.update({f.targets[0]: f.name for f in model.faults.values() if f.kind == "mode"})
    s = score(Path(scenario_path).stem, list(scenario.faults), report, mode_names,
              early=for_model(model, config, 1.0 / scenario.fs).window / 2 + 1.0 / scenario.fs,
              expect_nothing=scenario.expect == "nothing")
    s.duration = scenario.T
    s.diagnosed = [{k: f[k] for k in ("name", "type", "model", "t0", "value", "period", "b") if f.get(k) is not None}
                   for f in report["diagnosis"]["faults"]]
    if not s.expect_nothing and not (s.isolated and s.typed) and s.detection is not None:
        s.design_check = design_check(model_path, meas, o, report, list(scenario.faults))
    if not s.expect_nothing:
        s.rul = rul_checkpoints(model_path, model, config, scenario, meas, report, o, life_points, memo)
        s.prognostics = trajectory_metrics(s.rul)
        regrade(s, list(scenario.faults), report, mode_names, max(life_points, default=None), model)
    return s


def regrade(s: Score, events: list[FaultEvent], report: dict, mode_names: dict[str, str],
            late: float | None, model) -> None:
    """Grade each incipient fault's degradation model and coefficients on its refit at the life
    fraction ``late`` (the checkpoint's ``model``/``b``) where there is one; the decision's grade
    kept in ``typed_at_decision`` and ``models_at_decision``."""
    faults = [dict(f) for f in graded_faults(report, sorted({e.target for e in events}))[0]]
    by_name = {f["name"]: f for f in faults}
    s.typed_at_decision = s.typed
    s.models_at_decision = {e.target: by_name.get(e.target, {}).get("model") for e in events if e.type == "incipient"}
    s.design_models = {e.target: e.model for e in events if e.type == "incipient"}
    refits = {r["fault"]: r for r in s.rul if r["fraction"] == late and r.get("model") is not None}
    window = report.get("window") or [None, (report.get("detection") or {}).get("time")]
    ends = {e.target: window[1] for e in events if e.type == "incipient" and window[1] is not None}
    for f in faults:
        r = refits.get(f["name"])
        if r is not None and f["type"] == "incipient":
            f["model"], f["b"], f["t0"] = r["model"], list(r["b"]), r["refit_t0"]
            ends[f["name"]] = r["t"]
    if refits:
        s.typed = score(s.name, events, {**report, "diagnosis": {**report["diagnosis"], "faults": faults}},
                        mode_names).typed
        if not s.typed:
            s.refit_check = next((r["refit_check"] for r in refits.values() if r.get("refit_check")), None)
    s.coefficient_errors = identification_errors(events, faults)
    s.errors = identification_errors(events, faults, {e.target: nominal(model, e.target) for e in events
                                                      if e.type == "incipient" and e.target in model.faults}, ends)


def design_check(model_path: str, meas: Measurements, o: Options, report: dict,
                 events: list[FaultEvent]) -> dict | None:
    """Why a diagnosis missed its design: the design's faults and the answer's, each held at its
    values, costed on the same data (the identification window since t_D to the final decision)
    and compared by Schwarz's criterion. ``verdict`` is "search" when the design is preferred by
    more than 2 (Kass & Raftery: the data hold the truth and the search missed it), else "data"
    (the data do not prefer the design: no search could have found it there). None without a
    detection or with a mode fault on either side (its switch time is not a design value)."""
    from ..episodes import MAX_GROWTH
    det, faults = report.get("detection"), report["diagnosis"]["faults"]
    if det is None:
        return None
    t_d, now = report.get("window") or (det["time"], det["time"])
    return held_check(model_path, meas, o, events, list(faults), t_d, now, MAX_GROWTH)


def held_check(model_path: str, meas: Measurements, o: Options, events: list[FaultEvent], faults: list[dict],
               since: float, until: float, windows: int) -> dict | None:
    """:func:`design_check` with the answer ``faults`` on the data from the detection ``since`` to
    ``until`` (at most ``windows`` identification windows, as the diagnosis took them): a refit at a
    checkpoint is checked on the data it was fitted on (``refit_check``). None with a mode fault on
    either side."""
    from ..criterion import information
    from ..objective import Objective, window
    from ..pipeline import prepare
    if any(e.type == "mode" for e in events) or any(f["type"] == "mode" for f in faults):
        return None
    c = compiled(model_path)
    p = prepare(c.with_config(o.settings), meas, o)
    start, count = since_detection(meas.t, since, until, p.samples, windows)
    win = window(meas.t, p.raw, start, count, p.window_s)
    n_eff = effective_samples(count, len(c.residuals), meas.ts, p.window_s)
    design = [{k: v for k, v in (("name", e.target), ("type", e.type), ("value", e.value), ("period", e.period),
                                 ("model", e.model), ("b", list(e.b) if e.b else None), ("t0", e.t0)) if v is not None}
              for e in events]

    def cost(fs: list[dict]) -> float:
        m = p.monitor                # the options' thresholds (a table by mode dropped for one given) as p.weights
        return float(Objective(m.model, m.residuals, win, (), p.weights, p.window_s, fixed=fs, config=m.config,
                               modes=p.modes).constant())
    ours, theirs = cost(design), cost([dict(f) for f in faults])
    ic_design, ic_answer = information(ours, design, n_eff), information(theirs, list(faults), n_eff)
    return {"design_cost": ours, "answer_cost": theirs, "criterion_difference": ic_design - ic_answer,
            "verdict": "search" if ic_design < ic_answer - 2.0 else "data"}


def trajectory_metrics(checkpoints: list[dict], alpha: float = ALPHA) -> list[dict]:
    """:func:`prognostic_metrics` of each fault's checkpoints that the run reaches; each
    checkpoint gets its relative accuracy ``ra`` (None without a prediction)."""
    out = []
    for name in dict.fromkeys(r["fault"] for r in checkpoints):
        points = sorted((r for r in checkpoints if r["fault"] == name and "run ends" not in r.get("note", "")),
                        key=lambda r: r["t"])
        if not points:
            continue
        eol, onset = points[0]["eol"], points[0]["onset"]
        m = prognostic_metrics(points, eol, onset, alpha)
        for r, ra in zip(points, m["ra"]):
            r["ra"] = ra
        out.append({"fault": name, "onset": onset, "eol": eol, "alpha": alpha, "ph": m["ph"],
                    "ph_fraction": None if m["ph"] is None else m["ph"] / (eol - onset), "cra": m["cra"],
                    "convergence": m["convergence"], "predictions": sum(r["rul"] is not None for r in points)})
    return out


def true_end_of_life(model, scenario: Scenario, e: FaultEvent, failure: float) -> float:
    """The design's end of life: from the reference plant's own profile when it simulated the run,
    else from bgfdi's degradation models."""
    if scenario.plant == "cycab":
        from . import plant_cycab
        return plant_cycab.end_of_life(e, failure)
    return end_of_life(e.model, list(e.b), nominal(model, e.target), failure, e.t0, e.t0,
                       horizon=max(HORIZON_SAMPLES / scenario.fs, scenario.T), ts=1.0 / scenario.fs)


def rul_checkpoints(model_path: str, model, config, scenario, meas: Measurements, report: dict,
                    o: Options, life_points: tuple[float, ...] = LIFE_POINTS, memo: dict | None = None) -> list[dict]:
    """For each incipient design fault with a failure value: the RUL the toolkit gives at 50 % and
    90 % of its life (the data up to then diagnosed and refitted), against the true RUL. ``memo``:
    the estimators already run on this record (a prefix's windows are the record's). A design
    fault a checkpoint's diagnosis names by its partner read together is refitted from the
    report's fit of the design (:func:`graded_faults`; the entry's ``read_together``), as the
    diagnosis is graded."""
    out = []
    for e in scenario.faults:
        failure = e.failure if e.failure is not None else config.failure(e.target)
        if e.type != "incipient" or failure is None:
            continue
        eol = true_end_of_life(model, scenario, e, failure)
        if not math.isfinite(eol):
            continue
        for fraction in life_points:
            at = e.t0 + fraction * (eol - e.t0)
            entry = {"fault": e.target, "fraction": fraction, "t": at, "true_rul": eol - at, "rul": None,
                     "error": None, "alpha_ok": False, "rul_low": None, "rul_high": None, "covered": False,
                     "ra": None, "onset": e.t0, "eol": eol}
            k = int(np.searchsorted(meas.t, at, side="right"))
            if at > meas.t[-1]:
                entry["note"] = "the run ends before this point of life"
                out.append(entry)
                continue
            prefix = Measurements(meas.path, meas.t[:k], {c: v[:k] for c, v in meas.columns.items()})
            try:
                d = compiled(model_path).diagnose(prefix, o, None, memo)
                part = d.to_dict()
            except (DataError, UsageError) as exc:    # a prefix too short to decide is scored as a miss
                entry["note"] = f"no diagnosis at this point ({type(exc).__name__})"
                out.append(entry)
                continue
            graded, together = graded_faults(part, sorted({g.target for g in scenario.faults if g.t0 <= at}))
            if part["detection"] is None:
                entry["note"] = "nothing is detected yet at this point of life"
            elif not any(f["name"] == e.target and f["type"] == "incipient" for f in graded):
                entry["note"] = "the fault is not diagnosed incipient at this point"
            else:
                if together:                # the design's own fit, which the report offers beside its partner's
                    d = replace(d, faults=tuple(Fault.from_dict(f) for f in graded))
                    entry["read_together"] = together
                refit, prognosis = refresh_prognosis(compiled(model_path), prefix, d, o, memo)
                f = next((f for f in refit if f["name"] == e.target and f["type"] == "incipient"), None)
                if f is not None:
                    entry["model"], entry["b"], entry["refit_t0"] = f["model"], list(f["b"]), f["t0"]
                    if f["model"] != e.model:       # the data the refit saw: would they prefer the design?
                        entry["refit_check"] = held_check(model_path, prefix, o, list(scenario.faults),
                                                          [dict(g) for g in refit], d.detection.time,
                                                          float(prefix.t[-1]), MAX_REFIT)
                p = next((p for p in prognosis if p.name == e.target), None)
                if p is not None and math.isfinite(p.rul):
                    entry["rul"] = p.rul
                    entry["error"] = (p.rul - entry["true_rul"]) / entry["true_rul"]
                    entry["alpha_ok"] = abs(entry["error"]) <= ALPHA
                    low, high = sorted((p.rul_low, p.rul_high))
                    entry["rul_low"], entry["rul_high"] = low, high
                    entry["covered"] = bool(low <= entry["true_rul"] <= high)
            out.append(entry)
    return out


def relative_accuracy(true_rul: float, rul: float) -> float:
    """Saxena et al. (2010), eq. of RA: 1 - |r* - r| / r* at one time (1 is perfect; negative when
    the error exceeds the true RUL)."""
    return 1.0 - abs(true_rul - rul) / true_rul


def prognostic_metrics(trajectory: list[dict], eol: float, onset: float, alpha: float = ALPHA) -> dict:
    """Prognostic horizon, relative accuracy and convergence of one fault's RUL trajectory
    (Saxena, Celaya, Saha, Saha, Goebel, "Metrics for offline evaluation of prognostic
    performance", IJPHM 1(1), 2010, sec. 6). ``trajectory``: the predictions in time order, each a
    dict with ``t`` (s, when it was made), ``true_rul`` and ``rul`` (None: no prediction there).
    Time is the fault's life: from its ``onset`` (the paper's time 0) to the true ``eol``, so the
    paper's t_EoL is ``eol - onset`` here.

    - **prognostic horizon** PH = t_EoL - t_i, i the first prediction within the alpha bounds
      r*(t_i) +- alpha * t_EoL (bounds of constant width, unlike alpha-lambda's shrinking cone);
      None if no prediction is ever within them. Longer is better.
    - **relative accuracy** RA = 1 - |r* - r| / r* of each prediction (``ra``, None where there is
      none) and the cumulative relative accuracy CRA, their mean over the predictions made.
    - **convergence** C_M = sqrt((x_c - t_P)^2 + y_c^2) (s): the distance from the first prediction
      t_P to the centroid (x_c, y_c) of the area under M(t) = |r* - r| (s), M(i) held from its
      prediction to the next and the last to t_EoL:
      x_c = 1/2 sum (t_{i+1}^2 - t_i^2) M(i) / sum (t_{i+1} - t_i) M(i),
      y_c = 1/2 sum (t_{i+1} - t_i) M(i)^2 / sum (t_{i+1} - t_i) M(i).
      Smaller is better (errors small, and small early); 0 when every prediction is exact; None
      without predictions.

    A designed trajectory (life 100 s; predictions at 50, 70, 90 s of 75, 32, 10 s for true RULs of
    50, 30, 10 s; alpha 0.2, so the PH bounds are +-20 s): 25 s off at 50 s, inside from 70 s, so
    PH = 30 s; RA = 0.5, 0.933, 1; M = 25, 2, 0 s over 20, 20, 10 s gives x_c = 61.48 s, y_c = 11.65 s:

    >>> traj = [{"t": t, "true_rul": 100 - t, "rul": r} for t, r in ((50, 75), (70, 32), (90, 10))]
    >>> m = prognostic_metrics(traj, eol=100.0, onset=0.0)
    >>> m["ph"], [round(x, 4) for x in m["ra"]], round(m["cra"], 4), round(m["convergence"], 3)
    (30.0, [0.5, 0.9333, 1.0], 0.8111, 16.356)
    """
    life = eol - onset
    made = [(float(p["t"]) - onset, float(p["true_rul"]), float(p["rul"])) for p in trajectory
            if p.get("rul") is not None and math.isfinite(p["rul"])]
    ph = next((life - t for t, true, r in made if abs(r - true) <= alpha * life), None)
    ra = [None if p.get("rul") is None or not math.isfinite(p["rul"]) else relative_accuracy(p["true_rul"], p["rul"])
          for p in trajectory]
    done = [x for x in ra if x is not None]
    convergence = None
    if made:
        times = [t for t, _, _ in made] + [life]
        m = [abs(true - r) for _, true, r in made]
        area = sum((b - a) * e for a, b, e in zip(times, times[1:], m))
        if area > 0:
            x_c = 0.5 * sum((b * b - a * a) * e for a, b, e in zip(times, times[1:], m)) / area
            y_c = 0.5 * sum((b - a) * e * e for a, b, e in zip(times, times[1:], m)) / area
            convergence = math.hypot(x_c - times[0], y_c)
        else:
            convergence = 0.0
    return {"ph": ph, "ra": ra, "cra": float(np.mean(done)) if done else None, "convergence": convergence}


def _fraction(flags: list[bool]) -> float | None:
    return float(np.mean(flags)) if flags else None


def _median(xs: list) -> float | None:
    xs = [x for x in xs if x is not None]
    return float(np.median(xs)) if xs else None


def summary(scores: list[Score]) -> dict:
    """Totals over a suite; ``goals`` reads the suite's targets off one run (every detectable
    faulty scenario isolated and typed, values within 5 %, RUL within 12.5 % at 90 % of life, the
    RUL band's coverage at least 90 %, no false alarm on the longest nominal run, nothing reported
    for the sub-threshold designs)."""
    faulty = [s for s in scores if s.truth and not s.expect_nothing]
    nominal = [s for s in scores if not s.truth]
    quiet_designs = [s for s in scores if s.expect_nothing]
    delays = [s.delay for s in faulty if s.delay is not None]
    errors = [e for s in faulty for e in s.errors.values()]
    ruls = [r for s in scores for r in s.rul]
    at = {f: [r for r in ruls if r["fraction"] == f] for f in LIFE_POINTS}
    inside = [r for r in ruls if "run ends" not in r.get("note", "")]      # checkpoints the run reaches
    late = [r for r in at[0.9] if "run ends" not in r.get("note", "")]
    longest = max(nominal, key=lambda s: s.duration or 0.0, default=None)
    totals = {
        "scenarios": len(scores), "faulty": len(faulty), "nominal": len(nominal),
        "false_alarms": sum(s.false_alarm for s in scores),
        "missed": sum(s.detection is None for s in faulty),
        "mean_delay_s": float(np.mean(delays)) if delays else None,
        "isolation_accuracy": float(np.mean([s.isolated for s in faulty])) if faulty else None,
        "type_accuracy": float(np.mean([s.typed for s in faulty])) if faulty else None,
        "typed_at_decision": _fraction([s.isolated and bool(s.typed if s.typed_at_decision is None
                                                            else s.typed_at_decision) for s in faulty]),
        "models_at_decision_wrong": sorted({s.name for s in faulty for name, model in s.design_models.items()
                                            if s.models_at_decision.get(name) != model}),
        "identification_error_median": float(np.median(errors)) if errors else None,
        "identification_within_5pct": float(np.mean([e <= VALUE_TOLERANCE for e in errors])) if errors else None,
        **{f"rul_error_{int(f * 100)}": (float(np.median([abs(r["error"]) for r in at[f] if r["error"] is not None]))
                                         if any(r["error"] is not None for r in at[f]) else None) for f in LIFE_POINTS},
        **{f"alpha_lambda_{int(f * 100)}": (float(np.mean([r["alpha_ok"] for r in at[f]])) if at[f] else None)
           for f in LIFE_POINTS},
        "isolated_and_typed": _fraction([s.isolated and s.typed for s in faulty]),
        "wrong": [s.name for s in faulty if not (s.isolated and s.typed)],
        "values_off": [s.name for s in faulty if any(e > VALUE_TOLERANCE for e in s.errors.values())],
        "rul_checkpoints": len(inside),
        "rul_predicted": sum(r["rul"] is not None for r in inside),
        "rul_band_coverage": _fraction([bool(r.get("covered")) for r in inside]),
        "rul_within_12_5pct_at_90": _fraction([r["error"] is not None and abs(r["error"]) <= RUL_TOLERANCE
                                               for r in late]),
        "nominal_false_alarms": sum(s.false_alarm for s in nominal),
        "longest_nominal": None if longest is None else {"name": longest.name, "duration_s": longest.duration,
                                                         "false_alarm": longest.false_alarm},
        "prognostic_horizon_fraction_median": _median([p["ph_fraction"] for s in scores for p in s.prognostics]),
        "prognostic_horizon_found": _fraction([p["ph"] is not None for s in scores for p in s.prognostics]),
        "relative_accuracy_90": _median([r["ra"] for r in late if r.get("ra") is not None]),
        "cumulative_relative_accuracy_median": _median([p["cra"] for s in scores for p in s.prognostics]),
        "convergence_median_s": _median([p["convergence"] for s in scores for p in s.prognostics]),
        "subthreshold": len(quiet_designs),
        "subthreshold_quiet": sum(not s.false_alarm for s in quiet_designs),
        "subthreshold_reported": [s.name for s in quiet_designs if s.false_alarm],
    }
    totals["goals"] = {                   # None: the suite has nothing to judge it on
        "isolated_and_typed": all(s.isolated and s.typed for s in faulty) if faulty else None,
        "values_within_5pct": not totals["values_off"] if faulty else None,
        "rul_within_12_5pct_at_90": (None if totals["rul_within_12_5pct_at_90"] is None
                                     else totals["rul_within_12_5pct_at_90"] == 1.0),
        "rul_band_coverage": (None if totals["rul_band_coverage"] is None
                              else totals["rul_band_coverage"] >= COVERAGE_GOAL),
        "no_false_alarm_on_longest_nominal": None if longest is None else not longest.false_alarm,
        "nothing_below_thresholds": not totals["subthreshold_reported"] if quiet_designs else None,
    }
    return totals


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.0f} %"


def _num(x, unit: str = "") -> str:
    return "-" if x is None else f"{x:.3g}{unit}"


def _band(r: dict) -> str:
    if r["error"] is None:
        return "-"
    return f"{100 * r['error']:+.1f} %{'' if r.get('covered') else ' (out of band)'}"


def format_scores(scores: list[Score], totals: dict) -> str:
    """The suite as a table and its totals, as `bgfdi evaluate` prints them."""
    lines = [f"{'scenario':<32}{'truth':<28}{'found':<28}{'delay [s]':>10}  {'isolated':<9}{'typed':<6}"
             f"{'max id. error':>14}  RUL error at 50 % / 90 % of life"]
    for s in scores:
        if s.expect_nothing:
            delay = "false alarm" if s.false_alarm else "quiet"
            truth = f"({', '.join(s.truth)} below)"
        else:
            delay = "false alarm" if s.false_alarm else ("-" if s.delay is None else f"{s.delay:.2f}")
            truth = ', '.join(s.truth) or 'none'
        err = max(s.errors.values()) if s.errors else None
        rul = " / ".join(_band(r) for r in s.rul) or "-"
        lines.append(f"{s.name:<32}{truth:<28}{', '.join(s.found) or 'none':<28}{delay:>10}  "
                     f"{('yes*' if s.read_together else 'yes') if s.isolated or not s.truth else 'no':<9}"
                     f"{'yes' if s.typed else 'no':<6}"
                     f"{_pct(err):>14}  {rul}")
    t = totals
    longest = t.get("longest_nominal")
    lines += ["",
              f"{t['scenarios']} scenarios ({t['faulty']} with faults, {t['nominal']} nominal, "
              f"{t.get('subthreshold', 0)} below the thresholds): "
              f"{t['false_alarms']} false alarm(s), {t['missed']} missed; mean detection delay "
              f"{'-' if t['mean_delay_s'] is None else format(t['mean_delay_s'], '.2f')} s",
              f"isolation accuracy {_pct(t['isolation_accuracy'])}, type and model accuracy {_pct(t['type_accuracy'])} "
              f"(degradation models at 90 % of life; at the decision {_pct(t.get('typed_at_decision'))}"
              + (f", other models then: {', '.join(t['models_at_decision_wrong'])}" if t.get("models_at_decision_wrong")
                 else "") + "), "
              f"identified values within 5 %: {_pct(t['identification_within_5pct'])} "
              f"(median error {_pct(t['identification_error_median'])})",
              f"RUL: median |error| {_pct(t['rul_error_50'])} at 50 % of life, {_pct(t['rul_error_90'])} at 90 %; "
              f"alpha-lambda accuracy (alpha {ALPHA:g}) {_pct(t['alpha_lambda_50'])} at 50 %, "
              f"{_pct(t['alpha_lambda_90'])} at 90 %",
              f"prognostic horizon (alpha {ALPHA:g} of life) median {_pct(t.get('prognostic_horizon_fraction_median'))} "
              f"of life, found for {_pct(t.get('prognostic_horizon_found'))} of the drifts; relative accuracy at 90 %: "
              f"{_num(t.get('relative_accuracy_90'))}, cumulative (median) {_num(t.get('cumulative_relative_accuracy_median'))}; "
              f"convergence (median) {_num(t.get('convergence_median_s'), ' s')}",
              f"RUL within {100 * RUL_TOLERANCE:g} % at 90 % of life: {_pct(t.get('rul_within_12_5pct_at_90'))}; "
              f"true RUL inside the 95 % band: {_pct(t.get('rul_band_coverage'))} of {t.get('rul_checkpoints', 0)} "
              f"checkpoints ({t.get('rul_predicted', 0)} with a prediction; goal {_pct(COVERAGE_GOAL)})",
              f"below the thresholds: {t.get('subthreshold_quiet', 0)} of {t.get('subthreshold', 0)} quiet; "
              + ("no nominal run" if not longest else
                 f"longest nominal run {longest['name']} ({longest['duration_s']:g} s): "
                 + ("false alarm" if longest["false_alarm"] else "quiet"))]
    together = [s for s in scores if s.read_together and s.isolated]
    if together:
        lines.append("* named by a fault the residuals read only together with the design's (no data separate "
                     "them; the report offers both): " + ", ".join(
                         f"{s.name} ({' for '.join(sorted(set(s.found) - set(s.truth)) + sorted(set(s.truth) - set(s.found)))}"
                         "; graded on the report's fit of the design's fault)" for s in together))
    if t.get("wrong"):
        checks = {s.name: s.refit_check or s.design_check for s in scores if s.refit_check or s.design_check}
        lines.append("not isolated and typed: " + ", ".join(
            name + (f" (design {checks[name]['design_cost']:.4g}, answer {checks[name]['answer_cost']:.4g}: "
                    f"{'missed by the search' if checks[name]['verdict'] == 'search' else 'the data do not prefer the design'})"
                    if name in checks else "") for name in t["wrong"]))
    if t.get("goals"):
        lines.append("goals: " + ", ".join(f"{k} {'n/a' if v is None else 'yes' if v else 'NO'}"
                                           for k, v in t["goals"].items()))
    return "\n".join(lines) + "\n"


def scenario_cost(scenario) -> float:
    """A scenario's weight in the progress of a suite: the samples it simulates and diagnoses
    (T fs + 1), which set its simulation's and its diagnosis's time."""
    return float(round(scenario.T * scenario.fs) + 1)


def suite_files(paths: list[str], skipped: Callable[[str], None] | None = None) -> list[Path]:
    """Scenario files from files and folders (every *.json and *.yaml regular file in a folder,
    sorted). A FIFO, socket or device in a folder is skipped (reading one would wait for a writer
    forever), and ``skipped`` told in one line; a folder that cannot be listed is a UsageError."""
    out: list[Path] = []
    for p in map(Path, paths):
        try:
            folder = p.is_dir()
        except OSError:                              # a name the system cannot look up: read as a file (one line there)
            folder = False
        if not folder:
            out.append(p)
            continue
        try:
            found = sorted(q for q in p.iterdir() if q.suffix.lower() in (".json", ".yaml", ".yml"))
        except OSError as exc:
            raise UsageError(f"{p}: cannot list the folder ({exc.strerror or exc}); give scenario files or a "
                             "readable folder") from None
        for q in found:
            if q.is_file():                          # follows links: a link to a regular file counts
                out.append(q)
            elif skipped is not None:
                skipped(f"{q}: not a regular file (a FIFO, socket, device or broken link): skipped")
    return out
