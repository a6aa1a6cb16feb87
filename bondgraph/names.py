"""Names as a model file's expressions read them (no sympy: the data reader checks its header with it)."""
from __future__ import annotations

import unicodedata


def same_name(names) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of ``names`` that are one name as expressions read them:
    equal, or equal once Unicode-normalised (NFKC: 'µ' is 'μ', 'ﬁx' is 'fix', as Python's parser
    reads identifiers); None when every name is its own.

    >>> same_name(["t", "µ", "x", "μ"])
    (1, 3)
    >>> same_name(["t", "x"]) is None
    True
    """
    seen: dict[str, int] = {}
    for j, name in enumerate(names):
        key = unicodedata.normalize("NFKC", name)
        if key in seen:
            return seen[key], j
        seen[key] = j
    return None


# Greek and Cyrillic letters drawn as Latin ones (Unicode's confusables for the letters a model's
# names use): a name that differs from another only by them reads the same to a person
_LATIN = str.maketrans({
    "Α": "A", "Β": "B", "Ε": "E", "Ζ": "Z", "Η": "H", "Ι": "I", "Κ": "K", "Μ": "M", "Ν": "N", "Ο": "O", "Ρ": "P",
    "Τ": "T", "Υ": "Y", "Χ": "X", "ο": "o", "ν": "v", "ρ": "p", "ι": "i", "κ": "k", "υ": "u", "χ": "x",
    "А": "A", "В": "B", "Е": "E", "К": "K", "М": "M", "Н": "H", "О": "O", "Р": "P", "С": "C", "Т": "T", "Х": "X",
    "а": "a", "е": "e", "о": "o", "р": "p", "с": "c", "у": "y", "х": "x", "і": "i", "ј": "j", "ѕ": "s", "ԁ": "d",
    "ɡ": "g", "һ": "h", "І": "I", "Ј": "J", "Ѕ": "S"})


def skeleton(name: str) -> str:
    """``name`` as a person reads it: NFKC, then Greek and Cyrillic look-alikes as Latin letters.

    >>> skeleton("\u039apa") == skeleton("Kpa"), skeleton("pA") == skeleton("p\u0410")
    (True, True)
    """
    return unicodedata.normalize("NFKC", name).translate(_LATIN)


def look_alike(name: str, other: str) -> str:
    """Which characters tell two look-alike names apart, for a message: each non-ASCII one of
    ``name`` with its code point and Unicode name.

    >>> look_alike("\u039apa", "Kpa")
    "'\u039a' is U+039A GREEK CAPITAL LETTER KAPPA"
    """
    odd = [c for c in dict.fromkeys(name + other) if ord(c) > 127]
    return ", ".join(f"'{c}' is U+{ord(c):04X} {unicodedata.name(c, '?')}" for c in odd)


__all__ = ["same_name", "skeleton", "look_alike"]
