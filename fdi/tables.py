"""AGARRs and signature matrices as text, Markdown, LaTeX, JSON or CSV (``bgfdi tables``).

The JSON shape is fixed because other tools read it:
``{"arrs": [{"name", "sensor", "expr", "latex"}], "fsm": [{"mode", "columns", "rows": [{"fault",
"structural", "nominal", "Db"}]}], "mcsm": {"columns", "rows": [{"mode_change", "signature", "Db",
"Ib"}]}}``; ``expr`` is ``str(expr)``, which ``sympy.parsing.sympy_parser.parse_expr`` reads back
with signals as functions of t.

A current source feeding a capacitor and a resistor in parallel, its voltage measured: the AGARR
is Kirchhoff's current law, each measurement divided by its efficiency factor and the source
multiplied by its own.

>>> from bondgraph.examples import rc_parallel
>>> from fdi.scaph import derive_arrs
>>> m = rc_parallel()
>>> arr_text(derive_arrs(m)[0])
"-C1*v'/beta_v + beta_i_in*i_in - v/(R*beta_v)"
"""
from __future__ import annotations

import csv
import io
import json

import sympy as sp

from .notation import display as _display, expr_latex, expr_text, latex_names as _names
from .scaph import ARR
from .signatures import FSM, MCSM, _mode_label

FORMATS = ("text", "markdown", "latex", "json", "csv")


def arr_text(arr: ARR) -> str:
    """The ARR's expression as one line of text (:func:`fdi.notation.expr_text`)."""
    return expr_text(arr.expr)


def arr_latex(arr: ARR) -> str:
    """The ARR's expression in LaTeX (:func:`fdi.notation.expr_latex`)."""
    return expr_latex(arr.expr)


LINE = 110      # characters of LaTeX per line of a broken ARR (a page holds about this much math)


def arr_latex_lines(arr: ARR) -> list[str]:
    """The ARR's terms in lines of about LINE characters (an align row each): a long ARR breaks
    between its terms instead of running off the page. A term longer than a line (a fraction or
    a product cannot be broken inside) has sub-expressions named first (:func:`arr_latex_parts`);
    this gives the lines of the named form, without the definitions."""
    return arr_latex_parts(arr)[0]


MIN_NAMED = 30  # characters of LaTeX: a shorter sub-expression (1/beta, xi^2 + 1) is not worth a name


def _abbreviate(e: sp.Expr, names: dict, limit: int = LINE) -> tuple[sp.Expr, list[tuple[sp.Symbol, sp.Expr]]]:
    """``e`` with sub-expressions named xi_1, xi_2 ... until every term of it is at most ``limit``
    characters of LaTeX, and the definitions in order (each one line: a named sub-expression is
    chosen no longer than ``limit``). The sub-expression named first is the one that saves the most
    characters, its length times how often it occurs (so a repeated tan(theta2/beta) goes before
    a long part that occurs once)."""
    def size(x: sp.Expr) -> int:
        return len(sp.latex(x, symbol_names=names))

    taken = {str(s) for s in e.free_symbols}
    defs: list[tuple[sp.Symbol, sp.Expr]] = []
    for _ in range(200):                      # each step shortens the longest term; 200 is far more than needed
        long = [t for t in sp.Add.make_args(e) if size(t) > limit]
        if not long:
            break
        term = max(long, key=size)
        counts: dict[sp.Expr, int] = {}
        for sub in sp.preorder_traversal(e):
            counts[sub] = counts.get(sub, 0) + 1
        candidates = [x for x in set(sp.preorder_traversal(term))
                      if x is not term and not x.is_Atom and MIN_NAMED <= size(x) <= limit]
        k = len(defs) + 1
        while f"xi_{k}" in taken:
            k += 1
        sym = sp.Symbol(f"xi_{k}")
        taken.add(sym.name)
        if not candidates:        # a sum or product of many short parts: name its first parts that fit a line
            sums = [x for x in sp.preorder_traversal(term) if (x.is_Add or x.is_Mul) and size(x) > limit]
            if not sums:
                break
            whole = min(sums, key=size)
            chunk: list[sp.Expr] = []
            for arg in whole.args:
                if len(chunk) >= 2 and size(whole.func(*chunk, arg)) > limit:
                    break
                chunk.append(arg)
            if len(chunk) == len(whole.args):
                break
            defs.append((sym, whole.func(*chunk)))
            e = e.xreplace({whole: whole.func(sym, *whole.args[len(chunk):])})
            continue
        best = max(candidates, key=lambda x: (size(x) * counts.get(x, 1), size(x)))
        negated = best.is_Mul and best.args[0] == -1          # -J1*theta1''/k3 named for J1*theta1''/k3
        defs.append((sym, -best if negated else best))
        e = e.xreplace({best: -sym if negated else sym})
    return e, defs


