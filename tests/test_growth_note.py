"""``check`` names a plant that grows at its initial state (a parameter of the wrong sign).

Designed truth from the physics of tests/data/gas_accumulator.yaml: a gas spring
e = p0 (V0 / (V0 - q))^n charged through a line resistance R from a supply ps. Linearised at the
initial pressure pa = ps, its compliance is C = dq/de = V0 (p0/e)^(1/n) / (n e) and the one state
decays (or grows) at lambda = -1 / (R C): -61.8 1/s with the volume V0 = 4 l, +61.8 1/s with a
sign slip, V0 = -4 l (a user trial: every check passed and a diagnosis read nominal data as a
precharge fault).
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
GAS = (HERE / "data" / "gas_accumulator.yaml").read_text(encoding="utf-8")


def _lambda(V0: float, p0=5.0e6, n=1.4, R=1.0e9, e=4.0e7) -> float:
    return -1.0 / (R * V0 * (p0 / e) ** (1 / n) / (n * e))


def _check(tmp_path: Path, text: str, *extra: str) -> subprocess.CompletedProcess:
    path = tmp_path / "gas.yaml"
    path.write_text(text, encoding="utf-8")
    return subprocess.run([sys.executable, "-m", "fdi", "check", str(path), *extra], capture_output=True, text=True,
                          timeout=300)


def test_a_negative_volume_is_named_with_the_growth_rate_of_the_physics(tmp_path):
    assert _lambda(-4.0e-3) == pytest.approx(61.8, abs=0.05)
    done = _check(tmp_path, GAS.replace("V0: {value: 4.0e-3", "V0: {value: -4.0e-3"))
    assert done.returncode == 0, done.stderr
    notes = [line for line in done.stdout.splitlines() if "grow at the initial state" in line]
    assert len(notes) == 1 and f"eigenvalue {_lambda(-4.0e-3):+.3g} 1/s" in notes[0]
    assert f"doubles every {math.log(2) / _lambda(-4.0e-3):.3g} s" in notes[0] and "wrong sign" in notes[0]
    report = json.loads(_check(tmp_path, GAS.replace("V0: {value: 4.0e-3", "V0: {value: -4.0e-3"), "--json").stdout)
    assert report["simulation"]["growing"] == [notes[0].removeprefix("  note: ")]


def test_the_accumulator_as_built_decays_and_check_says_nothing(tmp_path):
    assert _lambda(4.0e-3) == pytest.approx(-61.8, abs=0.05)
    done = _check(tmp_path, GAS)
    assert done.returncode == 0 and "grow at the initial state" not in done.stdout
