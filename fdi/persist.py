"""A compiled monitor as bytes and back, for the disk cache (:mod:`fdi.diskcache`).

What a monitor derives once (its AGARRs, their residual kernels, the model's time scales, the FSM
and MCSM of each mode asked so far) is pickled with its model and settings. A residual kernel is a
function sympy's ``lambdify`` generated from an expression this program derived; it is stored as
that generated source and compiled again on load in the namespace ``lambdify`` gives it (numpy's
functions), after checking, when it is stored, that every global name it reads means the same
object there. The sympy parts (the model's expressions, each residual's expression, the AGARRs)
are nested pickles of their own, unpickled only when something reads them
(:mod:`bondgraph.deferred`, :class:`Pickled`): a diagnosis of a monitor read back imports no
sympy. The faults' linear transforms (:func:`fdi.objective.linear_transforms`) travel with it. The
bytes are only ever read back through :func:`fdi.diskcache.fetch`, which
authenticates them (an HMAC under this user's private key) before anything is unpickled.

>>> from fdi.monitor import Monitor
>>> m = Monitor("models/two_tank_valve.yaml")
>>> back = restore(pack(m))
>>> back["_arrs"].get() == m.arrs and back["_residuals"][0].expr == m.residuals[0].expr
True
"""
from __future__ import annotations

import hashlib
import inspect
import pickle
from typing import TYPE_CHECKING, Any

from bondgraph import deferred

if TYPE_CHECKING:
    from .residuals import Residual

FORMAT = 4          # 4: the faults the residuals read together travel with the FSMs (Monitor.coinciding)


SOURCE = "__bgfdi_source__"       # the attribute a kernel compiled from its source keeps it in


class NotPortable(ValueError):
    """A kernel whose source cannot be compiled back to the same function (then nothing is stored)."""


def _names(code) -> set[str]:
    """Every global name a code object (and the code nested in it) reads."""
    out = set(code.co_names)
    for c in code.co_consts:
        if hasattr(c, "co_names"):
            out |= _names(c)
    return out


def _kernel_source(func) -> tuple[str, tuple[str, ...]]:
    """The generated source of a lambdified kernel and the numpy names it reads: each global it
    reads must be numpy's attribute of that name (what ``lambdify(..., modules="numpy")`` binds),
    or a builtin, so that the source compiled again in a namespace of those names is the same
    function (and the load needs neither sympy's printers nor ``from numpy import *``)."""
    import builtins

    import numpy as np
    source = getattr(func, SOURCE, None) or inspect.getsource(func)
    g = func.__globals__
    reads = []
    for name in sorted(_names(func.__code__)):
        if name in g:
            ours = getattr(np, name, None)
            if ours is not g[name] and not (isinstance(ours, float) and ours == g[name]):
                raise NotPortable(f"the kernel reads {name}, which is not numpy's")
            reads.append(name)
        elif not hasattr(builtins, name):
            raise NotPortable(f"the kernel reads {name}, which it does not define")
    return source, tuple(reads)


def _spec(r: "Residual") -> tuple:
    """A residual's kernel as its source, its plain fields, and its expression as bytes of its own
    (unpickled, with sympy, only where a diagnosis reads it: :mod:`bondgraph.deferred`)."""
    _, blob = deferred.pickled(r)
    return (r.name, r.sensor, *_kernel_source(r.func), r.signals, r.symbols, blob,
            tuple((order, _spec(inner)) for order, inner in r.composites), r.ident)


def _residual(spec: tuple) -> "Residual":
    from .residuals import Residual
    name, sensor, source, reads, signals, symbols, blob, composites, ident = spec
    func = _function(name, source, reads)
    state = {"name": name, "sensor": sensor, "func": func, "signals": signals, "symbols": symbols,
             "composites": tuple((order, _residual(inner)) for order, inner in composites), "ident": ident}
    return deferred.rebuilt(Residual, state, blob)


class Pickled:
    """Bytes unpickled on first use, then kept: a compiled model's AGARRs read back from the disk
    cache or received by a worker (sympy objects: a diagnosis reads its residual kernels, not them,
    and starts without importing sympy)."""
    __slots__ = ("blob", "value")

    def __init__(self, blob: bytes) -> None:
        self.blob, self.value = blob, None

    def get(self) -> Any:
        if self.value is None:
            self.value = pickle.loads(self.blob)        # authenticated or our own pickle (:func:`restore`)
        return self.value


def pack(monitor: Any, config=None) -> bytes | None:
    """The monitor's model, settings (``config``, else its own) and everything it derived, as bytes; None when a kernel is not
    portable (the monitor is then simply not cached)."""
    from bondgraph import timescales
    memo = monitor.__dict__.get("_packed")
    config = config if config is not None else monitor.config
    if memo is not None and memo[0] == size(monitor) and memo[1] is config:
        return memo[2]
    try:
        warm(monitor)
    except Exception:                       # noqa: BLE001 - what fails here fails again, and is reported, where asked
        pass
    hit = timescales._CACHE.get(id(monitor.model))
    scales = hit[1] if hit is not None and hit[0] is monitor.model else None
    try:
        residuals = tuple(_spec(r) for r in monitor._residuals)     # the AGARRs' (a table by mode: per settings)
        signals = _signal_specs(monitor.model)
    except (NotPortable, OSError, TypeError):
        return None
    arrs = monitor.__dict__.get("_arrs")
    arrs = arrs.blob if isinstance(arrs, Pickled) else pickle.dumps(tuple(arrs), protocol=pickle.HIGHEST_PROTOCOL)
    record = {"format": FORMAT, "model": monitor.model, "config": config, "key": monitor.key,
              "arrs": arrs, "residuals": residuals, "time_scales": scales, "signals": signals,
              "matrices": dict(monitor._matrices), "linear": _linear_of(monitor)}
    try:
        out = pickle.dumps(record, protocol=pickle.HIGHEST_PROTOCOL)
    except (pickle.PicklingError, TypeError, AttributeError):
        return None
    monitor.__dict__["_packed"] = (size(monitor), config, out)     # one pickle per pool job: packed once
    return out


