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
motor J_line -> J_motor e[8] = e[9]/Dm; f[9] = f[8]/Dm
"""
from __future__ import annotations

from bondgraph.model import Model

KINDS = ("TF", "MTF", "GY", "MGY")


def laws(model: Model) -> list[dict]:
    """Per two-port element, in the model's order: its name, kind, the node power comes from and
    the node it goes to, and its two laws as text (``e[4] = Dp*e[5]``)."""
    import sympy as sp

    from bondgraph.laws import bond_variables, solve_for, two_port_equations

    out = []
    for el in model.elements.values():
        if el.kind not in KINDS:
            continue
        ports = [(b.id, b.other(el.name), +1 if b.target == el.name else -1) for b in model.bonds_of(el.name)]
        if len(ports) != 2:
            continue
        (b_in, src, _), (b_out, dst, _) = sorted(ports, key=lambda p: -p[2])
        e_in, f_in = bond_variables(b_in)
        e_out, f_out = bond_variables(b_out)
        left = (e_in, f_out) if el.kind in ("TF", "MTF") else (e_in, e_out)
        text = []
        for eq, var in zip(two_port_equations(el, ports), left):
            value = solve_for(eq, var)
            text.append(f"{var} = {sp.sstr(value)}" if value is not None else f"{sp.sstr(eq.expr)} = 0")
        out.append({"name": el.name, "kind": el.kind, "from": src, "to": dst, "laws": text})
    return out
