"""Small models for examples and experiments, built from YAML text (as networkx ships small graphs).

- :func:`source_resistor`: a voltage source u across a resistor R, its current i measured: one
  residual, Ohm's law u - R i;
- :func:`rc_parallel`: a current source i_in into a capacitor C1 and a resistor R in parallel,
  their voltage v measured: one residual, Kirchhoff's current law i_in - C1 dv/dt - v/R.

>>> m = rc_parallel()
>>> sorted(m.elements), list(m.sensors)
(['cap', 'res', 'src'], ['v'])
"""
from __future__ import annotations

from .loader import load_model_text
from .model import Model

SOURCE_RESISTOR = """
name: source_resistor
parameters: {R: {value: 2.0, unit: Ohm}}
inputs: {u: {column: u, unit: V}}
elements: {src: {type: MSe, input: u}, res: {type: R, parameter: R}}
junctions: {j: {type: "1"}}
sensors: {i: {type: Df, junction: j, unit: A}}
bonds: {1: [src, j], 2: [j, res]}
"""

RC_PARALLEL = """
name: rc_parallel
parameters: {C1: {value: 1.0e-3, unit: F}, R: {value: 100.0, unit: Ohm}}
inputs: {i_in: {unit: A, column: i_in}}
elements: {src: {type: MSf, input: i_in}, cap: {type: C, parameter: C1}, res: {type: R, parameter: R}}
junctions: {j: {type: "0"}}
sensors: {v: {type: De, junction: j, unit: V}}
bonds: {1: [src, j], 2: [j, cap], 3: [j, res]}
"""


def source_resistor() -> Model:
    """A voltage source across a resistor, its current measured (module doc)."""
    return load_model_text(SOURCE_RESISTOR, "<source_resistor>")


def rc_parallel() -> Model:
    """A current source into a capacitor and a resistor in parallel, their voltage measured."""
    return load_model_text(RC_PARALLEL, "<rc_parallel>")