def warm(monitor: Any) -> None:
    """Derive what every diagnosis asks for first, so the packed monitor carries it: the residuals'
    units, the sensors', inputs' and autonomous modes' functions, the faults' linear transforms,
    the faults the residuals read together (a report names them), the FSM and MCSM of the nominal
    mode (a worker that receives it then derives nothing before its first file)."""
    from .data import _signal_functions
    from .objective import linear_transforms
    from .signatures import nominal_mode
    try:
        monitor.coinciding                  # first and apart: a later step that fails keeps it
    except Exception:                       # noqa: BLE001 - asked again (and reported) where a report needs it
        pass
    monitor.units
    _signal_functions(monitor.model)
    linear_transforms(monitor.model, monitor.residuals)
    mode = nominal_mode(monitor.model)
    monitor.fsm(mode)
    monitor.mcsm(mode)


def restore(payload: bytes) -> dict[str, Any]:
    """What :func:`pack` stored, as the monitor's attributes (``model``, ``config``, ``key``,
    ``_arrs``: :class:`Pickled`, ``_residuals`` (the AGARRs' kernels, undivided), ``_matrices``), the model's time scales and signal functions given
    back to the caches that keep them (raises on anything else: the caller derives it afresh).
    The payload comes from :func:`fdi.diskcache.fetch` (authenticated) or from this user's own
    pickle stream (:meth:`fdi.monitor.Monitor.__reduce__`)."""
    record = pickle.loads(payload)          # authenticated by fdi.diskcache before it gets here
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise ValueError("not a compiled monitor of this format")
    model = record["model"]
    out = {"model": model, "config": record["config"], "key": record["key"], "_arrs": Pickled(record["arrs"]),
           "_residuals": tuple(_residual(s) for s in record["residuals"]), "_matrices": dict(record["matrices"])}
    if record["time_scales"] is not None:
        from bondgraph import timescales
        if len(timescales._CACHE) > 32:
            timescales._CACHE.clear()
        timescales._CACHE[id(model)] = (model, record["time_scales"])   # what model_time_scales keeps
    if record["linear"] is not None:
        from . import objective
        if len(objective._LINEAR) + len(record["linear"]) > objective.LINEAR_KEPT:
            objective._LINEAR.clear()
        objective._LINEAR.update(record["linear"])
    if record["signals"] is not None:
        from . import data
        if len(data._SIGNALS) > 16:
            data._SIGNALS.clear()
        data._SIGNALS[id(model)] = (model, {name: (args, _function(name, source, reads))
                                            for name, (args, source, reads) in record["signals"].items()})
    return out


def _function(name: str, source: str, reads: tuple[str, ...]):
    """A lambdified function compiled again from its generated source, in numpy's names it reads;
    the source kept on it (it is packed again when its monitor is pickled for a worker) and in
    ``linecache`` (a traceback through it shows the line)."""
    import linecache

    import numpy as np
    scope = {n: getattr(np, n) for n in reads}
    local: dict[str, Any] = {}
    filename = f"<bgfdi kernel {name} {hashlib.sha256(source.encode()).hexdigest()[:12]}>"
    exec(compile(source, filename, "exec"), scope, local)   # source lambdify generated, authenticated
    (func,) = local.values()
    setattr(func, SOURCE, source)
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    return func


def _linear_of(monitor: Any) -> dict | None:
    """How each fault's magnitude enters the monitor's residuals (:func:`fdi.objective.linear_transforms`,
    by what each answer depends on; :func:`warm` answered them), or None where that failed."""
    from . import objective
    try:
        return objective.linear_transforms(monitor.model, monitor.residuals)
    except Exception:                       # noqa: BLE001 - not kept: a diagnosis asks again and reports
        return None


def _signals_of(model):
    """The lambdified sensor and input expressions :mod:`fdi.data` keeps for ``model``, if made."""
    from . import data
    hit = data._SIGNALS.get(id(model))
    return hit[1] if hit is not None and hit[0] is model else None


def _signal_specs(model) -> dict | None:
    functions = _signals_of(model)
    if functions is None:
        return None
    return {name: (args, *_kernel_source(fn)) for name, (args, fn) in functions.items()}


def size(monitor: Any) -> int:
    """How many derived things a monitor holds beyond its residuals (so the caller knows when to store again)."""
    from bondgraph import timescales
    hit = timescales._CACHE.get(id(monitor.model))
    return (len(monitor._matrices) + (1 if hit is not None and hit[0] is monitor.model else 0)
            + (_signals_of(monitor.model) is not None))


__all__ = ["pack", "restore", "size", "NotPortable", "Pickled"]
