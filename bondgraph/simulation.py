"""Simulation in integral causality, with dependent storage, switching and time-varying faults.

The state is the energy variable of every storage element in integral causality (p of an I, q of
a C) plus the time integral of every sensor that measures a displacement or a momentum (so that a
modulated element such as F1(theta2) can use it). Storage elements that SCAP leaves in derivative
causality are *dependent*: their effort (or flow) is d/dt of an expression of the states, which
puts the state derivatives on both sides of the state equations. The equations are therefore
derived as ``A(x, t) x' = b(x, t)`` (linear in x', checked symbolically), and x' is obtained at
every step by a linear solve: the exact reduction to an ODE, never an approximation.

Structure follows the parameters: a resistor whose flow law is identically zero at the current
parameter values (a healthy leakage with R4 = inf) is an open circuit (a zero flow source) in
that *configuration*. When a fault makes it finite, causality is assigned again for the new
configuration and the state is carried over: states that exist in both keep their values, new
ones start from the values their variables had just before the switch (p = I f, q = C e).
Mode variables (controlled junctions) are inputs of the equations; the diagnostic hybrid bond graph
form (outputs x a) serves every mode with one causality.

The ODE is solved piece by piece between breakpoints (fault instants, switching instants), each
piece with its parameters' one-sided limits at its ends (a profile's value at a switching instant
may be the other side's: R4 = inf at an intermittent leak's switch, where eq. 15 gives the mean,
and at an incipient leak's onset): by ROS2, a fixed-step L-stable Rosenbrock-W method, when the equations are
discontinuous (Coulomb friction, leakage: see ``simulate``), otherwise by scipy's LSODA; Radau, BDF
or RK45 on request. ROS2 watches its own steps and takes backward Euler where a stiff law has no
slope to linearise (a leak at zero flow, right after it opens or as the pressure reverses): see
``_ros2``.
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Callable, Iterator, Mapping, Sequence

import numpy as np
import sympy as sp

from .causality import SIMULATION, assign
from .deep import collector_paused
from .equations import relations, resolve
from .linear import Linear
from .program import Line, Program, compile_lines, linear_coefficients, needed_lines, substitute, triangular_order
from .errors import CausalityError
from .laws import bond_variables, resistor_equation, solve_for, storage_equations
from .model import Element, Model, t
from .timescales import model_integration_step


class SimulationError(Exception):
    """The model cannot be simulated as given (the message says why and what to change).
    ``where``: the model file's key at fault when the model itself is the cause (an input without
    an expression, an algebraic loop: ``"elements"``), None when the run is (its span, its values):
    a caller names the model file or the scenario accordingly. ``stalled``: an error-controlled
    integrator gave up (a fixed-step method may pass; the caller says how to ask for one)."""

    def __init__(self, message: str, where: str | None = None, stalled: bool = False) -> None:
        super().__init__(message)
        self.where = where
        self.stalled = stalled


@dataclass
class System:
    """The reduced state equations of one configuration, compiled to Python functions.

    ``prepare(p)`` extends a parameter vector by the terms that depend on parameters only; with
    that, ``f(t, x, c)`` gives x' (tuples in, a list out; plain ``math``, one call per evaluation)
    and ``step`` is one ROS2 step of :func:`_ros2`. ``observe(t, x, p, dx)`` gives the outputs,
    then the energy variables, elementwise over arrays of samples (numpy)."""
    states: list[str]                 # storage elements in integral causality, then sensor integrals
    kinds: list[str]                  # 'storage' | 'sensor'
    open_resistors: frozenset[str]
    prepare: Callable                 # p -> c: parameters and the terms computed from them only
    f: Callable                       # (t, x, c) -> x'
    step: Callable                    # (t0, t1, h, x, W, c0, c1) -> x after one ROS2 step (W flat, row-major)
    observe: Callable                 # (t, x, p, dx) -> outputs, then the energy of every storage element
    output_names: list[str]           # sensor true values, then storage flows/efforts
    param_names: list[str]
    storage_names: list[str]
    discontinuous: bool               # sign/abs/heaviside in the equations (Coulomb friction, leakage)
    full: Callable | None = None      # (t, x, c) -> x' and the torn variables of algebraic loops

    def rates(self, t: float, x: np.ndarray, params: Sequence[float]) -> np.ndarray:
        """x' and the unknowns of the algebraic loops at one instant (what ``observe`` takes)."""
        g = self.full or self.f
        return np.asarray(g(t, tuple(x), self.prepare(params)), dtype=float).reshape(-1)

    def derivative(self, t: float, x: np.ndarray, params: Sequence[float]) -> np.ndarray:
        """x' at one instant."""
        return np.asarray(self.f(t, tuple(x), self.prepare(params)), dtype=float).reshape(-1)

    def outputs(self, t: float, x: np.ndarray, params: Sequence[float], dx: np.ndarray) -> np.ndarray:
        """Outputs (``output_names``) at one instant."""
        return self._observed(t, x, params, dx)[:len(self.output_names)]

    def energy(self, t: float, x: np.ndarray, params: Sequence[float], dx: np.ndarray) -> np.ndarray:
        """Energy variable of every storage element (``storage_names``) at one instant."""
        return self._observed(t, x, params, dx)[len(self.output_names):]

    def _observed(self, t, x, params, dx) -> np.ndarray:
        return np.array([float(v) for v in self.observe(t, tuple(x), tuple(params), tuple(dx))])


def _specialise(model: Model, values: Mapping[str, float]) -> tuple[Model, frozenset[str]]:
    """Resistors whose flow law (their law solved for f, :func:`bondgraph.laws.resistor_equation`)
    vanishes at these values become open circuits (Sf: 0)."""
    subs = {model.symbols[k]: (sp.oo if np.isinf(v) else sp.Float(v)) for k, v in values.items() if k in model.symbols}
    opened = set()
    elements = dict(model.elements)
    for e in model.elements.values():
        if e.kind != "R":
            continue
        law = solve_for(resistor_equation(model, e, e.name), bond_variables(e.name)[1])
        if law is not None and _vanishes(law.xreplace(subs)):
            opened.add(e.name)
            elements[e.name] = Element(e.name, "Sf", value=sp.Integer(0), description=f"{e.name} open (infinite)")
    if not opened:
        return model, frozenset()
    return replace(model, elements=elements), frozenset(opened)


def _configure(model: Model, values: Mapping[str, float]) -> tuple[Model, frozenset[str], tuple]:
    """The configuration these values imply: open resistors (:func:`_specialise`) and, where the
    model has controlled junctions that switch as physical switches (``switched_off: all``), the
    plain bond graph of the current mode (:func:`bondgraph.modes.in_mode`): its switched-off
    junctions become zero sources, which are opened as a zero resistor is. Returns the model of
    the configuration, its opened elements and a key for the compiled system."""
    switched = [j for j in model.junctions.values() if j.controlled and j.off == "all"]
    mode = ()
    if switched:
        from .modes import in_mode
        names = sorted({s.name for j in switched for s in model.symbols[j.mode].free_symbols})
        mode = tuple((n, int(round(float(values[n])))) for n in names)
        graph = in_mode(model, dict(mode))
        zero_sources = frozenset(e for e in graph.model.elements if e not in model.elements)
        model = graph.model
    else:
        zero_sources = frozenset()
    spec, opened = _specialise(model, values)
    opened = opened | zero_sources
    return spec, opened, (opened, mode)


