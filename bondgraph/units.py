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
