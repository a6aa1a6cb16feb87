"""AGARRs and signature matrices as text, Markdown, LaTeX, JSON or CSV (``bgfdi tables``).

The JSON shape is fixed because other tools read it:
``{"arrs": [{"name", "sensor", "expr", "latex"}], "fsm": [{"mode", "columns", "rows": [{"fault",
"structural", "nominal", "Db"}]}], "mcsm": {"columns", "rows": [{"mode_change", "signature", "Db",
"Ib"}]}}``; ``expr`` is ``str(expr)``, which ``sympy.parsing.sympy_parser.parse_expr`` reads back
with signals as functions of t.
"""
from __future__ import annotations

import csv
import html
import io
import json
import re

import sympy as sp

from bondgraph.equations import is_signal

from .arrs import ARR
from .signatures import FSM, MCSM

FORMATS = ("text", "markdown", "latex", "json", "csv")
_DOTS = {1: "dot", 2: "ddot", 3: "dddot"}


def _display(expr: sp.Expr, latex: bool) -> sp.Expr:
    """Signals as plain symbols, derivatives as theta1' (text) or a dot accent (LaTeX)."""
    rep: dict[sp.Expr, sp.Expr] = {}
    rates = [d for d in expr.atoms(sp.Derivative) if not is_signal(d.expr)]
    for d in rates:         # the rate of an expression estimated on data (bondgraph.rates): d/dt(...)
        order = sum(c for _, c in d.variable_count)
        inner = _display(d.expr, latex)
        if latex:
            rep[d] = sp.Derivative(inner, (sp.Symbol("t"), order))
        else:
            rep[d] = sp.Function("d/dt" if order == 1 else f"d^{order}/dt^{order}")(inner)
    expr = expr.xreplace(rep)
    rep = {}
    for d in expr.atoms(sp.Derivative):
        if not is_signal(d.expr):
            continue
        name = d.expr.func.__name__
        order = sum(c for _, c in d.variable_count)
        if latex and order in _DOTS:
            m = re.match(r"^([A-Za-z]+?)(\d*)$", name)
            base, sub = (m.group(1), m.group(2)) if m else (name, "")
            rep[d] = sp.Symbol(f"{base}{_DOTS[order]}" + (f"_{sub}" if sub else ""))
        else:
            rep[d] = sp.Symbol(name + "'" * order)
    expr = expr.xreplace(rep)
    funcs = {f: sp.Symbol(f.func.__name__) for f in expr.atoms(sp.core.function.AppliedUndef) if is_signal(f)}
    return expr.xreplace(funcs)


def arr_text(arr: ARR) -> str:
    return str(_display(arr.expr, latex=False))


def _names(expr: sp.Expr) -> dict[sp.Symbol, str]:
    """LaTeX names: an efficiency factor beta_theta1 as \\beta_{\\theta_{1}} (sympy would write
    \\beta_{theta1}, the word), beta_u_in as \\beta_{u_{in}}."""
    out = {}
    for s in expr.free_symbols:
        if isinstance(s, sp.Symbol) and s.name.startswith("beta_") and len(s.name) > 5:
            out[s] = r"\beta_{" + sp.latex(sp.Symbol(s.name[5:])) + "}"
    return out


def arr_latex(arr: ARR) -> str:
    e = _display(arr.expr, latex=True)
    return sp.latex(e, symbol_names=_names(e))


LINE = 110      # characters of LaTeX per line of a broken ARR (a page holds about this much math)


def arr_latex_lines(arr: ARR) -> list[str]:
    """The ARR's terms in lines of about LINE characters (an align row each): a long ARR breaks
    between its terms instead of running off the page."""
    e = _display(arr.expr, latex=True)
    names = _names(e)
    terms = [sp.latex(t, symbol_names=names) for t in sp.Add.make_args(e)] if e.is_Add else [sp.latex(e, symbol_names=names)]
    lines, current = [], ""
    for k, t in enumerate(terms):
        piece = t if k == 0 else (f" - {t[1:].lstrip()}" if t.startswith("-") else f" + {t}")
        if current and len(current) + len(piece) > LINE:
            lines.append(current)
            current = piece.lstrip()
        else:
            current += piece
    lines.append(current)
    return lines


def _mode_label(mode: dict) -> str:
    return " ".join(f"{k}={v}" for k, v in mode.items()) or "(no modes)"


