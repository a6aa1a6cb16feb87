"""LaTeX and DOT output (issue 13): beta subscripts as symbols, long ARRs broken, DOT line breaks."""
from __future__ import annotations

import sympy as sp

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.dot import to_dot
from fdi.tables import LINE, _display, _names, arr_latex, arr_latex_lines, to_latex


def test_latex_writes_beta_theta1_as_a_subscripted_symbol(cycab, cycab_arrs):
    text = arr_latex(cycab_arrs[0])
    assert r"\beta_{\theta_{1}}" in text and "theta1" not in text
    assert r"\beta_{u_{in}}" in text                                      # not \beta_{u in}


def test_long_arrs_break_between_terms(cycab, cycab_arrs):
    for arr in cycab_arrs:
        lines = arr_latex_lines(arr)
        assert len(lines) > 1 or len(arr_latex(arr)) <= LINE
        # a line longer than LINE holds one term only (a term is never split)
        e = _display(arr.expr, latex=True)
        terms = [sp.latex(t, symbol_names=_names(e)).lstrip("-").strip() for t in sp.Add.make_args(e)]
        for line in lines:
            if len(line) > LINE:
                assert any(line.lstrip("+- ") == t for t in terms)
    doc = to_latex(list(cycab_arrs), [], _empty_mcsm())
    assert r"\usepackage{amsmath}" in doc and doc.count(r"\mathrm{ARR") == 3


def _empty_mcsm():
    from types import SimpleNamespace
    return SimpleNamespace(columns=[], rows=[])


def test_dot_labels_break_lines_the_dot_way(cycab):
    dot = to_dot(cycab, assign(cycab, DIAGNOSIS))
    assert "\\n(" in dot and "\\\\n" not in dot                           # \n for graphviz, not a literal backslash
