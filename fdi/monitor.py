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

A monitor pickles compiled (its model, settings, kernels as the source lambdify generated, time
scales and nominal FSM and MCSM: :mod:`fdi.persist`), so a worker of a pool started with
``spawn`` (macOS, Windows, Python 3.14) or of a dask cluster derives nothing; a process unpickles
one monitor once, however many jobs carry it. Where a kernel is not portable it pickles as its
model and settings, and a process that unpickles it derives the model once (a process-wide cache
keyed by the model's content).

A model file's compiled monitor is also kept on disk between processes (:mod:`fdi.diskcache`:
per user, authenticated before it is read, keyed by the file's path and text, bgfdi's source and
the versions of Python, numpy and sympy), so a second ``bgfdi diagnose`` of the same model skips
the derivation; ``BGFDI_CACHE=off`` or ``--no-cache`` turns that off.
"""
from __future__ import annotations

import hashlib
import os
import pickle
import stat
import time
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from bondgraph.model import Model

from .config import MonitorConfig, load, load_text
from .persist import Pickled

if TYPE_CHECKING:                   # the derivation's modules are imported where a model is derived, not on a warm start
    from .arrs import ARR
    from .residuals import Residual
    from .signatures import FSM, MCSM
    from .options import Options
    from .results import Coincidence, Diagnosis
    from .scales import Scales
    from .stream import Stream

CACHE = 8                 # derived models kept per process (an edited model file is a new one)
LOG_ENV = "BGFDI_DERIVATION_LOG"   # a file each derivation appends its process id to (tests count them)
_derived: OrderedDict[str, tuple[tuple[ARR, ...], tuple[Residual, ...]]] = OrderedDict()
_files: OrderedDict[tuple, "Monitor"] = OrderedDict()
_unpacked: OrderedDict[bytes, "Monitor"] = OrderedDict()     # monitors received pickled, by their bytes' digest


def _value(x: Any) -> Any:
    return x.get() if isinstance(x, Pickled) else x


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
        arrs, residuals = _derived[key]
        return _value(arrs), residuals
    from .arrs import select_arrs
    from .residuals import compile_residuals
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
    """A model file compiled once per process and file version (its real path and its bytes): a
    model edited between two diagnoses is derived again, never served stale, even when the edit
    kept the file's size and modification time (``touch -r``, or two saves within the clock's
    tick: a key of size and mtime served the old derivation then)."""
    source = _disk_source(path)                     # None: the loader reports the file as missing
    version = None if source is None else hashlib.sha256(source).digest()
    if version is not None and version in _files:
        _files.move_to_end(version)
        return _files[version]
    m = _from_disk(path, source)
    from . import diskcache
    if m is not None:
        diskcache.note(f"compiled model of {path}: read from the cache")
    else:
        started = time.process_time()
        model, config = load(path)
        m = Monitor(model, config)
        diskcache.note(f"compiled model of {path}: derived in {time.process_time() - started:.2f} s CPU"
                               + ("" if diskcache.enabled() else " (cache off)"))
        if source is not None and _disk_source(path) == source:    # stored only if the file did not change meanwhile
            _to_disk(m, path, source)
        else:
            version = None                          # changed while it was read: not kept under the old bytes
    if version is not None:
        _remember(_files, version, m)
    return m


def _disk_source(path: str) -> bytes | None:
    """What a model file's compiled monitor is derived from: its real path and its bytes (at most
    1 MB and one byte: the loader refuses more); None for anything but a regular file (a named
    FIFO is not opened as a file, which would wait for a writer: the loader says what it is)."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        with open(path, "rb") as fh:
            raw = fh.read(1 << 20 | 1)
    except (OSError, ValueError):
        return None
    return os.path.realpath(path).encode("utf-8", "surrogateescape") + b"\0" + raw


