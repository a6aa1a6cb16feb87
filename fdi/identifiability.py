"""Faults the residuals read only through one combination: isolation by identification fails there.

Faults with one signature are not isolated by the residuals' alarms (:mod:`fdi.isolability`);
bgfdi still tells them apart by fitting each one's profile to the residuals (Sec. III-D): a
tank's section and its drain valve, both read by one mass balance, leave different traces. Not
always: when every residual reads two fault parameters a and b only through one function
phi(a, b), a constant fault of either is the same change of phi, and its fit is the same fit.
The gravity-drained tank measured at its inflow and outflow only reads its capacitance C and its
valve coefficient Kv through C/Kv**2 (its level is the valve law read backwards, p = Q**2/Kv**2):
a clog Kv x 0.7 is fitted by C x 2.04 to the last digit.

The test, on the AGARRs (constant parameters, as an abrupt fault holds them after its onset): a
and b are read together when, in every residual that reads either, dr/da / dr/db is free of the
signals and one value (compared at random values of the signals and their derivatives, of either
sign: a probabilistic identity test, wrong only on a set of measure zero). Then r
depends on (a, b) through one function whose level sets that ratio describes; it is named when
it is a product of powers (dr/da / dr/db = (p/q) b/a: a**p * b**q) or a weighted sum (a ratio
k free of a and b: a + b/k).

>>> import sympy as sp
>>> C, Kv, Rv, q = sp.symbols("C Kv Rv q")
>>> Q = sp.Function("Q")(sp.Symbol("t"))
>>> tank = [q - sp.Derivative(C * Q**2 / Kv**2, sp.Symbol("t"))]
>>> read_together(tank, C, Kv, {"C", "Kv"})
True
>>> r = ratio(tank, C, Kv)
>>> r, combination(r, C, Kv)
(-Kv/(2*C), C/Kv**2)
>>> read_together([q - C * Q.diff() - Q / Rv], C, Rv, {"C", "Rv"})     # an RC node: they differ
False
"""
from __future__ import annotations

import random
from itertools import combinations
from typing import TYPE_CHECKING, Iterable

import sympy as sp

from .results import Coincidence

if TYPE_CHECKING:
    from bondgraph.model import Model

    from .scaph import ARR

MAX_OPS = 400     # sympy operations of a pair's two partial derivatives beyond which the combination is not named
DRAWS = 6         # points of the signals the ratio of the partial derivatives is compared at (two of fixed sign)
TOL = 1e-9        # relative: two values of the ratio that differ by less are equal


def _signals(expr: sp.Expr) -> list[sp.Expr]:
    """The signals ``expr`` reads: its derivatives of functions of time (each order its own value:
    a signal's value and its derivatives are free of each other at an instant), its functions of
    time, and time itself."""
    found = set(expr.atoms(sp.Derivative)) | set(expr.atoms(sp.core.function.AppliedUndef))
    found |= {s for s in expr.free_symbols if s.name == "t"}
    return sorted(found, key=sp.default_sort_key)


def _value(expr: sp.Expr, point: dict) -> complex | None:
    """``expr`` at ``point`` (a value for each signal and symbol), or None where it has none."""
    try:
        v = complex(sp.N(expr.xreplace(point)))
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return v if v == v and abs(v) != float("inf") else None


