"""Trust (issue 23): no planted file is read, no input is lost or damaged, inputs that cannot be
meant are refused in one line, and every input is read within bounded memory and time.

Each test builds its designed truth by hand: a planted file whose model would answer otherwise,
an output path that *is* an input, a header written twice, and so on."""
from __future__ import annotations

import hashlib
import os
import tempfile

import numpy as np
import pytest

from fdi.api import diagnose

from .conftest import MODELS

TANK = (MODELS / "two_tank_valve.yaml").read_text(encoding="utf-8")
QUIET = TANK.replace("thresholds: {ARR1: 1.0e-4, ARR2: 1.0e-4, ARR3: 1.5e-4}",
                     "thresholds: {ARR1: 1.0e3, ARR2: 1.0e3, ARR3: 1.0e3}")
LOUD = TANK.replace("thresholds: {ARR1: 1.0e-4, ARR2: 1.0e-4, ARR3: 1.5e-4}",
                    "thresholds: {ARR1: 1.0e-12, ARR2: 1.0e-12, ARR3: 1.0e-12}")


def tank_data() -> dict:
    """Constant pressures far from the tanks' equilibrium: every residual is about 1e-4 m^3/s."""
    t = np.arange(0, 200, 0.1)
    return {"t": t, "Qin": 1e-4 * (1 + 0.5 * np.sin(0.01 * t)), "p1": np.full_like(t, 5000.0),
            "p2": np.full_like(t, 2000.0)}


# ------------------------------------------------------------------ 1. no temporary file is trusted

def test_the_api_reads_no_planted_file_and_follows_no_planted_link(tmp_path, monkeypatch):
    """Earlier versions wrote YAML text to <tmp>/bgfdi-model-<sha256[:16]>.yaml and reused it when
    it existed. A file planted there (thresholds of 1e-12: everything detected) and a .tmp link to
    a victim file are both ignored: the text's own thresholds (1e3: nothing crosses) decide, the
    victim is untouched and nothing is written in the temporary folder."""
    shared = tmp_path / "shared"
    shared.mkdir()
    monkeypatch.setenv("TMPDIR", str(shared))
    monkeypatch.setattr(tempfile, "tempdir", str(shared))
    digest = hashlib.sha256(QUIET.encode("utf-8")).hexdigest()[:16]
    planted = shared / f"bgfdi-model-{digest}.yaml"
    planted.write_text(LOUD, encoding="utf-8")
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n", encoding="utf-8")
    os.symlink(victim, shared / f"bgfdi-model-{digest}.tmp")
    before = sorted(p.name for p in shared.iterdir())
    d = diagnose(QUIET, tank_data(), workers=1)
    assert d.detection is None                                    # the text's thresholds, not the planted file's
    assert victim.read_text(encoding="utf-8") == "precious\n"
    assert planted.read_text(encoding="utf-8") == LOUD
    assert sorted(p.name for p in shared.iterdir()) == before     # nothing written there
