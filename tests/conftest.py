"""Shared fixtures: the shipped models and the CyCab reference data (copied into tests/data)."""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from bondgraph.loader import load_model
from fdi.arrs import derive_arrs

# bgfdi's disk cache (compiled models, the built C kernels) in a folder of this test process's own,
# removed at its exit, and shared with the processes it starts: a test never reads or fills the
# user's ~/.cache. With the cache off (as until 2026-11-29) no process could keep the C kernels
# (optim.kernels takes C only with a store): every process that identified took numba's path
# instead, paying its import and kernel loading (~1.2 s a process: bench diagnose's "numba kernels
# in a fresh process"), and every CLI subprocess derived its model again. A test
# that counts derivations, or compares a fresh process with a warm one, turns the cache off or
# gives it a folder of its own (tests/test_worker_pool.py, tests/test_diskcache.py).
_CACHE = tempfile.mkdtemp(prefix="bgfdi-tests-")
os.environ.pop("BGFDI_CACHE", None)
os.environ["BGFDI_CACHE_DIR"] = _CACHE
atexit.register(shutil.rmtree, _CACHE, True)

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
DATA = Path(__file__).resolve().parent.parent / "models" / "data" / "cycab"
CYCAB = MODELS / "cycab_steering.yaml"
SHIPPED = sorted(MODELS.glob("*.yaml"))


@pytest.fixture(scope="session")
def cycab():
    return load_model(CYCAB)


@pytest.fixture(scope="session")
def cycab_arrs(cycab):
    return derive_arrs(cycab)


SLOW_FIRST = ("test_tutorial.py", "test_golden.py", "test_evaluate.py", "test_domain_converter.py",
              "test_plant_accuracy.py", "test_rediagnosis.py")


def pytest_collection_modifyitems(config, items):
    """The longest tests first (the tutorial's commands take about 3 minutes of one core): with
    ``-n auto`` a long test collected last ran alone at the end while the other worker idled
    (measured: CI's wall time 10 min 56 s with tests of 20 core-minutes on 2 cores). A stable sort:
    the order within each group is the files' own."""
    items.sort(key=lambda item: 0 if item.nodeid.split("::")[0].endswith(SLOW_FIRST) else 1)
