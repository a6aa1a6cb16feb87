"""A residual kernel as a tape: the operations that depend on the individual, in order, for the
compiled objective (:mod:`fdi.fused`, :func:`fdi._jit.fused_cost`).

A residual kernel is the numpy function lambdify generated (:mod:`fdi.residuals`): straight-line
code ``x0 = ...; ...; return ...``. An estimator evaluates it for every individual of a population,
but most of its inputs are the same for all of them (the signals no candidate fault corrects, the
parameters no candidate fault changes). :func:`build` walks the generated code (Python's ``ast``:
nothing is executed but numpy's own operations on numbers the program computed) with each argument
either *concrete* (the array or number the numpy path would pass) or *per individual* (a parameter
profile, a corrected signal's derivative). A node whose inputs are all concrete is evaluated there
and then, by the very numpy operation the generated code applies to the very same arrays, so it is
the numpy path's number bit for bit (the constants folded, the common subexpressions of the
individual-free signals hoisted); a node that depends on the individual becomes one instruction of
the tape, run by the compiled kernel on blocks of samples of each individual. Elementwise
arithmetic is IEEE's in both; the transcendental functions are numpy's SIMD code in the numpy
path and, in the kernel, :mod:`fdi.trig`'s cos, sin and tan (loops that vectorise, within 1 ulp)
and libm's others (exp, general powers), a last-bit difference (tests/test_kernels.py compares
the costs to 1e-9). numpy's ``x ** 2``, ``x ** -1`` and
``x ** 0.5`` are square, reciprocal and square root (its fast scalar powers), and so are the
tape's.

Anything else (comparisons, ``select`` of a Piecewise, subscripts, keyword arguments) raises
:class:`Unsupported`, and the objective keeps its numpy path.

A signal (two samples), a parameter, and a parameter profile per individual: the cosine of
the signal plus twice the parameter is hoisted (one fixed array), the rest is three instructions
after the load:

>>> import numpy as np
>>> source = "def f(_a0, _a1, _a2):\\n    x0 = _a1 * 2\\n    return cos(_a0 + x0) * _a2 ** 2\\n"
>>> t = build(source, {"cos": np.cos}, [np.array([0.0, 1.0]), 0.25, Row(LOADP, 0)], 2)
>>> [NAMES[op] for op in t.code[:, 0]]
['LOADP', 'SQUARE', 'LOADF', 'MUL']
>>> t.fixed[0].tolist() == np.cos(np.array([0.0, 1.0]) + 0.5).tolist()
True
"""
from __future__ import annotations

import ast
import operator
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

# opcodes (fdi._jit reads them as constants): loads into a register, then elementwise operations
LOADF, LOADP, LOADS, CONST, COPY = 0, 1, 2, 3, 4
ADD, SUB, MUL, DIV, POW, ATAN2 = 10, 11, 12, 13, 14, 15
(NEG, ABS, SIGN, SQRT, SQUARE, RECIP, EXP, LOG, SIN, COS, TAN, ASIN, ACOS, ATAN, SINH, COSH, TANH,
 ASINH, ACOSH, ATANH) = range(20, 40)
NAMES = {v: k for k, v in dict(globals()).items() if k.isupper() and isinstance(v, int)}

UNARY = {np.negative: NEG, np.absolute: ABS, abs: ABS, np.sign: SIGN, np.sqrt: SQRT, np.square: SQUARE,
         np.reciprocal: RECIP, np.exp: EXP, np.log: LOG, np.sin: SIN, np.cos: COS, np.tan: TAN,
         np.arcsin: ASIN, np.arccos: ACOS, np.arctan: ATAN, np.sinh: SINH, np.cosh: COSH, np.tanh: TANH,
         np.arcsinh: ASINH, np.arccosh: ACOSH, np.arctanh: ATANH}
BINARY = {np.arctan2: ATAN2, np.power: POW}
BINOPS = {ast.Add: (ADD, operator.add), ast.Sub: (SUB, operator.sub), ast.Mult: (MUL, operator.mul),
          ast.Div: (DIV, operator.truediv), ast.Pow: (POW, operator.pow)}
FAST_POWERS = {2.0: SQUARE, -1.0: RECIP, 0.5: SQRT}     # numpy's fast scalar powers of an array


class Unsupported(ValueError):
    """The generated code does something the tape does not (the numpy path stays)."""


