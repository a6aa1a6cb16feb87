"""The notebook API: ``diagnose(model, data, config) -> Diagnosis``.

    >>> from fdi.api import diagnose
    >>> d = diagnose("models/cycab_steering.yaml", "models/data/cycab/scenario2.csv", workers=1)
    >>> [(f["name"], f["type"]) for f in d.faults]
    [('R4', 'abrupt'), ('beta_theta2', 'incipient')]
    >>> round(d.prognosis[0]["rul"], 1)
    23.3

``d.to_json()`` is what ``bgfdi diagnose --json`` prints for the same file.

The model is a path to a YAML file, or YAML text; a :class:`bondgraph.model.Model` is taken by
the path it was loaded from. The data are a CSV path, a pandas DataFrame, a dict of arrays, a numpy
structured array, or :class:`fdi.data.Measurements` (a ``t`` column in seconds; the model's
columns). ``config`` is the monitor settings (:class:`fdi.config.MonitorConfig`: thresholds,
windows, fault bounds and failure values; by default the model file's), or
:class:`fdi.diagnose.Options` (engine, seed, workers, threshold overrides, ...), whose fields may
also be given as keyword arguments. Nothing is cached across an edit: a model file is derived
again when it changes on disk.
"""
from __future__ import annotations

import copy
import hashlib
import html
import json
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from bondgraph.model import Model

from .config import MonitorConfig
from .data import DataError, Measurements, checked, read_csv
from .diagnose import Options, deterministic, public
from .diagnose import diagnose as _diagnose


@dataclass
class Diagnosis:
    """A diagnosis: what ``bgfdi diagnose --json`` prints (``to_dict``), with the residuals kept
    for ``plot``. The fields are the report's: ``detection`` (None when nothing was detected),
    ``mode``, ``candidates``, ``estimators``, ``faults``, ``prognosis``, ``episodes``."""
    report: dict
    model_path: str
    residuals: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    thresholds: np.ndarray = field(repr=False)
    names: list[str] = field(default_factory=list)

    @property
    def detection(self) -> dict | None:
        return self.report["detection"]

    @property
    def mode(self) -> dict:
        return self.report["mode"]

    @property
    def candidates(self) -> list[list[str]]:
        return self.report["candidates"]

    @property
    def estimators(self) -> list[dict]:
        return self.report["estimators"]

    @property
    def faults(self) -> list[dict]:
        return self.report["diagnosis"]["faults"]

    @property
    def prognosis(self) -> list[dict]:
        return self.report["prognosis"]

    @property
    def episodes(self) -> list[dict]:
        return self.report.get("episodes", [])

    def to_dict(self) -> dict:
        """The report as ``bgfdi diagnose --json`` prints it (a copy: plain lists, dicts, numbers)."""
        return copy.deepcopy(self.report)

    def to_json(self, indent: int | None = 1) -> str:
        """``bgfdi diagnose --json``, character for character."""
        return json.dumps(self.report, indent=indent, default=float) + "\n"

    def plot(self) -> dict:
        """matplotlib Figures by name: residuals with thresholds, estimator fitness, fault profiles,
        RUL (needs the plot extra)."""
        from .identify import compiled
        from .plots import diagnosis_figures
        private = {**self.report, "_t": self.t, "_residuals": self.residuals, "_thresholds": self.thresholds,
                   "_names": self.names}
        return diagnosis_figures(private, compiled(self.model_path).model)

    def _repr_html_(self) -> str:
        d = self.detection
        rows = [("detection", "none" if d is None else
                 f"t<sub>D</sub> = {d['time']:.2f} s, coherence {d['coherence']}; at {d['decision_time']:.2f} s: "
                 f"{d['final_coherence']}")]
        rows += [(f["name"], describe_fault(f).split(": ", 1)[1]) for f in self.faults] or [("diagnosis", "no fault")]
        rows += [(f"RUL of {p['name']}", f"{p['rul']:.2f} s at {p['at']:.2f} s (EOL {p['eol']:.2f} s)")
                 for p in self.prognosis if p.get("rul") is not None]
        body = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th><td style='text-align:left'>"
                       f"{html.escape(str(v)) if '<sub>' not in str(v) else v}</td></tr>" for k, v in rows)
        return f"<table><caption>bgfdi diagnosis</caption>{body}</table>"


