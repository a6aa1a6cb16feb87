"""Graphviz DOT of a bond graph with its causality: half-arrows for power, bars for causal strokes.

Elements are drawn as ``TYPE:name``, junctions as 0/1 (controlled ones boxed, with their mode
variable), sensors as De/Df in dashed outline. Each bond carries its id; the causal stroke sits at
the end that receives the effort (Graphviz arrow shape ``tee``).
"""
from __future__ import annotations

from .causality import Causality
from .model import Model


def _quote(s: str) -> str:
    """A DOT string: backslashes and quotes escaped, a line break as DOT's own \\n."""
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


RANKS_PER_COLUMN = 7      # a power chain longer than this many bond hops is folded into columns


def _spine(model: Model) -> list[str]:
    """The longest chain of bonds (a path of the bond graph taken undirected): its two ends by two
    breadth-first searches, the path between them."""
    adj: dict[str, list[str]] = {}
    for b in model.bonds:
        adj.setdefault(b.source, []).append(b.target)
        adj.setdefault(b.target, []).append(b.source)

    def farthest(start: str) -> tuple[str, dict[str, str | None]]:
        parent: dict[str, str | None] = {start: None}
        queue, last = [start], start
        while queue:
            nxt = []
            for n in queue:
                for m in adj.get(n, ()):
                    if m not in parent:
                        parent[m] = n
                        nxt.append(m)
            if nxt:
                last = nxt[-1]
            queue = nxt
        return last, parent

    if not adj:
        return []
    end, _ = farthest(model.bonds[0].source)
    other, parent = farthest(end)
    path = [other]
    while parent[path[-1]] is not None:
        path.append(parent[path[-1]])
    return path


def folds(model: Model, per_column: int = RANKS_PER_COLUMN) -> set[frozenset]:
    """The bonds of the longest chain where the drawing starts a new column: every ``per_column``
    hops, in as many columns as make the page about as wide as it is tall (the CyCab's chain of 17
    hops in 3 columns). Graphviz lays a chain out as one rank per hop, a strip 235 x 960 px for
    the CyCab; a bond drawn with ``constraint=false`` no longer ranks its head below its tail, so
    the chain after it starts again at the top, beside the part before it."""
    spine = _spine(model)
    hops = len(spine) - 1
    if hops <= per_column + 2:
        return set()
    columns = -(-hops // per_column)
    length = -(-hops // columns)
    return {frozenset((spine[i - 1], spine[i])) for i in range(length, hops, length)}


def to_dot(model: Model, causality: Causality) -> str:
    """The DOT text: top to bottom, a long chain folded into columns (:func:`folds`), on a page of
    at most 10 x 8 inches (landscape: a screen or a slide)."""
    cut = folds(model)
    lines = [f"digraph {_quote(model.name)} {{", "  rankdir=TB; size=\"10,8\"; ratio=compress; nodesep=0.35; fontname=Helvetica;",
             "  node [fontname=Helvetica, shape=plaintext];",
             "  edge [fontname=Helvetica, fontsize=10];",
             f"  label={_quote(f'{model.name}: {causality.purpose} causality')}; labelloc=t;"]
    for e in model.elements.values():
        storage = causality.storage.get(e.name)
        extra = f"\n({storage})" if storage else ""
        lines.append(f"  {_quote(e.name)} [label={_quote(e.kind + ':' + e.name + extra)}];")
    for j in model.junctions.values():
        if j.controlled:
            lines.append(f"  {_quote(j.name)} [label={_quote(j.kind + ' (' + str(j.mode) + ')')}, shape=box, "
                         "style=rounded, color=red];")
        else:
            lines.append(f"  {_quote(j.name)} [label={_quote(j.kind)}, tooltip={_quote(j.name)}];")
    for s in model.sensors.values():
        lines.append(f"  {_quote(s.name)} [label={_quote(s.kind + ':' + s.name)}, shape=box, style=dashed];")
    bonds = [(b.id, b.source, b.target, False) for b in model.bonds]
    bonds += [(s.name, s.junction, s.name, True) for s in model.sensors.values()]
    for key, src, dst, signal in bonds:
        receiver = causality.effort_to.get(key)
        head = ("tee" if receiver == dst else "") + ("lvee" if not signal else "normal")
        tail = "tee" if receiver == src else "none"
        style = ", style=dashed" if signal else ""
        label = "" if signal else f", label={_quote(str(key))}"
        fold = ", constraint=false, color=gray40" if frozenset((src, dst)) in cut else ""
        lines.append(f"  {_quote(src)} -> {_quote(dst)} [dir=both, arrowhead={head}, arrowtail={tail}{label}{style}{fold}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
