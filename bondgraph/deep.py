"""Deep derivations: run a function on a thread whose stack and recursion limit fit a long chain.

A residual collected along a long causal path is one sympy expression nested about as deep as the
path is long (a drivetrain chain of 10 000 elements: a sum inside a product inside a sum, about
6 000 levels). Written flat it would be quadratic in size (every prefix product of the transformer
moduli spelled out), so the depth is the price of a linear size. sympy walks expressions
recursively (``free_symbols``, ``xreplace``, ``diff``, printing), two to four Python frames per level,
and CPython's default limit of 1 000 frames on a main thread's 8 MiB stack stops at about 1 600
elements. :func:`run_deep` gives the walk room instead: a thread with a large stack (reserved
address space; pages are touched only as deep as the walk goes) and a recursion limit to match.
The limit stays finite, so a runaway recursion is still a ``RecursionError``, not a crash.

A derivation also runs with Python's cyclic garbage collector paused (:func:`collector_paused`):
it makes millions of sympy objects that live to its end, almost none in cycles (reference
counting frees the rest), and the collector's full passes rescan them all again and again (20
passes in the check of a 10 000-element chain, about a third of its CPU time: 10.1-10.6 s with
them, 6.5-6.9 s without, the same machine and load; peak memory 214 -> 289 MB, the few cycles
freed after the derivation instead of during it).

>>> run_deep(lambda n: n + 1, 41)
42
"""
from __future__ import annotations

import gc
import sys
import threading
from contextlib import contextmanager
from typing import Any, Callable, Iterator

STACK_BYTES = 1 << 30           # 1 GiB of address space for the worker thread's stack
LIMIT = 250_000                 # Python frames: about 4 KiB of that stack per frame at worst


def run_deep(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)`` on a thread with a :data:`STACK_BYTES` stack and a recursion limit of
    :data:`LIMIT`, the collector paused (:func:`collector_paused`); its value returned and its
    exception re-raised here. The calling thread waits
    in short slices, so Ctrl-C and signal handlers still run there; the worker is a daemon thread
    (it does not keep an interrupted process alive). Where a thread of that stack cannot be made,
    ``fn`` runs here with the limits as they are."""
    out: dict[str, Any] = {}

    def work() -> None:
        try:
            with collector_paused():
                out["value"] = fn(*args, **kwargs)
        except BaseException as exc:          # noqa: BLE001 - handed to the caller as it is
            out["error"] = exc

    old_limit = sys.getrecursionlimit()
    try:
        old_size = threading.stack_size(STACK_BYTES)
    except (ValueError, RuntimeError):        # a platform without settable thread stacks
        with collector_paused():
            return fn(*args, **kwargs)
    try:
        worker = threading.Thread(target=work, name="bgfdi-deep", daemon=True)
        sys.setrecursionlimit(max(old_limit, LIMIT))      # the limit is per interpreter, read per thread
        worker.start()
    finally:
        threading.stack_size(old_size)
    try:
        while worker.is_alive():
            worker.join(0.1)
    finally:
        sys.setrecursionlimit(old_limit)
    if "error" in out:
        raise out["error"]
    return out.get("value")


def nodes(expr, descend=None):
    """Every distinct subexpression of ``expr`` (``expr`` first), each once, without recursion;
    the arguments of a node are visited only where ``descend(node)`` (None: everywhere).

    sympy's own walks (``preorder_traversal``, ``has``, ``free_symbols``) treat an expression as a
    tree: a residual of a long chain shares its subexpressions (the flows of a transformer chain
    hold one another), so a tree walk visits them again and again (2.4 million visits for one
    residual of a 4 000-element chain) and recurses as deep as the expression.

    >>> import sympy as sp
    >>> shared = sp.Symbol("x_shared") + 1
    >>> expr = sp.sin(shared) + sp.cos(shared)      # a tree walk sees x_shared + 1 twice
    >>> sorted(map(str, nodes(expr)))
    ['1', 'cos(x_shared + 1)', 'sin(x_shared + 1)', 'sin(x_shared + 1) + cos(x_shared + 1)', 'x_shared', 'x_shared + 1']

    Nodes are told apart by identity (hashing a deep expression would walk it): an equal copy
    made apart (after ``sympy.core.cache.clear_cache()``) is visited again, which changes no answer.
    """
    seen: set[int] = set()
    stack = [expr]
    while stack:
        node = stack.pop()
        key = id(node)
        if key in seen:
            continue
        seen.add(key)
        yield node
        if descend is None or descend(node):
            stack.extend(node.args)


def has_any(expr, targets) -> bool:
    """``expr.has(*targets)`` for atoms (numbers such as ``zoo``, ``nan``, ``oo``, symbols), each
    shared subexpression looked at once (:func:`nodes`).

    >>> import sympy as sp
    >>> has_any(1 / sp.Symbol("a") + sp.zoo, (sp.zoo, sp.nan)), has_any(sp.Symbol("a"), (sp.nan,))
    (True, False)
    """
    wanted = set(targets)
    return any(node in wanted for node in nodes(expr) if not node.args)


def free_symbols(expr) -> set:
    """``expr.free_symbols``, each shared subexpression visited once and without recursion
    (:func:`nodes`; sympy's property took 6.3 s on one residual of a 4 000-element chain). A node
    that binds variables (an Integral, a Lambda, a Subs) gives its own ``free_symbols``.

    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> sorted(free_symbols(sp.sin(x) * (x + y) + sp.Derivative(sp.Function("w")(x), x)), key=str)
    [x, y]
    """
    bound = lambda node: getattr(node, "bound_symbols", None)
    out: set = set()
    for node in nodes(expr, descend=lambda node: not bound(node)):
        if node.is_Symbol:
            out.add(node)
        elif bound(node):
            out |= node.free_symbols
    return out


@contextmanager
def collector_paused() -> Iterator[None]:
    """Python's cyclic garbage collector off for a derivation, restored as it was after it (it is
    one per process: a pause in one thread pauses it for all; the first to end restores it).
    The objects a derivation makes are freed by reference counting as before; only the rare
    cycles wait for the collector's next pass after it.

    >>> import gc
    >>> with collector_paused():
    ...     gc.isenabled()
    False
    >>> gc.isenabled()
    True
    """
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()
