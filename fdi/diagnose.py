"""``diagnose(model, data, options) -> Diagnosis``: the pipeline's functional front.

The model is a :class:`fdi.monitor.Monitor`, a :class:`bondgraph.model.Model`, a path to a YAML
file or YAML text; it is compiled once per process (:mod:`fdi.monitor`) and its diagnosis run
(:func:`fdi.pipeline.run`: detect, isolate, identify, prognose). The result is a
:class:`fdi.results.Diagnosis`; ``to_dict()`` is the JSON report.

    >>> d = diagnose("models/cycab_steering.yaml", "models/data/cycab/nominal.csv")
    >>> d.detection is None, d.to_dict()["diagnosis"]
    (True, {'faults': []})
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from bondgraph.model import Model

from .data import Measurements
from .monitor import Monitor, monitor_of
from .options import (MAX_GENERATIONS, MAX_POP, MIN_POP, MIN_SAMPLES, MIN_WINDOW_S, Options, check_samples,
                      min_samples)
from .results import Diagnosis, deterministic


def diagnose(model: Monitor | Model | str | Path, data: str | Path | Measurements, options: Options | None = None,
             progress: Callable | None = None, memo: dict | None = None) -> Diagnosis:
    """Detect, isolate, identify and prognose ``data`` (a CSV path or Measurements) with ``model``."""
    return monitor_of(model).diagnose(data, options, progress, memo)


def public(d: Diagnosis) -> dict:
    """The JSON report of a diagnosis (``Diagnosis.to_dict``)."""
    return d.to_dict()


def min_period(model: Monitor | Model | str | Path, options: Options, ts: float) -> float:
    """The shortest intermittent period identified on data sampled every ``ts`` s with ``options``."""
    return monitor_of(model).with_config(options.settings).scaled(ts)[1].min_period


__all__ = ["diagnose", "Options", "Diagnosis", "public", "deterministic", "check_samples", "min_samples",
           "min_period", "MIN_POP", "MAX_POP", "MAX_GENERATIONS", "MIN_SAMPLES", "MIN_WINDOW_S"]
