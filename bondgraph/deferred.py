"""Symbolic fields that unpickle on first read: a compiled model starts without sympy.

A model's elements, sensors, inputs and modes carry sympy expressions; a diagnosis of a model
read back from the disk cache, or received by a worker, reads their names, kinds and columns
and almost never the expressions (the residual kernels are compiled already). Importing sympy
to unpickle them costs a warm process about 0.25 s of its 1.3 s. A class decorated with
:func:`deferred` pickles the named fields as one nested pickle of their own; an unpickled
object holds those bytes and unpickles them (importing sympy) the first time one of the fields
is read. Everything else reads as before: equality, hashing, ``repr``, :func:`dataclasses.replace`
and copies read the fields through attribute access, so they load them first. A field whose
value is None is kept as None (``mode.positive is None`` costs no load).

>>> import pickle
>>> from bondgraph.loader import load_model
>>> m = load_model("models/cycab_steering.yaml")
>>> back = pickle.loads(pickle.dumps(m))
>>> dp = back.sensors["dp"]
>>> loaded(dp), dp.kind, dp.unit            # its plain fields read without sympy
(False, 'De', 'Pa')
>>> dp.signal, loaded(dp)                   # its expression unpickled on first read
(p1 - p2, True)
>>> back == m
True
"""
from __future__ import annotations

import pickle
from typing import Any, Callable, TypeVar

BUNDLE = "_deferred_bundle"         # the instance attribute that holds the fields' pickled bytes
PROTOCOL = 4                        # the bundles' pickle protocol, whatever the outer pickle's: an object
                                    # read back pickles to the bytes it was read from (fdi.monitor.model_key)

T = TypeVar("T")


def _load(obj: Any) -> None:
    """Unpickle the object's deferred fields into its ``__dict__``. The fields are set before the
    bytes are dropped, so a thread that reads one meanwhile finds either the bytes or the field
    (two threads may both unpickle: the same values, set twice)."""
    blob = obj.__dict__.get(BUNDLE)
    if blob is not None:
        for name, value in pickle.loads(blob).items():   # bytes this program pickled itself
            object.__setattr__(obj, name, value)
        obj.__dict__.pop(BUNDLE, None)


def _getattr(self: Any, name: str) -> Any:
    """Called only for an attribute the instance lacks: a deferred field not loaded yet."""
    if name in type(self)._deferred_fields:
        d = self.__dict__
        if BUNDLE in d:
            _load(self)
        if name in d:
            return d[name]
    raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")


def rebuilt(cls: type, state: dict, blob: bytes | None) -> Any:
    """An instance of ``cls`` from its plain fields ``state`` and its deferred fields' bytes
    (:func:`pickled`), which stay bytes until a deferred field is read."""
    obj = object.__new__(cls)
    obj.__dict__.update(state)
    if blob is not None:
        obj.__dict__[BUNDLE] = blob
    return obj


def pickled(obj: Any) -> tuple[dict, bytes | None]:
    """An instance's plain fields and its deferred fields' bytes (as read, when never loaded): what
    :func:`rebuilt` takes back. Deferred fields that are None stay plain."""
    names = type(obj)._deferred_fields
    d = obj.__dict__
    state = {k: v for k, v in d.items() if k != BUNDLE and not (k in names and v is not None)}
    blob = d.get(BUNDLE)
    if blob is None:
        later = {n: d[n] for n in names if d.get(n) is not None}
        blob = pickle.dumps(later, protocol=PROTOCOL) if later else None
    return state, blob


def _reduce_ex(self: Any, protocol: int) -> tuple:
    return (rebuilt, (type(self), *pickled(self)))


def deferred(*names: str) -> Callable[[type[T]], type[T]]:
    """Class decorator (outside ``@dataclass``): the fields ``names`` pickle apart and unpickle
    when first read. Their class-level defaults are removed (a dataclass's ``__init__`` keeps its
    own), so a field missing from an instance reaches ``__getattr__``."""
    def wrap(cls: type[T]) -> type[T]:
        for n in names:
            if n in cls.__dict__:
                delattr(cls, n)
        cls._deferred_fields = frozenset(names)
        cls.__getattr__ = _getattr
        cls.__reduce_ex__ = _reduce_ex
        return cls
    return wrap


def loaded(obj: Any) -> bool:
    """Whether an object's deferred fields are in memory (False: still pickled bytes)."""
    return BUNDLE not in getattr(obj, "__dict__", {})


__all__ = ["deferred", "loaded", "pickled", "rebuilt"]
