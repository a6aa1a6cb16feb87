"""SI unit strings as the SI brochure (BIPM, 9th ed., sec. 5.4.3) writes them: a solidus followed
by a parenthesised denominator, a space or a half-high dot for a product, negative exponents; and
the one-line refusals of what is not a unit."""
from __future__ import annotations

import re

import pytest

from bondgraph.units import UnitError, check_unit, dimension

SPECIFIC_HEAT = {"m": 2, "s": -2, "K": -1}        # J/(kg K) = m^2 s^-2 K^-1


@pytest.mark.parametrize("text", ["J/(kg*K)", "J/(kg K)", "J kg^-1 K^-1", "J·kg^-1·K^-1", "m^2/(s^2*K)",
                                  "(m/s)^2/K"])
def test_the_brochures_ways_of_writing_a_specific_heat(text):
    assert check_unit(text) == text
    assert dimension(text) == SPECIFIC_HEAT


@pytest.mark.parametrize("text, expected", [
    ("W/(m^2*K)", {"kg": 1, "s": -3, "K": -1}),            # a heat transfer coefficient
    ("Pa^(1/2)", {"kg": 0.5, "m": -0.5, "s": -1}),
    ("Pa^0.5*s/m^3", {"kg": 0.5, "m": -3.5}),
    ("1/s", {"s": -1}),
])
def test_other_units(text, expected):
    assert dimension(text) == expected


@pytest.mark.parametrize("text, message", [
    ("J/(kg*K", "at 'its end'"),
    ("J/kg*K)", "at ')'"),
    ("()", "at ')'"),
    ("m^", "at '^'"),
    ("2*m", "at '2*m'"),
    ("kcal/K", "unknown unit 'kcal'"),
    ("m^(1/0)", "divides by zero"),
    ("m" * 300, "300 characters long"),
])
def test_what_is_not_a_unit_is_refused_with_where_it_stops(text, message):
    with pytest.raises(UnitError, match=re.escape(message)):
        check_unit(text)


@pytest.mark.parametrize("text, shown", [
    ("kg*m^2*K/s^4", "W*K/s"),        # a trial's thermal term with a wrong unit: was kg*m^2*K/s^4
    ("J/K", "J/K"), ("kg*m^2/s", "J*s"), ("V*K", "V*K"),
    ("kg/s", "kg/s"), ("kg/m^3", "kg/m^3"), ("m^3/s", "m^3/s"), ("W", "W"), ("N*m", "N*m"),
])
def test_a_unit_is_shown_through_a_named_unit_where_that_is_shorter(text, shown):
    from bondgraph.units import format_dimension
    assert format_dimension(dimension(text)) == shown
    assert dimension(shown) == dimension(text)         # and it reads back as the same dimension
