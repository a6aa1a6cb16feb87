"""The hybrid bond graph model as plain frozen values (what the YAML loader returns).

Conventions (Karnopp, Margolis & Rosenberg; also 20-sim):
- a bond's power direction goes from ``source`` to ``target``;
- TF/MTF with modulus m, power entering on bond 1 and leaving on bond 2: e1 = m*e2, f2 = m*f1;
- GY/MGY with modulus r: e1 = r*f2, e2 = r*f1;
- R: e = law(f) (resistance form) and/or f = law(e) (conductance form); linear: e = R*f;
- C: e = q/C, I: f = p/I (or a law in q, p); in derivative causality f = C*de/dt, e = I*df/dt;
- controlled junctions (0c, 1c) carry a mode variable a in {0, 1}; in the diagnostic hybrid bond
  graph every output variable of a controlled junction is multiplied by a.

The CyCab's steering (Yu & Wang 2014): three sensors, so three AGARRs; at nominal values every
efficiency factor is 1, the mode variables take their nominal value and the leakage resistance
R4 is infinite (a healthy cylinder leaks nothing):

>>> from bondgraph.loader import load_model
>>> m = load_model("models/cycab_steering.yaml")
>>> list(m.sensors), m.arr_names()
(['theta1', 'dp', 'theta2'], ['ARR1', 'ARR2', 'ARR3'])
>>> nominal = m.nominal_values()
>>> nominal[m.beta_symbol("theta1")], nominal[m.symbols["a1"]], nominal[m.symbols["R4"]]
(1.0, 1, inf)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

from .deferred import deferred

if TYPE_CHECKING:           # sympy is imported where an expression is built or read (bondgraph.deferred)
    import sympy as sp

SOURCE_KINDS = ("Se", "Sf", "MSe", "MSf")
STORAGE_KINDS = ("C", "I")
TWO_PORT_KINDS = ("TF", "GY", "MTF", "MGY")
ELEMENT_KINDS = SOURCE_KINDS + ("R",) + STORAGE_KINDS + TWO_PORT_KINDS
SENSOR_KINDS = ("De", "Df")
JUNCTION_KINDS = ("0", "1", "0c", "1c")
FAULT_KINDS = ("parametric", "sensor", "source", "mode")


def __getattr__(name: str) -> Any:
    """The module's sympy constants, made on first use (a compiled model is read without sympy):
    ``t``, time; ``LAW_VARIABLES``, the local variable of a constitutive law as written in a model
    file (``f`` in an R's effort law, ``q`` in a C's effort law), whose names are no identifiers, so
    a user's parameter named e, f, q or p never meets them."""
    if name not in ("t", "LAW_VARIABLES"):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import sympy as sp
    globals()["t"] = sp.Symbol("t", real=True)
    globals()["LAW_VARIABLES"] = {n: sp.Symbol(f"{n}~", real=True) for n in ("e", "f", "q", "p")}
    return globals()[name]


@dataclass(frozen=True)
class Parameter:
    name: str
    value: float
    unit: str
    description: str = ""


@deferred("expr")
@dataclass(frozen=True)
class Input:
    """A named input signal: a data column, an expression of t (for simulation), or both."""
    name: str
    unit: str
    column: str | None
    expr: sp.Expr | None
    description: str = ""


@deferred("expr", "positive")
@dataclass(frozen=True)
class Mode:
    """A mode variable (0 or 1) of controlled junctions. A *commanded* mode follows a data column
    (``column``: the controller's command, sample by sample; ``expr``, a function of t, is the
    command simulation gives): the physical mode disagreeing with the command is a mode fault. An
    *autonomous* mode is 1 while ``positive`` (an expression of sensor signals and inputs: a diode's
    current) is above zero: the data decide it sample by sample, the simulator from its states."""
    name: str
    nominal: int
    description: str = ""
    column: str | None = None
    expr: sp.Expr | None = None
    positive: sp.Expr | None = None     # autonomous: 1 while this expression of signals is > 0

    @property
    def autonomous(self) -> bool:
        """Whether the mode follows the sign of a signal (a diode's current) rather than a command."""
        return self.positive is not None


