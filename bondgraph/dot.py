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


def to_dot(model: Model, causality: Causality) -> str:
    # rankdir LR lays a chain of elements out as a strip; TB with a size and ratio keeps a model of a
    # few dozen nodes on a page
    lines = [f"digraph {_quote(model.name)} {{", "  rankdir=TB; ratio=compress; size=\"8,10\";",
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
        lines.append(f"  {_quote(src)} -> {_quote(dst)} [dir=both, arrowhead={head}, arrowtail={tail}{label}{style}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
