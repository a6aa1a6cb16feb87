"""Validation of SI unit strings such as ``N*m*s/rad``, ``Pa^0.5*s/m^3`` or ``J/(kg*K)``.

bgfdi works in SI throughout, so a unit string is checked, not converted: it must be a product
and quotient of unprefixed SI symbols (``kg`` is the one prefixed base unit) with optional
rational exponents, grouped by parentheses as the SI brochure writes them (``W/(m^2*K)``, and a
space for a product: ``J/(kg K)``). ``-`` or ``1`` mark a dimensionless quantity.

>>> dimension("J/(kg K)") == dimension("m^2/(s^2*K)") == {"m": 2, "s": -2, "K": -1}
True
"""
from __future__ import annotations

import re
from functools import lru_cache

SI_UNITS = frozenset({
    "m", "kg", "s", "A", "K", "mol", "cd",
    "N", "Pa", "J", "W", "V", "Ohm", "Ω", "F", "H", "C", "S", "T", "Wb", "Hz", "rad", "sr",
})
_EXP = r"(?:\^|\*\*)(?P<exp>-?\d+(?:\.\d+)?|\(-?\d+/\d+\))"
_LEX = re.compile(r"\s*(?:(?P<sym>[A-Za-zΩ]+|1(?![\d.]))(?:" + _EXP.replace("exp", "sexp") + r")?|(?P<op>[*/()])"
                  r"(?:(?<=\))" + _EXP.replace("exp", "gexp") + r")?)")
_MAX_LENGTH = 200       # a unit is a few symbols; a longer string is a mistake, not a unit
HINT = "write SI symbols joined by * and /, with ^ for powers, e.g. Pa^0.5*s/m^3 or J/(kg*K)"


class UnitError(ValueError):
    """A unit string that is not made of SI symbols."""


def _parse(unit: str) -> dict[str, float]:
    """:func:`_read`'s exponents, a fresh dict: a model names the same few units thousands of
    times (a 10 000-element chain: 10 000 units, 2 distinct)."""
    return dict(_read(unit))


@lru_cache(maxsize=1024)
def _read(unit: str) -> tuple[tuple[str, float], ...]:
    """The exponents of the SI symbols in ``unit`` (not yet reduced to base units), or UnitError
    naming where it stops. Grammar: product := factor (('*' | '/' | space) factor)*, factor :=
    symbol [^exp] | '1' | '(' product ')' [^exp]; a '/' divides by the factor after it."""
    body = unit.replace("·", "*").replace("⋅", "*")
    if len(body) > _MAX_LENGTH:
        raise UnitError(f"unit '{unit[:40]}...' is {len(body)} characters long ({HINT})")
    tokens: list[tuple[str, str, float]] = []       # (kind, text, exponent)
    pos = 0
    while pos < len(body):
        if body[pos:].strip() == "":
            break
        m = _LEX.match(body, pos)
        if not m or m.end() == pos:
            rest = body[pos:].strip()
            raise UnitError(f"cannot read unit '{unit}' at '{rest.split()[0] if rest else rest}' ({HINT})")
        if m.group("sym"):
            tokens.append(("sym", m.group("sym"), eval_fraction(m.group("sexp") or "1")))
        else:
            tokens.append(("op", m.group("op"), eval_fraction(m.group("gexp") or "1")))
        pos = m.end()

    def fail(at: int) -> UnitError:
        what = tokens[at][1] if at < len(tokens) else "its end"
        return UnitError(f"cannot read unit '{unit}' at '{what}' ({HINT})")

    def product(i: int) -> tuple[dict[str, float], int]:
        out: dict[str, float] = {}
        sign, first = 1.0, True
        while i < len(tokens):
            kind, text, _ = tokens[i]
            if kind == "op" and text == ")":
                break
            if not first:
                if kind == "op" and text in "*/":
                    sign = 1.0 if text == "*" else -1.0
                    i += 1
                elif kind == "op" and text != "(":
                    raise fail(i)
                else:
                    sign = 1.0                   # a space between two factors: a product
            part, i = factor(i)
            for k, v in part.items():
                out[k] = out.get(k, 0.0) + sign * v
            first = False
        if first:
            raise fail(i)
        return out, i

    def factor(i: int) -> tuple[dict[str, float], int]:
        if i >= len(tokens):
            raise fail(i)
        kind, text, exp = tokens[i]
        if kind == "sym":
            if text == "1":
                return {}, i + 1
            if text not in SI_UNITS:
                raise UnitError(f"unknown unit '{text}' in '{unit}' (SI symbols only: {', '.join(sorted(SI_UNITS))})")
            return {text: exp}, i + 1
        if text != "(":
            raise fail(i)
        inner, j = product(i + 1)
        if j >= len(tokens) or tokens[j][1] != ")":
            raise fail(j)
        power = tokens[j][2]
        return {k: v * power for k, v in inner.items()}, j + 1

    out, end = product(0)
    if end != len(tokens):
        raise fail(end)
    return tuple(out.items())


def check_unit(text: object) -> str:
    """Return the unit string unchanged if it is valid SI, raise UnitError saying why if not."""
    if text is None:
        return "-"
    if not isinstance(text, str):
        raise UnitError(f"unit must be a string such as 'N*m*s/rad', got {text!r}")
    unit = text.strip()
    if unit in ("", "-", "1"):
        return "-"
    _parse(unit)
    return unit


