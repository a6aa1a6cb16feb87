"""A lithium-ion cell (tests/data/li_ion_cell.yaml: its Thevenin equivalent circuit, open-circuit
voltage, ohmic resistance R0 and one polarisation pair R1 || C1 under a measured load current; a
domain no shipped model covers), data from tests/independent/cell.py (scipy, typed by hand).

Designed truth: the ohmic resistance steps 0.05 -> 0.08 Ohm at 300 s (a loose tab). The derivative
window is 10 s: the residual reads C1 dV/dt with C1 = 1000 F, and over a 1 s window the 1 mV noise
alone gave 9.5 A of residual against the fault's 2 A."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from fdi.api import Options, diagnose

from .independent import by_hand, cell, measurements, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "li_ion_cell.yaml")
T0 = 300.0

_data = partial(measurements, cell.simulate)    # (name, seed, **the simulator's keywords)
thresholds = thresholds_fixture(MODEL, cell.simulate)    # two nominal runs; a third asserted quiet


def test_the_residual_is_the_polarisation_pair_s_balance():
    """By hand (input and sensor factors at 1): C1 d/dt(E - R0 I - V) - I + (E - R0 I - V)/R1,
    up to its sign."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled
    (arr,) = compiled(MODEL).arrs
    expr, syms, fn = by_hand(arr.expr)
    R0, R1, C1 = (syms[n] for n in ("R0", "R1", "C1"))
    u1 = fn["E"] - R0 * fn["I"] - fn["V"]
    hand = C1 * sp.diff(u1, t) - fn["I"] + u1 / R1
    assert sp.simplify(expr - hand) == 0 or sp.simplify(expr + hand) == 0


def test_a_loose_tab_is_found_and_sized(thresholds):
    report = diagnose(MODEL, _data("loose_tab", 4, t0=T0, r0=0.08),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 5.0 <= report["detection"]["time"] <= T0 + 5.0     # half the 10 s window early at most
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("R0", "abrupt")
    assert found["value"] == pytest.approx(0.08, rel=0.01)