def _vanishes(law: sp.Expr) -> bool:
    """Whether a law is identically zero. A value clearly off zero at a sample point (evaluated
    to 50 digits, so that rounding cannot fake one) proves it is not, the common case, decided
    without sympy's ``simplify``; otherwise simplify decides."""
    if law == 0:
        return True
    free = sorted(law.free_symbols, key=str)
    for sample in (sp.Rational(7, 10), sp.Rational(-13, 10), sp.Rational(29, 10)):
        value = law.xreplace({s: sample * (k + 1) for k, s in enumerate(free)}).evalf(50)
        if value.is_number and value.is_finite and abs(complex(value)) > 1e-30:
            return False
    return sp.simplify(law) == 0


def _inlined(program: Program, expr: sp.Expr) -> sp.Expr:
    """``expr`` with the program's names replaced by their lines (a :class:`Linear` one as the sum it
    stands for), down to states, parameters, inputs and time. The lines it needs are found back from
    it, then replaced in the program's order (no recursion: a chain of thousands of lines)."""
    lines = {name: line.as_expr() if isinstance(line, Linear) else line for name, line in program.lines}
    expr = sp.sympify(expr)
    needed, todo = set(), [x for x in expr.free_symbols if x in lines]
    while todo:
        x = todo.pop()
        if x in needed:
            continue
        needed.add(x)
        todo += [y for y in lines[x].free_symbols if y in lines and y not in needed]
    done: dict[sp.Symbol, sp.Expr] = {}
    for name, _ in program.lines:
        if name in needed:
            line = lines[name]
            done[name] = line.xreplace({y: done[y] for y in line.free_symbols if y in done})
    return expr.xreplace({x: done[x] for x in expr.free_symbols if x in done})


def _signal_laws(spec: Model, names: list[str]) -> str:
    """Why a model whose element laws read measured signals the simulator cannot compute (an
    effort or a flow sensor's reading: it integrates displacements and momenta) is not simulated,
    naming the elements (a trial's brake law kb*pc*tanh(w/w0) on the caliper pressure pc)."""
    wanted = {spec.symbols[n] for n in names if n in spec.symbols}
    users = [e.name for e in spec.elements.values()
             if any(isinstance(x, sp.Basic) and x.free_symbols & wanted
                    for x in (*e.laws.values(), e.modulus, e.value))]
    where = f"element(s) {', '.join(users)} read" if users else "a modulated element reads"
    return (f"{where} the measured signal(s) {', '.join(names)}, whose readings the simulator cannot compute "
            "from its states without those laws (a loop through the sensor, or a rate): give the signal as "
            "an input (a column), or read a signal the states set (the effort of a 0-junction that holds a "
            "capacitance in integral causality, the flow of a 1-junction that holds an inertia)")


def build_system(model: Model, values: Mapping[str, float]) -> System:
    """Derive and compile the state equations of the configuration these parameter values imply."""
    with collector_paused():     # bondgraph.deep: 0.63 -> 0.54 s CPU for a 2000-element chain, peak memory alike
        return _build(*_configure(model, values)[:2])


def _known_values(spec: Model, opened: frozenset[str]) -> dict[str, sp.Expr]:
    """What each source imposes (beta times its input expression or value); sensors impose nothing."""
    known: dict[str, sp.Expr] = {}
    for e in spec.sources():
        if e.name in opened:
            known[e.name] = sp.Integer(0)
            continue
        if e.input:
            inp = spec.inputs[e.input]
            if inp.expr is None:
                raise SimulationError(f"input '{e.input}' has no expr: give inputs.{e.input}.expr (a function of t) "
                                      "to simulate", where=f"inputs.{e.input}")
            base = inp.expr
        else:
            base = e.value
            silent = sorted(i for i in spec.inputs if spec.inputs[i].expr is None
                            and spec.symbols[i] in base.free_symbols)
            if silent:            # (the value's inputs are put in with the laws' signals: _build)
                raise SimulationError(f"source '{e.name}' reads input '{silent[0]}', which has no expr: give "
                                      f"inputs.{silent[0]}.expr (a function of t) to simulate",
                                      where=f"inputs.{silent[0]}")
        known[e.name] = spec.symbols[f"beta_{e.input or e.name}"] * base
    for s in spec.sensors.values():
        known[s.name] = sp.Integer(0)
    return known


def _bonds_of(spec: Model, elements: list[Element]) -> dict[str, int]:
    """The bond of each of these one-port elements (one pass over the bonds)."""
    names = {e.name for e in elements}
    found: dict[str, list[int]] = {n: [] for n in names}
    for x in spec.bonds:
        for end in {x.source, x.target} & names:
            found[end].append(x.id)
    return {n: b for n, (b,) in found.items()}


