"""Fuzzing in the suite (issues 12 and 23): a bounded number of drawn model files, measurement
files and streams, scenario files, Unicode names, notebook data, command lines and output paths
each end as a result or as the project's own one-line error, within a few seconds and 1 GB. ``python -m tests.fuzz --cases 10000`` runs the long version and counts."""
from __future__ import annotations

import pytest

from . import fuzz

BUDGET = {"models": 150, "csv": 150, "scenarios": 150, "options": 12, "streams": 40, "unicode": 40, "api": 150,
          "outputs": 30}


@pytest.mark.parametrize("target", list(BUDGET))
def test_fuzzed_inputs_never_crash_or_hang(target):
    counts = fuzz.run(target, BUDGET[target])
    examples = counts.pop("_examples")
    counts.pop("_peak_mb")
    counts.pop("_out_of_time", None)
    counts.pop("_worst")
    assert counts["crash"] + counts["slow"] + counts["hang"] + counts["memory"] == 0, examples
    assert counts["ok"] + counts["error"] == BUDGET[target]