def read_together(exprs: Iterable[sp.Expr], a: sp.Symbol, b: sp.Symbol, constants: Iterable[str],
                  seed: int = 0) -> bool:
    """Whether every residual ``r`` of ``exprs`` that reads ``a`` or ``b`` reads both (and some does),
    with dr/da / dr/db one value at ``DRAWS`` random points of the signals (and of any symbol not
    among the model's ``constants``, its parameters and efficiency factors, which are drawn once:
    a mode variable changes in time): a ratio free of the signals and the same in every residual,
    what one combination of (a, b) gives. Decided by random points, not by simplifying the ratio
    (sympy's ``cancel`` took 260 s on a pendulum's arcsine relation): a ratio that moves with the
    signals differs at random points but on a set of measure zero. The signals are drawn of either
    sign (a|x| + b x reads a and b together only while x keeps its sign: a flow that reverses
    separates them); the parameters are drawn too (positive), not taken at their nominal values: a
    leak's infinite resistance has no value to put there.

    The ratio is compared where the residual vanishes, which is where data are: a residual that
    reads a signal linearly (most do: a sensor's reading over its gain) has that signal solved from
    r = 0 at each point (:func:`_zero_set`), the others drawn. A pair read as a quotient with a
    sensor's gain (a load cell F/beta_F against the load's mass, F/beta_F - m_L (g + z''): the
    data determine beta_F m_L only) has one ratio there and not elsewhere (a trial's hoist: a
    heavier load diagnosed as a load cell's gain, the margin "clear", no alternative named)."""
    rng = random.Random(seed)
    constants = set(constants)
    exprs = list(exprs)
    symbols = sorted({s for e in exprs for s in e.free_symbols}, key=sp.default_sort_key)
    base = {s: sp.Float(rng.uniform(0.5, 2.0)) for s in symbols if s.name in constants or s in (a, b)}
    seen, first = False, None
    for e in exprs:
        if a not in e.free_symbols and b not in e.free_symbols:
            continue
        da, db = sp.diff(e, a), sp.diff(e, b)
        if da == 0 or db == 0:
            return False
        drawn = sorted((set(_signals(e)) | set(_signals(da)) | set(_signals(db)) | e.free_symbols | da.free_symbols
                        | db.free_symbols) - set(base), key=sp.default_sort_key)    # with the mode variables:
        x, solved = _zero_set(e)                                                     # any symbol not drawn once
        if x is not None and not _real_at_draws(solved, [s for s in drawn if s != x], base,
                                                random.Random(rng.random())):
            x = None                      # a zero set not real at the draws (a square root of a signal): free points
        signals = [s for s in drawn if s != x]
        for k in range(DRAWS):
            point = _point(signals, base, rng, k)
            if x is not None:
                value = _value(solved, point)
                if value is None or abs(value.imag) > TOL * max(1.0, abs(value)):
                    return False
                point[x] = sp.Float(value.real)
            num, den = _value(da, point), _value(db, point)
            if num is None or den is None or den == 0:
                return False
            r = num / den
            if first is None:
                first = r
            elif abs(r - first) > TOL * max(abs(r), abs(first)):
                return False
        seen = True
    return seen


def _zero_set(e: sp.Expr) -> tuple[sp.Expr | None, sp.Expr | None]:
    """A signal ``e`` reads linearly and its value where ``e`` vanishes (the others free): the
    residual's zero set, where data from the model lie. (None, None) when ``e`` reads no signal
    linearly (the ratio is then compared at free points, as the zero set is not parameterised).

    >>> t, m, bF, g = sp.Symbol("t"), *sp.symbols("m_L beta_F g")
    >>> F, z = sp.Function("F")(t), sp.Function("z")(t)
    >>> _zero_set(F / bF - m * (g + z.diff(t, 2)))
    (F(t), beta_F*m_L*(g + Derivative(z(t), (t, 2))))
    """
    if sp.count_ops(e) > MAX_OPS:
        return None, None
    for x in _signals(e):
        if not (isinstance(x, sp.core.function.AppliedUndef)
                or isinstance(x, sp.Derivative) and isinstance(x.expr, sp.core.function.AppliedUndef)):
            continue                      # time itself, or the rate of an expression (d/dt(C Q^2/Kv^2)) as written
        if any(d != x and d.has(x) for d in e.atoms(sp.Derivative)):
            continue                      # read differentiated too (i and i'): its value is not free of them
        slope = sp.diff(e, x)
        if slope == 0 or slope.has(x):
            continue
        rest = e.xreplace({x: sp.Integer(0)})
        if rest.has(x):
            continue
        return x, -rest / slope
    return None, None


def _point(signals: list, base: dict, rng: random.Random, k: int) -> dict:
    """The ``k``-th random point of :func:`read_together`: ``base`` and each signal drawn in
    [0.2, 1] in size, all positive (k = 0), all negative (k = 1), then signs at random."""
    signs = [1 if k == 0 else -1 if k == 1 else rng.choice((-1, 1)) for _ in signals]
    return {**base, **{s: sp.Float(sign * rng.uniform(0.2, 1.0)) for s, sign in zip(signals, signs)}}


def _real_at_draws(solved: sp.Expr, signals: list, base: dict, rng: random.Random) -> bool:
    """Whether the zero set's ``solved`` value is real and finite at draws of ``signals`` like those
    :func:`read_together` makes (its own ``rng``: the comparison's draws are not used up)."""
    for k in range(DRAWS):
        value = _value(solved, _point(signals, base, rng, k))
        if value is None or abs(value.imag) > TOL * max(1.0, abs(value)):
            return False
    return True