def _build(spec: Model, opened: frozenset[str], read: Mapping[sp.Symbol, sp.Expr] | None = None) -> System:
    """The state equations of one configuration (a model with its open resistors replaced), as a
    straight-line program (:mod:`bondgraph.program`): derived, reduced and compiled in time linear
    in the size of the model. A law that reads an effort or flow sensor's signal (a thermostat's
    lift on the measured coolant temperature, a brake's torque on the caliper pressure) reads what
    the states give that sensor (the temperature q/C of the engine's capacitance on its 0-junction):
    derived once with the signal unknown, its reading from the states then put in (``read``) and
    derived again; where the reading itself needs the law (a loop through the sensor) or a rate, the
    model is refused (:func:`_signal_laws`)."""
    causality = assign(spec, SIMULATION)
    bad = [p for p in causality.problems if "dependent storage" not in p]
    if bad:
        raise CausalityError(bad + list(causality.loops))
    storage = [e for e in spec.elements.values() if e.kind in ("C", "I")]
    integral = [e for e in storage if causality.storage[e.name] == "integral"]
    integrals = [s for s in spec.sensors.values() if s.measures in ("displacement", "momentum")]
    X = {e.name: sp.Function(f"x_{e.name}", real=True)(t) for e in integral}
    X.update({s.name: sp.Function(f"x_{s.name}", real=True)(t) for s in integrals})
    signals = {spec.symbols[s.name]: X[s.name] for s in integrals}
    for s in spec.sensors.values():
        if spec.symbols[s.name] not in signals:
            signals[spec.symbols[s.name]] = sp.Symbol(f"__signal_{s.name}")   # an error below if used
    signals.update({spec.symbols[i]: spec.inputs[i].expr for i in spec.inputs if spec.inputs[i].expr is not None})
    signals.update(read or {})
    # a source's value may read inputs and sensors as the laws do (a heater's Joule heat U**2/Rh on
    # the measured mains voltage): the same signals put in
    known = {k: v.xreplace(signals) for k, v in _known_values(spec, opened).items()}
    rels = relations(spec, causality, known=known,
                     states={e.name: X[e.name] for e in integral}, signals=signals)
    rels, torn = _tear(rels) if causality.loops else (rels, [])
    bond = _bonds_of(spec, storage)
    wanted = [("e" if e.kind == "I" else "f", bond[e.name]) for e in integral]
    wanted += [("e", s.name) if s.kind == "De" else ("f", s.name) for s in spec.sensors.values()]
    flows = [("f" if e.kind == "I" else "e", bond[e.name]) for e in storage]
    program = Program()
    loop_inputs = [i for _, r in torn for i in r.inputs]
    try:
        values_ = resolve(rels, wanted + flows + loop_inputs, program=program)
    except ValueError as exc:
        raise SimulationError(str(exc), where="elements") from None
    # each torn variable z of an algebraic loop: its own law once more, z = g(..., z), an unknown
    # solved with the state derivatives (linear loops; the solver's linear system)
    z_fun = [z for z, _ in torn]
    z_sym = [sp.Symbol(f"_z{k}") for k in range(len(torn))]
    loop_laws = [program.name(r.law(*[values_[i] for i in r.inputs])) for _, r in torn]
    if z_fun and any(line.has(sp.Derivative) and any(line.has(sp.Derivative(z, t)) for z in z_fun)
                     for _, line in program.lines if not isinstance(line, Linear)):
        raise SimulationError("a storage element in derivative causality needs the rate of a variable of an "
                              "algebraic loop; bgfdi solves loops for values only: add a small storage element "
                              "to break the loop", where="elements")
    n_st = len(integral)
    sensor_vals = {s.name: values_[w] for s, w in zip(spec.sensors.values(), wanted[n_st:])}
    derivs = [values_[w] for w in wanted[:n_st]] + [sensor_vals[s.name] for s in integrals]
    states = [e.name for e in integral] + [s.name for s in integrals]
    n = len(states)
    x_sym = [sp.Symbol(f"_x{i}") for i in range(n)]
    dx_sym = [sp.Symbol(f"_dx{i}") for i in range(n)]
    residual = [program.name(d) for d in derivs] + loop_laws
    outputs = [sensor_vals[s] for s in spec.sensors] + [values_[f] for f in flows]
    outputs += [_energy(spec, e, var).xreplace(signals) for e, var in zip(storage, outputs[len(spec.sensors):])]
    used = set().union(*(e.free_symbols for _, e in program.lines), *(e.free_symbols for e in outputs))
    leftovers = sorted(s.name[9:] for s in used if s.name.startswith("__signal_"))
    if leftovers:
        given = dict(read or {})
        readings = {n: _inlined(program, sensor_vals[n]) for n in leftovers if n in sensor_vals}
        unknown = {sp.Symbol(f"__signal_{n}"): spec.symbols[n] for n in readings}
        progress = True
        while progress:              # each reading the states give, the readings known so far put in
            progress = False         # (a chain of readings: resolved here, derived again once)
            for name, reading in readings.items():
                if spec.symbols[name] in given:
                    continue
                reading = readings[name] = reading.xreplace(
                    {x: given[s] for x, s in unknown.items() if s in given and x in reading.free_symbols})
                if not reading.has(sp.Derivative) and not any(
                        x.name.startswith("__signal_") for x in reading.free_symbols):
                    given[spec.symbols[name]] = reading
                    progress = True
        if len(given) == len(read or {}):     # none more: a loop through a sensor, or a rate
            raise SimulationError(_signal_laws(spec, leftovers), where="elements")
        return _build(spec, opened, given)
    params = sorted({s for s in used if not s.name.startswith("__v") and s != t and s not in z_sym}
                    | {spec.symbols[k] for k in spec.parameters} | {spec.symbols[m] for m in spec.modes}
                    | {spec.symbols[f"beta_{e.input or e.name}"] for e in spec.sources() if e.name not in opened},
                    key=lambda s: s.name)
    p_sym = [sp.Symbol(f"_p{i}") for i in range(len(params))]
    t_sym = sp.Symbol("_t")
    # one pass over the lines: d/dt of a state first (xreplace matches a node before its arguments),
    # then states, parameters and time as plain symbols of the generated code
    mapping = {sp.Derivative(X[s], t): d for s, d in zip(states, dx_sym)}
    mapping |= {X[s]: x for s, x in zip(states, x_sym)} | dict(zip(z_fun, z_sym)) | dict(zip(params, p_sym))
    mapping |= {t: t_sym}
    # a line that became an atom is folded: its name goes into the mapping, for the outputs too (a trial's
    # three-cell pack read a folded name in its observer: NameError '__v0' ended simulate)
    lines, mapping = substitute(program.lines, mapping)
    outputs = [e.xreplace(mapping) for e in outputs]
    residual = [r.xreplace(mapping) for r in residual]        # names, or atoms such as a parameter
    unknowns = dx_sym + z_sym
    try:
        coeff_lines, grad = linear_coefficients(lines, unknowns)
    except ValueError:
        if torn:
            raise SimulationError("algebraic loop through " + ", ".join(f"{v[0]}{v[1]}" for v, _ in
                                  ((r.output, r) for _, r in torn)) + " is nonlinear; bgfdi solves linear loops: "
                                  "add a storage element (a small capacitance or inertia) to break it", where="elements") from None
        raise SimulationError("the state equations are not linear in the state derivatives; "
                              "this dependent storage cannot be reduced", where="elements") from None
    coefficients = {i: {unknowns.index(u): c for u, c in grad.get(r, {}).items()} for i, r in enumerate(residual)}
    at_rest, folded = substitute(lines + coeff_lines, {d: sp.Integer(0) for d in unknowns})
    residual = [r.xreplace(folded) for r in residual]
    coefficients = {i: {j: c.xreplace(folded) for j, c in row.items()} for i, row in coefficients.items()}
    at_rest = needed_lines(at_rest, residual + [c for row in coefficients.values() for c in row.values()])
    full, prepare = _solver(at_rest, residual, coefficients, (t_sym, x_sym, p_sym))
    f = full if not torn else _leading(full, n)
    step = _step_function(f, n, n_st)
    observe = compile_lines([t_sym, x_sym, p_sym, unknowns], lines, outputs, "numpy")
    discontinuous = any(e.has(sp.sign, sp.Abs, sp.Heaviside) for _, e in at_rest)
    return System(states, ["storage"] * n_st + ["sensor"] * len(integrals), opened, prepare, f, step, observe,
                  list(spec.sensors) + [f"flow_{e.name}" for e in storage], [p.name for p in params],
                  [e.name for e in storage], discontinuous, full)


def _leading(full: Callable, n: int) -> Callable:
    """x' alone from a function that also gives the torn variables of algebraic loops."""
    def f(t_: float, x: tuple, c: tuple):
        return list(full(t_, x, c))[:n]
    return f


def _tear(rels: list) -> tuple[list, list]:
    """Algebraic loops of the relations broken open: in each cycle of the causal dependencies one
    variable (the output of a linear law where there is one) is computed from an unknown z
    instead of its law; returns the relations and the torn ones, (z, relation), whose law gives
    the loop's equation z = law(...). A cycle through a differentiation is no algebraic loop and
    is left for resolve to report."""
    import networkx as nx
    from .equations import Relation

    by_output = {r.output: r for r in rels}
    torn: list = []
    for _ in range(len(rels)):
        g = nx.DiGraph()
        g.add_edges_from((i, r.output) for r in by_output.values() for i in r.inputs)
        try:
            cycle = [u for u, _ in nx.find_cycle(g)]
        except nx.NetworkXNoCycle:
            break
        candidates = [v for v in cycle if v in by_output and not by_output[v].derivative]
        if not candidates:
            break
        v = next((c for c in candidates if by_output[c].coefficients is not None), candidates[0])
        z = sp.Function(f"_z{len(torn)}", real=True)(t)      # of time: a rate asked of it shows
        torn.append((z, by_output[v]))
        by_output[v] = Relation(v, (), lambda z=z: z)
    return list(by_output.values()), torn


def _energy(spec: Model, e: Element, var: sp.Expr) -> sp.Expr:
    """The energy variable of a storage element (p of an I, q of a C) from its flow or effort:
    its law solved for it (:func:`bondgraph.laws.storage_equations`); nan where the law has no
    inverse."""
    x, (law, _rate) = storage_equations(spec, e, e.name)
    effort, flow = bond_variables(e.name)
    energy = solve_for(law, x)
    return sp.nan if energy is None else energy.xreplace({flow if e.kind == "I" else effort: var})


