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


def _tank_links(i: int, last: bool, bid: int, junctions: list[str], bonds: list[str]) -> int:
    """Tank i's bonds in a chain of tanks: its 0-junction to its capacitance, then to its valve (the
    last tank's outlet) or, through a 1-junction, its valve and the next tank. Returns the last
    bond number used."""
    bonds.append(f"  {bid + 1}: [J{i}, tank{i}]")
    if last:
        bonds.append(f"  {bid + 2}: [J{i}, valve{i}]")
        return bid + 2
    junctions.append(f"  V{i}: {{type: '1'}}")
    bonds += [f"  {bid + 2}: [J{i}, V{i}]", f"  {bid + 3}: [V{i}, valve{i}]", f"  {bid + 4}: [V{i}, J{i + 1}]"]
    return bid + 4


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
        lines.append(f"  tank{i}: {{type: C, parameter: CT{i}}}")
        lines.append(f"  valve{i}: {{type: R, parameter: Rv{i}}}")
        junctions.append(f"  J{i}: {{type: '0'}}")
        sensors.append(f"  p{i}: {{type: De, junction: J{i}, column: p{i}, unit: Pa, noise: 5.0}}")
        faults.append(f"  fT{i}: {{kind: parametric, parameters: [CT{i}]}}")
        faults.append(f"  fV{i}: {{kind: parametric, parameters: [Rv{i}]}}")
        if sensor_faults:
            faults.append(f"  fp{i}: {{kind: sensor, sensor: p{i}}}")
        bid = _tank_links(i, i == n, bid, junctions, bonds)
    return "\n".join(lines + junctions + sensors + bonds + faults) + "\n"


PUMP = "1.0e-5*(1 + 0.1*sin(0.01*t))"    # m^3/s, the pump of fault_chain_yaml


def fault_chain_yaml(n_tanks: int, threshold: float = 3.0e-6) -> str:
    """``n_tanks`` tanks in series for diagnosis benchmarks: a pump into tank 1, linear valves
    between the tanks and a linear outlet on the last, a pressure sensor on every tank and one
    fault candidate per tank capacitance (``fT<i>``), so that a capacitance fault anywhere is
    isolated to its tank by the balance of that tank alone:
    ``ARR_i = q_{i-1} - CT_i dp_i/dt - (p_i - p_{i+1})/Rv_i`` (``q_0`` the pump, ``p_{n+1} = 0``).

    Every tank has CT = 1e-5 m^3/Pa and Rv = 1e6 Pa s/m^3 (a time constant of 10 s) and starts
    at the equilibrium of the mean pump flow (``initial``: volumes CT*p_i, p_i = (n - i + 1) Rv q0).
    A capacitance fault shows as a jump of its tank's pressure (the stored volume is continuous)
    and the relaxation after it; the pump's slow swing alone does not reach the middle of a long
    chain (a chain of RC stages is a low-pass line).

    >>> "fT2: {kind: parametric, parameters: [CT2]}" in fault_chain_yaml(3)
    True
    """
    n = max(1, int(n_tanks))
    q0 = 1.0e-5
    lines = [f"name: fault_chain_{n}", "parameters:"]
    for i in range(1, n + 1):
        lines += [f"  CT{i}: {{value: 1.0e-5, unit: m^3/Pa}}", f"  Rv{i}: {{value: 1.0e6, unit: Pa*s/m^3}}"]
    lines += ["data: {columns: [t, q0, " + ", ".join(f"p{i}" for i in range(1, n + 1)) + "], sampling_time: 0.5}",
              "inputs:", f"  q0: {{column: q0, unit: m^3/s, expr: '{PUMP}'}}",
              "elements:", "  pump: {type: MSf, input: q0}"]
    junctions, sensors, bonds, faults = ["junctions:"], ["sensors:"], ["bonds:", "  1: [pump, J1]"], ["faults:"]
    initial, thresholds = ["initial:"], []
    bid = 1
    for i in range(1, n + 1):
        lines += [f"  tank{i}: {{type: C, parameter: CT{i}}}", f"  valve{i}: {{type: R, parameter: Rv{i}}}"]
        junctions.append(f"  J{i}: {{type: '0'}}")
        sensors.append(f"  p{i}: {{type: De, junction: J{i}, column: p{i}, unit: Pa, noise: 0.1}}")
        faults.append(f"  fT{i}: {{kind: parametric, parameters: [CT{i}]}}")
        initial.append(f"  tank{i}: {1.0e-5 * (n - i + 1) * 1.0e6 * q0:.6g}")    # q = CT p at the mean flow
        thresholds.append(f"ARR{i}: {threshold:g}")
        bid = _tank_links(i, i == n, bid, junctions, bonds)
    settings = ["thresholds: {" + ", ".join(thresholds) + "}",
                "diagnosis: {waiting_time: 20.0, derivative_window: 5.0, samples: 400}"]
    return "\n".join(lines + junctions + sensors + bonds + faults + settings + initial) + "\n"