def model_file(model: str | Path | Model) -> str:
    """A path the pipeline (and its worker processes) can load: the file itself, or YAML text
    written once to a file named by its hash in the temporary folder."""
    if isinstance(model, Model):
        return model.path
    text = str(model)
    if "\n" not in text:                             # one line: a path (load_model reports a missing one)
        return text
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    path = Path(tempfile.gettempdir()) / f"bgfdi-model-{digest}.yaml"
    if not path.exists():
        tmp = path.with_suffix(".tmp")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(path)
    return str(path)


def measurements(data: Any, name: str = "data") -> Measurements:
    """Measurements from a CSV path, a DataFrame, a dict of arrays or a structured array."""
    if isinstance(data, Measurements):
        return data
    if isinstance(data, (str, Path)):
        return read_csv(data)
    if hasattr(data, "columns") and hasattr(data, "to_numpy"):            # a pandas DataFrame
        header = [str(c) for c in data.columns]
        table = np.asarray(data.to_numpy(dtype=float))
    elif isinstance(data, np.ndarray) and data.dtype.names:                # a structured array
        header = list(data.dtype.names)
        table = np.column_stack([np.asarray(data[h], dtype=float) for h in header])
    elif isinstance(data, dict):
        header = [str(k) for k in data]
        try:
            table = np.column_stack([np.asarray(v, dtype=float).reshape(-1) for v in data.values()])
        except ValueError as exc:
            raise DataError(f"{name}: the columns are not arrays of one length ({exc})") from None
    else:
        raise DataError(f"{name}: data must be a CSV path, a DataFrame, a dict of arrays or a structured array, "
                        f"not {type(data).__name__}")
    if "t" not in header:
        raise DataError(f"{name}: no 't' column (time in s) among {', '.join(header)}")
    return checked(name, header, table)


def diagnose(model: str | Path | Model, data: Any, config: MonitorConfig | Options | None = None,
             **options) -> Diagnosis:
    """Detect, isolate, identify and prognose (see :mod:`fdi.diagnose`). ``config``: the monitor
    settings (a :class:`fdi.config.MonitorConfig`, e.g. ``fdi.config.load(path)[1].replace(...)``)
    in place of the model file's, or run :class:`Options`; ``options`` are fields of
    :class:`Options` that override it."""
    if isinstance(config, MonitorConfig):
        config = Options(settings=config)
    o = replace(config or Options(), **options) if options else (config or Options())
    path = model_file(model)
    meas = measurements(data)
    report = _diagnose(path, meas, o)
    return Diagnosis(deterministic(public(report)), path, report["_residuals"], report["_t"], report["_thresholds"],
                     list(report["_names"]))


def _vec(v) -> str:
    return "[" + " ".join(str(x) for x in v) + "]"


def describe_fault(f: dict) -> str:
    """One fault of a report in words, as the text report and the notebook table show it."""
    if f["type"] == "abrupt":
        return f"{f['name']}: abrupt, value {f['value']:.5g}"
    if f["type"] == "intermittent":
        return f"{f['name']}: intermittent, value {f['value']:.5g}, period {f['period']:.4g} s"
    if f["type"] == "incipient":
        b = ", ".join(f"{x:.5g}" for x in f["b"])
        return f"{f['name']}: incipient, model {f['model']} (eq. {15 + f['model']}, eta {_vec(f['eta'])}), b = [{b}]"
    if f["type"] == "stuck":
        return f"{f['name']}: stuck at {f['value']:.5g} from {f['t0']:.4g} s"
    return f"{f['name']}: fault mode ({f['name']} = {f.get('value', 0)})"
