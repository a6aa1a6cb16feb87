"""Binary DE alone, for the fault-mode estimator (Yu & Wang 2014, Sec. III-C: 'only part of AHDE
is used ... BDE with the adaptive law (26)').

It *is* that part: the paper's AHDE run with no real dimensions, so mutation (23), binomial
crossover with CR_b = sin(pi/2 * IM) * rand (26) and greedy selection (22) are the same code. A
mode vector is short (one bit per mode variable), so the freeze of eq. (23) matters little here; a
small ``bit_flip`` probability is still on by default (0.02) to keep the search alive when the
population agrees early.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .ahde_paper import AHDEPaper, PaperOptions
from .core import Engine, Posed, Result


@dataclass(frozen=True)
class BDEOptions(PaperOptions):
    """A mode vector's small search: 20 individuals, 30 generations, stop after 10 without gain."""
    pop: int = 20
    generations: int = 30
    stagnation: int | None = 10
    bit_flip: float = 0.02                  # keeps the search alive when the population agrees early


ENGINE = Engine("BDE", AHDEPaper, BDEOptions)


def minimize(objective, n_bits: int, options: BDEOptions | None = None, **overrides) -> Result:
    """Minimise ``objective(real (pop, 0), bits (pop, B))`` over B bits; ``overrides`` are fields
    of ``BDEOptions``."""
    return ENGINE.minimize(Posed(objective, np.zeros((0, 2)), n_bits), options, **overrides)
