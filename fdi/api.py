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

import numpy as np

from bondgraph.model import Model

from .config import MonitorConfig
from .data import DataError, Measurements, check_header, checked, read_csv
from .monitor import Monitor, monitor_of
from .options import Options
from .results import Diagnosis


def measurements(data: Any, name: str = "data") -> Measurements:
    """Measurements from a CSV path, a DataFrame, a dict of arrays or a structured array."""
    if isinstance(data, Measurements):
        return data
    if isinstance(data, (str, Path)):
        if isinstance(data, str) and ("\n" in data or "\r" in data) and not Path(data).exists():
            raise DataError(f"{name}: text with line ends, not a file name; give the path of a CSV file, or the "
                            "data as a DataFrame, a dict of arrays or a structured array")
        return read_csv(data)
    if hasattr(data, "columns") and hasattr(data, "to_numpy"):            # a pandas DataFrame
        header = [str(c) for c in data.columns]
        check_header(name, header)
        try:
            table = np.asarray(_real(name, data.to_numpy(), "a column"), dtype=float)
        except DataError:
            raise
        except (TypeError, ValueError) as exc:              # object cells: text, None, lists
            raise DataError(f"{name}: {_not_numbers(data, header)} (as {str(exc)[:60]}); give numbers "
                            "(DataFrame.astype(float) shows where)") from None
    elif isinstance(data, np.ndarray) and data.dtype.names:                # a structured array
        header = list(data.dtype.names)
        try:
            table = np.column_stack([_column(name, h, data[h]) for h in header])
        except DataError:
            raise
        except (TypeError, ValueError) as exc:
            raise DataError(f"{name}: a field is not numbers ({str(exc)[:60]}); give numeric fields") from None
    elif isinstance(data, dict):
        header = [str(k) for k in data]
        check_header(name, header)                      # 1 and "1" are one column name
        try:
            table = np.column_stack([_column(name, h, v) for h, v in zip(header, data.values())])
        except DataError:
            raise
        except (TypeError, ValueError) as exc:
            raise DataError(f"{name}: the columns are not arrays of numbers of one length ({str(exc)[:80]})") from None
    else:
        raise DataError(f"{name}: data must be a CSV path, a DataFrame, a dict of arrays or a structured array, "
                        f"not {type(data).__name__}")
    if "t" not in header:
        raise DataError(f"{name}: no 't' column (time in s) among {', '.join(header)}")
    return checked(name, header, table)


def _real(name: str, values, what: str) -> np.ndarray:
    """``values`` as float64, refusing complex numbers (a cast to float would drop their imaginary
    parts silently, with only a warning)."""
    array = np.asarray(values)
    if np.iscomplexobj(array):
        raise DataError(f"{name}: {what} holds complex numbers; give real values (e.g. .real or abs())")
    return array.astype(float)


def _column(name: str, header: str, values) -> np.ndarray:
    """One column of a dict or structured array: one number per sample. An array with more than
    one axis of length > 1 (a matrix) is refused, where flattening it would read its rows as later
    samples; a column vector (n, 1) or row (1, n) is one column."""
    array = _real(name, values, f"column '{header}'")
    if sum(n > 1 for n in array.shape) > 1:
        raise DataError(f"{name}: column '{header}' is an array of shape {array.shape}, not one value per sample; "
                        "give one column per signal")
    return array.reshape(-1)


def _not_numbers(frame, header: list[str]) -> str:
    """Which column of a DataFrame holds a cell that is no number (the first found)."""
    for h, column in zip(header, frame.columns):
        try:
            cells = frame[column].to_numpy()
        except (TypeError, KeyError, AttributeError):    # a frame-like object without columns by name
            break
        try:
            np.asarray(cells, dtype=float)
        except (TypeError, ValueError):
            return f"column '{h}' holds a value that is no number"
    return "a value is no number"


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
    return monitor.diagnose(measurements(data), o)


__all__ = ["diagnose", "measurements", "Diagnosis", "Options"]
