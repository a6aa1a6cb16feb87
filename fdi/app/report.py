"""The diagnosis report as readable text (the JSON report is ``Diagnosis.to_dict``)."""
from __future__ import annotations

import math
from typing import Collection, Mapping

from ..isolate import COVERING_NOTE
from ..results import COMMANDED, DETERMINED, Coincidence, Fault, _vec, eol_passed, partners


def describe_fault(f: dict, variables: Mapping[str, str] | None = None, units: Mapping[str, str] | None = None) -> str:
    """One fault of a report in words; ``variables``: each mode fault's mode variable (the report's
    entry names the fault, ``in_stuck_open``; the text says which variable it sets); ``units``:
    each fault's value's unit (:func:`fdi.results.value_unit`)."""
    return Fault.from_dict(f).describe((variables or {}).get(f["name"]), (units or {}).get(f["name"], ""))


def _estimate(variable: str, value, autonomous: Collection[str]) -> str:
    """One variable of the fault-mode estimate: its value, ``commanded`` where it follows its
    command, and for an autonomous mode (a diode, a thermostat's wax) ``as its condition`` (the
    report's value is "commanded" for both: a trial read "th=commanded" of a mode with no command).

    >>> _estimate("th", "commanded", {"th"}), _estimate("v", "commanded", ()), _estimate("v", 1, ())
    ('th=as its condition', 'v=commanded', 'v=1')
    """
    return f"{variable}={'as its condition' if value == COMMANDED and variable in autonomous else value}"


def _confidence(margin) -> str:
    if margin is None:
        return "type decision margin: n/a"
    word = "clear" if margin > 1.2 else "fair" if margin > 1.02 else "weak: the runner-up structure fits almost as well"
    return f"type decision margin {margin:.3f} (runner-up / best, each cost charged for its parameters; {word})"


def _raced_out(e: dict, candidates: list | None = None) -> str:
    from ..estimators import SET_REACH, SET_STALL, SUBSET_GAIN   # the rules (imported only when a set was raced out)
    if e.get("outdone_by"):
        # (a subset fitted only to start the set from, its faults alone, is no candidate of its own: a trial
        # looked for "{ks}" among the estimators)
        part = ("" if candidates is None or list(e["outdone_by"]) in [list(c) for c in candidates]
                else ", fitted as a part to start it from, not a candidate")
        return (f"raced out: its race gained under {100 * SET_STALL:g} % in its last rung, its fit no better than "
                f"{{{', '.join(e['outdone_by'])}}}'s (within {100 * SUBSET_GAIN:g} %{part}), which the criterion "
                f"prefers")
    return (f"raced out: it cost over {1 + SET_REACH:g}x the best set of its size and gained under "
            f"{100 * SET_STALL:g} % in its last rung")


def _never(fault: dict | None, start: float | None, failure: float) -> str:
    """Why a fitted drift never reaches its failure value, where its closed form says: eq. (16),
    P = P0 exp(b1 tau), keeps P0's sign and moves as b1 P0; eq. (17), 1/P = 1/P0 - b2 tau, moves 1/P
    one way, b2's. ``start``: P0, the fault's nominal value (the drift starts there). A user trial's
    bearing given a failure value below its growing friction read "does not reach" with nothing to
    say the drift moves away from it."""
    if not fault or fault.get("type") != "incipient" or fault.get("model") not in (1, 2) or not fault.get("b") \
            or start is None or not (math.isfinite(start) and start != 0 and math.isfinite(failure)):
        return ""
    b = float(fault["b"][0])
    if b == 0 or not math.isfinite(b):
        return ": the fitted drift does not move it"
    eq = 16 if fault["model"] == 1 else 17
    if eq == 16 and failure / start <= 0:
        return (f": the fitted drift, eq. (16), P0 exp(b1 tau), keeps it on its nominal value's side of 0 "
                f"({start:.5g}), and the failure value is not")
    rate = b * start if eq == 16 else b                   # the sign of dP/dtau at the onset
    towards = (failure - start) * rate > 0
    if towards:                                           # (eq. (17) through its pole: 1/P passes 0 first)
        return ""
    return (f": the fitted drift moves it away from that value ({'up' if rate > 0 else 'down'} from "
            f"{start:.5g}, eq. ({eq}), b = {b:.5g})")


