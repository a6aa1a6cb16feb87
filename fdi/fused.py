"""The identification objective compiled: a population's eq. (24) costs in one call.

:meth:`fdi.objective.Objective.evaluate` on the numpy path makes, per call, some forty numpy calls
per residual, each over (population, samples) arrays: the corrected signals filtered, every
residual kernel run on the parameter profiles (twice more per linear fault: its unit step), the
magnitudes solved, the sums taken. Here the same computation runs in one compiled call
(:func:`fdi._jit.fused_cost`), individual by individual, on blocks of samples that stay in cache:

- the profiles and the solved faults' unit steps are the numpy path's (:meth:`Objective.prepare`),
  as are the corrections (:meth:`Objective.corrections`);
- the population is decoded in one compiled pass (:func:`fdi._jit.decode_rows`) around numpy's
  powers 10 ** x (SIMD code: numpy's bits), and what depends only on which linear faults are
  solved is built once (:meth:`Fused.pattern`): a call's Python is ~40 us before the kernel;
- eqs. (16) and (18) are formed in the kernel, row by row, with the kernels' exponential (the numpy
  path's operations; the exponential written to vectorise, :func:`fdi.profiles._exp`, within 1 ulp
  of numpy's): they were numpy passes over the whole population before the
  kernel (three passes and a temporary of rows x samples each call: 22 ns a sample, where the
  kernel's own exponential costs 9; measured on docs/tutorial.md's RC filter, A/B: its eq. (16)
  rows 49 -> 35 ns a sample on 5 000-sample windows, its whole diagnosis 11.2-13.3 -> 9.0-10.9 s CPU,
  the numbers the same to the bit here: tests/golden identical);
- a corrected signal is formed and filtered in the kernel by the same operations in the same
  order (:func:`fdi.derivatives.fir`), so its derivatives are the numpy path's bits (a Coulomb
  friction's sign of a derivative then agrees);
- each active residual is a :mod:`fdi.tape`: the part of its generated code that no individual
  changes is evaluated once per objective and sampling stride, by numpy, on the very arrays the
  numpy path uses (constants folded, the individual-free signals' terms hoisted); the rest runs
  in the kernel;
- a linear fault's magnitude is the weighted median of the same points with the same weights
  (:func:`fdi._jit._median`, the numba path's own), three passes when several are solved (a
  fault's median is not taken again while the others' magnitudes are those it last saw: the
  same points, the same median; an individual that solves one of them takes one median, not three).

The numbers are the numpy path's to round-off: the sums of |r| are taken one sample after
another (numpy sums pairwise) and the transcendental functions are libm's or the kernels' own
exponential (numpy's are SIMD code), a last-bit difference (tests/test_kernels.py: 1e-9 relative on random populations of every fault
type and model). The kernel is generic (no model-specific code is compiled): numba keeps it on
disk, and a model costs no compilation.

A stored quantity a candidate changes (d(C p)/dt with C faulty, or p a faulty sensor's corrected
reading; nested ones, the three tanks', level by level) is formed per individual on every sample
of the window by a tape of its own and its rate filtered at the samples evaluated
(:meth:`Fused._stored_quantities`); measured on the RC filter of docs/tutorial.md (5 000-sample
windows) 416 -> 106 us per full row, and its whole diagnosis 14.6 -> 10.3 s CPU, the same answer;
the three tanks, two-mass and probe models 5-13x per row. An objective the tapes do not cover (a
mode switch inside the window; a residual whose code has a comparison or a Piecewise) keeps the
numpy path (:meth:`Fused.make` gives None).
"""
from __future__ import annotations

import builtins
import inspect
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import derivatives, encoding, kernels, tape
from .profiles import STEP19
from .residuals import Residual, corrects_signal, mode_breaks, samples_of

Objective = Any     # fdi.objective.Objective (which imports this module where it is first used)

