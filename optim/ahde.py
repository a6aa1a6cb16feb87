"""The improved AHDE, bgfdi's default identification engine.

Measured against the paper's AHDE (``optim.ahde_paper``) on identification problems of the paper's
shape (``bgfdi bench optim``), two things fail there: the binary mutation (23) can only set bits,
so the discrete part freezes within a few dozen generations, and the IM-based adaptation is
nearly inert (the best cost never falls far below the noise floor, so IM stays near 1 and F, CR
are uniform draws). This engine keeps the paper's idea, real and binary decisions on one
population with one fitness, and changes the two parts that fail:

1. the reals are searched by L-SHADE (success-history adaptation of F and CR, current-to-pbest/1
   with an archive, linear population reduction), and the bits evolve *with* them as random keys,
   so every bit stays reachable; one-hot groups (the fault discrimination vector zeta) are read as
   the argmax of their keys, always valid;
2. the discrete decision is then checked: the best ``polish`` structures seen (a structure is
   whatever ``structure(bits)`` says, e.g. each fault's type and degradation model) are each
   refined with the bits fixed, and the best refined one wins. The cost of the runner-up over the
   winner's is the **discrimination margin**: near 1 means the data hardly separate the two.

Budget: the same pop * (generations + 1) evaluations as the paper's engine; ``phase`` of it for the
joint search, the rest split between the polished structures.
"""
from __future__ import annotations

import time
from typing import Callable, Hashable, Sequence

import numpy as np

from . import shade
from .core import Counter, Result, check_bounds


def minimize(objective, bounds, n_bits: int = 0, *, pop: int = 150, generations: int = 300, seed: int | None = 0,
             target: float | None = None, stagnation: int | None = None, onehot: Sequence[Sequence[int]] = (),
             structure: Callable[[np.ndarray], Hashable] | None = None, polish: int = 3, phase: float = 0.7,
             callback=None, **_ignored) -> Result:
    """Joint L-SHADE search over reals and bit keys, then per-structure refinement."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    bounds = check_bounds(bounds)
    nr = bounds.shape[0]
    budget = pop * (generations + 1)
    describe = structure or (lambda b: tuple(int(x) for x in b))
    keys: dict[bytes, Hashable] = {}          # bit pattern -> structure, computed once per pattern
    counter = Counter(objective)
    seen: dict[Hashable, tuple[float, np.ndarray, np.ndarray]] = {}

    def joint_cost(z: np.ndarray) -> np.ndarray:
        bits = shade.keys_to_bits(z[:, nr:], onehot)
        c = counter(z[:, :nr], bits)
        for i in np.argsort(c)[: max(4, len(c) // 4)]:
            pattern = bits[i].tobytes()
            if pattern not in keys:
                keys[pattern] = describe(bits[i])
            key = keys[pattern]
            if key not in seen or c[i] < seen[key][0]:
                seen[key] = (float(c[i]), z[i, :nr].copy(), bits[i].copy())
        return c

    full = np.vstack([bounds, np.tile([0.0, 1.0], (n_bits, 1))]) if n_bits else bounds
    history: list[float] = []
    phase_evals = budget if not n_bits or polish <= 0 else int(phase * budget)
    x, f, stop = shade.run(joint_cost, full, rng, pop=pop, max_evals=phase_evals, history=history,
                           target=target, stagnation=stagnation, callback=callback)
    best_z = x[int(np.argmin(f))]
    best = (float(f.min()), best_z[:nr].copy(), shade.keys_to_bits(best_z[None, nr:], onehot)[0])
    refined: list[tuple[float, Hashable, np.ndarray, np.ndarray]] = []
    if n_bits and polish > 0 and stop != "target":
        ranked = sorted(seen.items(), key=lambda kv: kv[1][0])[:polish]
        share = max(pop, (budget - counter.evaluations) // max(1, len(ranked)))
        for key, (_c0, real0, bits0) in ranked:
            fixed = np.broadcast_to(bits0, (1, n_bits))
            small = max(10, min(pop, 30))
            cost = lambda z, b=fixed: counter(z, np.broadcast_to(b, (z.shape[0], n_bits)))
            sub_hist: list[float] = []
            xs, fs, _ = shade.run(cost, bounds, rng, pop=small, max_evals=share, init=real0[None, :],
                                  history=sub_hist, target=target)
            i = int(np.argmin(fs))
            refined.append((float(fs[i]), key, xs[i].copy(), bits0.copy()))
            history.append(min(history[-1], float(fs[i])))
        refined.sort(key=lambda r: r[0])
        if refined[0][0] <= best[0]:
            best = (refined[0][0], refined[0][2], refined[0][3])
    margin = float("inf")
    if len(refined) >= 2:
        margin = refined[1][0] / max(refined[0][0], 1e-300)
    extra = {"margin": margin, "structures": [(r[1], r[0]) for r in refined]}
    return Result(best[1], best[2], best[0], history, counter.evaluations, len(history) - 1,
                  time.perf_counter() - t0, counter.seconds, stop, extra)