def ratio(exprs: Iterable[sp.Expr], a: sp.Symbol, b: sp.Symbol) -> sp.Expr | None:
    """dr/da / dr/db of the first residual of ``exprs`` that reads ``a``, on its zero set
    (:func:`_zero_set`: the signal it reads linearly replaced by its value there), simplified
    (sympy's ``cancel``) when its derivatives are small (``MAX_OPS``), else None. For pairs
    :func:`read_together` found: the ratio is then the same in every residual.

    >>> t, m, bF, g = sp.Symbol("t"), *sp.symbols("m_L beta_F g")
    >>> F, z = sp.Function("F")(t), sp.Function("z")(t)
    >>> hoist = [F / bF - m * (g + z.diff(t, 2))]
    >>> read_together(hoist, m, bF, {"m_L", "beta_F", "g"}), ratio(hoist, m, bF)
    (True, beta_F/m_L)
    """
    for e in exprs:
        if a in e.free_symbols:
            da, db = sp.diff(e, a), sp.diff(e, b)
            if sp.count_ops(da) + sp.count_ops(db) > MAX_OPS:
                return None
            x, solved = _zero_set(e)
            slope = da / db if x is None else (da / db).xreplace({x: solved})
            return sp.cancel(slope)
    return None


def combination(slope: sp.Expr | None, a: sp.Symbol, b: sp.Symbol) -> sp.Expr | None:
    """The function of (a, b) whose level sets have slope ``slope`` (= dr/da / dr/db), where it is
    a product of powers a**p * b**q (slope * a / b a rational constant p/q; p > 0) or a weighted
    sum a + b / slope (a slope free of a and b: a turns ratio squared that refers a winding's
    resistance to the other side); None otherwise, and for a slope that still reads a signal.

    >>> R1, R2, n = sp.symbols("R1 R2 n")
    >>> combination(sp.Integer(1), R1, R2), combination(-R2 / R1, R1, R2), combination(n**2, R1, R2)
    (R1 + R2, R1/R2, R1 + R2/n**2)
    """
    if slope is None or _signals(slope):
        return None                       # a ratio cancel left with signals in it names nothing
    power = sp.cancel(slope * a / b)
    if power.is_Rational and power != 0:
        p, q = sp.fraction(power)
        if p < 0:
            p, q = -p, -q
        return a ** p * b ** q
    if slope != 0 and not ({a, b} & slope.free_symbols):
        return a + b / slope
    return None


def coinciding(model: "Model", arrs: Iterable["ARR"]) -> tuple[Coincidence, ...]:
    """Every pair of the model's faults that act through one symbol each (a parameter, or a sensor's
    or a source's efficiency factor) and that the derivative-causality residuals ``arrs`` read
    only through one combination (:func:`read_together`). A residual that integrates (mixed
    causality) is not decided here, nor a law sympy cannot differentiate or evaluate: a pair they
    read is left out (what this finds explains a report; it never stops a diagnosis)."""
    arrs = [(arr, _plain(arr.expr)) for arr in arrs]
    names = [{s.name for s in e.free_symbols} for _, e in arrs]
    constants = set(model.nominal_by_name()) - set(model.modes)
    single = {name: f.symbols[0] for name, f in model.faults.items()
              if f.kind != "mode" and f.effect == "gain" and len(f.symbols) == 1}    # an offset or a frozen reading
                                                                                     # acts on no symbol: left out
    signature = {name: frozenset(i for i, n in enumerate(names) if s in n) for name, s in single.items()}
    out = []
    for (fa, sa), (fb, sb) in combinations(single.items(), 2):
        if sa == sb or not signature[fa] or signature[fa] != signature[fb]:
            continue                     # another signature: the residuals' alarms separate them
        a, b = sp.Symbol(sa), sp.Symbol(sb)
        reading = [arrs[i] for i in sorted(signature[fa])]
        if any(arr.causality != "derivative" for arr, _ in reading):
            continue
        exprs = [e for _, e in reading]
        try:
            if not read_together(exprs, a, b, constants):
                continue
            named = combination(ratio(exprs, a, b), a, b)
        except Exception:    # noqa: BLE001 - sympy on a law it cannot differentiate or evaluate: not decided
            continue
        out.append(Coincidence((fa, fb), "" if named is None else str(named), tuple(arr.name for arr, _ in reading),
                               (sa, sb)))
    return tuple(out)


def _plain(expr: sp.Expr) -> sp.Expr:
    """``expr`` with every symbol a plain one of its name (the model's carry assumptions, positive
    or real; the test's symbols must be the same objects)."""
    return expr.xreplace({s: sp.Symbol(s.name) for s in expr.free_symbols if s != sp.Symbol(s.name)})