def _from_disk(path: str, source: bytes | None) -> "Monitor | None":
    """The compiled monitor of this very file text (``source``: :func:`_disk_source`) from the disk
    cache (:mod:`fdi.diskcache`), or None (absent, stale, foreign, tampered, or the cache off: then
    it is derived afresh)."""
    from . import diskcache
    if source is None or not diskcache.enabled():
        return None
    payload = diskcache.fetch("monitor", source)
    if payload is None:
        return None
    try:
        m = _restored(payload)
    except Exception:                               # noqa: BLE001 - an unreadable entry is rebuilt, never trusted
        return None
    m._disk = (path, source, _persisted_size(m), m.config)
    _derived[m.key] = (m._arrs, m._residuals)
    return m


def _persisted_size(m: "Monitor") -> int:
    from .persist import size
    return size(m)


def _to_disk(m: "Monitor", path: str, source: bytes, config: MonitorConfig | None = None) -> None:
    """Store the monitor of the file ``path`` (whose content is ``source``) with the file's settings."""
    from . import diskcache
    if not diskcache.enabled():
        return
    from .persist import pack
    config = config or m.config
    payload = pack(m, config)
    if payload is not None and diskcache.store("monitor", source, payload):
        m._disk = (path, source, _persisted_size(m), config)


def persist(monitor: "Monitor") -> None:
    """Store a model file's monitor again when it has derived more since it was stored (the time
    scales, the FSM and MCSM of a mode): the next process starts with them. Cheap when nothing is new."""
    disk = getattr(monitor, "_disk", None)
    if disk is None or _persisted_size(monitor) <= disk[2]:
        return
    path, source, _, config = disk
    if _disk_source(path) == source:                # the file is still what was derived
        _to_disk(monitor, path, source, config)


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
    def arrs(self) -> tuple[ARR, ...]:
        """The AGARRs the residual selection kept (sympy; unpickled on first read when the monitor
        was read back compiled: :class:`Pickled`)."""
        return _value(self._arrs)

    @arrs.setter
    def arrs(self, value: tuple[ARR, ...]) -> None:
        self._arrs = value

    @property
    def residuals(self) -> tuple[Residual, ...]:
        """The residual kernels monitored: each AGARR's, divided by its mode's threshold where the
        settings give thresholds by mode (:mod:`fdi.mode_thresholds`; compiled once per table)."""
        tables = self.config.mode_thresholds
        if not tables:
            return self._residuals
        key = tuple(sorted((name, tuple(sorted(t.items()))) for name, t in tables.items()))
        hit = self.__dict__.get("_scaled")
        if hit is None or hit[0] != key or hit[1] is not self._residuals:
            from .residuals import divided_by_mode
            hit = (key, self._residuals, divided_by_mode(self.model, self.arrs, self._residuals, tables))
            self.__dict__["_scaled"] = hit
        return hit[2]

    @residuals.setter
    def residuals(self, value: tuple[Residual, ...]) -> None:
        self._residuals = value

    @property
    def arr_residuals(self) -> tuple[Residual, ...]:
        """The AGARRs' residual kernels, undivided (in their units, whatever the settings):
        what calibration measures."""
        return self._residuals

    @property
    def names(self) -> tuple[str, ...]:
        """The residuals' names (ARR1, ARR2, ...): each residual is its AGARR's."""
        return tuple(r.name for r in self.residuals)

    @property
    def units(self) -> tuple[str, ...]:
        """Each residual's unit, from its causality (:func:`fdi.arrs.arr_unit`; "?" where unknown)."""
        if "units" not in self._matrices:
            from .arrs import arr_unit
            self._matrices["units"] = tuple(arr_unit(self.model, a) for a in self.arrs)
        tables = self.config.mode_thresholds        # divided by its mode's threshold: in thresholds
        return tuple("1" if r.name in tables else u for r, u in zip(self._residuals, self._matrices["units"]))

    @property
    def coinciding(self) -> tuple["Coincidence", ...]:
        """The pairs of faults the residuals read only through one combination (a constant fault of
        one is fitted as well by the other: :func:`fdi.identifiability.coinciding`), decided once."""
        if "coinciding" not in self._matrices:
            from .identifiability import coinciding
            self._matrices["coinciding"] = coinciding(self.model, self.arrs)
        return self._matrices["coinciding"]

    @property
    def affine(self) -> frozenset[str]:
        """The mode variables every residual reads affinely (:func:`fdi.mode_estimation.affine_modes`),
        decided once and kept with the compiled model (a warm process dates a mode fault without sympy)."""
        tables = self.config.mode_thresholds        # (the residuals divided by their mode's threshold: read so)
        key = ("affine",) + tuple(sorted((n, tuple(sorted(t.items()))) for n, t in tables.items()))
        if key not in self._matrices:
            from .mode_estimation import affine_modes
            self._matrices[key] = affine_modes(self.model, self.residuals)
        return self._matrices[key]

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
            from .signatures import fault_signature_matrix
            self._matrices[key] = fault_signature_matrix(self.model, list(self.arrs), mode)
        return self._matrices[key]

    def mcsm(self, mode: dict[str, int]) -> MCSM:
        """The MCSM in ``mode`` (computed once per mode)."""
        key = ("mcsm",) + tuple(sorted(mode.items()))
        if key not in self._matrices:
            from .signatures import mode_change_signature_matrix
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
        """Detect, isolate, identify and prognose (:func:`fdi.pipeline.run`); ``data``: a CSV path,
        :class:`fdi.data.Measurements`, a pandas DataFrame, a dict of arrays or a structured array
        (:func:`fdi.ingest.measurements`), as for :func:`fdi.api.diagnose`."""
        from .pipeline import run
        return run(self, data, options, progress, memo)

    def stream(self, emit: Callable[[dict], None], options: "Options | None" = None, **kw) -> "Stream":
        """A streaming monitor that feeds blocks of rows and emits events (:class:`fdi.stream.Stream`);
        closed, it keeps what it derived (the time scales, FSMs) with a model file's compiled monitor
        on disk (:func:`persist`), as ``bgfdi monitor`` and :func:`fdi.api.diagnose` do."""
        from .stream import Stream
        kw.setdefault("closed", lambda: persist(self))
        return Stream(self, emit, options, **kw)

    def __reduce__(self):
        """Pickled compiled: its model, settings and what it derived (kernels as the source lambdify
        generated, :mod:`fdi.persist`), so a worker process (a pool's, a dask cluster's) starts
        without deriving; as its model and settings where a kernel is not portable (the worker
        then derives it once)."""
        from .persist import pack
        payload = pack(self)
        if payload is not None:
            return (_unpack, (payload,))
        return (_rebuild, (self.model, self.config))

    def __repr__(self) -> str:
        return f"<Monitor of {self.model.name}: {len(self.arrs)} residuals, {len(self.model.faults)} faults>"


def _unpack(payload: bytes) -> Monitor:
    """A monitor pickled compiled (:meth:`Monitor.__reduce__`), in the process that receives it;
    the first one of a model in a process is kept, so later ones share its derivation."""
    digest = hashlib.sha256(payload).digest()
    if digest in _unpacked:                         # the same monitor again (a pool's next job): unpickled once
        _unpacked.move_to_end(digest)
        return _unpacked[digest]
    m = _restored(payload)
    _remember(_unpacked, digest, m)
    if m.key in _derived:
        _derived.move_to_end(m.key)
        m._arrs, m.residuals = _derived[m.key]
    else:
        _remember(_derived, m.key, (m._arrs, m._residuals))
    return m


def _restored(payload: bytes) -> Monitor:
    """A monitor from the bytes :func:`fdi.persist.pack` made (authenticated or our own pickle)."""
    from .persist import restore
    m = object.__new__(Monitor)
    m.__dict__.update(restore(payload))
    return m


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


__all__ = ["Monitor", "compiled", "monitor_of", "derive", "model_key", "persist"]