@dataclass(frozen=True)
class Row:
    """An argument that differs per individual: loaded by ``op`` (LOADP: a parameter slot, LOADS:
    a filtered signal slot) from ``slot``."""
    op: int
    slot: int


@dataclass(frozen=True)
class Tape:
    """A program of instructions (op, destination register, operand a, operand b) computing
    several residuals (and their variants), the constants and the hoisted individual-free arrays
    they read (``fixed``, each of the samples' length), the registers used, and the register
    holding each residual: ``results[i, 0]`` the residual, ``results[i, 1 + v]`` the residual with
    the slots of variant v remapped (a linear fault's parameters at their unit step)."""
    code: np.ndarray
    consts: np.ndarray
    fixed: tuple
    registers: int
    results: np.ndarray


@lru_cache(maxsize=256)
def _parse(source: str) -> tuple[tuple[str, ...], tuple]:
    """The generated function's argument names and its statements."""
    (fn,) = ast.parse(source).body
    if not isinstance(fn, ast.FunctionDef):
        raise Unsupported("not a function")
    return tuple(a.arg for a in fn.args.args), tuple(fn.body)


class _Builder:
    def __init__(self, names: dict, samples: int) -> None:
        self.names, self.samples = names, samples
        self.code: list[list[int]] = []
        self.consts: list[float] = []
        self.fixed: list[np.ndarray] = []
        self.count = 0                     # virtual registers
        self.memo: dict = {}               # an instruction already emitted: its register (common subexpressions)
        self.const_at: dict = {}
        self.fixed_at: dict = {}

    def emit(self, op: int, a: int = -1, b: int = -1) -> int:
        key = (op, a, b)
        got = self.memo.get(key)
        if got is not None:
            return got
        self.code.append([op, self.count, a, b])
        self.memo[key] = self.count
        self.count += 1
        return self.count - 1

    def register(self, value) -> int:
        """A virtual register holding ``value``: an instruction's result as it is, a concrete
        number or array loaded (numbers as constants, arrays of the samples' length as fixed)."""
        if isinstance(value, _Reg):
            return value.index
        a = np.asarray(value, dtype=float)
        if a.size == 1:
            c = float(a.reshape(-1)[0])
            key = np.float64(c).tobytes()
            if key not in self.const_at:
                self.const_at[key] = len(self.consts)
                self.consts.append(c)
            return self.emit(CONST, self.const_at[key])
        if a.size == self.samples and a.shape[-1] == self.samples:
            x = np.ascontiguousarray(a.reshape(self.samples))
            key = x.tobytes()
            if key not in self.fixed_at:
                self.fixed_at[key] = len(self.fixed)
                self.fixed.append(x)
            return self.emit(LOADF, self.fixed_at[key])
        raise Unsupported(f"an array of shape {a.shape} where {self.samples} samples are evaluated")

    def value(self, node, env: dict):
        if isinstance(node, ast.Name):
            if node.id in env:
                return env[node.id]
            if node.id in self.names:
                return self.names[node.id]
            raise Unsupported(f"unknown name {node.id}")
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return node.value
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            x = self.value(node.operand, env)
            if not isinstance(x, _Reg):
                return -x if isinstance(node.op, ast.USub) else +x
            return x if isinstance(node.op, ast.UAdd) else _Reg(self.emit(NEG, x.index))
        if isinstance(node, ast.BinOp) and type(node.op) in BINOPS:
            op, fn = BINOPS[type(node.op)]
            a, b = self.value(node.left, env), self.value(node.right, env)
            if not isinstance(a, _Reg) and not isinstance(b, _Reg):
                return fn(a, b)                      # numpy's own operation on the numpy path's operands
            if op == POW and isinstance(a, _Reg) and not isinstance(b, _Reg) and np.ndim(b) == 0:
                e = float(b)
                if e == 1.0:
                    return a
                if e in FAST_POWERS:
                    return _Reg(self.emit(FAST_POWERS[e], a.index))
            return _Reg(self.emit(op, self.register(a), self.register(b)))
        if isinstance(node, ast.Call) and not node.keywords:
            fn = self.value(node.func, env)
            args = [self.value(a, env) for a in node.args]
            if not any(isinstance(a, _Reg) for a in args):
                return fn(*args)
            if len(args) == 1 and any(fn is f for f in UNARY):
                return _Reg(self.emit(next(v for f, v in UNARY.items() if fn is f), args[0].index))
            if len(args) == 2 and any(fn is f for f in BINARY):
                return _Reg(self.emit(next(v for f, v in BINARY.items() if fn is f), self.register(args[0]),
                                      self.register(args[1])))
        raise Unsupported(f"cannot evaluate {ast.dump(node)[:80]}")


