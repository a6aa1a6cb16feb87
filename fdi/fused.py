"""The identification objective compiled: a population's eq. (24) costs in one call.

:meth:`fdi.objective.Objective.evaluate` on the numpy path makes, per call, some forty numpy calls
per residual, each over (population, samples) arrays: the corrected signals filtered, every
residual kernel run on the parameter profiles (twice more per linear fault: its unit step), the
magnitudes solved, the sums taken. Here the same computation runs in one compiled call
(:func:`fdi._jit.fused_cost`), individual by individual, on blocks of samples that stay in cache:

- the profiles and the solved faults' unit steps are the numpy path's (:meth:`Objective.prepare`),
  as are the corrections (:meth:`Objective.corrections`);
- a corrected signal is formed and filtered in the kernel by the same operations in the same
  order (:func:`fdi.derivatives.fir`), so its derivatives are the numpy path's bits (a Coulomb
  friction's sign of a derivative then agrees);
- each active residual is a :mod:`fdi.tape`: the part of its generated code that no individual
  changes is evaluated once per objective and sampling stride, by numpy, on the very arrays the
  numpy path uses (constants folded, the individual-free signals' terms hoisted); the rest runs
  in the kernel;
- a linear fault's magnitude is the weighted median of the same points with the same weights
  (:func:`fdi._jit._median`, the numba path's own), three passes when several are solved.

The numbers are the numpy path's to round-off: the sums of |r| are taken one sample after
another (numpy sums pairwise) and the transcendental functions are libm's (numpy's are SIMD code),
a last-bit difference (tests/test_kernels.py: 1e-9 relative on random populations of every fault
type and model). The kernel is generic (no model-specific code is compiled): numba keeps it on
disk, and a model costs no compilation. An objective the tapes do not cover (a stored quantity
differentiated, a mode switch inside the window, a residual whose code has a comparison or a
Piecewise) keeps the numpy path (:meth:`Fused.make` gives None).
"""
from __future__ import annotations

import builtins
import inspect
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import derivatives, kernels, tape
from .residuals import mode_breaks

if TYPE_CHECKING:
    from .objective import Objective

BLOCK = 256         # samples per block of a tape's registers (registers x 2 kB: in L1/L2)
SOURCE = "__bgfdi_source__"     # fdi.persist's attribute for a kernel compiled from its source


@dataclass
class Plan:
    """What one sampling stride's calls share: the residual tapes, concatenated, with their
    hoisted arrays and constants; the slots of per-individual parameters and filtered signals."""
    crop: slice
    m: int
    code: np.ndarray
    results: np.ndarray
    registers: int
    consts: np.ndarray
    fixed: np.ndarray
    gaps: np.ndarray
    constant: float


