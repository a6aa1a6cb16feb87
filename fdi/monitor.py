"""A model compiled for monitoring, once: ``Monitor(model, config)``.

The bond graph (a path to a YAML file, YAML text, or a :class:`bondgraph.model.Model` built or
changed in memory), its monitor settings, the AGARRs the residual selection keeps and their
compiled residual kernels, and the FSM and MCSM of each mode as they are asked for. Every front
door (the CLI, the notebook API, fleets, the streaming monitor) diagnoses through one:

    >>> m = Monitor("models/cycab_steering.yaml")
    >>> m.names
    ('ARR1', 'ARR2', 'ARR3')
    >>> d = m.diagnose("models/data/cycab/scenario3.csv")
    >>> d.detection.time, [(f.name, f.type) for f in d.faults]
    (31.96, [('a1', 'mode')])

A monitor pickles as its model and settings; a process that unpickles it derives the model once
(a process-wide cache keyed by the model's content), so a pool of workers started with
``spawn`` (macOS, Windows, Python 3.14) derives it once per worker, not once per job.
"""
from __future__ import annotations

import hashlib
import os
import pickle
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from bondgraph.model import Model

from .arrs import ARR, select_arrs
from .config import MonitorConfig, load, load_text
from .residuals import Residual, compile_residuals
from .signatures import FSM, MCSM, fault_signature_matrix, mode_change_signature_matrix

if TYPE_CHECKING:
    from .options import Options
    from .results import Diagnosis
    from .scales import Scales
    from .stream import Stream

CACHE = 8                 # derived models kept per process (an edited model file is a new one)
LOG_ENV = "BGFDI_DERIVATION_LOG"   # a file each derivation appends its process id to (tests count them)
_derived: OrderedDict[str, tuple[tuple[ARR, ...], tuple[Residual, ...]]] = OrderedDict()
_files: OrderedDict[tuple, "Monitor"] = OrderedDict()


def _remember(cache: OrderedDict, key, value) -> None:
    cache[key] = value
    cache.move_to_end(key)
    while len(cache) > CACHE:
        cache.popitem(last=False)


def model_key(model: Model) -> str:
    """The identity of a model's physics: a digest of its pickled content, so a model changed in
    memory is derived again, never served a stale derivation (pickling is not canonical: two loads
    of one file may digest apart and derive twice; a monitor keeps its key)."""
    return hashlib.sha256(pickle.dumps(model, protocol=4)).hexdigest()


def derive(model: Model, key: str | None = None) -> tuple[tuple[ARR, ...], tuple[Residual, ...]]:
    """The AGARRs the residual selection keeps and their residual kernels, once per process."""
    key = key or model_key(model)
    if key in _derived:
        _derived.move_to_end(key)
        return _derived[key]
    arrs = tuple(select_arrs(model).arrs)
    out = (arrs, tuple(compile_residuals(model, list(arrs))))
    _remember(_derived, key, out)
    log = os.environ.get(LOG_ENV)
    if log:
        with open(log, "a", encoding="utf-8") as fh:
            fh.write(f"{os.getpid()}\n")
    return out


def _source(model: Model | str | Path) -> tuple[Model, MonitorConfig]:
    """The bond graph and the file's monitor settings of a path, YAML text or Model. A Model takes
    its settings from the file it was loaded from when that file still exists, else the defaults."""
    if isinstance(model, Model):
        path = Path(model.path) if model.path else None
        if path is not None and path.is_file():
            return model, _file(model.path).config
        return model, MonitorConfig()
    if not isinstance(model, (str, Path)):
        raise TypeError(f"a model is a path to a YAML file, YAML text, a bondgraph Model or an fdi Monitor, "
                        f"not {type(model).__name__}")
    text = str(model)
    if "\n" in text:                                # YAML text; one line is a path
        return load_text(text)
    m = _file(text)
    return m.model, m.config


def _file(path: str) -> "Monitor":
    """A model file compiled once per process and file version (path, size, modification time):
    a model edited between two diagnoses is derived again, never served stale."""
    try:
        st = os.stat(path)
        version = (os.path.realpath(path), st.st_size, st.st_mtime_ns)
    except OSError:
        version = None                              # the loader reports the file as missing
    if version is not None and version in _files:
        _files.move_to_end(version)
        return _files[version]
    model, config = load(path)
    m = Monitor(model, config)
    if version is not None:
        _remember(_files, version, m)
    return m