@dataclass(frozen=True)
class _Reg:
    index: int


def build(source: str, names: dict, args: list, samples: int) -> Tape:
    """The tape of the generated function ``source`` (its globals ``names``) called with ``args``:
    each a concrete number or array (cut to the ``samples`` evaluated) or a :class:`Row`."""
    return program([(source, names, args)], [], samples)


def program(residuals: list[tuple[str, dict, list]], variants: list[dict[int, int]], samples: int) -> Tape:
    """One tape computing every residual of ``residuals`` (source, globals, arguments as for
    :func:`build`), an instruction shared by several computed once; and each residual again for
    every variant (a map of parameter slots to other slots), where only the instructions that
    read a remapped slot, directly or not, are run again."""
    b = _Builder({}, samples)
    outs = []
    with np.errstate(all="ignore"):
        for source, names, args in residuals:
            params, body = _parse(source)
            if len(params) != len(args):
                raise Unsupported("argument count")
            b.names = names
            env = {}
            for p, a in zip(params, args):
                env[p] = _Reg(b.emit(a.op, a.slot)) if isinstance(a, Row) else a
            result = None
            for stmt in body:
                if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1 and isinstance(stmt.targets[0], ast.Name):
                    env[stmt.targets[0].id] = b.value(stmt.value, env)
                elif isinstance(stmt, ast.Return) and stmt.value is not None:
                    result = b.value(stmt.value, env)
                    break
                else:
                    raise Unsupported(f"statement {type(stmt).__name__}")
            if result is None:
                raise Unsupported("no return")
            outs.append(b.register(result))
    base = list(b.code)
    results = [[o] for o in outs]
    for remap in variants:
        moved: dict[int, int] = {}
        for op, dst, x, y in base:
            if op == LOADP and x in remap:
                moved[dst] = b.emit(LOADP, remap[x])
            elif op >= ADD and (x in moved or y in moved):
                moved[dst] = b.emit(op, moved.get(x, x), moved.get(y, y) if y >= 0 else -1)
        for row, o in zip(results, outs):
            row.append(moved.get(o, o))
    return _allocate(b, np.array(results, dtype=np.int64).reshape(len(outs), 1 + len(variants)))


def _allocate(b: _Builder, results: np.ndarray) -> Tape:
    """Virtual registers mapped onto as few physical ones as their lifetimes allow (a register
    is free after the last instruction that reads it, but never taken by that instruction's own
    result: the kernel's elementwise loops are SIMD code only where the destination does not
    overlap an operand, and LLVM's run-time overlap check sends an operation in place to the scalar
    loop: 20-25 % of a CyCab objective row), and the instructions that no result needs dropped."""
    code = b.code
    wanted = set(results.ravel().tolist())
    needed = set(wanted)
    keep = []
    for ins in reversed(code):
        if ins[1] in needed:
            keep.append(ins)
            if ins[0] >= ADD:
                needed.update(x for x in ins[2:] if x >= 0)
    keep.reverse()
    last = {}
    for q, ins in enumerate(keep):
        if ins[0] >= ADD:
            for x in ins[2:]:
                if x >= 0:
                    last[x] = q
    for x in wanted:
        last[x] = len(keep)
    free: list[int] = []
    phys: dict[int, int] = {}
    top = 0
    rows = []
    for q, ins in enumerate(keep):
        op, dst, a, c = ins
        released = []
        if op >= ADD:
            a = phys[a] if a >= 0 else -1
            c = phys[c] if c >= 0 else -1
            for x in {ins[2], ins[3]} - {-1}:
                if last.get(x) == q:
                    released.append(phys.pop(x))
        if free:
            r = free.pop()
        else:
            r, top = top, top + 1
        free.extend(released)        # not the destination: an operation in place defeats the kernel's SIMD loops
        phys[dst] = r
        if last.get(dst, -1) < 0 and dst not in wanted:
            free.append(phys.pop(dst))
        rows.append([op, r, a, c])
    mapped = np.vectorize(lambda v: phys[v], otypes=[np.int64])(results) if results.size else results
    return Tape(np.array(rows, dtype=np.int64).reshape(-1, 4), np.array(b.consts or [0.0], dtype=float),
                tuple(b.fixed), max(top, 1), mapped)