class Fused:
    """The compiled path of one :class:`fdi.objective.Objective`."""

    def __init__(self, obj: "Objective") -> None:
        self.obj = obj
        model = obj.model
        self.rows = []                      # parameters that differ per individual: (name, fault index)
        for j, name in enumerate(obj.candidate):
            f = model.faults[name]
            if f.kind not in ("sensor", "source"):
                self.rows += [(t, j) for t in f.targets]
        self.slot = {name: k for k, (name, _) in enumerate(self.rows)}
        self.linear = [j for j, s in enumerate(obj.spaces) if s.name in obj.linear]
        # the stepped copies of each linear fault's parameters: slots after the base ones
        extra = len(self.rows)
        self.variants: list[dict[int, int]] = []
        self.stepped: list[list[tuple[str, int]]] = []
        for j in self.linear:
            mine = []
            for name, owner in self.rows:
                if owner == j:
                    mine.append((name, extra))
                    extra += 1
            self.stepped.append(mine)
            self.variants.append({self.slot[name]: k for name, k in mine})
        self.n_p = extra
        # the signals corrected per individual, their filters and slots
        self.varying = sorted(s for s in obj.varying_signals if s in obj.orders)
        self.s_at, at = [], 0
        self.filters = []
        for s in self.varying:
            order = obj.orders[s]
            p = max(derivatives.DEFAULT_ORDER, order)
            n = derivatives.window_samples(obj.window_s, obj.win.ts, p)
            self.filters.append(derivatives.kernels(n, p, order, float(obj.win.ts), n // 2))
            self.s_at.append(at)
            at += order + 1
        self.n_slots = at
        nmax = max((k.shape[0] for k in self.filters), default=1)
        dmax = max((k.shape[1] for k in self.filters), default=1)
        self.fk = np.zeros((max(1, len(self.filters)), nmax, dmax))
        for v, k in enumerate(self.filters):
            self.fk[v, :k.shape[0], :k.shape[1]] = k
        self.fk_n = np.array([k.shape[0] for k in self.filters] or [1], dtype=np.int64)
        self.fk_orders = np.array([k.shape[1] for k in self.filters] or [1], dtype=np.int64)
        self.raw = np.array([np.asarray(obj.win.raw[s], dtype=float) for s in self.varying]).reshape(
            len(self.varying), obj.win.t.size)
        self.is_source = np.array([s not in model.sensors for s in self.varying], dtype=np.bool_)
        # which candidate fault corrects which signal (efficiency factor or offset), else a fixed fault's
        self.beta_of, self.bias_of = {}, {}
        for j, name in enumerate(obj.candidate):
            f = model.faults[name]
            if f.kind in ("sensor", "source") and f.targets[0] in self.varying:
                (self.bias_of if f.effect == "bias" else self.beta_of)[f.targets[0]] = j
        fixed = []
        self.fixed_at = {}
        for s in self.varying:
            for kind, table in (("beta", obj.fixed_betas), ("bias", obj.fixed_biases)):
                if s in table and s not in (self.beta_of if kind == "beta" else self.bias_of):
                    self.fixed_at[(s, kind)] = len(fixed)
                    fixed.append(np.broadcast_to(np.asarray(table[s], dtype=float), (1, obj.win.t.size))[0])
        self.corr_fixed = np.array(fixed).reshape(len(fixed), obj.win.t.size) if fixed else np.zeros((1, 1))
        self.plans: dict[int, Plan] = {}
        self.names = {"abs": builtins.abs}

    @classmethod
    def make(cls, obj: "Objective") -> "Fused | None":
        """The compiled path of ``obj``, or None where the numpy path must stay."""
        if any(obj.residuals[i].composites for i in obj.active) or len(mode_breaks(obj.model, obj.win.raw)):
            return None
        try:
            out = cls(obj)
            out.plan(1)
            out.plan(obj.stride)
        except tape.Unsupported:
            return None
        return out

    def plan(self, stride: int) -> Plan:
        """The tapes of the active residuals on the samples of ``crop(stride)`` (built once)."""
        got = self.plans.get(stride)
        if got is not None:
            return got
        obj = self.obj
        crop = obj.crop(stride)
        m = len(range(crop.start, crop.stop, stride))

        def cut(a):      # as fdi.residuals.Residual.arguments cuts an argument
            return a[..., crop] if isinstance(a, np.ndarray) and a.ndim and a.shape[-1] > 1 else a
        entries = []
        for i in obj.active:
            r = obj.residuals[i]
            if r.composites:
                raise tape.Unsupported("a stored quantity")
            args = []
            for s, k in r.signals:
                if s in self.varying:
                    args.append(tape.Row(tape.LOADS, self.s_at[self.varying.index(s)] + k))
                else:
                    args.append(cut(obj.base_signals[s][k]))
            for name in r.symbols:
                args.append(tape.Row(tape.LOADP, self.slot[name]) if name in self.slot else cut(obj.nominal[name]))
            source = getattr(r.func, SOURCE, None) or inspect.getsource(r.func)
            entries.append((source, {**self.names, **r.func.__globals__}, args))
        t = tape.program(entries, self.variants, m)
        out = Plan(crop, m, t.code, t.results, t.registers, t.consts,
                   np.array(t.fixed).reshape(len(t.fixed), m) if t.fixed else np.zeros((1, m)),
                   np.ascontiguousarray(obj.gaps[crop]), obj.constant(stride))
        self.plans[stride] = out
        return out

    def evaluate(self, real: np.ndarray, bits: np.ndarray, stride: int) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`fdi.objective.Objective.evaluate`'s costs and population, by the compiled kernel."""
        obj = self.obj
        plan = self.plan(stride)
        real, solve, ps, steps = obj.prepare(real, bits)
        values, betas, biases, invalid = obj.corrections(ps)
        n, w = real.shape[0], obj.win.t.size
        crop = plan.crop
        P = np.empty((max(1, self.n_p), n, plan.m))
        for name, k in self.slot.items():
            P[k] = np.broadcast_to(values[name], (n, w))[:, crop]
        for jj, j in enumerate(self.linear):
            if j in solve:
                for name, k in self.stepped[jj]:
                    stepped = steps[j] if len(obj.model.faults[obj.candidate[j]].targets) == 1 else \
                        obj.nominal[name] * steps[j]
                    P[k] = np.broadcast_to(stepped, (n, w))[:, crop]
        corr = []
        beta_at, beta_rows, bias_at, bias_rows = [], [], [], []
        for s in self.varying:
            for kind, table, at, rowwise in (("beta", betas, beta_at, beta_rows), ("bias", biases, bias_at, bias_rows)):
                if s in table:
                    at.append(len(corr))
                    rowwise.append(True)
                    corr.append(np.broadcast_to(table[s], (n, w)))
                elif (s, kind) in self.fixed_at:
                    at.append(self.fixed_at[(s, kind)])
                    rowwise.append(False)
                else:
                    at.append(-1)
                    rowwise.append(False)
        corr_rows = np.array(corr) if corr else np.zeros((1, 1, 1))
        active = list(obj.active)
        entered = [j for j in self.linear if j in solve]
        plain = [q for q, i in enumerate(active) if not any(obj.enters[j][i] for j in entered)]
        joint = [q for q in range(len(active)) if q not in plain]
        enters = np.zeros((max(1, len(self.linear)), max(1, len(joint))), dtype=np.bool_)
        solve_rows = np.zeros((len(self.linear), n), dtype=np.bool_)
        lo = np.zeros(max(1, len(self.linear)))
        hi = np.zeros(max(1, len(self.linear)))
        for jj, j in enumerate(self.linear):
            if j in solve:
                solve_rows[jj] = solve[j]
                for q, a in enumerate(joint):
                    enters[jj, q] = obj.enters[j][active[a]]
                lo[jj], hi[jj] = obj.delta_bounds(j)
        weights = np.asarray(obj.weights, dtype=float)
        total, d = kernels.jit().fused_cost(
            n, plan.code, plan.results, plan.registers, plan.consts, plan.fixed, P,
            self.raw, self.is_source, np.array(beta_at, dtype=np.int64), np.array(beta_rows, dtype=np.bool_),
            np.array(bias_at, dtype=np.int64), np.array(bias_rows, dtype=np.bool_), corr_rows, self.corr_fixed,
            self.fk, self.fk_n, self.fk_orders, np.array(self.s_at, dtype=np.int64), self.n_slots, crop.start, stride,
            plan.m, np.array(plain, dtype=np.int64), weights[[active[q] for q in plain]],
            np.array(joint, dtype=np.int64), weights[[active[q] for q in joint]], enters, solve_rows, lo, hi,
            3 if len(entered) > 1 else 1, plan.gaps, plan.constant, BLOCK)
        deltas = {j: d[jj] for jj, j in enumerate(self.linear) if j in solve} if joint else {}
        return obj.finish(real, solve, deltas, total, invalid, stride)
