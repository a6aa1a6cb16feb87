"""Measurements from whatever a caller holds: a CSV path, a pandas DataFrame, a dict of arrays, a
numpy structured array, or :class:`fdi.data.Measurements` (a ``t`` column in seconds; the model's
columns). Every front door that takes data in memory reads it here, with the checks every CSV file
gets (:func:`fdi.data.checked`): :func:`fdi.api.diagnose` and :meth:`fdi.monitor.Monitor.diagnose`
alike.

>>> import numpy as np
>>> m = measurements({"t": np.arange(3) * 0.1, "p": [1.0, 2.0, 3.0]})
>>> m.ts, list(m.columns)
(0.1, ['t', 'p'])
>>> measurements({"t": [0.0, 0.1], "p": [1.0, 2.0j]})
Traceback (most recent call last):
fdi.data.DataError: data: column 'p' holds complex numbers; give real values (e.g. .real or abs())
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .data import DataError, Measurements, check_header, checked, read_csv


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
    return checked(name, header, table, in_memory=True)


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


__all__ = ["measurements"]
