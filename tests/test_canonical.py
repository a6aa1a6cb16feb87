"""bondgraph.canonical builds sympy's own products and substitutions: checked against sympy.Mul,
xreplace and sympy's assumption machinery themselves (srepr equal: the same tree, the same order)."""
from __future__ import annotations

import itertools
import random
from pathlib import Path

import sympy as sp
from sympy.core.assumptions import _assume_defined

from bondgraph.canonical import product, quotient, substitute
from bondgraph.equations import ParameterProduct, _positive_product
from bondgraph.laws import bond_variables
from bondgraph.model import t


def _same(got: sp.Expr, want: sp.Expr) -> bool:
    return got == want and sp.srepr(got) == sp.srepr(want)


def _pool() -> list[sp.Expr]:
    """Factors of every kind the laws and values hold, and some that sympy treats apart (numbers,
    floats, pi, powers of numbers and of products, exp, a repeated base, non-commuting symbols)."""
    a, b, c = sp.symbols("a b c", positive=True)
    x, y = bond_variables(3)
    q = sp.Symbol("q[tank]", real=True)
    u = sp.Function("u", real=True)(t)
    grouped = ParameterProduct(a * b * c)
    return [a, b, c, x, y, q, u, 1 / a, a ** 2, sp.sqrt(b), c ** sp.Rational(-3, 2), sp.sign(x), sp.Abs(q),
            sp.Derivative(u, t), grouped, 1 / grouped, x + y, q - a * x, 1 / (x + y), (x + y) ** 2, a * x, -b * y,
            2 * q, sp.Integer(-1), sp.Integer(2), sp.Rational(1, 3), sp.Integer(0), sp.Integer(1), sp.Float(1.5),
            sp.pi, sp.sqrt(2), sp.exp(q), sp.Symbol("n1", commutative=False), sp.I, sp.Mul(-1, x + y, evaluate=False),
            sp.Pow(a, 1, evaluate=False), -x]


def test_a_product_is_the_product_sympy_builds():
    """product() against sympy.Mul on 4 000 random lists of one to five factors of the pool, and
    quotient() against ``/``. The shortcut must also have been taken often (not only fallen back)."""
    pool = _pool()
    rng = random.Random(7)
    direct = 0
    for n in range(1, 6):
        for _ in range(800):
            fs = [rng.choice(pool) for _ in range(n)]
            got, want = product(fs), sp.Mul(*fs)
            assert _same(got, want), fs
            direct += all(f.is_commutative and not f.is_Float for f in fs)
    assert direct > 1000
    for a, b in itertools.product(pool[:24], repeat=2):
        if b != 0:
            assert _same(quotient(a, b), a / b), (a, b)


def test_a_substitution_is_xreplace():
    """substitute() against xreplace: every law of the shipped models (and a chain's), solved as
    the causal forms solve it, with its variables replaced by sums, products, signals and other
    bond variables of the pool."""
    from bondgraph.chains import chain_yaml
    from bondgraph.loader import load_model, load_model_text
    from bondgraph.structure import equations

    root = Path(__file__).resolve().parent.parent / "models"
    models = [load_model(p) for p in sorted(root.glob("*.yaml"))] + [load_model_text(chain_yaml(40), "chain_40")]
    pool = [p for p in _pool() if p.is_commutative and p != 0]
    rng = random.Random(3)
    checked = 0
    for m in models:
        for eq in equations(m).equations:
            for v in eq.variables:
                expr = eq.solutions.get(v) if v in eq.solutions else None
                for target in (eq.expr, expr):
                    if target is None:
                        continue
                    rule = {w: rng.choice(pool) for w in eq.variables}
                    assert _same(substitute(target, rule), target.xreplace(rule)), (m.name, eq.name, rule)
                    checked += 1
    assert checked > 500
    x, y = bond_variables(3)
    assert substitute(x, {}) is x and _same(substitute(sp.sign(x) * y, {x: x}), (sp.sign(x) * y).xreplace({x: x}))


def test_a_grouped_product_knows_what_sympy_would_deduce():
    """A ParameterProduct made knowing it is positive answers every assumption as one left to
    sympy's machinery (its own _eval_is_positive) answers it."""
    a, b, c = sp.symbols("a b c", positive=True)
    inner = ParameterProduct(a * b)
    for factors in ([a, b, c], [a, 1 / b, c ** 2], [inner, c], [1 / inner, sp.sqrt(a), b]):
        made, asked = _positive_product(factors), ParameterProduct(sp.Mul(*factors))
        assert _same(made, asked) and made is not asked
        for fact in sorted(_assume_defined):
            assert getattr(made, f"is_{fact}") == getattr(asked, f"is_{fact}"), (factors, fact)
