"""LaTeX and DOT output (issue 13): beta subscripts as symbols, long ARRs broken, DOT line breaks."""
from __future__ import annotations

import sympy as sp

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.dot import to_dot
from bondgraph.dot import folds
from fdi.tables import LINE, _abbreviate, _display, _names, arr_latex, arr_latex_lines, arr_latex_parts, to_latex


def test_latex_writes_beta_theta1_as_a_subscripted_symbol(cycab, cycab_arrs):
    text = arr_latex(cycab_arrs[0])
    assert r"\beta_{\theta_{1}}" in text and "theta1" not in text
    assert r"\beta_{u_{in}}" in text                                      # not \beta_{u in}


def test_long_arrs_never_overflow_a_line(cycab, cycab_arrs):
    """Every line of an ARR, and every definition of a named sub-expression, is at most LINE
    characters of LaTeX; before, the CyCab's ARR3 had one fraction of 2 233 characters
    (pdflatex: Overfull hbox 947pt too wide; none now, checked with pdflatex 2022)."""
    for arr in cycab_arrs:
        lines, defs = arr_latex_parts(arr)
        assert all(len(line) <= LINE for line in lines), arr.name
        assert all(len(value) <= LINE for _, value in defs), arr.name
        assert lines == arr_latex_lines(arr)
        # the named form is the same expression: the definitions substituted back give the ARR
        e = _display(arr.expr, latex=True)
        named, abbreviations = _abbreviate(e, _names(e))
        for sym, value in reversed(abbreviations):
            named = named.xreplace({sym: value})
        assert sp.simplify(named - e) == 0, arr.name
    arr3 = arr_latex_parts(cycab_arrs[2])
    assert arr3[1] and len(arr_latex(cycab_arrs[2])) > 2000          # ARR3 needs names, and has them
    doc = to_latex(list(cycab_arrs), [], _empty_mcsm())
    assert r"\usepackage{amsmath}" in doc and doc.count(r"\mathrm{ARR") == 3
    assert doc.count(r"\begin{align}") == 3 == doc.count(r"\end{align}")   # a page may break between ARRs
    assert r"\text{where}\quad \xi_{1} &=" in doc


def _empty_mcsm():
    from types import SimpleNamespace
    return SimpleNamespace(columns=[], rows=[])


def test_dot_labels_break_lines_the_dot_way(cycab):
    dot = to_dot(cycab, assign(cycab, DIAGNOSIS))
    assert "\\n(" in dot and "\\\\n" not in dot                           # \n for graphviz, not a literal backslash


def test_a_long_chain_is_folded_into_columns(cycab):
    """The CyCab's chain of bonds (17 hops) drawn in columns (Graphviz: 949 x 759 px, was a strip
    of 235 x 960): its folding bonds do not constrain the ranks; a short model is not folded."""
    from bondgraph.examples import rc_parallel
    dot = to_dot(cycab, assign(cycab, DIAGNOSIS))
    assert len(folds(cycab)) == 2 and dot.count("constraint=false") == 2
    assert 'size="10,8"' in dot and "rankdir=TB" in dot
    small = rc_parallel()
    assert folds(small) == set() and "constraint=false" not in to_dot(small, assign(small, DIAGNOSIS))