def compiled(path: str | Path) -> "Monitor":
    """The monitor of a model file with the file's settings (cached per file version)."""
    return _file(str(path))


class Monitor:
    """A model ready to monitor: ``model`` (physics), ``config`` (monitor settings: thresholds,
    windows, fault bounds and failure values), ``arrs`` and their compiled ``residuals``."""

    def __init__(self, model: Model | str | Path, config: MonitorConfig | None = None) -> None:
        physics, settings = (model, config) if isinstance(model, Model) and config is not None else _source(model)
        self.model: Model = physics
        self.config: MonitorConfig = config if config is not None else settings
        self.key = model_key(physics)
        self.arrs, self.residuals = derive(physics, self.key)
        self._matrices: dict[tuple, Any] = {}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.arrs)

    @property
    def units(self) -> tuple[str, ...]:
        """Each residual's unit, from its causality (:func:`fdi.arrs.arr_unit`; "?" where unknown)."""
        if "units" not in self._matrices:
            from .arrs import arr_unit
            self._matrices["units"] = tuple(arr_unit(self.model, a) for a in self.arrs)
        return self._matrices["units"]

    def with_config(self, config: MonitorConfig | None) -> "Monitor":
        """This monitor with other settings (the derivation is shared)."""
        if config is None or config == self.config:
            return self
        other = object.__new__(Monitor)
        other.__dict__.update(self.__dict__, config=config, _matrices=self._matrices)
        return other

    def fsm(self, mode: dict[str, int]) -> FSM:
        """The MD-FSM in ``mode`` (computed once per mode)."""
        key = ("fsm",) + tuple(sorted(mode.items()))
        if key not in self._matrices:
            self._matrices[key] = fault_signature_matrix(self.model, list(self.arrs), mode)
        return self._matrices[key]

    def mcsm(self, mode: dict[str, int]) -> MCSM:
        """The MCSM in ``mode`` (computed once per mode)."""
        key = ("mcsm",) + tuple(sorted(mode.items()))
        if key not in self._matrices:
            self._matrices[key] = mode_change_signature_matrix(self.model, list(self.arrs), mode)
        return self._matrices[key]

    def scaled(self, ts: float) -> tuple["Monitor", "Scales"]:
        """The monitor with the times its settings leave to the data filled in for sampling time
        ``ts`` (:func:`fdi.scales.resolve`), and the time scales of a diagnosis."""
        from . import scales
        config = scales.resolve(self.config, self.model, ts)
        return self.with_config(config), scales.for_model(self.model, config, ts)

    def min_period(self, options: "Options", ts: float) -> float:
        """The shortest intermittent period identified on data sampled every ``ts`` s with ``options``
        (its monitor settings, if any)."""
        return self.with_config(options.settings).scaled(ts)[1].min_period

    def diagnose(self, data, options: "Options | None" = None, progress: Callable | None = None,
                 memo: dict | None = None) -> "Diagnosis":
        """Detect, isolate, identify and prognose (:func:`fdi.pipeline.run`); ``data``: a CSV path
        or :class:`fdi.data.Measurements`."""
        from .pipeline import run
        return run(self, data, options, progress, memo)

    def stream(self, emit: Callable[[dict], None], options: "Options | None" = None, **kw) -> "Stream":
        """A streaming monitor that feeds blocks of rows and emits events (:class:`fdi.stream.Stream`)."""
        from .stream import Stream
        return Stream(self, emit, options, **kw)

    def __reduce__(self):
        return (_rebuild, (self.model, self.config))

    def __repr__(self) -> str:
        return f"<Monitor of {self.model.name}: {len(self.arrs)} residuals, {len(self.model.faults)} faults>"


def _rebuild(model: Model, config: MonitorConfig) -> Monitor:
    m = object.__new__(Monitor)
    m.model, m.config, m.key = model, config, model_key(model)
    m.arrs, m.residuals = derive(model, m.key)
    m._matrices = {}
    return m


def monitor_of(model: "Monitor | Model | str | Path", config: MonitorConfig | None = None) -> Monitor:
    """A Monitor from anything a front door accepts: a Monitor, a Model, a path or YAML text."""
    if isinstance(model, Monitor):
        return model.with_config(config)
    if isinstance(model, (str, Path)) and "\n" not in str(model):
        return compiled(model).with_config(config)
    return Monitor(model, config)


__all__ = ["Monitor", "compiled", "monitor_of", "derive", "model_key"]