def _solver(lines: list[Line], residual: list[sp.Expr], coefficients: dict[int, dict[int, sp.Expr]],
            args: tuple) -> tuple[Callable, Callable]:
    """x' from x' = r(x) + G(x) x' (``lines`` evaluated at x' = 0, G sparse in ``coefficients``).

    When no cycle couples the x' (always so for independent storage, where G = 0), each x'_i is
    solved in turn, (r_i + sum_j G_ij x'_j) / (1 - G_ii), as more lines of one compiled function.
    Otherwise G is evaluated and (I - G) x' = r solved numerically at every call. Returns f(t, x, c)
    and prepare(p) -> c: the lines that depend on parameters only are computed by prepare, once
    per parameter vector, instead of at every evaluation."""
    n = len(residual)
    t_sym, x_sym, p_sym = args
    order = triangular_order(coefficients, n)
    if order is not None:
        outputs = [sp.Symbol(f"_xd{i}") for i in range(n)]
        lines = list(lines)
        for i in order:
            row = coefficients[i]
            rest = sp.Add(residual[i], *[c * outputs[j] for j, c in row.items() if j != i])
            lines.append((outputs[i], rest / (1 - row[i]) if i in row else rest))
    else:
        entries = [(i, j, c) for i, row in coefficients.items() for j, c in row.items()]
        outputs = residual + [c for _, _, c in entries]
        rows, cols = [i for i, _, _ in entries], [j for _, j, _ in entries]
    constant, varying = _split_constant(needed_lines(lines, outputs), p_sym)
    used = set().union(*(e.free_symbols for _, e in varying), *(o.free_symbols for o in outputs))
    names = [s for s, _ in constant if s in used]             # what f reads of them, not every step
    computed = compile_lines([p_sym], constant, names, "math")

    def prepare(p: Sequence[float]) -> tuple:
        return (*p, *computed(tuple(p)))
    raw = compile_lines([t_sym, x_sym, list(p_sym) + names], varying, outputs, "math")
    if order is not None:
        return raw, prepare

    def f(t_: float, x: tuple, c: tuple) -> np.ndarray:
        values = raw(t_, x, c)
        A = np.eye(n)
        A[rows, cols] -= values[n:]
        return np.linalg.solve(A, values[:n])
    return f, prepare


def _split_constant(lines: list[Line], params: Sequence[sp.Symbol]) -> tuple[list[Line], list[Line]]:
    """The lines that depend on parameters only (and on such lines), and the others."""
    known = set(params)
    constant, varying = [], []
    for name, expr in lines:
        if expr.free_symbols <= known:
            constant.append((name, expr))
            known.add(name)
        else:
            varying.append((name, expr))
    return constant, varying


UNROLLED = 12     # up to this many states a ROS2 step is generated as scalar code, beyond it uses numpy
GAMMA = 1.0 + 1.0 / 2.0 ** 0.5      # ROS2's gamma (L-stable)
LINEARITY = 4.0   # a step whose stage 2 misses the Jacobian's prediction by more than this many x' is redone
SLACK = 1e-3      # ... unless the miss would move the state by less than this fraction of itself per step
STIFF = 10.0      # a flagged step ending where h * (spectral radius of J) exceeds this is redone by backward Euler
EDGE = 1e-9       # s: parameters at a piece's ends are its one-sided limits, taken this far inside


def _step_function(f: Callable, n: int, checked: int | None = None) -> Callable:
    """One ROS2 step (see :func:`_ros2`): k1 = W f(t0, x), k2 = W (f(t1, x + h k1) - 2 k1),
    x + h (3 k1 + k2) / 2, with W flat (row-major). Returns the new state and whether the
    Jacobian behind W held along the step: stage 2 evaluates b = f(t1, x + h k1), which the
    Jacobian J of W predicts as a + h J k1 = a + (k1 - a)/gamma (from (I - gamma h J) k1 = a,
    a = f(t0, x)); the step is flagged when, for some state, the miss exceeds LINEARITY |a| +
    SLACK |x| / h (NaN fails). That happens when the stiffness grew since J was formed (a leak whose
    flow left zero: d(R4^2 f|f|)/df = 2 R4^2 |f|), where the W-method turns unstable once the true
    stiffness exceeds some 4 times J's, and at a Coulomb friction reversal, where a fresh J changes
    nothing. A few hundred of the 60 000 steps of a CyCab run are flagged. Only the first
    ``checked`` states (default all) are checked: the storage states, where stiff modes live; the
    sensor integrals after them are quadratures of those.
    For a few states the products with W are generated as scalar Python (no array per stage: a
    step costs little more than its two calls of f); for many, numpy does them."""
    q, ig = 1.0 - 1.0 / GAMMA, 1.0 / GAMMA
    m = n if checked is None else checked
    if n > UNROLLED or n == 0:
        def step(t0: float, t1: float, h: float, x: tuple, W: tuple, p0: tuple, p1: tuple) -> tuple[tuple, bool]:
            Wm = np.asarray(W).reshape(n, n)
            xv = np.asarray(x)
            a = np.asarray(f(t0, x, p0))
            k1 = Wm @ a
            b = np.asarray(f(t1, tuple(xv + h * k1), p1))
            k2 = Wm @ (b - 2.0 * k1)
            ok = bool(np.all((np.abs(b - q * a - ig * k1) <= LINEARITY * np.abs(a) + SLACK / h * np.abs(xv))[:m]))
            return tuple(xv + h * (1.5 * k1 + 0.5 * k2)), ok
        return step
    r = range(n)
    xs, ws = [f"x{i}" for i in r], [f"w{i}_{j}" for i in r for j in r]
    lines = ["def step(t0, t1, h, x, W, p0, p1):",
             f"    {', '.join(xs)}, = x",
             f"    {', '.join(ws)}, = W",
             f"    {', '.join(f'a{i}' for i in r)}, = f(t0, x, p0)"]
    lines += [f"    k{i} = " + " + ".join(f"w{i}_{j}*a{j}" for j in r) for i in r]
    lines += [f"    {', '.join(f'b{i}' for i in r)}, = f(t1, ({''.join(f'x{i} + h*k{i}, ' for i in r)}), p1)"]
    lines += [f"    c{i} = " + " + ".join(f"w{i}_{j}*(b{j} - 2.0*k{j})" for j in r) for i in r]
    lines += [f"    s = {SLACK!r}/h",
              "    ok = (" + " and\n          ".join(
                  f"abs(b{i} - {q!r}*a{i} - {ig!r}*k{i}) <= {LINEARITY!r}*abs(a{i}) + s*abs(x{i})"
                  for i in range(m)) + ")" if m else "    ok = True"]
    lines += [f"    return ({''.join(f'x{i} + h*(1.5*k{i} + 0.5*c{i}), ' for i in r)}), ok"]
    namespace = {"f": f}
    exec("\n".join(lines), namespace)
    return namespace["step"]


@dataclass
class Trajectory:
    t: np.ndarray
    signals: dict[str, np.ndarray]         # true sensor values and inputs
    states: dict[str, np.ndarray]
    configurations: list[tuple[float, frozenset[str]]]


