"""LaTeX and DOT output (issue 13): beta subscripts as symbols, long ARRs broken, DOT line breaks."""
from __future__ import annotations

from bondgraph.causality import DIAGNOSIS, assign
from bondgraph.dot import to_dot
from fdi.tables import LINE, arr_latex, arr_latex_lines, to_latex


def test_latex_writes_beta_theta1_as_a_subscripted_symbol(cycab, cycab_arrs):
    text = arr_latex(cycab_arrs[0])
    assert r"\beta_{\theta_{1}}" in text and "theta1" not in text
    assert r"\beta_{u_{in}}" in text                                      # not \beta_{u in}


def test_long_arrs_break_between_terms(cycab, cycab_arrs):
    for arr in cycab_arrs:
        lines = arr_latex_lines(arr)
        assert len(lines) > 1 or len(arr_latex(arr)) <= LINE
        # every line but one that holds a single long term stays near the page width
        assert all(len(line) <= LINE + 40 or " + " not in line[1:] and " - " not in line[1:] for line in lines)
    doc = to_latex(list(cycab_arrs), [], _empty_mcsm())
    assert r"\usepackage{amsmath}" in doc and doc.count(r"\mathrm{ARR") == 3


def _empty_mcsm():
    from types import SimpleNamespace
    return SimpleNamespace(columns=[], rows=[])


def test_dot_labels_break_lines_the_dot_way(cycab):
    dot = to_dot(cycab, assign(cycab, DIAGNOSIS))
    assert "\\n(" in dot and "\\\\n" not in dot                           # \n for graphviz, not a literal backslash
