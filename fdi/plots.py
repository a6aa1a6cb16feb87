"""Optional plots (``pip install bgfdi[plot]``): matplotlib is imported only here, only when asked."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .errors import need_matplotlib


def _plt():
    """pyplot, with whatever backend matplotlib chooses (inline in a notebook, Agg without a
    display): bgfdi never forces one."""
    try:
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        raise need_matplotlib() from None


_SUPERSCRIPT = {"2": "\u00b2", "3": "\u00b3", "4": "\u2074", "-1": "\u207b\u00b9", "-2": "\u207b\u00b2"}
# a unit a prefix may stand in front of: its first symbol has no exponent and is not kg (2 kN*m,
# 3 mm/s, 5 MOhm are right; a prefix on m^3/s would read (mm)^3/s, on kg a double prefix)
_PREFIXABLE = re.compile(r"^(?!kg)[A-Za-z\u03a9]+(?=$|[*/])")


def pretty_unit(unit: str | None) -> str:
    """A model's unit as a reader writes it: N*m -> N·m, m^3/s -> m³/s, Ohm -> Ω; '-' and '?' kept.

    >>> pretty_unit("Pa^0.5*s/m^3"), pretty_unit("Ohm"), pretty_unit("kg*m^2")
    ('Pa^0.5·s/m³', 'Ω', 'kg·m²')
    """
    if not unit:
        return "-"
    out = re.sub(r"\bOhm\b", "\u03a9", unit).replace("*", "\u00b7")
    return re.sub(r"\^(-?\d+)(?![.\d])", lambda m: _SUPERSCRIPT.get(m.group(1), m.group(0)), out)


def unit_axis(axis, unit: str | None, name: str = "") -> None:
    """Label a matplotlib axis (``ax.xaxis``/``ax.yaxis``) with ``name`` and give its ticks SI
    prefixes (``matplotlib.ticker.EngFormatter``): 2.2 mF, 600 kPa, 40 s. Where a prefix may stand
    before the unit, the ticks carry the unit and the label is the name alone ("p1", ticks "600 kPa");
    where it may not (m³/s, kg·m²), the ticks carry the prefix and the label the unit ("Q [m³/s]", ticks
    "500 µ"); a dimensionless axis ('-') keeps plain numbers (an efficiency reads 0.5, not 500 m)."""
    from matplotlib.ticker import EngFormatter

    pretty = pretty_unit(unit)
    if unit in (None, "", "-", "?"):
        axis.set_label_text(f"{name} [{pretty}]" if name else f"[{pretty}]")
    elif _PREFIXABLE.match(unit):
        axis.set_major_formatter(EngFormatter(unit=pretty))
        axis.set_label_text(name or pretty)
    else:
        axis.set_major_formatter(EngFormatter())
        axis.set_label_text(f"{name} [{pretty}]" if name else f"[{pretty}]")


def _time_axis(ax) -> None:
    unit_axis(ax.xaxis, "s", "time t")


def column_units(model) -> dict[str, str]:
    """The unit of each data column a model reads: an input's unit, a sensor's unit where the
    column is the sensor's signal itself (a column computed from a signal, p1 = 1e5 + dp, keeps
    the sensor's unit too: an offset or a sum of pressures is a pressure)."""
    out = {i.column: i.unit for i in model.inputs.values() if i.column}
    for s in model.sensors.values():
        for c in sorted(str(x) for x in s.signal.free_symbols):
            out.setdefault(c, s.unit)
    for m in model.modes.values():
        if m.column:
            out[m.column] = "-"
    return out