FRESH = (1, 2, 3, 4, 5, 6, 7, 8, 15)   # fused_cost's arguments a call gives: the population's (onsets,
                                      # decoded structure, coefficients, seen steps, eq. 19's span)
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
            elif not corrects_signal(model, f):     # a fixed-value source: its beta_<name> slot
                self.rows.append((f.symbols[0], j))
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
            self.filters.append((n, derivatives.centred(n, p, order, float(obj.win.ts))))
            self.s_at.append(at)
            at += order + 1
        self.n_slots = at
        nmax = max((n for n, _ in self.filters), default=1)
        dmax = max((k.shape[1] for _, k in self.filters), default=1)
        self.fk = np.zeros((max(1, len(self.filters)), nmax // 2 + 1, dmax))     # the half kernels (centred)
        for v, (_, k) in enumerate(self.filters):
            self.fk[v, :k.shape[0], :k.shape[1]] = k
        self.fk_n = np.array([n for n, _ in self.filters] or [1], dtype=np.int64)
        self.fk_orders = np.array([k.shape[1] for _, k in self.filters] or [1], dtype=np.int64)
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
        self.beta_fault = np.array([self.beta_of.get(s, -1) for s in self.varying], dtype=np.int64)
        self.bias_fault = np.array([self.bias_of.get(s, -1) for s in self.varying], dtype=np.int64)
        self.beta_fixed = np.array([self.fixed_at.get((s, "beta"), -1) for s in self.varying], dtype=np.int64)
        self.bias_fixed = np.array([self.fixed_at.get((s, "bias"), -1) for s in self.varying], dtype=np.int64)
        # per candidate fault: nominal value, unit-step value (linear faults), role (0 parameter, 1
        # efficiency factor, 2 offset)
        w = obj.win.t.size
        self.f_nominal = np.array([sp.nominal for sp in obj.spaces], dtype=float)
        self.f_linear = np.array([j in self.linear for j in range(len(obj.spaces))], dtype=np.bool_)
        self.f_unit = np.array([obj.unit_value(j) if j in self.linear else 0.0 for j in range(len(obj.spaces))])
        self.f_role = np.array([2 if model.faults[n].effect == "bias" else 1 if model.faults[n].kind in ("sensor", "source")
                                else 0 for n in obj.candidate], dtype=np.int64)
        self.f_lo = np.array([sp.bounds[0] for sp in obj.spaces], dtype=float)    # a correction's plausible range
        self.f_hi = np.array([sp.bounds[1] for sp in obj.spaces], dtype=float)
        self.lin_fault = np.array(self.linear, dtype=np.int64)
        # the parameter slots: the base ones, then each linear fault's stepped copies
        slots = [(name, j, False) for name, j in self.rows]
        for jj, j in enumerate(self.linear):
            slots += [(name, j, True) for name, _ in self.stepped[jj]]
        self.slot_fault = np.array([j for _, j, _ in slots], dtype=np.int64)
        self.slot_step = np.array([st for _, _, st in slots], dtype=np.bool_)
        self.slot_group = np.array([len(model.faults[obj.candidate[j]].targets) > 1 for _, j, _ in slots], dtype=np.bool_)
        self.tnom = np.array([np.broadcast_to(np.asarray(obj.nominal[name], dtype=float), (1, w))[0]
                              for name, _, _ in slots]).reshape(len(slots), w)
        self.t = np.ascontiguousarray(obj.win.t, dtype=float)
        self.plans: dict[int, Plan] = {}
        self.patterns: dict[tuple[bool, ...], Pattern] = {}
        self.calls: dict[tuple[int, tuple[bool, ...]], Any] = {}     # bind's, per (stride, solving)
        self.s_at_array = np.array(self.s_at, dtype=np.int64)
        self.seen = SeenSteps(obj)
        # the decoding's constants (fdi._jit.decode_rows): logarithmic values, coefficient scales, and
        # the reals numpy raises 10 to (every rate slot, then each logarithmic value)
        self.log = np.array([sp.log for sp in obj.spaces], dtype=np.bool_)
        self.scale = np.array([[1, 1 / sp.reference, 1, sp.reference, 1 / sp.reference, 1, sp.reference]
                               for sp in obj.spaces], dtype=float).reshape(len(obj.spaces), encoding.N_REAL - 2)
        logs = [j for j, sp in enumerate(obj.spaces) if sp.log]
        self.power_cols = np.array([encoding.N_REAL * j + encoding.RATE_SLOT for j in range(len(obj.spaces))]
                                   + [encoding.N_REAL * j for j in logs], dtype=np.int64)
        self.vpow = np.full(len(obj.spaces), -1, dtype=np.int64)
        self.vpow[logs] = len(obj.spaces) + np.arange(len(logs))
        self.names = {"abs": builtins.abs}
        self._stored_quantities()

    def _stored_quantities(self) -> None:
        """The stored quantities an individual changes (a candidate fault's parameter or corrected
        signal inside d^k q/dt^k, :attr:`fdi.residuals.Residual.composites`, or such a quantity's
        rate inside another's, the three tanks' d(C2 (... d(C1 p1)/dt ...))/dt): q formed per
        individual on every sample of the window by tapes of their own, one level of nesting after
        another (the parameter slots over the whole window, the corrected signals' samples, a
        derivative no individual changes as the numpy path estimated it, a corrected signal's
        derivative filtered on every sample, its ends mirrored as the numpy path's, an inner quantity's
        rate over the whole window), then its rate filtered as :meth:`fdi.residuals.Residual._rate` does:
        at the samples evaluated into the filtered-signal slots ``comp_at`` for a residual, on every
        sample into ``full_at`` for an enclosing quantity (the edge half-windows by the polynomial of
        the edge window, as ``derivatives.estimate``'s ``interp``). q comes from the samples, not
        their smoothed values; an individual whose q is not finite somewhere is invalid. A stored
        quantity no individual changes is filtered by the numpy path once (:meth:`plan`)."""
        obj = self.obj
        ts = float(obj.win.ts)
        self.stored: dict = {}                    # (inner expression, order) -> index (children first)
        found: list[tuple[int, Residual, int]] = []          # (order, inner, level)
        read_whole: set[int] = set()              # quantities whose whole-window rate an enclosing one reads

        def changed(order: int, inner: Residual) -> int | None:
            key = (inner.key, order)
            if key in self.stored:
                return self.stored[key]
            children = [changed(o, q) for o, q in inner.composites]
            if not (any(c is not None for c in children) or any(n in self.slot for n in inner.symbols)
                    or any(sig in self.varying for sig, _ in inner.signals)):
                return None
            read_whole.update(c for c in children if c is not None)
            level = 1 + max((found[c][2] for c in children if c is not None), default=-1)
            self.stored[key] = len(found)
            found.append((order, inner, level))
            return self.stored[key]
        read_cut = {c for i in obj.active for o, q in obj.residuals[i].composites if (c := changed(o, q)) is not None}
        # a corrected signal's samples (order 0) or derivative on every sample, kept per (signal, order)
        self.full_of = np.full((max(1, len(self.varying)), int(self.fk_orders.max())), -1, dtype=np.int64)
        for _, inner, _ in found:
            for sig, k in inner.signals:
                if sig in self.varying:
                    v = self.varying.index(sig)
                    if self.full_of[v, k] < 0:
                        self.full_of[v, k] = int(self.full_of.max()) + 1
        n_samples = int(self.full_of.max()) + 1
        self.full_at = np.full(max(1, len(found)), -1, dtype=np.int64)
        for k, c in enumerate(sorted(read_whole)):
            self.full_at[c] = n_samples + k
        self.n_full = n_samples + len(read_whole)
        self.comp_at = np.full(max(1, len(found)), -1, dtype=np.int64)
        filters = []
        for c, (order, _, _) in enumerate(found):
            p = max(derivatives.DEFAULT_ORDER, order)
            n = derivatives.window_samples(obj.window_s, ts, p)
            filters.append((n, p, derivatives.centred(n, p, order, ts)))
            if c in read_cut:
                self.comp_at[c] = self.n_slots
                self.n_slots += order + 1
        self.comp_order = np.array([order for order, _, _ in found] or [0], dtype=np.int64)
        self._stored_tapes(found)
        self._stored_filters(filters)

    def _stored_tapes(self, found: list) -> None:
        """One tape per level of nesting of the stored quantities ``found`` (order, inner, level),
        concatenated, their constants and fixed arrays renumbered: ``inner`` (code, constants,
        fixed arrays, registers), each level's first instruction ``level_at``, the quantities level
        by level ``members`` (from ``level_members``), the register holding each ``result_of``. No
        unit-step variants: a fault whose magnitude is solved never enters a stored quantity
        (:func:`fdi.objective.linear_transform`)."""
        w = self.obj.win.t.size
        levels = sorted({lev for _, _, lev in found})
        self.level_at = np.zeros(len(levels) + 1, dtype=np.int64)
        self.level_members = np.zeros(len(levels) + 1, dtype=np.int64)
        self.members = np.zeros(max(1, len(found)), dtype=np.int64)
        self.result_of = np.zeros(max(1, len(found)), dtype=np.int64)
        codes, consts, fixed, registers, at = [], [], [], 1, 0
        for li, lev in enumerate(levels):
            mine = [c for c, (_, _, l) in enumerate(found) if l == lev]
            t = tape.program([self._stored_entry(found[c][1]) for c in mine], [], w)
            code = t.code.copy()
            code[code[:, 0] == tape.CONST, 2] += len(consts)
            code[code[:, 0] == tape.LOADF, 2] += len(fixed)
            consts += t.consts.tolist()
            fixed += list(t.fixed)
            codes.append(code)
            registers = max(registers, t.registers)
            self.level_at[li + 1] = self.level_at[li] + code.shape[0]
            self.members[at:at + len(mine)] = mine
            self.result_of[mine] = t.results[:, 0]
            at += len(mine)
            self.level_members[li + 1] = at
        self.inner = (np.vstack(codes) if codes else np.zeros((1, 4), dtype=np.int64), np.array(consts or [0.0]),
                      np.array(fixed).reshape(len(fixed), w) if fixed else np.zeros((1, w)), registers)

    def _stored_filters(self, filters: list) -> None:
        """The stored quantities' rate filters (window n, polynomial order p, centred half kernel) as
        the kernel reads them: ``ck`` and ``ck_n``, and the edge half-windows' kernels ``edge`` (the
        polynomial of the edge window), for a rate read on every sample and for one read at the
        samples evaluated where they come within half a filter of the window's ends (a window that
        ends with the data: a prognosis refreshed at the last sample, evaluate's RUL checkpoints;
        until 2026-11 those kept the numpy path)."""
        ts = float(self.obj.win.ts)
        nmax = max((n for n, _, _ in filters), default=1)
        self.ck = np.zeros((max(1, len(filters)), nmax // 2 + 1, int(self.comp_order.max()) + 1))
        short = [n * (n // 2) * (int(self.comp_order[c]) + 1) <= derivatives.EDGE_VALUES
                 for c, (n, _, _) in enumerate(filters)]
        if any(self.full_at[c] >= 0 and not short[c] for c in range(len(filters))):
            raise tape.Unsupported("a stored quantity inside another, filtered over a long window")
        self.edge_known = np.array(short or [False])     # a rate at the samples evaluated may meet the edges
        whole = max((n for c, (n, _, _) in enumerate(filters) if short[c]), default=1)
        self.edge = np.zeros((max(1, len(filters)), 2, whole, whole // 2))
        for c, (n, p, k) in enumerate(filters):
            self.ck[c, :k.shape[0], :k.shape[1]] = k
            if short[c]:
                order, h = int(self.comp_order[c]), n // 2
                self.edge[c, 0, :n, :h] = derivatives.kernels_at(n, p, order, ts, 0, h)[:, :, order]
                self.edge[c, 1, :n, :h] = derivatives.kernels_at(n, p, order, ts, h + 1, n)[:, :, order]
        self.ck_n = np.array([n for n, _, _ in filters] or [1], dtype=np.int64)

    def _stored_entry(self, inner: Residual) -> tuple:
        """A stored quantity's tape entry: its generated code with each argument on every sample of
        the window (a signal's samples or a corrected one's slot, a derivative as the numpy path
        estimated it, an inner quantity's whole-window rate, a parameter's slot or value)."""
        obj = self.obj
        args = []
        for sig, k in inner.signals:
            if sig in self.varying:
                args.append(tape.Row(tape.LOADS, int(self.full_of[self.varying.index(sig), k])))
            else:
                base = obj.base_signals[sig]
                args.append(np.asarray(base[k] if k else samples_of(base), dtype=float))
        for o, q in inner.composites:
            c = self.stored.get((q.key, o))
            args.append(tape.Row(tape.LOADS, int(self.full_at[c])) if c is not None else
                        Residual._rate(o, q, obj.base_signals, obj.nominal, obj.win.ts, obj.window_s, None, None))
        for name in inner.symbols:
            args.append(tape.Row(tape.LOADP, self.slot[name]) if name in self.slot else obj.nominal[name])
        source = getattr(inner.func, SOURCE, None) or inspect.getsource(inner.func)
        return source, {**self.names, **inner.func.__globals__}, args

    @classmethod
    def make(cls, obj: "Objective") -> "Fused | None":
        """The compiled path of ``obj``, or None where the numpy path must stay."""
        if len(mode_breaks(obj.model, obj.win.raw)):
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
        for c, n in enumerate(self.ck_n[:len(self.stored)]):      # a stored quantity's rate reads whole windows
            if self.comp_at[c] >= 0 and not self.edge_known[c] and \
                    (crop.start < n // 2 or crop.start + (m - 1) * stride + n // 2 >= obj.win.t.size):
                raise tape.Unsupported("a stored quantity's rate at the window's edge, filtered over a long window")
        entries = []
        for i in obj.active:
            r = obj.residuals[i]
            args = []
            for s, k in r.signals:
                if s in self.varying:
                    args.append(tape.Row(tape.LOADS, self.s_at[self.varying.index(s)] + k))
                else:
                    args.append(cut(obj.base_signals[s][k]))
            for order, inner in r.composites:
                c = self.stored.get((inner.key, order))
                if c is not None:
                    args.append(tape.Row(tape.LOADS, int(self.comp_at[c]) + order))
                else:            # no individual changes it: the numpy path's rate, once per stride
                    args.append(Residual._rate(order, inner, obj.base_signals, obj.nominal, obj.win.ts, obj.window_s,
                                               crop, None))
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
        """:meth:`fdi.objective.Objective.evaluate`'s costs and population, by the compiled kernel.
        The population is decoded in one compiled pass around numpy's powers
        (:func:`fdi._jit.decode_rows`, :func:`fdi.encoding.decode_table`'s numbers) and what depends
        only on which linear faults are solved is built once (:meth:`pattern`): a call's Python
        costs a few tens of microseconds before the kernel."""
        obj = self.obj
        plan = self.plan(stride)
        fast = kernels.jit()
        real = np.array(real, dtype=float)         # a copy: finish writes the solved magnitudes in
        t = self.t
        onset = real[:, -1].copy()
        bits = np.asarray(bits)
        flags = bits if bits.dtype == np.bool_ else bits.astype(bool) if ((bits == 0) | (bits == 1)).all() else None
        if flags is not None and flags.ndim == 2 and flags.shape[0] == real.shape[0]:
            kinds, models, values, periods, b, pre_at, counts, span19, level = fast.decode_rows(
                real, np.ascontiguousarray(flags), self.log, self.scale, 10.0 ** real[:, self.power_cols],
                self.vpow, encoding.ZETA_TYPES, float(t[-1]))
        else:                                       # bits other than 0/1: decode_table's reading of them
            kinds, models, values, periods, b, pre_at, counts, span19, level = self.decode_numpy(real, bits)
        solving = tuple(level[self.lin_fault].tolist())
        formed = []
        # order 0: a step's seen profile depends on its first sample alone (kept; read here, not copied)
        keep = derivatives.STEP_ORDER == 0 and self.seen.keeps()
        with self.seen.lock:            # (the kept steps and this call's rows: one call at a time)
            self.seen.begin()
            for jj, j in enumerate(self.linear):      # a solved step or square wave as the filtered residuals see it
                if solving[jj]:
                    rows = np.flatnonzero(kinds[j] == 0)
                    if rows.size and keep:
                        pre_at[j, rows] = self.seen.steps(j, onset[rows])
                    elif rows.size:
                        formed.append((j, rows, obj.seen_steps(j, onset[rows])))
                    rows = np.flatnonzero(kinds[j] == 1)
                    if rows.size:
                        formed.append((j, rows, obj.seen_steps(j, onset[rows], periods[j, rows])))
            pre = self.seen.table(formed, pre_at)
            call = self.calls.get((stride, solving)) or self.bind(fast, stride, solving)
            total, d, invalid = call(onset, kinds, models, values, periods, np.ascontiguousarray(b[:, :, COEFFS]),
                                     pre, pre_at, span19)
        solve = {j: kinds[j] < 2 for jj, j in enumerate(self.linear) if solving[jj]}
        deltas = {j: d[jj] for jj, j in enumerate(self.linear) if solving[jj]} if self.pattern(solving).joint.size else {}
        return obj.finish(real, solve, deltas, total, invalid, stride)

    def bind(self, fast, stride: int, solving: tuple[bool, ...]):
        """The kernel's call for one sampling stride and set of solved linear faults: every
        argument but the population's (:data:`FRESH`) fixed, and described once where the
        compiled path can (:func:`fdi._native.bind_fused`); kept per (stride, solving)."""
        plan, p = self.plan(stride), self.pattern(solving)
        args = (self.t, None, None, None, None, None, None, None, None,
                self.f_nominal, self.f_unit, self.f_linear, self.f_role, self.f_lo, self.f_hi, None, STEP19,
                self.slot_fault, self.slot_step, self.slot_group, self.tnom,
                plan.code, plan.results, plan.registers, plan.consts, plan.fixed,
                self.raw, self.is_source, self.beta_fault, self.beta_fixed, self.bias_fault, self.bias_fixed,
                self.corr_fixed, self.fk, self.fk_n, self.fk_orders, self.s_at_array, self.n_slots,
                plan.crop.start, stride, plan.m, p.plain, p.plain_w, p.joint, p.joint_w, p.enters, self.lin_fault,
                p.lo, p.hi, p.passes, plan.gaps, plan.constant, BLOCK,
                *self.stored_arguments())
        bound = getattr(fast, "bind_fused", None)
        call = bound(args, FRESH) if bound is not None else None
        if call is None:
            def call(*values, fused_cost=fast.fused_cost):
                a = list(args)
                for k, v in zip(FRESH, values):
                    a[k] = v
                return fused_cost(*a)
        self.calls[(stride, solving)] = call
        return call

    def stored_arguments(self) -> tuple:
        """The kernel's arguments for the stored quantities (:meth:`_stored_quantities`)."""
        code, consts, fixed, registers = self.inner
        return (len(self.stored), code, self.level_at, self.level_members, self.members, self.result_of, registers,
                consts, fixed, self.full_of, max(1, self.n_full), self.comp_at, self.full_at, self.comp_order, self.ck,
                self.ck_n, self.edge)

    def decode_numpy(self, real: np.ndarray, bits: np.ndarray) -> tuple:
        """What :func:`fdi._jit.decode_rows` returns, by :func:`fdi.encoding.decode_table`."""
        obj = self.obj
        table = encoding.decode_table(obj.spaces, real[:, :-1], bits)
        kinds = np.ascontiguousarray(table.kind, dtype=np.int64)
        models = np.ascontiguousarray(table.model, dtype=np.int64)
        incipient = kinds == 2
        counts = np.stack([(incipient & (models == 1)).sum(axis=1), (incipient & (models == 3)).sum(axis=1)], axis=1)
        pre_at = np.full(kinds.shape, -1, dtype=np.int64)
        span19 = np.zeros(len(obj.spaces))
        onset = real[:, -1]
        for j in range(len(obj.spaces)):
            rows = incipient[j] & (models[j] == 4)
            late = self.t[-1] - onset[rows]
            late = late[~np.isnan(late)]
            span19[j] = max(0.0, float(late.max())) if late.size else 0.0
        return (kinds, models, np.ascontiguousarray(table.value, dtype=float),
                np.ascontiguousarray(table.period, dtype=float), np.ascontiguousarray(table.b, dtype=float),
                pre_at, counts, span19, (kinds < 2).any(axis=1))

    def pattern(self, solving: tuple[bool, ...]) -> "Pattern":
        """The kernel's residual split for one set of solved linear faults (``solving``: per linear
        fault, whether any individual solves its magnitude): the residuals no solved fault enters
        (summed as they are) and the others (magnitudes solved on them), their weights, which
        fault enters which, the magnitudes' bounds; built once per set."""
        got = self.patterns.get(solving)
        if got is not None:
            return got
        obj = self.obj
        entered = [j for jj, j in enumerate(self.linear) if solving[jj]]
        active = list(obj.active)
        plain = [q for q, i in enumerate(active) if not any(obj.enters[j][i] for j in entered)]
        joint = [q for q in range(len(active)) if q not in plain]
        enters = np.zeros((max(1, len(self.linear)), max(1, len(joint))), dtype=np.bool_)
        lo = np.zeros(max(1, len(self.linear)))
        hi = np.zeros(max(1, len(self.linear)))
        for jj, j in enumerate(self.linear):
            if solving[jj]:
                for q, a in enumerate(joint):
                    enters[jj, q] = obj.enters[j][active[a]]
                lo[jj], hi[jj] = obj.delta_bounds(j)
        weights = np.asarray(obj.weights, dtype=float)
        got = self.patterns[solving] = Pattern(
            np.array(plain, dtype=np.int64), weights[[active[q] for q in plain]], np.array(joint, dtype=np.int64),
            weights[[active[q] for q in joint]], enters, lo, hi, 3 if len(entered) > 1 else 1)
        return got


class SeenSteps:
    """The profiles the fused kernel reads for solved linear faults (its ``pre`` rows). A unit step as
    the smoothing filter sees it is kept by fault and by q, the first sample at or after the onset:
    with the order-0 filter (:data:`fdi.derivatives.STEP_ORDER`) :func:`fdi.objective.seen_step_profile`
    is a function of q alone (the sharp step is t >= onset; the blend around it depends on q only),
    so a population's steps are formed once per sample they start at, not per individual and call
    (scenario 2: 451 calls, 33 ms). An intermittent fault's square waves (edges anywhere) are formed
    each call, after the kept rows. Past ``MAX_BYTES`` of kept rows they are dropped at the start of
    the next call (a row handed out is never overwritten within its call; a call may add a
    population's worth past the cap); a window longer than ``MAX_BYTES`` a row keeps none."""

    MAX_BYTES = 16 << 20

    def __init__(self, obj: "Objective") -> None:
        import threading
        self.obj, self.t = obj, np.ascontiguousarray(obj.win.t, dtype=float)
        self.cap_rows = self.MAX_BYTES // (8 * max(1, self.t.size))   # 0 for a window of over 2 M samples: none kept
        self.rows: dict[int, np.ndarray] = {}           # fault -> its kept row at each q (0..nw), -1 where none
        self.matrix = np.zeros((1, max(1, self.t.size)))
        self.used = 0
        self.lock = threading.Lock()                    # a call's rows: one call at a time

    def begin(self) -> None:
        """A call starts: the kept rows dropped if they passed the cap (the matrix shrunk to it)."""
        if self.used > self.cap_rows:
            self.rows.clear()
            self.used = 0
            if self.matrix.shape[0] > max(1, self.cap_rows):
                self.matrix = np.zeros((max(1, self.cap_rows), self.matrix.shape[1]))

    def _grow(self, rows: int) -> None:
        if rows > self.matrix.shape[0]:
            grown = np.empty((max(rows, 2 * self.matrix.shape[0]), self.matrix.shape[1]))
            grown[:self.used] = self.matrix[:self.used]
            self.matrix = grown

    def keeps(self) -> bool:
        """Whether steps are kept at all (a window of at most MAX_BYTES a row)."""
        return self.cap_rows > 0

    def steps(self, j: int, onsets: np.ndarray) -> np.ndarray:
        """The rows of linear fault j's seen unit steps at ``onsets`` (order-0 filter), formed for the
        q not kept yet."""
        q = np.searchsorted(self.t, onsets, side="left")
        at = self.rows.get(j)
        if at is None:
            at = self.rows[j] = np.full(self.t.size + 1, -1, dtype=np.int64)
        rows = at[q]
        if (rows < 0).any():
            new, first = np.unique(q[rows < 0], return_index=True)
            self._grow(self.used + new.size)
            self.matrix[self.used:self.used + new.size] = self.obj.seen_steps(j, onsets[rows < 0][first])
            at[new] = self.used + np.arange(new.size)
            self.used += new.size
            rows = at[q]
        return rows

    def table(self, formed: list, pre_at: np.ndarray) -> np.ndarray:
        """The ``pre`` array of this call: the kept rows, then the profiles formed this call
        (``formed``: (fault, rows, profiles)), their rows written into ``pre_at``."""
        extra = sum(p.shape[0] for _, _, p in formed)
        if extra:
            self._grow(self.used + extra)
            at = self.used
            for j, rows, profiles in formed:
                self.matrix[at:at + profiles.shape[0]] = profiles
                pre_at[j, rows] = at + np.arange(profiles.shape[0])
                at += profiles.shape[0]
        return self.matrix


@dataclass
class Pattern:
    """What :meth:`Fused.pattern` builds for one set of solved linear faults."""
    plain: np.ndarray
    plain_w: np.ndarray
    joint: np.ndarray
    joint_w: np.ndarray
    enters: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    passes: int


COEFFS = [1, 4, 5, 6, 0, 2, 3]   # the decoded coefficients the kernel reads: b2 (eq. 17), b5, b6, b7 (eq. 19),
                                 # b1 (eq. 16), b3, b4 (eq. 18); kernels.c's NCOEFFS
