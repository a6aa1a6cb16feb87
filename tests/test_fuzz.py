"""Fuzzing in the suite (issue 12): a bounded number of drawn model files, measurement files,
scenario files and command lines each end as a result or as the project's own one-line error,
within a few seconds. ``python -m tests.fuzz --cases 10000`` runs the long version and counts."""
from __future__ import annotations

import pytest

from . import fuzz

BUDGET = {"models": 150, "csv": 150, "scenarios": 150, "options": 12}


@pytest.mark.parametrize("target", list(BUDGET))
def test_fuzzed_inputs_never_crash_or_hang(target):
    counts = fuzz.run(target, BUDGET[target])
    examples = counts.pop("_examples")
    assert counts["crash"] + counts["slow"] + counts["hang"] == 0, examples
    assert counts["ok"] + counts["error"] == BUDGET[target]