def simulate(model: Model, t_eval: np.ndarray, *, values: Callable[[float], Mapping[str, float]],
             breakpoints: Sequence[float] = (), initial: Mapping[str, float] | None = None,
             method: str = "auto", max_step: float | None = None, progress: Callable[[float], None] | None = None,
             vectorised: bool = False, stages: dict[str, float] | None = None,
             tolerances: tuple[float, float] = (1e-6, 1e-9), autonomous: bool = True) -> Trajectory:
    """Simulate on ``t_eval``. ``values(t)`` gives every parameter, efficiency factor and mode
    variable at time t (faults included); ``breakpoints`` are the instants where they jump. With
    ``vectorised``, ``values`` also takes an array of times and gives arrays (or constants): the
    parameters are then tabulated once per piece instead of once per step.

    ``method``: a scipy ``solve_ivp`` method (LSODA, Radau, BDF for stiff problems; RK45), ``ros2``
    (fixed-step L-stable Rosenbrock-W, step ``max_step``, by default the sampling time or a twentieth
    of the model's fastest time constant, the shorter: :func:`bondgraph.timescales.integration_step`), or ``auto``: ros2 when the
    equations are discontinuous (Coulomb friction sign(v), leakage sqrt|dp|: error-controlled
    methods stall at the switching surface when a velocity sticks near zero, and a leak makes the
    problem stiff; a fixed step bounds the chatter to F_c/J * h, far below sensor resolution),
    LSODA otherwise. ``tolerances``: rtol and atol of the scipy methods (a leak makes the pressure
    so sensitive to the flows, dp = R4^2 f|f|, that checking it takes far tighter ones).

    ``stages``: if given, the CPU seconds of each stage are added to it: ``build`` (state
    equations), ``integrate``, ``outputs``. ``autonomous``: False holds every autonomous mode at the
    value ``values`` gives (a diode held conducting: what checking each mode's ARRs needs)."""
    clock = _StageClock(stages)
    initial = consistent_readings(model, dict(initial or {}))
    t_eval = np.asarray(t_eval, dtype=float)
    edges = sorted({float(t_eval[0]), float(t_eval[-1])} | {float(b) for b in breakpoints if t_eval[0] < b < t_eval[-1]})
    cache: dict[frozenset, System] = {}
    ros2_step = max_step      # the caller's step, else the model's (bondgraph.timescales.integration_step)
    max_step = max_step or float(np.min(np.diff(t_eval))) if t_eval.size > 1 else None
    pieces: list[tuple[System, np.ndarray, np.ndarray, tuple[float, float], Callable]] = []
    configs: list[tuple[float, frozenset[str]]] = []
    system: System | None = None
    x = None
    span = (edges[0], edges[0])
    auto = _Autonomous(model if autonomous else None)
    queue = [(a, b) for a, b in zip(edges[:-1], edges[1:])]
    queue.reverse()
    restarts = 0
    while queue:
        a, b = queue.pop()
        if auto and b > a:
            inside = t_eval[(t_eval > a) & (t_eval < b)]
            if inside.size > AUTONOMOUS_CHUNK:         # short chunks: a switch found costs one chunk again
                cut = float(inside[AUTONOMOUS_CHUNK])
                queue.append((cut, b))
                b = cut
        vals = auto.values(values)
        spec, opened, key = _configure(model, vals(0.5 * (a + b)))
        if key not in cache:
            with clock("build"):
                cache[key] = _build(spec, opened)
        new = cache[key]
        # the piece's parameters are their limits from inside it: at a switching instant a profile
        # may give the other side's value, or a mean (R4 = inf at the onset of a leak)
        previous, span = span, (a + min(EDGE, 0.25 * (b - a)), b - min(EDGE, 0.25 * (b - a)))
        # a state new in this configuration starts on the constraint that just ended (an opened
        # leak with no flow yet): the first step is then one of backward Euler (see _ros2)
        fresh_states = system is not None and bool(set(new.states) - set(system.states))
        if system is None:
            x = _initial_state(new, initial, a, vals(span[0]))
            if auto and restarts < 4 and auto.settle(new, a, x, vals(span[0])):
                restarts += 1                          # the initial state decides the autonomous modes
                system, span = None, (edges[0], edges[0])
                queue.append((a, b))
                continue
        elif new is not system:
            x = _carry_over(system, new, x, a, last_values(previous[1]))
        if new is not system:
            configs.append((a, new.open_resistors))
        system, last_values = new, vals
        mask = (t_eval >= a) & ((t_eval < b) | (b == edges[-1]))
        pts = t_eval[mask]
        table = _ParameterTable(vals, system.param_names, vectorised, span)
        how = method if method != "auto" else ("ros2" if system.discontinuous else "LSODA")
        with clock("integrate"):
            if how == "ros2":
                ros2_step = ros2_step or model_integration_step(model, max_step or np.inf)
                sol = _ros2(system, table, a, b, x, pts, ros2_step, implicit_start=fresh_states)
            else:
                sol = _scipy(system, table, how, a, b, x, pts, max_step, tolerances)
        x = sol.end
        if auto and pts.size > 1:
            k = auto.first_switch(system, sol.t, sol.y, table)
            if k is not None:                          # a diode stopped or started conducting at pts[k]
                sol = _Solution(sol.t[:k + 1], sol.y[:, :k + 1], sol.y[:, k])
                x = sol.end
                queue.append((float(sol.t[-1]), b))
                b = float(sol.t[-1])
                auto.switch(system, sol.t[-1:], sol.y[:, -1:], table)
        if pts.size:
            keep = sol.t.size if not (auto and queue and sol.t.size and sol.t[-1] == b) else sol.t.size - 1
            if keep:
                pieces.append((system, sol.t[:keep], sol.y[:, :keep], span, vals))
        if progress:
            progress(b)
    with clock("outputs"):
        return _trajectory(model, pieces, vectorised, configs)


AUTONOMOUS_CHUNK = 64    # output points integrated at a time while a mode follows the state


class _Autonomous:
    """The autonomous modes of a model (a diode conducting while its current is positive) as the
    simulation decides them: their values now, the parameter function with them in, and where in
    a stretch of solution a condition changes sign (the stretch is then cut there and the model
    switched: an event located to one output point)."""

    def __init__(self, model: Model | None):
        self.model = model
        self.modes = {m.name: m for m in model.modes.values() if m.autonomous} if model is not None else {}
        self.now = {n: float(m.nominal) for n, m in self.modes.items()}
        self._conditions = {}
        for n, m in self.modes.items():
            syms = sorted(m.positive.free_symbols, key=lambda x: x.name)
            self._conditions[n] = ([x.name for x in syms], sp.lambdify(syms, m.positive, modules="numpy"))
        self._inputs = {}                      # each input's expression, a function of t and the parameters
        if model is not None:
            for name, i in model.inputs.items():
                if i.expr is not None:
                    params = sorted(i.expr.free_symbols - {t}, key=lambda x: x.name)
                    self._inputs[name] = ([p.name for p in params],
                                          sp.lambdify([t] + params, i.expr, modules="numpy"))

    def __bool__(self) -> bool:
        return bool(self.modes)

    def values(self, values: Callable) -> Callable:
        fixed = dict(self.now)

        def merged(tt):
            out = dict(values(tt))
            out.update(fixed)
            return out
        return merged

    def _states(self, system: System, ts: np.ndarray, ys: np.ndarray, table: "_ParameterTable") -> dict[str, np.ndarray]:
        """Each autonomous condition's on/off at the points ``ts`` of a solution."""
        P = table.rows(ts)
        dx = np.array([system.rates(tt, y, p) for tt, y, p in zip(ts, ys.T.tolist(), P.tolist())],
                      dtype=float).reshape(len(ts), -1)
        observed = system.observe(ts, tuple(ys), tuple(P.T), tuple(dx.T))
        signals = {name: np.broadcast_to(np.asarray(v, dtype=float), ts.shape)
                   for name, v in zip(system.output_names, observed)}
        for s in self.model.sensors.values():      # a displacement or momentum sensor reads its state
            if s.measures in ("displacement", "momentum") and s.name in system.states:
                signals[s.name] = np.asarray(ys[system.states.index(s.name)], dtype=float)
        for name in self.model.sensors:
            signals.setdefault(name, np.zeros(ts.shape))
        params = dict(zip(system.param_names, P.T))
        for name, (names, f) in self._inputs.items():
            args = [params[p] if p in params else 0.0 for p in names]
            signals[name] = np.broadcast_to(np.asarray(f(ts, *args), dtype=float), ts.shape)
        out = {}
        for n, (names, f) in self._conditions.items():
            args = [signals[x] if x in signals else params.get(x, 0.0) for x in names]
            out[n] = np.asarray(f(*args), dtype=float) > 0
        return out

    def first_switch(self, system: System, ts: np.ndarray, ys: np.ndarray, table) -> int | None:
        """The first point (after the first) where some condition disagrees with its mode now."""
        states = self._states(system, ts, ys, table)
        hits = [int(np.argmax(on[1:] != bool(self.now[n]))) + 1 for n, on in states.items()
                if np.any(on[1:] != bool(self.now[n]))]
        return min(hits) if hits else None

    def switch(self, system: System, ts: np.ndarray, ys: np.ndarray, table) -> None:
        """Every autonomous mode set as its condition is at the (one) point given."""
        for n, on in self._states(system, ts, ys, table).items():
            self.now[n] = float(on[-1])

    def settle(self, system: System, t0: float, x: np.ndarray, vals: Mapping[str, float]) -> bool:
        """Set the modes from the initial state; whether any changed (the system is then rebuilt)."""
        before = dict(self.now)
        table = _ParameterTable(lambda tt: vals, system.param_names, False)
        self.switch(system, np.array([t0]), np.asarray(x, dtype=float).reshape(-1, 1), table)
        return self.now != before