def _grid(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]
    line = lambda r: "  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip()
    return "\n".join([line(header), line(["-" * w for w in widths])] + [line(r) for r in rows])


def to_text(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    out = ["Augmented global analytical redundancy relations (residual = expression)", ""]
    for a in arrs:
        if a.origin == "SCAPH":
            out.append(f"{a.name}  [sensor {a.sensor} on junction {a.junction}]")
        elif a.origin == "SCAPH by mode":
            out.append(f"{a.name}  [sensor {a.sensor} on junction {a.junction}; each mode's own SCAPH ARR, "
                       "joined by mode indicators]")
        elif a.origin.endswith("+modes"):
            out.append(f"{a.name}  [{a.origin[:-6]} residual at {a.junction}; sensors {a.sensor}; rebuilt mode by "
                       "mode where the one-causality form is wrong]")
        else:
            how = "integrates states: " + ", ".join(str(x) for x, _ in a.states) if a.states else "derivative causality"
            out.append(f"{a.name}  [MSO of {len(a.equations)} equations, residual at {a.junction}; sensors "
                       f"{a.sensor}; {how}]")
        out.append(f"  0 = {arr_text(a)}")
        out.append("")
    for fsm in fsms:
        out.append(f"MD-FSM at mode {_mode_label(fsm.mode)}   (structural signature; nominal in brackets where it differs)")
        rows = []
        for r in fsm.rows:
            cells = [str(s) if s == n else f"{s} [{n}]" for s, n in zip(r.structural, r.nominal)]
            rows.append([r.fault] + cells + [str(r.Db)])
        out.append(_grid(["fault"] + list(fsm.columns) + ["Db"], rows))
        out.append("")
    out.append(f"MCSM (from mode {_mode_label(mcsm.mode)})")
    out.append(_grid(["mode change"] + list(mcsm.columns) + ["Db", "Ib"],
                     [[r.mode_change] + [str(s) for s in r.signature] + [str(r.Db), str(r.Ib)] for r in mcsm.rows]))
    return "\n".join(out) + "\n"


def to_markdown(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    out = ["## AGARRs", ""]
    for a in arrs:
        out.append(f"- **{a.name}** (sensor `{a.sensor}`): $0 = {arr_latex(a)}$")
    for fsm in fsms:
        out += ["", f"## MD-FSM at mode {_mode_label(fsm.mode)}", "",
                "| fault | " + " | ".join(fsm.columns) + " | Db |",
                "|---|" + "---|" * (len(fsm.columns) + 1)]
        for r in fsm.rows:
            cells = [str(s) if s == n else f"{s} ({n} nominal)" for s, n in zip(r.structural, r.nominal)]
            out.append(f"| {r.fault} | " + " | ".join(cells) + f" | {r.Db} |")
    out += ["", "## MCSM", "", "| mode change | " + " | ".join(mcsm.columns) + " | Db | Ib |",
            "|---|" + "---|" * (len(mcsm.columns) + 2)]
    for r in mcsm.rows:
        out.append(f"| {r.mode_change} | " + " | ".join(map(str, r.signature)) + f" | {r.Db} | {r.Ib} |")
    return "\n".join(out) + "\n"


def _html_table(caption: str, header: list[str], rows: list[list[str]]) -> str:
    esc = lambda x: html.escape(str(x))
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><caption>{esc(caption)}</caption><tr>{head}</tr>{body}</table>"


def fsm_html(fsm: FSM) -> str:
    """An MD-FSM as an HTML table (a notebook's view): the structural signature, the nominal one
    in brackets where it differs (a term that vanishes at the nominal values), Db."""
    rows = [[r.fault] + [str(s) if s == n else f"{s} [{n}]" for s, n in zip(r.structural, r.nominal)] + [r.Db]
            for r in fsm.rows]
    return _html_table(f"MD-FSM at mode {_mode_label(dict(fsm.mode))}", ["fault", *fsm.columns, "Db"], rows)


def mcsm_html(mcsm: MCSM) -> str:
    """The MCSM as an HTML table: each mode change's signature, Db and Ib."""
    rows = [[r.mode_change, *r.signature, r.Db, r.Ib] for r in mcsm.rows]
    return _html_table(f"MCSM from mode {_mode_label(dict(mcsm.mode))}", ["mode change", *mcsm.columns, "Db", "Ib"],
                       rows)


def _latex_escape(s: str) -> str:
    return s.replace("_", r"\_")


def to_latex(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    out = [r"% generated by bgfdi tables; needs \usepackage{amsmath} (align, \operatorname): e.g.",
           r"% \documentclass{article}\usepackage{amsmath}\begin{document} <this> \end{document}",
           r"\begin{align}"]
    for a in arrs:
        lines = arr_latex_lines(a)
        out.append(rf"  \mathrm{{{a.name}}}:\quad 0 &= {lines[0]} \\")
        out[-1] = out[-1].replace(r" \\", r" \nonumber \\") if len(lines) > 1 else out[-1]
        out += [rf"  &\quad {line} \nonumber \\" for line in lines[1:-1]]
        out += [rf"  &\quad {lines[-1]} \\"] if len(lines) > 1 else []   # the number on the ARR's last line
    out[-1] = out[-1].rstrip(" \\")
    out.append(r"\end{align}")
    for fsm in fsms:
        cols = len(fsm.columns) + 1
        out += ["", r"\begin{table}[ht]", r"\centering",
                rf"\caption{{MD-FSM at mode {_latex_escape(_mode_label(fsm.mode))}}}",
                r"\begin{tabular}{l" + "c" * cols + "}", r"\hline",
                "Fault & " + " & ".join(fsm.columns) + r" & $D_b$ \\", r"\hline"]
        for r in fsm.rows:
            cells = [str(s) if s == n else f"{s}$^*$" for s, n in zip(r.structural, r.nominal)]
            out.append(_latex_escape(r.fault) + " & " + " & ".join(cells) + rf" & {r.Db} \\")
        out += [r"\hline", r"\end{tabular}", r"\\[2pt] {\footnotesize $^*$ structural only: 0 at nominal values}",
                r"\end{table}"]
    out += ["", r"\begin{table}[ht]", r"\centering", r"\caption{MCSM}",
            r"\begin{tabular}{l" + "c" * (len(mcsm.columns) + 2) + "}", r"\hline",
            "Mode change & " + " & ".join(mcsm.columns) + r" & $D_b$ & $I_b$ \\", r"\hline"]
    for r in mcsm.rows:
        out.append(_latex_escape(r.mode_change) + " & " + " & ".join(map(str, r.signature)) + rf" & {r.Db} & {r.Ib} \\")
    out += [r"\hline", r"\end{tabular}", r"\end{table}"]
    return "\n".join(out) + "\n"


def to_dict(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> dict:
    return {
        "arrs": [{"name": a.name, "sensor": a.sensor, "expr": str(a.expr), "latex": arr_latex(a)} for a in arrs],
        "fsm": [{"mode": dict(f.mode), "columns": list(f.columns),
                 "rows": [{"fault": r.fault, "structural": list(r.structural), "nominal": list(r.nominal),
                           "Db": r.Db} for r in f.rows]} for f in fsms],
        "mcsm": {"columns": list(mcsm.columns),
                 "rows": [{"mode_change": r.mode_change, "signature": list(r.signature), "Db": r.Db, "Ib": r.Ib}
                          for r in mcsm.rows]},
    }


def to_json(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    return json.dumps(to_dict(arrs, fsms, mcsm), indent=1) + "\n"


def to_csv(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = list(fsms[0].columns if fsms else mcsm.columns)
    w.writerow(["table", "mode", "name", "signature"] + cols + ["Db", "Ib"])
    for f in fsms:
        for r in f.rows:
            w.writerow(["fsm", _mode_label(f.mode), r.fault, "structural"] + list(r.structural) + [r.Db, ""])
            w.writerow(["fsm", _mode_label(f.mode), r.fault, "nominal"] + list(r.nominal) + [int(any(r.nominal)), ""])
    for r in mcsm.rows:
        w.writerow(["mcsm", _mode_label(mcsm.mode), r.mode_change, "mode change"] + list(r.signature) + [r.Db, r.Ib])
    return buf.getvalue()


def render(fmt: str, arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    return {"text": to_text, "markdown": to_markdown, "latex": to_latex, "json": to_json,
            "csv": to_csv}[fmt](arrs, fsms, mcsm)