def plot_signals(columns: dict[str, np.ndarray], path: str | Path, units: dict[str, str] | None = None,
                 onsets: list[tuple[str, float]] = ()) -> None:
    """Every data column against time, one panel each, labelled with its unit; ``onsets`` (fault
    name, time in s) drawn as vertical lines on every panel."""
    plt = _plt()
    units = units or {}
    names = [c for c in columns if c != "t"]
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 1.8 * len(names)), sharex=True)
    for k, (ax, name) in enumerate(zip(np.atleast_1d(axes), names)):
        ax.plot(columns["t"], columns[name], lw=0.8, label=name)
        for j, (fault, t0) in enumerate(onsets):
            ax.axvline(t0, color=f"C{j + 1}", ls="--", lw=0.8, label=f"{fault} onset ({t0:g} s)" if k == 0 else None)
        unit_axis(ax.yaxis, units.get(name, "?"), name)
        ax.grid(alpha=0.3)
        if k == 0 and onsets:
            ax.legend(fontsize=7, loc="upper left", ncol=4)
    _time_axis(np.atleast_1d(axes)[-1])
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def _save(fig, path: str | Path) -> None:
    """The figure as a PNG file, written atomically (never half a file, never over a link planted
    in a shared folder: :func:`fdi.atomic.write_atomic`)."""
    import io

    from .atomic import write_atomic
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=110, format="png")
    write_atomic(path, buffer.getvalue())


def plot_diagnosis(d, folder: str | Path, model) -> list[Path]:
    """The figures of :func:`diagnosis_figures` written as PNG files into ``folder``; returns them."""
    plt = _plt()
    out_dir = Path(folder)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, fig in diagnosis_figures(d, model).items():
        written.append(out_dir / f"{name}.png")
        _save(fig, written[-1])
        plt.close(fig)
    return written


def diagnosis_figures(d, model) -> dict:
    """A :class:`fdi.results.Diagnosis` drawn: residuals with thresholds and t_D (Figs. 4, 7, 11,
    13), fitness evolution of every estimator (Figs. 9, 12), the fault-mode estimate (Fig. 8),
    identified fault profiles, and the RUL prediction, as matplotlib Figures by name (the caller
    shows, saves or closes them)."""
    plt = _plt()
    report = d.to_dict()
    figures = {"residuals": _residual_figure(plt, d, report.get("detection"))}
    if report.get("estimators"):
        figures["fitness"] = _fitness_figure(plt, report["estimators"])
    if report.get("mode_costs"):
        figures["mode_estimate"] = _mode_figure(plt, report, model)
    faults = [f for f in report["diagnosis"]["faults"] if f["type"] != "mode"]
    if faults and report.get("detection"):
        figures["profiles"] = _profile_figure(plt, report, faults, d.t, model)
    for prog in report["prognosis"]:
        f = next(x for x in faults if x["name"] == prog["name"])
        figures[f"rul_{prog['name']}"] = _rul_figure(plt, prog, f, f.get("t0", report["detection"]["time"]), model)
    return figures


def _residual_figure(plt, d, det: dict | None):
    """Each residual in its unit with its thresholds, the detection and the decision times."""
    names = list(d.names)
    units = dict(zip(names, d.units))
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 2.2 * len(names)), sharex=True)
    for k, (ax, name, ri, ti) in enumerate(zip(np.atleast_1d(axes), names, d.residuals, d.thresholds)):
        ax.plot(d.t, ri, lw=0.7, label="residual")
        ax.axhline(ti, color="k", ls="--", lw=0.8, label="threshold")
        ax.axhline(-ti, color="k", ls="--", lw=0.8)
        if det:
            ax.axvline(det["time"], color="r", lw=0.8, label="detection $t_D$")
            ax.axvline(det["decision_time"], color="r", ls=":", lw=0.8, label="decision $t_D + T_{wt}$")
        unit_axis(ax.yaxis, units.get(name, "?"), name)
        if k == 0:
            ax.legend(fontsize=7, loc="upper left", ncol=4)
    _time_axis(np.atleast_1d(axes)[-1])
    fig.tight_layout()
    return fig