class _StageClock:
    """Adds the CPU time of ``with clock(stage):`` blocks to a dict, when one is given."""

    def __init__(self, stages: dict[str, float] | None):
        self.stages = stages

    @contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        start = time.process_time()
        try:
            yield
        finally:
            if self.stages is not None:
                self.stages[stage] = self.stages.get(stage, 0.0) + time.process_time() - start


class _ParameterTable:
    """The parameter vectors of one system at given instants: one call of ``values`` on an array
    of times when it is vectorised, otherwise one call per instant (the last one remembered:
    integrators ask the same instant repeatedly). Instants are clipped into ``span`` (the piece,
    shrunk by EDGE at both ends), so that a piece never sees the value a profile takes at the
    switching instant that bounds it."""

    def __init__(self, values: Callable, names: list[str], vectorised: bool,
                 span: tuple[float, float] = (-np.inf, np.inf)):
        self.values, self.names, self.vectorised = values, names, vectorised
        self.span = span
        self._last: tuple[float | None, tuple] = (None, ())

    def at(self, tt: float) -> tuple:
        """The parameters at one instant."""
        tt = min(max(tt, self.span[0]), self.span[1])
        if self._last[0] != tt:
            v = self.values(tt)
            self._last = (tt, tuple(float(v[n]) for n in self.names))
        return self._last[1]

    def rows(self, times: np.ndarray) -> np.ndarray:
        """The parameters at every instant of ``times``, (len(times), len(names))."""
        if not self.vectorised:
            return np.array([self.at(float(tt)) for tt in times]).reshape(len(times), len(self.names))
        times = np.clip(times, *self.span)
        v = self.values(times)
        return np.column_stack([np.broadcast_to(np.asarray(v[n], dtype=float), times.shape) for n in self.names]
                               ) if self.names else np.zeros((len(times), 0))

    def prepared(self, times: np.ndarray, prepare: Callable[[tuple], tuple]) -> list[tuple]:
        """``prepare(p)`` at every instant of ``times``, computed once per run of instants with
        the same parameters (the whole piece but for a time-varying fault)."""
        table = self.rows(times)
        if not len(table):
            return []
        same = (table[1:] == table[:-1]) | (np.isnan(table[1:]) & np.isnan(table[:-1]))
        firsts = np.flatnonzero(np.r_[True, ~np.all(same, axis=1)])
        out: list[tuple] = []
        for first, count in zip(firsts.tolist(), np.diff(np.r_[firsts, len(table)]).tolist()):
            out += [prepare(tuple(table[first].tolist()))] * count
        return out


def _scipy(system: System, table: _ParameterTable, how: str, a: float, b: float, x: np.ndarray,
           pts: np.ndarray, max_step: float | None, tolerances: tuple[float, float] = (1e-6, 1e-9)) -> _Solution:
    """One piece by a scipy ``solve_ivp`` method (scipy.integrate imported here: loading it costs
    a third of a second that a ROS2 run does not need); LSODA with output points by
    :func:`_lsoda`."""
    from scipy.integrate import solve_ivp

    def rhs(tt, xx):
        return system.derivative(tt, xx, table.at(tt))
    rtol, atol = tolerances
    if np.ndim(atol) and np.size(atol) != len(x):      # per-state tolerances of another configuration
        atol = float(np.min(atol))
    if how == "LSODA" and pts.size:
        return _lsoda(rhs, a, b, x, pts, max_step, rtol, atol)
    sol = solve_ivp(rhs, (a, b), x, method=how, t_eval=pts if pts.size else None,
                    max_step=max_step or np.inf, rtol=rtol, atol=atol)
    if not sol.success:
        raise SimulationError(f"integration failed between {a:g} s and {b:g} s: {sol.message}", stalled=True)
    end = sol.y[:, -1]
    if pts.size and b - sol.t[-1] > 1e-12 * max(1.0, abs(b)):     # t_eval stopped short of the piece's end
        end = solve_ivp(rhs, (sol.t[-1], b), end, method=how, max_step=max_step or np.inf,
                        rtol=rtol, atol=atol).y[:, -1]
    return _Solution(sol.t, sol.y, end)


