"""A diagnosis opens one pool of worker processes and the model is derived once, in the parent,
also when workers are spawned (the default on macOS, Windows and from Python 3.14), where nothing
is inherited from the parent: the monitor travels to each worker once, compiled (its kernels as
the source lambdify generated: fdi.persist), and each job carries only its window of data.
Counted through fdi.monitor.LOG_ENV, a file each derivation appends its process id to."""
from __future__ import annotations

import collections
import os
import subprocess
import sys
import textwrap

from fdi.monitor import LOG_ENV

from .conftest import ROOT

SCRIPT = textwrap.dedent("""
    import multiprocessing as mp
    if __name__ == "__main__":
        mp.set_start_method("spawn")
        import fdi.estimators
        from fdi.api import diagnose
        fdi.estimators.POOL_WORTH_S = 0.0        # the pool for every batch's rest (these estimators are short)
        d = diagnose("models/cycab_steering.yaml", "models/data/cycab/scenario2.csv", workers=2, pop=12,
                     generations=6)
        print(len(d.estimates), sum(len(e.estimates) for e in d.episodes))
""")


def test_a_spawned_pool_derives_the_model_once_in_the_parent(tmp_path):
    log = tmp_path / "derivations"
    env = {**os.environ, LOG_ENV: str(log), "PYTHONPATH": str(ROOT), "BGFDI_CACHE": "off"}   # every derivation happens
    out = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    estimators = sum(int(x) for x in out.stdout.split())
    counts = collections.Counter(log.read_text().split())
    assert estimators >= 4                          # enough jobs that a per-job derivation would show
    assert set(counts.values()) == {1}              # once
    assert len(counts) == 1                         # in the parent: a worker receives the compiled monitor
