"""The notebook API: ``diagnose(model, data, config) -> Diagnosis``.

    >>> from fdi.api import diagnose
    >>> d = diagnose("models/cycab_steering.yaml", "models/data/cycab/scenario2.csv", workers=1)
    >>> [(f.name, f.type) for f in d.faults]
    [('R4', 'abrupt'), ('beta_theta2', 'incipient')]
    >>> round(d.prognosis[0].rul, 1)
    23.3

``d.to_json()`` is what ``bgfdi diagnose --json`` prints for the same file; ``d.summary()`` says
it in a few lines, ``d.plot()`` draws it.

The model is a path to a YAML file, YAML text, a :class:`bondgraph.model.Model` (as loaded, or
built and changed in memory: what is in memory is diagnosed, with the monitor settings of the file
it came from, if any) or a compiled :class:`fdi.monitor.Monitor`. Nothing is written to disk. The
data are a CSV path, a pandas DataFrame, a dict of arrays, a numpy structured array, or
:class:`fdi.data.Measurements` (a ``t`` column in seconds; the model's columns). ``config`` is the
monitor settings (:class:`fdi.config.MonitorConfig`: thresholds, windows, fault bounds and failure
values; by default the model file's), or :class:`fdi.options.Options` (engine, seed, workers,
threshold overrides, ...), whose fields may also be given as keyword arguments. A model file is
derived again when it changes on disk.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from bondgraph.model import Model

from .config import MonitorConfig
from .ingest import measurements
from .monitor import Monitor, monitor_of, persist
from .options import Options
from .results import Diagnosis


def diagnose(model: Monitor | Model | str | Path, data: Any, config: MonitorConfig | Options | None = None,
             **options) -> Diagnosis:
    """Detect, isolate, identify and prognose (see :mod:`fdi.pipeline`). ``config``: the monitor
    settings (a :class:`fdi.config.MonitorConfig`, e.g. ``fdi.config.load(path)[1].replace(...)``)
    in place of the model file's, or run :class:`Options`; ``options`` are fields of
    :class:`Options` that override it."""
    if isinstance(config, MonitorConfig):
        config = Options(settings=config)
    o = replace(config or Options(), **options) if options else (config or Options())
    o.check()                                       # the options, then the model, then the data
    monitor = monitor_of(model)
    out = monitor.diagnose(measurements(data), o)
    persist(monitor)            # what it derived (the time scales, FSMs) kept for the next process, as the CLI does
    return out


__all__ = ["diagnose", "measurements", "Diagnosis", "Options"]
