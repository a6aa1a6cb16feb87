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


__all__ = ["same_name"]