# ------------------------------------------------------------------ dimensions

BASE = ("kg", "m", "s", "A", "K", "mol", "cd")
DERIVED: dict[str, dict[str, float]] = {
    "m": {"m": 1}, "kg": {"kg": 1}, "s": {"s": 1}, "A": {"A": 1}, "K": {"K": 1}, "mol": {"mol": 1},
    "cd": {"cd": 1}, "rad": {}, "sr": {}, "Hz": {"s": -1},
    "N": {"kg": 1, "m": 1, "s": -2}, "Pa": {"kg": 1, "m": -1, "s": -2}, "J": {"kg": 1, "m": 2, "s": -2},
    "W": {"kg": 1, "m": 2, "s": -3}, "C": {"A": 1, "s": 1}, "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2}, "Ω": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "F": {"kg": -1, "m": -2, "s": 4, "A": 2}, "H": {"kg": 1, "m": 2, "s": -2, "A": -2},
    "S": {"kg": -1, "m": -2, "s": 3, "A": 2}, "T": {"kg": 1, "s": -2, "A": -1}, "Wb": {"kg": 1, "m": 2, "s": -2, "A": -1},
}
NAMED = [("N*m", {"kg": 1, "m": 2, "s": -2}), ("W", {"kg": 1, "m": 2, "s": -3}), ("N", {"kg": 1, "m": 1, "s": -2}),
         ("Pa", {"kg": 1, "m": -1, "s": -2}), ("V", {"kg": 1, "m": 2, "s": -3, "A": -1}), ("A", {"A": 1}),
         ("m^3/s", {"m": 3, "s": -1}), ("m/s", {"m": 1, "s": -1}), ("1/s", {"s": -1})]


def dimension(unit: str) -> dict[str, float]:
    """A checked unit string as exponents of the SI base units (rad and sr count as 1), e.g.
    ``dimension("Pa^0.5*s/m^3")`` = {kg: 0.5, m: -3.5, s: 0}.

    >>> dimension("N*m/rad") == {"kg": 1, "m": 2, "s": -2}
    True
    """
    unit = check_unit(unit)
    out: dict[str, float] = {}
    if unit == "-":
        return out
    for symbol, exp in _parse(unit).items():
        for base, e in DERIVED[symbol].items():
            out[base] = out.get(base, 0) + exp * e
    return {k: v for k, v in out.items() if abs(v) > 1e-12}


def eval_fraction(text: str) -> float:
    """``2``, ``-0.5`` or ``(1/2)`` as a number (no eval)."""
    text = text.strip("()")
    if "/" in text:
        a, b = text.split("/")
        if float(b) == 0:
            raise UnitError(f"a power of ({text}) divides by zero; write a number such as (1/2)")
        return float(a) / float(b)
    return float(text)


def combine(*parts: tuple[dict[str, float], float]) -> dict[str, float]:
    """The product of dimensions raised to powers: ``combine((W, 1), (Pa, -1))`` is W/Pa."""
    out: dict[str, float] = {}
    for dims, power in parts:
        for k, v in dims.items():
            out[k] = out.get(k, 0) + power * v
    return {k: v for k, v in out.items() if abs(v) > 1e-12}


def format_dimension(dims: dict[str, float]) -> str:
    """A dimension as a unit string, a familiar name where there is one (``m^3/s``, ``N*m``, ``Pa``).

    >>> format_dimension(combine((dimension("W"), 1), (dimension("Pa"), -1)))
    'm^3/s'
    """
    for name, d in NAMED:
        if d == {k: v for k, v in dims.items()}:
            return name
    if not dims:
        return "-"
    if dims.get("kg") == 1:
        # a named unit times a little rest where that is shorter (a thermal term of a wrong unit:
        # W*K/s, not kg*m^2*K/s^4)
        best = None
        for name in FACTORS:
            rest = combine((dims, 1), (DERIVED[name], -1))
            size = sum(abs(v) for v in rest.values())
            if size < sum(abs(v) for v in dims.values()) - 2 and (best is None or size < best[0]):
                best = (size, name, rest)
        if best is not None:
            return best[1] + _base_text(best[2], lead="*")
    return _base_text(dims)


FACTORS = ("W", "J", "N", "Pa", "V")   # the named units a composite unit is told through


def _base_text(dims: dict[str, float], lead: str = "") -> str:
    """``dims`` in base symbols (``m^3/s``), after ``lead`` (a named unit's ``*``) when it has a
    numerator; "" for no dimension after a lead."""
    def power(k: str, v: float) -> str:
        v = abs(v)
        return k if v == 1 else f"{k}^{int(v) if float(v).is_integer() else v:g}"
    num = [power(k, v) for k in BASE if (v := dims.get(k, 0)) > 0]
    den = [power(k, v) for k in BASE if (v := dims.get(k, 0)) < 0]
    if lead:
        return (lead + "*".join(num) if num else "") + ("/" + "*".join(den) if den else "")
    return ("*".join(num) or "1") + ("/" + "*".join(den) if den else "")