def _lsoda(rhs: Callable, a: float, b: float, x: np.ndarray, pts: np.ndarray, max_step: float | None,
           rtol: float, atol) -> _Solution:
    """One piece by ODEPACK's LSODA through ``odeint``: the same integrator as ``solve_ivp``'s LSODA,
    its loop over the steps and its output interpolation in Fortran (solve_ivp takes a Python step
    per step and builds a dense output for each: at one step a sample, 3.8 s of the tutorial's 30 s
    at 1 kHz, 1.1 s this way; the outputs agree within the tolerances, 1e-7 of the states there).
    ``tcrit`` keeps it from stepping past the piece's end, where a parameter may jump; an error in
    the right-hand side (a budget spent: fdi.verify) propagates as raised."""
    import warnings

    from scipy.integrate import ODEintWarning, odeint
    grid = pts if pts[0] == a else np.concatenate([[a], pts])
    tail = bool(grid[-1] < b)
    if tail:
        grid = np.concatenate([grid, [b]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ODEintWarning)      # its message is raised below
        y, info = odeint(rhs, np.asarray(x, dtype=float), grid, tfirst=True, rtol=rtol, atol=atol,
                         hmax=max_step or 0.0, tcrit=[b], full_output=True, mxstep=LSODA_STEPS)
    if not str(info.get("message", "")).startswith("Integration successful"):
        raise SimulationError(f"integration failed between {a:g} s and {b:g} s: {info.get('message')}",
                              stalled=True)
    keep = slice(0 if pts[0] == a else 1, len(grid) - tail)
    return _Solution(grid[keep], y[keep].T.copy(), y[-1].copy())


LSODA_STEPS = 1_000_000   # steps between two output points before LSODA gives up (solve_ivp had no limit)
OUTPUT_BLOCK = 4096   # output points whose parameters and rates are tabulated at a time in _trajectory


def _trajectory(model: Model, pieces: list[tuple[System, np.ndarray, np.ndarray, tuple[float, float], Callable]],
                vectorised: bool, configs: list) -> Trajectory:
    """Outputs at the output points of every piece (taken from ``pieces``, which is left empty),
    written into one array per signal and state, OUTPUT_BLOCK points at a time: the parameters,
    rates and outputs of a block are tabulated together (each point's numbers as over the whole
    piece at once), where tabulating a whole minute at 10 kHz held its parameter rows as Python
    lists (1 GB for the CyCab)."""
    n = sum(len(ts) for _, ts, _, _, _ in pieces)
    covered: dict[str, int] = {}            # samples each signal (state) is given in: kept if all n
    states_covered: dict[str, int] = {}
    for system, ts, _, _, _ in pieces:
        for name in list(system.output_names) + [s for s in model.sensors if s not in system.output_names]:
            covered[name] = covered.get(name, 0) + len(ts)
        for name in system.states:
            states_covered[name] = states_covered.get(name, 0) + len(ts)
    sig = {k: np.empty(n) for k, c in covered.items() if c == n}
    states = {k: np.empty(n) for k, c in states_covered.items() if c == n}
    t_all = np.concatenate([ts for _, ts, _, _, _ in pieces]) if pieces else np.zeros(0)
    at = 0
    pieces.reverse()                        # taken from the list: each piece's states released once copied
    while pieces:
        system, ts, ys, span, values = pieces.pop()
        table = _ParameterTable(values, system.param_names, vectorised, span)
        for a in range(0, len(ts), OUTPUT_BLOCK):
            b = min(len(ts), a + OUTPUT_BLOCK)
            tb, yb = ts[a:b], ys[:, a:b]
            P = table.rows(tb)
            dx = np.array([system.rates(tt, y, p) for tt, y, p in zip(tb, yb.T.tolist(), P.tolist())],
                          dtype=float).reshape(len(tb), -1)
            observed = system.observe(tb, tuple(yb), tuple(P.T), tuple(dx.T))
            for name, v in zip(system.output_names, observed):
                if name in sig:
                    sig[name][at + a:at + b] = np.broadcast_to(np.asarray(v, dtype=float), tb.shape)
            for name in model.sensors:          # a sensor on a switched-off junction measures zero
                if name not in system.output_names and name in sig:
                    sig[name][at + a:at + b] = 0.0
        for name, v in zip(system.states, ys):
            if name in states:
                states[name][at:at + len(ts)] = v
        at += len(ts)
        del ys
    for s in model.sensors.values():
        if s.measures in ("displacement", "momentum"):
            sig[s.name] = states.get(s.name, np.zeros(n))
    return Trajectory(t_all, sig, states, configs)


@dataclass
class _Solution:
    t: np.ndarray          # the output points reached
    y: np.ndarray          # states there, (n_states, points)
    end: np.ndarray        # the state at the end of the piece


def _ros2_grid(a: float, b: float, pts: np.ndarray, h_max: float) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Step start times and sizes landing exactly on every output point and on b, and the number
    of steps taken when each output point is reached."""
    marks = list(pts) + ([b] if not pts.size or pts[-1] < b else [])
    starts, sizes, reached = [], [], []
    tt = a
    for i, target in enumerate(marks):
        span = target - tt
        if span > 0:
            n = max(1, int(np.ceil(span / h_max - 1e-9)))
            h = span / n
            for _ in range(n):
                starts.append(tt)
                sizes.append(h)
                tt += h
            tt = target
        if i < len(pts):                   # an output point (b, appended, is none)
            reached.append(len(starts))
    return np.asarray(starts), np.asarray(sizes), reached


def _ros2(system: System, table: _ParameterTable, a: float, b: float, x: np.ndarray, pts: np.ndarray,
          h_max: float, jac_every: int = 5, implicit_start: bool = False) -> _Solution:
    """ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999): L-stable, order 2 with any Jacobian approximation
    (a W-method), so a finite-difference Jacobian is refreshed only every ``jac_every`` steps.
    Fixed step, landing exactly on every output point and on b.

        (I - g h J) k1 = f(x),   (I - g h J) k2 = f(x + h k1) - 2 k1,   x+ = x + h (3 k1 + k2) / 2,
        g = 1 + 1/sqrt(2).

    W = (I - g h J)^-1 is formed when the Jacobian is refreshed; a step is one call of
    ``system.step`` with the (prepared) parameters at both stages tabulated beforehand, for
    ROS2_CHUNK output points at a time (the same grid and numbers as all at once; memory of a chunk,
    where a minute at 10 kHz tabulated at once took 300 MB).

    Order 2 holds for any J, stability does not. A step whose stage 2 shows that the stiffness
    outgrew J (see :func:`_step_function`) is redone with J refreshed at its start; if it is still
    flagged and ends where the system is stiff at the step's scale (:func:`_stiff`), it is replaced
    by a step of backward Euler solved by Newton's method (:func:`_implicit_euler`). That is a stiff
    law with no slope where the step starts: a leak whose flow f crosses zero as the pressure
    reverses, d(R4^2 f|f|)/df = 0 there, so no Jacobian taken at the start sees the stiffness and
    a linearly implicit step overshoots the leak's flow many times over (then dp = R4^2 f|f| by its
    square); backward Euler, L-stable and solved to convergence, lands on the slow manifold (the leak's flow
    at the pressure the rest imposes). A flagged step that ends non-stiff (a Coulomb reversal: the
    jump has no slope to find) keeps its ROS2 result, so runs without a leak are as before.

    ``implicit_start``: the first step is one of backward Euler, as after a configuration change
    that adds a state: it starts from the constraint that just ended (an opened leak, no flow yet)."""
    n_state = len(x)
    eye = np.eye(n_state)
    xx = tuple(float(v) for v in x)
    ys = np.empty((n_state, len(pts)))       # the states at the output points, written as reached
    done = 0
    W, h_used = None, None
    step, f = system.step, system.f
    first = 0 if implicit_start else -1
    k0, start = 0, a                         # steps taken before the chunk, and where it starts
    for i in range(0, max(1, len(pts)), ROS2_CHUNK):   # the grid and parameters of ROS2_CHUNK points at a time
        part = pts[i:i + ROS2_CHUNK]
        last = i + ROS2_CHUNK >= len(pts)
        starts, sizes, reached = _ros2_grid(start, b if last else part[-1], part, h_max)
        if len(part):
            start = part[-1]
        c0, c1 = table.prepared(starts, system.prepare), table.prepared(starts + sizes, system.prepare)
        j = 0
        while j < len(reached) and reached[j] == 0:
            ys[:, done] = xx
            done, j = done + 1, j + 1
        for kl, (tt, h) in enumerate(zip(starts.tolist(), sizes.tolist())):
            k = k0 + kl
            fresh = k % jac_every == 0 or h != h_used
            if fresh:
                W = tuple(np.linalg.inv(eye - GAMMA * h * _jacobian(f, tt, xx, c0[kl])).ravel().tolist())
                h_used = h
            new, ok = step(tt, tt + h, h, xx, W, c0[kl], c1[kl])
            if not ok or k == first:                       # rare: a few hundred steps in 60 000
                if not ok and not fresh:
                    W = tuple(np.linalg.inv(eye - GAMMA * h * _jacobian(f, tt, xx, c0[kl])).ravel().tolist())
                    new, ok = step(tt, tt + h, h, xx, W, c0[kl], c1[kl])
                if k == first or not ok and _stiff(f, tt + h, h, new, c1[kl]):
                    new = _implicit_euler(f, tt + h, h, xx, c1[kl]) or new
            xx = new
            while j < len(reached) and reached[j] == kl + 1:
                ys[:, done] = xx
                done, j = done + 1, j + 1
        k0 += len(starts)
        del c0, c1, starts, sizes
    return _Solution(pts[:done] if pts.size else np.zeros(0), ys[:, :done], np.asarray(xx, dtype=float))


ROS2_CHUNK = 8192   # output points whose steps are laid out and parameters tabulated at a time (memory)


def _stiff(f: Callable, t1: float, h: float, y: tuple, c: tuple) -> bool:
    """Whether the system is stiff at the scale of the step where a step ends: the spectral radius
    of h J there (unit-free) above STIFF, or the end not finite."""
    if not all(np.isfinite(y)):
        return True
    return bool(np.max(np.abs(np.linalg.eigvals(h * _jacobian(f, t1, y, c)))) > STIFF)


def _implicit_euler(f: Callable, t1: float, h: float, x: tuple, c: tuple, iterations: int = 60) -> tuple | None:
    """y = x + h f(t1, y), by Newton's method from y = x with the Jacobian at every iterate (a
    leak's law is monotone: from the overshoot of the first iterate each one halves the excess, then
    converges quadratically). When the residual stops falling (three iterations running; Newton
    cycles at a Coulomb reversal, where the step's solution sticks between the two signs) or
    ``iterations`` are spent, the iterate of least residual after the start (None if there is
    none: the first solve failed or left the floats)."""
    xv = np.asarray(x, dtype=float)
    if not xv.size:
        return x
    y = xv.copy()
    eye = np.eye(len(xv))
    weights, best, least, previous, stalled = None, None, np.inf, np.inf, 0
    for k in range(iterations):
        fy = np.asarray(f(t1, tuple(y.tolist()), c), dtype=float)
        residual = xv + h * fy - y
        if weights is None:                    # residuals are measured on the scale of the start
            scale = np.abs(xv) + h * np.abs(fy)
            weights = 1.0 / np.where(scale > 0, scale, 1.0)
        size = float(np.max(np.abs(residual) * weights))
        if not size == size:                   # NaN
            break
        if k and size < least:
            best, least = y, size
        stalled = stalled + 1 if size > 0.9 * previous else 0
        if stalled >= 3:
            break
        previous = size
        jac = _jacobian(f, t1, tuple(y.tolist()), c, fy.tolist())
        try:
            d = np.linalg.solve(eye - h * jac, residual)
        except np.linalg.LinAlgError:
            break
        y = y + d
        if not np.all(np.isfinite(y)):
            break
        if np.all(np.abs(d) <= 1e-10 * (np.abs(y) + h * np.abs(fy))):
            return tuple(y.tolist())
    return None if best is None else tuple(best.tolist())


def _jacobian(f: Callable, tt: float, x: tuple, c: tuple, f0: Sequence[float] | None = None) -> np.ndarray:
    """Forward-difference Jacobian of x' (steps 1e-7 relative, at least 1e-10 absolute); non-finite
    entries set to zero (a square root at zero, say). ``f0``: f(tt, x, c) when known. The floor is
    small because a stiff law may bend within a small fraction of a state: a floor of 1e-7 moved
    the CyCab's motor momentum (2e-3) by 5e-5 of itself and the pump's flow by 2.5e-9 m^3/s, more
    than a whole leak's flow at R4 = 1e11, whose slope the Jacobian then missed."""
    if f0 is None:
        f0 = f(tt, x, c)
    columns = []
    for j, xj in enumerate(x):
        d = 1e-7 * max(1e-3, abs(xj))
        fj = f(tt, (*x[:j], xj + d, *x[j + 1:]), c)
        columns.append([(a - b) / d for a, b in zip(fj, f0)])
    jac = np.array(columns, dtype=float).T
    if not np.isfinite(jac).all():
        jac = np.nan_to_num(jac, nan=0.0, posinf=0.0, neginf=0.0)
    return jac


def consistent_readings(model: Model, initial: dict[str, float]) -> dict[str, float]:
    """``initial`` with the readings of sensors that measure a storage element's state
    (:mod:`bondgraph.measured`) kept where the model puts them relative to that state: a run that
    starts the element elsewhere (a scenario's ``spring_0``) and gives one of its readings no value
    starts that reading with it, as an absolute sensor would (the residuals read q = x - x(0) + q(0)
    with the model's values; a reading left at the model's zero would show the displacement as a
    constant offset in them, a review's false alarm). A run that gives both keeps both."""
    from .measured import coefficient, measured_storage, offset
    for element, readings in measured_storage(model).items():
        missing = [s for s in readings if s not in initial]
        if element not in initial or len(missing) != 1:
            continue
        (s,) = missing
        known = sum(coefficient(model, a) * initial[o] for o, a in readings.items() if o != s)
        initial[s] = (initial[element] - offset(model, element, readings) - known) / coefficient(model, readings[s])
    return initial


def _initial_state(system: System, initial: Mapping[str, float], t0: float, vals: Mapping[str, float]) -> np.ndarray:
    """States from the initial values given by state name; values given for other sensor signals
    (a tank pressure, say) are met by solving for the storage states not given explicitly."""
    x = np.array([initial.get(n, 0.0) for n in system.states], dtype=float)
    targets = {k: v for k, v in initial.items() if k not in system.states and k in system.output_names
               and k not in system.storage_names}
    free = [i for i, (n, kind) in enumerate(zip(system.states, system.kinds)) if kind == "storage" and n not in initial]
    # a storage element that is dependent in this configuration (its state fixed by the others) takes
    # no initial value of its own: it is skipped, not refused
    unknown = [k for k in initial if k not in system.states and k not in system.output_names
               and k not in system.storage_names]
    if unknown:
        raise SimulationError(f"initial value(s) for {', '.join(unknown)}: no state or sensor of that name")
    if not targets:
        return x
    if len(free) < len(targets):
        raise SimulationError(f"cannot meet initial values of {', '.join(targets)}: too few free storage states")
    from scipy.optimize import least_squares
    p = [vals[n] for n in system.param_names]
    idx = [system.output_names.index(k) for k in targets]
    want = np.array(list(targets.values()), dtype=float)

    def gap(z):
        xx = x.copy()
        xx[free] = z
        with np.errstate(all="ignore"):      # a trial step outside a law's domain (a gas spring past its
            dx = system.rates(t0, xx, p)     # shell): NaN there, which the solver steps back from, not a
            out = system.outputs(t0, xx, p, dx)   # warning on a Python caller's terminal
        return (out[idx] - want) / np.maximum(1.0, np.abs(want))
    # from zero first; then from larger magnitudes: a state of a large scale (the heat of 150 l of
    # water, 2e8 J, read as a temperature) moves its output by less than round-off over the
    # finite-difference step taken at zero, so the solver sees a flat gap and stops there
    sol = None
    for k, start in enumerate([x[free]] + [np.full(len(free), 10.0 ** d) for d in START_DECADES]):
        got = least_squares(gap, start, xtol=1e-14, ftol=1e-14, gtol=1e-14, **({"x_scale": "jac"} if k else {}))
        if sol is None or np.max(np.abs(got.fun)) < np.max(np.abs(sol.fun)):
            sol = got
        if np.max(np.abs(sol.fun)) <= 1e-6:
            break
    if np.max(np.abs(sol.fun)) > 1e-6:
        given = [n for n in system.states if n in initial and system.kinds[system.states.index(n)] == "storage"]
        raise SimulationError(f"cannot meet the initial values of {', '.join(targets)} (initial: in the model file or "
                              f"the scenario): no state of the storage elements left free reaches "
                              + ("them" if len(targets) > 1 else "it")
                              + (f"; the state(s) given ({', '.join(given)}) may fix "
                                 f"{'them' if len(targets) > 1 else 'it'} otherwise: give the reading or the state, not both"
                                 if given else ""))
    x[free] = sol.x
    return x


START_DECADES = (0, 3, 6, 9, 12, -3)    # _initial_state's further starting magnitudes, in turn


def _carry_over(old: System, new: System, x: np.ndarray, t0: float, vals: Mapping[str, float]) -> np.ndarray:
    """Map the state across a configuration change (see module doc)."""
    p = [vals[n] for n in old.param_names]
    dx = old.rates(t0, x, p)
    energy = dict(zip(old.storage_names, old.energy(t0, x, p, dx)))
    current = dict(zip(old.states, x))
    return np.array([current.get(n, energy.get(n, 0.0)) for n in new.states], dtype=float)