def _fitness_figure(plt, estimators: list[dict]):
    """The best fitness of every estimator per generation: the x axis counts the generations of its
    search (each one population of candidate fault parameters evaluated on the window by eq. 24), the
    legend how many evaluations that was in all."""
    from matplotlib.ticker import EngFormatter, MaxNLocator

    fig, ax = plt.subplots(figsize=(7, 4))
    for e in estimators:
        n = len(e["history"])
        ax.plot(np.arange(1, n + 1), e["history"],
                label="{" + ", ".join(e["candidate"]) + "}" + f": {e.get('evaluations', 0):,} evaluations "
                f"in {n} generations".replace(",", "\u2009"))
    ax.set_xlabel("generation of the estimator's search (one population of candidate faults evaluated by eq. 24 each)",
                  fontsize=8)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("best fitness 1/(cost + \u03b5) [-]")
    ax.yaxis.set_major_formatter(EngFormatter())
    ax.set_title("identification: best fitness per generation", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _profile_figure(plt, report: dict, faults: list[dict], t: np.ndarray, model):
    """Each identified fault's profile in its unit over the data window, with its onset."""
    from .objective import nominal as nominal_value
    from .profiles import profile

    det = report["detection"]
    fig, axes = plt.subplots(len(faults), 1, figsize=(8, 2.4 * len(faults)))
    start, end = _data_window(report, t)
    for ax, f in zip(np.atleast_1d(axes), faults):
        t0 = f.get("t0", det["time"])
        tt = np.linspace(min(t0, start) - 2, end + 2, 1400)
        nominal = nominal_value(model, f["name"])
        p = np.asarray(profile(f["type"], tt, t0, nominal, value=f.get("value"), period=f.get("period"),
                               model=f.get("model"), b=[f.get("b", [0])])).reshape(-1)
        ax.plot(tt, np.where(np.isfinite(p), p, np.nan), lw=1.0, label="identified profile")
        ax.axvspan(start, end, color="0.9", label="data window")
        ax.axvline(t0, color="C1", ls="--", lw=0.8, label=f"onset {t0:.2f} s")
        if not np.isfinite(nominal):
            ax.text(0.01, 0.9, "nominal value: infinite (a healthy part)", transform=ax.transAxes, fontsize=8)
        ax.set_title(f"{f['name']}: identified {f['type']} profile", fontsize=9)
        unit_axis(ax.yaxis, fault_unit(model, f["name"]), f["name"])
        _time_axis(ax)
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def _rul_figure(plt, prog: dict, f: dict, t0: float, model):
    """An incipient fault's identified degradation to its failure value: EOL, RUL and its band."""
    from .objective import nominal as nominal_value
    from .profiles import profile

    end = prog["eol"] if prog["eol"] and np.isfinite(prog["eol"]) else t0 + 60
    rul = prog["rul"] if prog["rul"] is not None else float("inf")    # null in JSON: no end of life predicted
    tt = np.linspace(t0, end + 5, 2000)
    p = np.asarray(profile("incipient", tt, t0, nominal_value(model, f["name"]), model=f["model"],
                           b=[f["b"]])).reshape(-1)
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(tt, p, label=f"identified {prog['name']}")
    ax.axhline(prog["failure"], color="r", ls="--", label="failure value")
    ax.axvline(prog["at"], color="k", ls=":", label=f"now ({prog['at']:.1f} s)")
    ax.axvline(end, color="r", lw=0.8, label=f"EOL {end:.1f} s, RUL {rul:.1f} s")
    low, high = prog.get("rul_low"), prog.get("rul_high")
    if low is not None and high is not None and np.isfinite(low) and np.isfinite(high) and high > low:
        ax.axvspan(prog["at"] + low, prog["at"] + high, color="r", alpha=0.12,
                   label=f"RUL band {low:.1f}-{high:.1f} s (95 % coefficient intervals)")
    ax.legend(fontsize=7)
    unit_axis(ax.yaxis, fault_unit(model, prog["name"]), prog["name"])
    _time_axis(ax)
    fig.tight_layout()
    return fig


def fault_unit(model, name: str) -> str:
    """The unit of a fault's magnitude: its parameter's unit, or '-' for an efficiency factor or a
    group's common factor."""
    f = model.faults[name]
    if f.kind == "parametric" and len(f.targets) == 1:
        return model.parameters[f.targets[0]].unit
    return "-"


def _data_window(report: dict, t: np.ndarray) -> tuple[float, float]:
    """The data the final fit saw (the report's ``window``: t_D to the end of the last decision's
    window); t_D to the decision time for older reports."""
    det = report["detection"]
    start, end = report.get("window") or (det["time"], det["decision_time"])
    return float(start), float(min(max(end, start), t[-1]))


def _mode_figure(plt, report: dict, model=None):
    """The fault-mode estimate (the paper's Fig. 8): the weighted residual cost, eq. (24), of every
    combination of the suspected mode variables on the identification window; the estimate is the
    lowest and is labelled so; the mode in force at the detection is marked where it differs (the
    report's ``mode`` is the estimate once a fault mode is diagnosed, so the mode at t_D is the
    estimate with each mode fault's variable switched back)."""
    from matplotlib.ticker import EngFormatter, LogLocator

    rows = report["mode_costs"]
    labels = [" ".join(f"{k}={v}" for k, v in r["mode"].items()) for r in rows]
    costs = [r["cost"] for r in rows]
    estimate = report.get("mode_estimate") or {}
    faults = getattr(model, "faults", {})
    faulted = {(faults[f["name"]].targets[0] if f["name"] in faults else f["name"]): f.get("value")
               for f in report["diagnosis"]["faults"] if f["type"] == "mode"}
    before = {k: (1 - v if k in faulted and v in (0, 1) else v) for k, v in estimate.items()}
    if not faulted:
        before = {k: report["mode"].get(k) for k in estimate}
    # a variable commanded to switch (its rows "commanded", fdi.results.COMMANDED, a text where the
    # others hold 0 or 1) was, at t_D, following its command; the estimate says whether it still does
    before.update({k: v for r in rows for k, v in r["mode"].items() if isinstance(v, str)})
    fig, ax = plt.subplots(figsize=(7, 0.5 * len(rows) + 1.6))
    is_estimate = [all(estimate.get(k) == v for k, v in r["mode"].items()) for r in rows]
    ax.barh(range(len(rows)), costs, color=["C3" if e else "C0" for e in is_estimate])
    ax.set_yticks(range(len(rows)), labels)
    for i, r in enumerate(rows):
        at_detection = all(before.get(k) == v for k, v in r["mode"].items())
        if is_estimate[i]:
            text = "  estimate (lowest cost)" + (": no mode change" if at_detection else ": a fault mode")
        elif at_detection:
            text = "  mode at t_D"
        else:
            continue
        ax.text(costs[i], i, text, va="center", fontsize=8)
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(EngFormatter())
    ax.xaxis.set_minor_locator(LogLocator(subs=(2.0, 3.0, 5.0)))   # minor ticks labelled, not crowded (9 k by 10 k)
    ax.xaxis.set_minor_formatter(EngFormatter())
    ax.set_xlabel("weighted residual cost, eq. (24) [-] (red: the estimate)")
    ax.set_title("fault-mode estimate", fontsize=9)
    fig.tight_layout()
    return fig


def plot_rul_cone(scores, path: str | Path, alpha: float = 0.2) -> Path:
    """RUL predictions of a suite against the time since each fault's onset, over the true RUL and
    its alpha cone (Saxena et al. 2010): one marker per prediction at 50 % and 90 % of life."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for s in scores:
        for fault in dict.fromkeys(r["fault"] for r in s.rul):
            points = []
            for r in s.rul:
                if r["fault"] == fault and r["rul"] is not None:
                    elapsed = r["fraction"] * r["true_rul"] / (1 - r["fraction"])   # life L: RUL* = (1 - f) L
                    life = elapsed + r["true_rul"]
                    points.append((elapsed / life, r["rul"] / life))
            if points:
                xs, ys = zip(*points)
                ax.plot(xs, ys, "o-", lw=0.8, label=f"{s.name} ({fault})")
    x = np.linspace(0, 1, 50)
    ax.plot(x, 1 - x, "k-", lw=1, label="true RUL")
    ax.fill_between(x, (1 - alpha) * (1 - x), (1 + alpha) * (1 - x), color="0.85", label=f"alpha = {alpha:g} cone")
    ax.set_xlabel("time since onset / life [-]")
    ax.set_ylabel("RUL / life [-]")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.5)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return Path(path)
