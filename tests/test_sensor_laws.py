"""Laws that read an effort or flow sensor's signal, simulated (bondgraph.simulation._build).

A chain of two RC stages whose second stage's conductance reads the first capacitor's voltage v1 and
whose load's conductance reads the current i2 between the stages: i2 is known only once v1 is (a
chain of readings, resolved one pass at a time); a conductance that reads its own junction's current
needs its own law (a loop) and is refused naming it. Against scipy on the circuit's equations.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from bondgraph.loader import load_model_text
from bondgraph.simulation import SimulationError, simulate

CHAIN = """
parameters: {R1: {value: 100.0, unit: Ohm}, R2: {value: 200.0, unit: Ohm}, R3: {value: 300.0, unit: Ohm},
             C1: {value: 1.0e-3, unit: F}, C2: {value: 2.0e-3, unit: F}}
inputs: {u: {column: u, expr: "1.0 + 0.5*sin(2*pi*t)", unit: V}}
elements: {src: {type: MSe, input: u}, r1: {type: R, parameter: R1}, c1: {type: C, parameter: C1},
           r2: {type: R, flow: "e/R2*(1 + 0.1*v1)"}, c2: {type: C, parameter: C2},
           r3: {type: R, flow: "%s"}}
junctions: {j1: {type: "1"}, j0a: {type: "0"}, j2: {type: "1"}, j0b: {type: "0"}, j3: {type: "1"}}
sensors: {v1: {type: De, junction: j0a, unit: V}, i2: {type: Df, junction: j2, unit: A}}
bonds: {1: [src, j1], 2: [j1, r1], 3: [j1, j0a], 4: [j0a, c1], 5: [j0a, j2], 6: [j2, r2], 7: [j2, j0b],
        8: [j0b, c2], 9: [j0b, j3], 10: [j3, r3]}
"""


def test_a_chain_of_sensor_readings_is_simulated_as_the_circuit():
    m = load_model_text(CHAIN % "e/R3*(1 + 20.0*i2)")
    t = np.arange(0.0, 2.0, 1e-3)
    got = simulate(m, t, values=lambda tt: {s.name: float(v) for s, v in m.nominal_values().items()})

    def rhs(tt, y):
        v1, v2 = y
        u = 1.0 + 0.5 * np.sin(2 * np.pi * tt)
        i2 = (v1 - v2) / 200.0 * (1 + 0.1 * v1)
        i3 = v2 / 300.0 * (1 + 20.0 * i2)
        return [((u - v1) / 100.0 - i2) / 1e-3, (i2 - i3) / 2e-3]
    ref = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12).y
    i2 = (ref[0] - ref[1]) / 200.0 * (1 + 0.1 * ref[0])
    assert np.max(np.abs(got.signals["v1"] - ref[0])) < 1e-5
    assert np.max(np.abs(got.signals["i2"] - i2)) < 1e-7 and np.ptp(i2) > 1e-3


def test_a_conductance_that_reads_its_own_current_is_refused_naming_it():
    m = load_model_text(CHAIN.replace('"e/R2*(1 + 0.1*v1)"', '"e/R2*(1 + 0.1*i2)"') % "e/R3")
    with pytest.raises(SimulationError, match="element\\(s\\) r2 read the measured signal\\(s\\) i2.*a loop through"):
        simulate(m, np.arange(0.0, 0.1, 1e-3), values=lambda tt: {s.name: float(v) for s, v in m.nominal_values().items()})


HEATER = """
parameters: {C: {value: 6.279e+5, unit: J/K}, Rh: {value: 17.6, unit: Ohm}, G: {value: 2.0, unit: W/K}}
inputs: {U: {column: U, unit: V, expr: "230 + 20*sin(2*pi*t/600)"},
         Tamb: {column: Tamb, unit: K, expr: "293.15"}}
elements: {heater: {type: MSf, value: "U**2/Rh"}, tank: {type: C, parameter: C},
           wall: {type: R, flow: "G*e"}, room: {type: MSe, input: Tamb}}
junctions: {JT: {type: "0"}, Jw: {type: "1"}, Ja: {type: "0"}}
sensors: {T: {type: De, junction: JT, unit: K}}
bonds: {1: [heater, JT], 2: [JT, tank], 3: [JT, Jw], 4: [Jw, wall], 5: [Jw, Ja], 6: [room, Ja]}
initial: {T: 330.0}
"""


def test_a_source_value_that_reads_an_input_is_derived_and_simulated_as_the_physics():
    """A water heater's Joule heat U**2/Rh on the measured mains voltage (a user trial, session 42:
    check and tables accepted it, simulate, verify, calibrate and diagnose ended in KeyError 'U').
    The ARR is the hand's C T' = U^2/Rh - G (T - Tamb); the simulation is scipy's on that ODE."""
    import sympy as sp

    from bondgraph.equations import signal
    from bondgraph.model import t as time
    from fdi.scaph import derive_arrs
    from fdi.verify import verify
    m = load_model_text(HEATER)
    (arr,) = derive_arrs(m)
    s = {n: m.symbols[n] for n in ("C", "Rh", "G", "beta_heater", "beta_Tamb", "beta_T")}
    T = signal("T") / s["beta_T"]
    hand = (s["beta_heater"] * signal("U") ** 2 / s["Rh"] - s["G"] * (T - s["beta_Tamb"] * signal("Tamb"))
            - s["C"] * sp.diff(T, time))
    assert sp.simplify(arr.expr - hand) == 0 or sp.simplify(arr.expr + hand) == 0
    tt = np.arange(0.0, 3600.0, 1.0)
    got = simulate(m, tt, values=lambda x: {k.name: float(v) for k, v in m.nominal_values().items()},
                   initial=m.initial, method="LSODA", tolerances=(1e-10, 1e-8))

    def rhs(x, y):
        u = 230 + 20 * np.sin(2 * np.pi * x / 600)
        return [(u ** 2 / 17.6 - 2.0 * (y[0] - 293.15)) / 6.279e5]
    ref = solve_ivp(rhs, (0.0, tt[-1]), [330.0], t_eval=tt, rtol=1e-10, atol=1e-10).y[0]
    assert np.max(np.abs(got.signals["T"] - ref)) < 1e-6 and np.ptp(ref) > 10.0
    assert verify(m, runs=1).ok


def test_a_source_value_that_reads_an_input_without_expr_is_refused_for_simulation_naming_it():
    m = load_model_text(HEATER.replace('expr: "230 + 20*sin(2*pi*t/600)"', 'expr: null'))
    with pytest.raises(SimulationError, match="source 'heater' reads input 'U', which has no expr: give inputs.U.expr"):
        simulate(m, np.arange(0.0, 10.0, 1.0), values=lambda x: {k.name: float(v) for k, v in m.nominal_values().items()})