@deferred("laws", "modulus", "value")
@dataclass(frozen=True)
class Element:
    """A bond-graph element. ``laws`` holds nonlinear constitutive laws by the variable they give
    (``effort``/``flow`` for R, ``effort`` of q for C, ``flow`` of p for I)."""
    name: str
    kind: str
    parameter: str | None = None
    laws: Mapping[str, sp.Expr] = field(default_factory=dict)
    modulus: sp.Expr | None = None
    input: str | None = None
    value: sp.Expr | None = None
    description: str = ""


@dataclass(frozen=True)
class Junction:
    """A 0 or 1 junction; a controlled one (0c, 1c) switches with ``mode`` (a mode variable, or
    an expression of them such as ``1 - s``, filed under that text in ``Model.symbols``).

    ``off`` (``switched_off:`` in a model file) says what a controlled junction does while its mode is 0: ``all`` (the physics of a
    switch, Mosterman & Biswas 1998: a 1c carries no flow on any bond, a 0c no effort) or
    ``outputs`` (the diagnostic hybrid bond graph as Yu & Wang 2014 write it: only the variables
    the junction computes are zero, so the side that drives it sees no load and the other side
    is held still)."""
    name: str
    kind: str
    mode: str | None = None
    description: str = ""
    off: str = "all"

    @property
    def controlled(self) -> bool:
        return self.kind.endswith("c")

    @property
    def base(self) -> str:
        """'0' or '1': the junction type without the controlled marker."""
        return self.kind[0]


@deferred("signal", "columns")
@dataclass(frozen=True)
class Sensor:
    """A De/Df detector on a junction. ``name`` is the signal it measures (``dp``, ``theta1``);
    ``columns`` says how simulation makes the data columns from the signal (``p1: 1e5 + max(dp, 0)``);
    ``measures`` says which bond quantity that signal is: the junction's effort or flow, or its
    time integral (``displacement`` for Df, ``momentum`` for De). ``signal`` computes the value
    from data columns; ``noise`` (standard deviation) and ``resolution`` (quantisation step)
    describe the measurement per data column, for simulation."""
    name: str
    kind: str
    junction: str
    measures: str
    signal: sp.Expr
    unit: str
    noise: Mapping[str, float] = field(default_factory=dict)
    resolution: Mapping[str, float] = field(default_factory=dict)
    description: str = ""
    columns: Mapping[str, sp.Expr] = field(default_factory=dict)   # data column <- expression of the signal

    def column_values(self, value):
        """The data columns this sensor writes, from its signal's value (for simulation)."""
        cols = sorted(str(s) for s in self.signal.free_symbols)
        if self.columns:
            return {c: self.columns[c] for c in cols}
        import sympy as sp
        if len(cols) != 1:
            return None
        col, reading = sp.Symbol(cols[0], real=True), sp.Symbol(self.name, real=True)
        if self.signal == col:
            return {cols[0]: reading}
        x = sp.Dummy("x", real=True)   # (the column may bear the sensor's own name: a level h read as 9810*h)
        try:        # one column through an expression: its inverse, where sympy finds one
            solved = sp.solve(sp.Eq(reading, self.signal.xreplace({col: x})), x)
        except (NotImplementedError, TypeError, ValueError):
            solved = []
        return {cols[0]: solved[0]} if len(solved) == 1 else None


@dataclass(frozen=True)
class Bond:
    id: int
    source: str
    target: str

    def other(self, node: str) -> str:
        return self.target if node == self.source else self.source


