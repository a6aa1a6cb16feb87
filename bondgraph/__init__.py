"""Hybrid bond graphs, physics only: a model read from YAML, its causality, its equations, its
modes, its time scales and its simulation. Nothing here knows about diagnosis (``fdi`` builds on
it). The names a researcher reaches for first are importable from the package itself; each is
loaded on first use, so ``import bondgraph`` costs no sympy, numpy or scipy.

An RC discharge, two elements on a 0-junction: its time constant is R*C = 0.1 s, and after one
time constant the capacitor holds 1/e of its initial 2 V.

>>> import numpy as np
>>> from bondgraph import load_model_text, simulate, time_scales
>>> m = load_model_text('''
... parameters: {R: {value: 100.0, unit: Ohm}, C1: {value: 1.0e-3, unit: F}}
... elements: {cap: {type: C, parameter: C1}, res: {type: R, parameter: R}}
... junctions: {j: {type: "0"}}
... sensors: {v: {type: De, junction: j, unit: V}}
... bonds: {1: [j, cap], 2: [j, res]}
... initial: {v: 2.0}
... ''')
>>> round(time_scales(m).fastest, 6)
0.1
>>> nominal = {s.name: float(v) for s, v in m.nominal_values().items()}
>>> run = simulate(m, np.array([0.0, 0.1]), values=lambda t: nominal, initial=m.initial)
>>> bool(np.isclose(run.signals["v"][-1], 2.0 / np.e, rtol=1e-4))
True

The structure's equations are exported as ``structural_equations``: ``bondgraph.equations`` is the
submodule of causal relations, which Python binds on the package once it is imported, so a
package attribute of that name would change meaning with import order.
"""
from __future__ import annotations

import importlib

# name -> (submodule, attribute): what ``from bondgraph import name`` gives
_EXPORTS = {
    "load_model": ("loader", "load_model"),
    "load_model_text": ("loader", "load_model_text"),
    "ModelError": ("errors", "ModelError"),
    "CausalityError": ("errors", "CausalityError"),
    "Model": ("model", "Model"),
    "assign": ("causality", "assign"),
    "Causality": ("causality", "Causality"),
    "DIAGNOSIS": ("causality", "DIAGNOSIS"),
    "SIMULATION": ("causality", "SIMULATION"),
    "structural_equations": ("structure", "equations"),
    "EquationSystem": ("structure", "EquationSystem"),
    "in_mode": ("modes", "in_mode"),
    "simulate": ("simulation", "simulate"),
    "Trajectory": ("simulation", "Trajectory"),
    "SimulationError": ("simulation", "SimulationError"),
    "time_scales": ("timescales", "time_scales"),
    "model_time_scales": ("timescales", "model_time_scales"),
    "TimeScales": ("timescales", "TimeScales"),
    "to_dot": ("dot", "to_dot"),
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'bondgraph' has no attribute {name!r}")
    module, attribute = _EXPORTS[name]
    value = getattr(importlib.import_module(f"{__name__}.{module}"), attribute)
    globals()[name] = value                 # once: later lookups do not come here
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
