"""The two-port elements' laws as ``check`` prints them: each TF's and GY's (and modulated one's)
equations in its model's bond numbers, from :func:`bondgraph.laws.two_port_equations` (the one
statement of them), with the junctions it joins. Why: a transformer's modulus is read from its
first bond to its second (e1 = m e2, f2 = m f1, docs/model-format.md), and a hydraulic motor written
line to shaft with m = Dm, as its pump shaft to line, gives residuals that read wm/Dm where
wm = Q/Dm was meant (found writing the hydrostatic transmission, tests/data/); this line shows it
before any residual is read.

>>> from bondgraph.loader import load_model
>>> for p in laws(load_model("tests/data/hydrostatic_transmission.yaml")):
...     print(p["name"], p["from"], "->", p["to"], "; ".join(p["laws"]))
pump J_pump -> J_line e[4] = Dp*e[5]; f[5] = Dp*f[4]
motor J_line -> J_motor e[8] = (1/Dm)*e[9]; f[9] = (1/Dm)*f[8]
"""
from __future__ import annotations

import functools
import re

from bondgraph.model import Model

KINDS = ("TF", "MTF", "GY", "MGY")
_TOKEN = re.compile(r"MODULUS_|[ef]\[[12]\]")


@functools.lru_cache(maxsize=None)
def _template(kind: str) -> tuple[str, ...]:
    """A two-port kind's laws as text on bonds 1 (power in) and 2 (out) and a placeholder modulus,
    from bondgraph.laws (each element's laws printed by sympy took 0.45 ms: 1.1 s for the 2 499
    transformers of a 10 000-element chain, where ``check`` must stay within 10 s)."""
    import sympy as sp

    from bondgraph.laws import bond_variables, solve_for, two_port_equations
    from bondgraph.model import Element

    e1, f1 = bond_variables(1)
    e2, f2 = bond_variables(2)
    eqs = two_port_equations(Element("_", kind, modulus=sp.Symbol("MODULUS_")), [(1, "a", +1), (2, "b", -1)])
    left = (e1, f2) if kind in ("TF", "MTF") else (e1, e2)
    return tuple(f"{var} = {sp.sstr(solve_for(eq, var))}" for eq, var in zip(eqs, left))


def laws(model: Model) -> list[dict]:
    """Per two-port element, in the model's order: its name, kind, the node power comes from and
    the node it goes to, and its two laws as text (``e[4] = Dp*e[5]``; a modulus other than a
    name or a number in parentheses)."""
    import sympy as sp

    at: dict[str, list] = {}                     # each two-port's bonds, in one pass over the bonds
    for b in model.bonds:
        for node, sign in ((b.target, +1), (b.source, -1)):
            if node in model.elements and model.elements[node].kind in KINDS:
                at.setdefault(node, []).append((b.id, b.other(node), sign))
    out = []
    for el in model.elements.values():
        ports = at.get(el.name, [])
        if el.kind not in KINDS or len(ports) != 2:
            continue
        (b_in, src, _), (b_out, dst, _) = sorted(ports, key=lambda p: -p[2])
        m = el.modulus
        text = sp.sstr(m) if isinstance(m, (sp.Symbol, sp.Number)) else f"({sp.sstr(m)})"
        names = {"MODULUS_": text, "e[1]": f"e[{b_in}]", "f[1]": f"f[{b_in}]", "e[2]": f"e[{b_out}]",
                 "f[2]": f"f[{b_out}]"}
        out.append({"name": el.name, "kind": el.kind, "from": src, "to": dst,
                    "laws": [_TOKEN.sub(lambda t: names[t.group(0)], law) for law in _template(el.kind)]})
    return out