@dataclass(frozen=True)
class Fault:
    """A candidate fault. ``targets`` are parameter names (parametric), one sensor or source
    name (its efficiency factor beta, or with ``effect`` "bias" an additive offset b: a sensor
    reads true + b, a source gives commanded + b; its signature is the efficiency factor's), or
    one mode variable (mode); ``value`` is the faulty mode of
    a mode fault (0: stuck off, 1: stuck on). How a fault is searched (bounds) and when it is a
    failure are monitor settings: :class:`fdi.config.MonitorConfig`."""
    name: str
    kind: str
    targets: tuple[str, ...]
    value: float | None = None
    description: str = ""
    effect: str = "gain"          # sensor/source: "gain" (beta x true), "bias" (true + b), "stuck" (a frozen reading)

    @property
    def symbols(self) -> tuple[str, ...]:
        """Names of the symbols this fault acts on in the AGARRs."""
        if self.kind == "sensor" or self.kind == "source":
            return (f"beta_{self.targets[0]}",)
        return self.targets


@deferred("definitions", "symbols")
@dataclass(frozen=True)
class Model:
    name: str
    path: str
    description: str
    reference: str
    parameters: Mapping[str, Parameter]
    definitions: Mapping[str, sp.Expr]
    inputs: Mapping[str, Input]
    modes: Mapping[str, Mode]
    elements: Mapping[str, Element]
    junctions: Mapping[str, Junction]
    sensors: Mapping[str, Sensor]
    bonds: tuple[Bond, ...]
    faults: Mapping[str, Fault]
    columns: tuple[str, ...]
    sampling_time: float | None
    initial: Mapping[str, float]
    symbols: Mapping[str, sp.Symbol]

    def _repr_html_(self) -> str:
        """A notebook's summary: elements, junctions, sensors, modes and faults, parameters with units."""
        from collections import Counter
        from html import escape

        def counts(kinds) -> str:
            return ", ".join(f"{n} {k}" for k, n in sorted(Counter(kinds).items())) or "none"
        rows = [("elements", counts(e.kind for e in self.elements.values())),
                ("junctions", counts(j.kind for j in self.junctions.values())),
                ("bonds", str(len(self.bonds))),
                ("sensors", ", ".join(f"{s.name} ({s.kind} on {s.junction}, {s.unit})" for s in self.sensors.values())),
                ("modes", ", ".join(f"{m.name} (nominal {m.nominal})" for m in self.modes.values()) or "none"),
                ("faults", ", ".join(f"{f.name} ({f.kind})" for f in self.faults.values()) or "none"),
                ("parameters", ", ".join(f"{p.name} = {p.value:g} {p.unit}" for p in self.parameters.values()))]
        body = "".join(f"<tr><th style='text-align:left'>{escape(k)}</th><td style='text-align:left'>{escape(v)}</td></tr>"
                       for k, v in rows)
        title = escape(self.name + (f": {self.description}" if self.description else ""))
        return f"<table><caption>{title}</caption>{body}</table>"

    def bonds_of(self, node: str) -> list[Bond]:
        return [b for b in self.bonds if node in (b.source, b.target)]

    def beta_symbol(self, name: str) -> sp.Symbol:
        """The efficiency factor of a sensor or source, ``beta_<name>``."""
        return self.symbols[f"beta_{name}"]

    def nominal_values(self) -> dict[sp.Symbol, float]:
        """Every parameter, efficiency factor and mode variable at its nominal value."""
        return {self.symbols[name]: v for name, v in self.nominal_by_name().items()}

    def nominal_by_name(self) -> dict[str, float]:
        """:meth:`nominal_values` keyed by the symbols' names (``R4``, ``beta_theta1``, ``a1``): no
        sympy needed, what a diagnosis of a compiled model reads."""
        values: dict[str, float] = {p: v.value for p, v in self.parameters.items()}
        for name in list(self.sensors) + [e.input or e.name for e in self.sources()]:
            values[f"beta_{name}"] = 1.0
        for m in self.modes.values():
            values[m.name] = m.nominal
        return values

    def sources(self) -> list[Element]:
        return [e for e in self.elements.values() if e.kind in ("Se", "Sf", "MSe", "MSf")]

    def arr_names(self) -> list[str]:
        """One AGARR per sensor, in the order the sensors are listed: ARR1, ARR2, ..."""
        return [f"ARR{i + 1}" for i in range(len(self.sensors))]
