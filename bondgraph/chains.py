"""Generated chain models for benchmarks, as model YAML text: a drivetrain of n stages
(:func:`chain_yaml`, symbolic derivation) and n measured tanks in series (:func:`tank_chain_yaml`,
residual selection).

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


def tank_chain_yaml(n_tanks: int, sensor_faults: bool = True) -> str:
    """``n_tanks`` tanks in series (the three-tank benchmark's build, lengthened): a pump into tank
    1, valve i between tanks i and i+1, a linear outlet on the last tank, and a pressure sensor on
    every tank. Faults on every tank capacitance, valve, the outlet and the pump, and (with
    ``sensor_faults``) every sensor. Tank i's mass balance is
    ``q_{i-1} - CT_i dp_i/dt - q_i = 0`` with ``q_i = (p_i - p_{i+1})/Rv_i``, ``q_0`` the pump flow
    and ``q_n = p_n/Rv_n`` the outlet."""
    n = max(1, int(n_tanks))
    lines = [f"name: tank_chain_{n}", "parameters:"]
    for i in range(1, n + 1):
        lines += [f"  CT{i}: {{value: 1.5698e-6, unit: m^3/Pa}}", f"  Rv{i}: {{value: 1.0e8, unit: Pa*s/m^3}}"]
    lines += ["data: {columns: [t, q0, " + ", ".join(f"p{i}" for i in range(1, n + 1)) + "], sampling_time: 0.1}",
              "inputs:", "  q0: {column: q0, unit: m^3/s, expr: '1.0e-5*(1 + 0.3*sin(0.01*t))'}",
              "elements:", "  pump: {type: MSf, input: q0}"]
    junctions, sensors, bonds, faults = ["junctions:"], ["sensors:"], ["bonds:", "  1: [pump, J1]"], ["faults:"]
    faults.append("  f_pump: {kind: source, source: q0}")
    bid = 1
    for i in range(1, n + 1):
        last = i == n
        lines.append(f"  tank{i}: {{type: C, parameter: CT{i}}}")
        lines.append(f"  valve{i}: {{type: R, parameter: Rv{i}}}")
        junctions.append(f"  J{i}: {{type: '0'}}")
        sensors.append(f"  p{i}: {{type: De, junction: J{i}, column: p{i}, unit: Pa, noise: 5.0}}")
        faults.append(f"  fT{i}: {{kind: parametric, parameters: [CT{i}]}}")
        faults.append(f"  fV{i}: {{kind: parametric, parameters: [Rv{i}]}}")
        if sensor_faults:
            faults.append(f"  fp{i}: {{kind: sensor, sensor: p{i}}}")
        bonds.append(f"  {bid + 1}: [J{i}, tank{i}]")
        bid += 1
        if last:
            bonds.append(f"  {bid + 1}: [J{i}, valve{i}]")
            bid += 1
        else:
            junctions.append(f"  V{i}: {{type: '1'}}")
            bonds += [f"  {bid + 1}: [J{i}, V{i}]", f"  {bid + 2}: [V{i}, valve{i}]", f"  {bid + 3}: [V{i}, J{i + 1}]"]
            bid += 3
    return "\n".join(lines + junctions + sensors + bonds + faults) + "\n"
