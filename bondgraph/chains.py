"""Generated chain models for benchmarks: a drivetrain of n stages, as model YAML text.

Stage i is a 1-junction with an inertia I_i and a friction R_i (viscous + Coulomb), coupled to
the next stage by a transformer. A torque source drives stage 1; one Df sensor measures the speed
of the last stage, so the single AGARR collects every element of the chain along one causal path
(the hardest case for an equation deriver: expressions grow with n). The torque is sin(t), so
the chain can be simulated too (state equations of n/4 coupled inertias).
"""
from __future__ import annotations


def chain_yaml(n_elements: int) -> str:
    """A chain with about ``n_elements`` elements and junctions (4 per stage)."""
    stages = max(1, n_elements // 4)
    lines = ["name: chain_%d" % n_elements, "parameters:"]
    for i in range(1, stages + 1):
        lines += [f"  J{i}: {{value: {1e-3 * i:.6g}, unit: kg*m^2}}",
                  f"  b{i}: {{value: {1e-2 * i:.6g}, unit: N*m*s/rad}}",
                  f"  c{i}: {{value: {1e-3:.6g}, unit: N*m}}",
                  f"  n{i}: {{value: {1.0 + 0.01 * i:.6g}, unit: '-'}}"]
    lines += ["data: {columns: [t, u, w]}", "inputs:", "  u: {column: u, unit: N*m, expr: 'sin(t)'}",
              "elements:", "  src: {type: MSe, input: u}"]
    junctions, bonds = ["junctions:"], ["bonds:"]
    bid = 1
    bonds.append(f"  {bid}: [src, j1]")
    for i in range(1, stages + 1):
        lines += [f"  I{i}: {{type: I, parameter: J{i}}}",
                  f"  R{i}: {{type: R, effort: 'b{i}*f + c{i}*sign(f)'}}"]
        junctions.append(f"  j{i}: {{type: '1'}}")
        bonds += [f"  {bid + 1}: [j{i}, I{i}]", f"  {bid + 2}: [j{i}, R{i}]"]
        bid += 2
        if i < stages:
            lines.append(f"  T{i}: {{type: TF, modulus: n{i}}}")
            bonds += [f"  {bid + 1}: [j{i}, T{i}]", f"  {bid + 2}: [T{i}, j{i + 1}]"]
            bid += 2
    sensors = ["sensors:", f"  w: {{type: Df, junction: j{stages}, column: w, unit: rad/s}}"]
    return "\n".join(lines + junctions + sensors + bonds) + "\n"
