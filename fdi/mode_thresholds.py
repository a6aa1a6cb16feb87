"""Thresholds by mode: one threshold per combination of some mode variables for a residual whose
noise or unit differs between the modes.

A controlled junction multiplies its outputs by its mode variable, so one residual takes another
form in each mode, and the forms' noise may differ by orders of magnitude: an EV precharge
circuit's link balance reads the main contactor's current as (Vb - vdc)/Rm while that contactor
is closed (Rm = 2 mOhm: tens of amperes of noise from the link voltage's) and the pack current
while precharging (a fraction of an ampere). One threshold is set by the noisiest form and blinds
the residual in the others (``bgfdi check`` predicts each mode's noise, :mod:`fdi.noise`;
``bgfdi calibrate`` measures it). In a model file::

    thresholds:
      ARR1: {p=0 m=1: 120.0, other: 0.8}     # the main contactor's modes, and every other
      ARR2: 56.8

Each key gives a value (0 or 1) to the same mode variables; ``other`` covers the combinations no
key names (needed unless every one is named). Such a residual is monitored as r / T(mode) against
1: every stage reads the divided residual (detection and its evidence, isolation's sensitivity
test, identification's weights, the streaming monitor, the generated C monitor), so the threshold
follows the mode sample by sample, and a mode fault's hypothesis is judged with the threshold of
the mode it assumes. ``bgfdi calibrate`` writes such tables where a residual's noise differs
tenfold between modes (:func:`fdi.calibrate.calibrate`).

>>> table = {(("p", 0), ("m", 1)): 120.0, (): 0.8}
>>> key_text((("p", 0), ("m", 1))), threshold_in(table, {"p": 0, "m": 1, "d": 0}), threshold_in(table, {"p": 1, "m": 0})
('p=0 m=1', 120.0, 0.8)
"""
from __future__ import annotations

import itertools
import re
from typing import Any, Mapping

from bondgraph.model import Model

OTHER = "other"
MAX_VARIABLES = 6          # mode variables one table may key on (64 combinations)
_PAIR = re.compile(r"^([^\W\d]\w*)=([01])$")        # a mode's name as the loader takes it (Unicode too: κ=0)


def key_text(key: tuple) -> str:
    """A table key as the file spells it: ``p=0 m=1``, or ``other`` for ()."""
    return " ".join(f"{k}={v}" for k, v in key) if key else OTHER


def variables(table: Mapping[tuple, float]) -> tuple[str, ...]:
    """The mode variables a table keys on (in its keys' order)."""
    return next((tuple(k for k, _ in key) for key in table if key), ())


def threshold_in(table: Mapping[tuple, float], mode: Mapping[str, int]) -> float:
    """The threshold of ``mode`` (a value for each of the table's variables, at least)."""
    key = tuple((v, int(mode[v])) for v in variables(table))
    return table[key] if key in table else table[()]


def parse_table(doc: Any, model: Model, value: Mapping, where: tuple) -> dict[tuple, float]:
    """A residual's thresholds by mode from the file (``doc``: :class:`bondgraph.loader.Document`,
    for its errors, each naming the key and its line); keys ordered as the model's modes."""
    if not value:
        raise doc.error(where, "thresholds by mode need at least one entry ({p=1 m=0: 0.9, other: 550}), or give "
                               "one number")
    order = {name: i for i, name in enumerate(model.modes)}
    out: dict[tuple, float] = {}
    names: tuple[str, ...] | None = None
    for raw, number in value.items():
        text = str(raw).strip()
        here = where + (raw,)
        if text == OTHER:
            key: tuple = ()
        else:
            pairs = [p for p in re.split(r"[\s,]+", text) if p]
            found = [_PAIR.match(p) for p in pairs]
            if not pairs or not all(found):
                raise doc.error(here, f"'{text}' is no mode combination: write mode=0 or mode=1 for each mode "
                                      f"variable, separated by spaces (p=1 m=0), or '{OTHER}'")
            key = tuple((m.group(1), int(m.group(2))) for m in found)
            unknown = [k for k, _ in key if k not in order]
            if unknown:
                raise doc.error(here, f"{', '.join(unknown)}: no mode of the model (its modes: "
                                      f"{', '.join(model.modes) or 'none'})")
            if len({k for k, _ in key}) != len(key):
                raise doc.error(here, f"'{text}' gives one mode variable twice")
            key = tuple(sorted(key, key=lambda kv: order[kv[0]]))
            mine = tuple(k for k, _ in key)
            if len(mine) > MAX_VARIABLES:
                raise doc.error(here, f"a table by mode keys on {MAX_VARIABLES} mode variables at most")
            if names is not None and mine != names:
                raise doc.error(here, f"every key of one residual names the same mode variables "
                                      f"({' '.join(names)}), not {' '.join(mine)}")
            names = mine
        if key in out:
            raise doc.error(here, f"'{key_text(key)}' is given twice")
        out[key] = doc.number(number, here, "threshold", above=0)
    names = names or ()
    missing = [combo for combo in itertools.product((0, 1), repeat=len(names))
               if tuple(zip(names, combo)) not in out]
    if missing and () not in out:
        shown = key_text(tuple(zip(names, missing[0])))
        raise doc.error(where, f"no threshold for {shown}" + (f" and {len(missing) - 1} other combination(s)"
                                                               if len(missing) > 1 else "")
                        + f": name it, or give '{OTHER}: <threshold>' for every combination not named")
    return out


def weight(model: Model, table: Mapping[tuple, float]):
    """1 / T(mode) as an expression of the mode variables: each combination's indicator (a
    product of m and 1 - m) over its threshold, summed (exact at modes of 0 and 1)."""
    import sympy as sp
    names = variables(table)
    terms = []
    for combo in itertools.product((0, 1), repeat=len(names)):
        ind = sp.Integer(1)
        for name, bit in zip(names, combo):
            m = model.symbols[name]
            ind = ind * (m if bit else 1 - m)
        terms.append(ind * sp.Float(1.0 / threshold_in(table, dict(zip(names, combo)))))
    return sp.Add(*terms)