def to_text(report: dict, model_name: str, data_name: str, variables: Mapping[str, str] | None = None,
            units: Mapping[str, str] | None = None, autonomous: Collection[str] = (),
            nominals: Mapping[str, float] | None = None) -> str:
    """The text report of a diagnosis' JSON ``report``. ``variables``: a mode fault's mode variable;
    ``units``: each fault's value unit; ``autonomous``: the autonomous mode variables; ``nominals``:
    each fault's nominal value (where a prognosis says why a drift never fails)."""
    out = [f"bgfdi diagnosis of {data_name} with model {model_name}"]
    det = report.get("detection")
    if det is None:
        out.append("detection: no residual crossed its threshold: nothing detected")
        if report.get("note"):
            out.append(f"note: {report['note']}")
        return "\n".join(out) + "\n"
    alarm = det.get("alarm", det["time"])
    confirmed = "" if alarm is None or f"{alarm:.2f}" == f"{det['time']:.2f}" else f" (confirmed at {alarm:.2f} s)"
    out.append(f"detection: t_D = {det['time']:.2f} s{confirmed}, coherence {_vec(det['coherence'])}; "
               f"at the decision {det['decision_time']:.2f} s: {_vec(det['final_coherence'])}")
    mode = report.get("mode") or {}
    if report.get("suspected_mode_changes"):
        cost = report.get("mode_fault_cost")
        estimate = report.get("mode_estimate") or {}
        final = report["diagnosis"]["faults"]
        won = bool(final) and all(f["type"] == "mode" for f in final)
        fitness = "" if cost is None else (f" (a mode fault: fitness {1.0 / (cost + 1e-12):.4g}, no parameter"
                                           + ("" if won else "; not the diagnosis: the faults below fit better"
                                              if final else "; not kept") + ")")
        if cost is None and estimate and all(v == COMMANDED or mode.get(k) == v for k, v in estimate.items()):
            fitness = " (the modes the data give: no mode fault)"
        out.append(f"suspected mode change(s) from the MCSM: {', '.join(report['suspected_mode_changes'])}; "
                   f"fault-mode estimator: {' '.join(_estimate(k, v, autonomous) for k, v in (report.get('mode_estimate') or {}).items())}"
                   f"{fitness}")
    out.append("mode: " + (" ".join(f"{k}={v}" for k, v in mode.items()) or "(none)"))
    cands = report.get("candidates") or []
    out.append("candidate sets: " + ("; ".join("{" + ", ".join(c) + "}" for c in cands) if cands else "none"))
    if report.get("exoneration_relaxed"):
        out.append("  (exoneration relaxed: the smallest sets that cover the coherence vector are candidates, "
                   + ("as the sets that equal it left the residuals far above their nominal level)"
                      if COVERING_NOTE in (report.get("note") or "") else "as no fault set's signature equals it)"))
    if report.get("pruned"):
        p = report["pruned"]
        out.append(f"  ({p['sets']} set(s) of {p['max_set'] + 1} faults also explain it and were not identified: "
                   f"raise --max-set to include them)")
    if report.get("estimators"):
        out.append("estimators (fitness = 1/(sum_l sum_n |G_l|/threshold_l + 1e-12), higher is better):")
        winner = report.get("winner")
        final = report["diagnosis"]["faults"]
        mode_won = bool(final) and all(f["type"] == "mode" for f in final) and report.get("mode_fault_cost") is not None
        starred = False
        if mode_won and not report.get("episodes"):
            out.append(f" * fault mode {' '.join(f'{k}={v}' for k, v in mode.items())}: fitness "
                       f"{1.0 / (report['mode_fault_cost'] + 1e-12):.4g}; no parameter")
            starred = True
        for e in sorted(report["estimators"], key=lambda e: -e["fitness"]):
            mark = "*" if e["candidate"] == winner and not report.get("episodes") and not mode_won else " "
            starred = starred or mark == "*"
            how = _raced_out(e, cands) if e.get("raced_out") else _confidence(e["margin"])
            out.append(f" {mark} {{{', '.join(e['candidate'])}}}: fitness {e['fitness']:.4g}; {how}")
        if starred:
            out.append("  (* the winner: the smallest information criterion, 2 N_eff ln(cost) + ln(N_eff) per "
                       "identified parameter)")
        elif report.get("episodes"):
            out.append("  (the first decision's fits; the diagnosis comes from the later decision(s) below)")
    for a in report.get("alternatives") or []:
        tie = ": lower, but within 2 is a tie and the smaller set wins" if a["criterion"] < 0 else ""
        out.append(f"  nearly as good: {{{', '.join(a['candidate'])}}} (criterion {a['criterion']:+.2f}{tie}; cost "
                   f"{a['cost']:.4g}): " + "; ".join(describe_fault(f, variables, units) for f in a["faults"]))
        if a.get("coincides"):
            out.append(f"    (one fit: {Coincidence.from_dict(a['coincides']).describe()}: a constant fault of either "
                       f"is fitted as well by the other within their ranges; bgfdi isolability proposes sensors that "
                       f"separate them)")
    for e in report.get("episodes") or []:
        head = (f"at {e['time']:.2f} s the fit no longer explained the data (its residuals left their thresholds, "
                f"the coherence vector still {list(e['coherence'])}); " if e.get("cause") == "misfit" else
                f"at {e['time']:.2f} s the coherence vector became {list(e['coherence'])}; ")
        if not e["candidates"]:
            out.append(head + "no candidate set was left to try for it, so the diagnosis stands: "
                       f"{{{', '.join(e['winner'])}}}")
        elif all(x.get("cost") is None for x in e.get("estimators") or []):
            out.append(head + f"no fit of its {len(e['candidates'])} candidate set(s) was finite there, so the "
                       f"diagnosis stands: {{{', '.join(e['winner'])}}}")
        else:
            out.append(head + f"decided again at {e['decision_time']:.2f} s over {len(e['candidates'])} candidate "
                       f"set(s): {{{', '.join(e['winner'])}}}")
    faults = report["diagnosis"]["faults"]
    for f in report.get("insignificant") or []:
        why = ("its own effect on the residuals stays within their noise" if f.get("unseen") else
               "switched in before the onset, it fits the healthy data there better than the model does, by the "
               "criterion: the model's mismatch, there before any fault, or a fault too small to tell from it"
               if f.get("before") else
               f"its parameters do not pay on the data since the detection: criterion {f['criterion_without']:+.2f} "
               f"without it")
        out.append(f"  left out: {describe_fault(f, variables, units)} ({why})")
    if report.get("note"):
        out.append(f"note: {report['note']}")
    if faults:
        out.append("diagnosis:")
    elif cands and not report.get("estimators") and report.get("note"):    # identification did not run
        out.append("diagnosis: none: the candidate sets were not identified (the note says why)")
    else:
        out.append("diagnosis: no fault explains the coherence vector")
    for f in faults:
        out.append(f"  {describe_fault(f, variables, units)}")
        if f["type"] == "mode" and variables is not None and f["name"] not in variables:
            # a mode change the model declares no fault for (the fault-mode estimator tries every
            # suspected variable): a trial read "tap: fault mode (tap = 0)" of a draw's condition
            how = ("the mode its condition gives: a signal the condition reads, or a law of that mode, may be "
                   "wrong" if f["name"] in autonomous else "its command: a switch that did not follow it")
            out.append(f"    (not one of the model's faults: the data fit {f['name']} = {f.get('value', 0)} better "
                       f"than {how})")
        out += [f"    or {describe_fault(g, variables, units)} (read together with {f['name']}: one fit)"
                for g in partners(report.get("alternatives"), f["name"], {g["name"] for g in faults},
                                  report.get("winner"))]
    without = report["diagnosis"].get("criterion_without")
    if faults and without is not None and without < DETERMINED:
        out.append(f"  (not determined by these data: criterion {without:+.2f} without these faults, under "
                   f"{DETERMINED:g}; the note says why)")
    for p in report.get("prognosis") or []:
        band = ""
        if p.get("rul_low") is not None and p.get("rul_high") is not None and p["rul_high"] != p["rul_low"]:
            band = f" (95 % band from the fit: {p['rul_low']:.2f} to {p['rul_high']:.2f} s)"
        if not all(isinstance(p.get(k), (int, float)) and math.isfinite(p[k]) for k in ("eol", "rul")):
            # infinite (null in JSON): the fitted degradation never gets there
            out.append(f"prognosis: {p['name']} does not reach its failure value {p['failure']:g} on the fitted "
                       f"degradation{_never(next((f for f in faults if f.get('name') == p['name']), None), (nominals or {}).get(p['name']), p['failure'])} "
                       f"(EOL = inf; RUL at {p['at']:.2f} s = inf){band}")
            continue
        if eol_passed(p["eol"], p["at"]):           # crossed before now: dated, not read as failing at this sample
            out.append(f"prognosis: {p['name']} reached its failure value {p['failure']:g} on the fitted degradation "
                       f"at EOL = {p['eol']:.2f} s, {p['at'] - p['eol']:.2f} s before {p['at']:.2f} s (passed): "
                       f"RUL = {p['rul']:.2f} s{band}")
            continue
        out.append(f"prognosis: {p['name']} reaches its failure value {p['failure']:g} at EOL = {p['eol']:.2f} s; "
                   f"RUL at {p['at']:.2f} s = {p['rul']:.2f} s{band}")
    return "\n".join(out) + "\n"
