"""A compiled monitor as bytes and back (fdi.persist, as a pool worker receives it): it diagnoses
as the monitor derived.

Tried and dropped: rebuilding the record's sympy expressions with sympy's evaluation off (they were
stored canonical). ``pickle.loads`` took 5 ms instead of 62 and every expression of eight models
came back equal, by ``srepr`` and arguments; but the whole ``bgfdi diagnose`` process of scenario 3
took 0.86-0.88 s instead of 0.57-0.58 s (sympy's later work on objects it had not built itself)."""
from __future__ import annotations

import pickle

from fdi.monitor import Monitor

from .conftest import ROOT


def test_a_monitor_restored_diagnoses_as_the_one_derived():
    """The solenoid's grown air gap (tests/test_domain_magnetic.py) diagnosed by a monitor derived
    here and by the same monitor sent through pickle (``Monitor.__reduce__``: fdi.persist, as a pool
    worker receives it): the same report."""
    from fdi.options import Options

    from .independent import measurements, solenoid
    model = ROOT / "tests" / "data" / "solenoid.yaml"
    data = measurements(solenoid.simulate, "gap", 4, t0=1.0, pg=2.0e-7)
    options = Options(workers=1, seed=0, thresholds={"ARR1": 0.1})
    derived = Monitor(model)
    restored = pickle.loads(pickle.dumps(derived))
    assert restored is not derived and restored.arrs[0].expr == derived.arrs[0].expr
    assert restored.diagnose(data, options).to_dict() == derived.diagnose(data, options).to_dict()
