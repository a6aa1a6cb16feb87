"""Power electronics no shipped model joins: an averaged buck converter (the switch network as an
ideal transformer of the duty cycle read from the data, an LC filter, a resistive load):
tests/data/buck_averaged.yaml, data from tests/independent/buck.py (linear under a constant plus
one tone of d Vin, solved exactly). References: the two laws by hand (the MTF's modulus 1/d from
the data column), a nominal run that raises no alarm, and a designed load step and voltage-sensor
gain, each found alone and sized."""
from __future__ import annotations

from pathlib import Path

import pytest
import sympy as sp

from .independent import buck, found_alone, laws_of, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "buck_averaged.yaml")
T0 = 0.12

thresholds = thresholds_fixture(MODEL, buck.simulate)


def test_the_residuals_are_the_inductor_and_the_capacitor_by_hand():
    (e1, e2), sym, sig = laws_of(MODEL)
    iL, vC, Vin, d = sig["iL"], sig["vC"], sig["Vin"], sig["d"]
    t = iL.args[0]
    L, rL, C, R = (sym[n] for n in ("L", "rL", "C", "R"))
    hand = [d * Vin - rL * iL - vC - L * sp.diff(iL, t),       # the inductor's loop, d Vin from the switch
            iL - vC / R - C * sp.diff(vC, t)]                   # the output node's currents
    for expr, want in zip((e1, e2), hand):
        assert sp.simplify(expr.doit() - want) == 0


@pytest.mark.parametrize("which, factor, seed, rel", [("R", 0.7, 41, 0.01), ("beta_vC", 0.9, 42, 0.005)])
def test_a_load_step_and_a_sensor_gain_are_found_and_sized(thresholds, which, factor, seed, rel):
    """The load drops to 3.5 Ohm (measured 3.4996) and the voltage sensor reads 0.9 of the truth (measured 0.90005)
    at 0.12 s; each is the single fault named, sized and dated."""
    report, found = found_alone(MODEL, buck.simulate, which, factor, seed, T0, thresholds)
    assert T0 - 0.001 <= report["detection"]["time"] < T0 + 0.005     # half the 1.44 ms window before
    assert found["value"] == pytest.approx(buck.NOMINAL.get(which, 1.0) * factor, rel=rel)
    assert found["t0"] == pytest.approx(T0, abs=0.001)


def test_check_shows_the_switch_reading_the_duty_cycle(capsys):
    """The averaged switch's laws in the file's bond numbers: the source's voltage is the inductor
    side's over d, the inductor's current reaches the source times d."""
    from fdi.app.cli import main
    assert main(["check", MODEL, "-q"]) == 0
    assert "    sw (MTF, src -> j1): e[1] = (1/d)*e[2], f[2] = (1/d)*f[1]" in capsys.readouterr().out