def arr_latex_parts(arr: ARR) -> tuple[list[str], list[tuple[str, str]]]:
    """The ARR's lines (see :func:`arr_latex_lines`) and its named sub-expressions as (name,
    LaTeX) pairs: the CyCab's ARR3, whose first term is one fraction of 2 233 characters, becomes
    lines of at most LINE characters with a few definitions, each one line."""
    e = _display(arr.expr, latex=True)
    names = _names(e)
    e, defs = _abbreviate(e, names)
    terms = [sp.latex(t, symbol_names=names) for t in sp.Add.make_args(e)] if e.is_Add else [sp.latex(e, symbol_names=names)]
    return _pack(terms), [(sp.latex(s), sp.latex(x, symbol_names=names)) for s, x in defs]


def _pack(terms: list[str]) -> list[str]:
    """Terms joined with their signs into lines of at most about LINE characters."""
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
        elif " in mode " in a.origin:
            out.append(f"{a.name}  [{a.origin.split(' in mode ')[0]} residual of mode {a.origin.split(' in mode ')[1]}'s "
                       f"own bond graph at {a.junction}; sensors {a.sensor}; times the mode's indicator: 0 in the "
                       "other modes]")
        elif a.origin.endswith("+zero"):
            base = (f"sensor {a.sensor} on junction {a.junction}" if a.origin.startswith("SCAPH")
                    else f"{a.origin[:-5]} residual at {a.junction}; sensors {a.sensor}")
            out.append(f"{a.name}  [{base}; where the junction is switched off the one-causality form is 0 = 0 and "
                       f"the sensor reads 0: that zero joined by the mode's indicator]")
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


def _latex_escape(s: str) -> str:
    return s.replace("_", r"\_")


def to_latex(arrs: list[ARR], fsms: list[FSM], mcsm: MCSM) -> str:
    out = [r"% generated by bgfdi tables; needs \usepackage{amsmath} (align, \operatorname): e.g.",
           r"% \documentclass{article}\usepackage{amsmath}\begin{document} <this> \end{document}",
           r"\begin{align}"]
    for a in arrs:
        lines, defs = arr_latex_parts(a)
        out.append(rf"  \mathrm{{{a.name}}}:\quad 0 &= {lines[0]} \\")
        out[-1] = out[-1].replace(r" \\", r" \nonumber \\") if len(lines) > 1 else out[-1]
        out += [rf"  &\quad {line} \nonumber \\" for line in lines[1:-1]]
        out += [rf"  &\quad {lines[-1]} \\"] if len(lines) > 1 else []   # the number on the ARR's last line
        for k, (name, value) in enumerate(defs):      # named sub-expressions, one line each, unnumbered
            lead = r"\text{where}\quad " if k == 0 else ""
            out.append(rf"  {lead}{name} &= {value} \nonumber \\")
        out[-1] = out[-1].rstrip(" \\")
        out += [r"\end{align}", r"\begin{align}"]       # one align per ARR: a page may break between them
    out = out[:-1]
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
