"""Validation of SI unit strings such as ``N*m*s/rad`` or ``Pa^0.5*s/m^3``.

bgfdi works in SI throughout, so a unit string is checked, not converted: it must be a product
and quotient of unprefixed SI symbols (``kg`` is the one prefixed base unit) with optional
rational exponents. ``-`` or ``1`` mark a dimensionless quantity.
"""
from __future__ import annotations

import re

SI_UNITS = frozenset({
    "m", "kg", "s", "A", "K", "mol", "cd",
    "N", "Pa", "J", "W", "V", "Ohm", "Ω", "F", "H", "C", "S", "T", "Wb", "Hz", "rad", "sr",
})
_TOKEN = re.compile(r"^(?P<unit>[A-Za-zΩ]+)(?:(?:\^|\*\*)(?P<exp>-?\d+(?:\.\d+)?|\(-?\d+/\d+\)))?$")


class UnitError(ValueError):
    """A unit string that is not made of SI symbols."""


def check_unit(text: object) -> str:
    """Return the unit string unchanged if it is valid SI, raise UnitError saying why if not."""
    if text is None:
        return "-"
    if not isinstance(text, str):
        raise UnitError(f"unit must be a string such as 'N*m*s/rad', got {text!r}")
    unit = text.strip()
    if unit in ("", "-", "1"):
        return "-"
    body = unit.replace("·", "*").replace(" ", "")
    parts = re.split(r"[*/]", body)
    for part in parts:
        if part in ("1",):
            continue
        match = _TOKEN.match(part)
        if not match:
            raise UnitError(f"cannot read unit '{unit}' at '{part}' "
                            "(write SI symbols joined by * and /, with ^ for powers, e.g. Pa^0.5*s/m^3)")
        if match.group("unit") not in SI_UNITS:
            raise UnitError(f"unknown unit '{match.group('unit')}' in '{unit}' "
                            f"(SI symbols only: {', '.join(sorted(SI_UNITS))})")
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
    body = unit.replace("·", "*").replace(" ", "")
    sign = 1
    for token in re.split(r"([*/])", body):
        if token in ("*", "/"):
            sign = 1 if token == "*" else -1
            continue
        if token == "1":
            continue
        m = _TOKEN.match(token)
        exp_text = m.group("exp") or "1"
        exp = float(eval_fraction(exp_text))
        for base, e in DERIVED[m.group("unit")].items():
            out[base] = out.get(base, 0) + sign * exp * e
    return {k: v for k, v in out.items() if abs(v) > 1e-12}


def eval_fraction(text: str) -> float:
    """``2``, ``-0.5`` or ``(1/2)`` as a number (no eval)."""
    text = text.strip("()")
    if "/" in text:
        a, b = text.split("/")
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

    def power(k: str, v: float) -> str:
        v = abs(v)
        return k if v == 1 else f"{k}^{int(v) if float(v).is_integer() else v:g}"
    num = [power(k, v) for k in BASE if (v := dims.get(k, 0)) > 0]
    den = [power(k, v) for k in BASE if (v := dims.get(k, 0)) < 0]
    return ("*".join(num) or "1") + ("/" + "*".join(den) if den else "")
