"""``bgfdi check --verify``: the verification of the ARRs (:mod:`fdi.verify`) as text lines, as
the ``verification`` section of ``check --json`` (shape in docs/cli.md), and as the one-line
findings of the ARRs that fail."""
from __future__ import annotations

import math

from ..verify import Check, Run, Verification


def _number(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _mode(x: Check | Run) -> dict[str, int]:
    return {k: int(v) for k, v in x.mode}


def to_json(v: Verification) -> dict:
    """Plain data: every ARR in every mode (violation null when not checked), the settings the
    model's time scale gave (s), the runs cut before a stall, and the notes."""
    s = v.settings
    return {
        "ok": v.ok,
        "complete": v.complete,
        "seed": v.seed,
        "threshold": None if s is None else s.threshold,
        "time_constant_s": None if s is None else s.tau,
        "sampling_period_s": None if s is None else s.ts,
        "duration_s": None if s is None else s.duration,
        "runs": None if s is None else s.runs,
        "checks": [{"arr": c.arr, "mode": _mode(c), "violation": _number(c.violation),
                    "residual": _number(c.residual), "scale": _number(c.scale), "runs": c.runs,
                    "passed": c.passed, "note": c.note or None} for c in v.checks],
        "cut_runs": [] if s is None else [{"mode": _mode(r), "run": r.index, "end_s": r.end} for r in s.cuts],
        "left_out_runs": [] if s is None else [{"mode": _mode(r), "run": r.index, "why": r.why} for r in s.left_out],
        "notes": list(v.notes),
        "zero": [{"arr": name, "mode": label} for name, label in v.zero],
    }


def to_lines(v: Verification) -> list[str]:
    """The text report: a header with the settings, one line per ARR and mode, the runs cut
    short, the notes and a count."""
    s = v.settings
    modes = len({c.mode for c in v.checks})
    if s is None:
        lines = [f"verification of the residuals on the simulated model ({modes} mode(s)): not run"]
    else:
        lines = [f"verification of the residuals on the simulated model: {modes} mode(s) x {s.runs} runs from random "
                 f"states under random inputs (time constant {s.tau:.3g} s: sampled every {s.ts:.3g} s for "
                 f"{s.duration:.3g} s; seed {v.seed}); a residual fails above {s.threshold:g} of the sum of its terms"]
    width = max([4] + [len(c.mode_text) for c in v.checks])
    lines.append(f"  {'ARR':<6} {'mode':<{width}} {'violation':>10}  {'runs':>4}  verdict")
    for c in v.checks:
        shown = f"{c.violation:.2e}" if math.isfinite(c.violation) else ("inf" if c.violation == math.inf else "-")
        verdict = (f"ok{' ' + c.note if c.note else ''}" if c.passed else f"FAIL: |r| up to {c.residual:.3g} against terms summing to {c.scale:.3g}"
                   if c.passed is False else f"not verified: {c.note}")
        lines.append(f"  {c.arr:<6} {c.mode_text:<{width}} {shown:>10}  {c.runs:>4}  {verdict}")
    if s is not None and s.cuts:
        lines.append("  runs cut where LSODA stalled on a switching surface (sticking friction, an emptied tank): "
                     + ", ".join(f"{r.mode_text} run {r.index} at {r.end:.3g} s" for r in s.cuts))
    if s is not None:
        lines += [f"  {r.mode_text} run {r.index} left out: {r.why}" for r in s.left_out]
    lines += [f"  note: {n}" for n in v.notes]
    if v.zero:
        where: dict[str, list[str]] = {}
        for name, label in v.zero:
            where.setdefault(name, []).append(label)
        lines.append("  0 by their mode's indicator, so not checked there: "
                     + "; ".join(f"{name} in {', '.join(labels)}" for name, labels in where.items()))
    passed = len(v.checks) - len(v.failures) - len(v.unverified)
    lines.append(f"  {passed} of {len(v.checks)} ARR-mode checks pass, {len(v.failures)} fail, "
                 f"{len(v.unverified)} not verified")
    return lines


def verified_nothing(data: dict) -> bool:
    """No ARR-mode check passed (none ran, or every one was left unverified: a model the simulator
    refuses). ``check --verify`` then exits 1, as for a failure: a trial's PV string printed "0 of
    4 ARR-mode checks pass, 0 fail, 4 not verified" and exited 0, a pass to a CI script."""
    return not any(c["passed"] for c in data["checks"])


def failures(data: dict, path: str) -> list[str]:
    """One line per failing ARR and mode (from :func:`to_json`'s data), and one when nothing was
    verified, with the first reason: the findings, for standard error."""
    out = []
    if verified_nothing(data):
        why = next(iter(data.get("notes") or []), None) or next((c["note"] for c in data["checks"] if c.get("note")),
                                                                None)
        out.append(f"{path}: --verify verified no residual{f' ({why})' if why else ''}")
    for c in data["checks"]:
        if c["passed"] is False:
            mode = ",".join(f"{k}={v}" for k, v in c["mode"].items()) or "(no modes)"
            violation = "inf" if c["violation"] is None else f"{c['violation']:.3g}"
            out.append(f"{path}: {c['arr']} does not vanish on the simulated model in mode {mode}: violation "
                       f"{violation} (max |r| {c['residual']:.3g} against terms summing to {c['scale']:.3g}; "
                       f"threshold {data['threshold']:g})")
    return out
