"""Identification problems of the paper's shape that need no data file (``bgfdi bench optim``).

Two faults of unknown type on N = 1000 samples (ts = 0.01 s from t0 = 32 s) and three residuals,
like the CyCab scenarios. Each fault f acts on the residuals of its signature through an
excitation s_f(t) (the paper's command input and its phase-shifted twin):

    G_l(t) = sum_f C[l, f] * s_f(t) * (g_f(P_f,hyp(t)) - g_f(P_f,true(t))) + noise_l(t)

with g = P_ref / P for a resistance or an efficiency factor (what a residual sees of them: a
conductance, a corrected measurement) and g = P for a multiplier. The cost is the paper's
sum |G| (eq. 24): its minimum is the noise floor, reached at the true profiles.

``recovered`` is the success test used by the bench for every problem: the type (and degradation
model) of each fault right, abrupt and intermittent values and the period within ``tol`` (2 %),
and an incipient profile within ``tol`` of the true one over the whole window (coefficients of
the second-order models are not separately identifiable to 2 %; their profiles are).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import encoding, hints
from ..encoding import FaultSpace

T0, TS, N = 32.0, 0.01, 1000


@dataclass
class Problem:
    name: str
    spaces: list[FaultSpace]
    truth: list[dict]
    t: np.ndarray
    t0: float
    cost: Callable[[np.ndarray, np.ndarray], np.ndarray]
    description: str = ""
    objective: object = None          # an fdi.objective.Objective (onset fixed at t0) when the problem is on data
    seeds: list = None                # per fault, (period, phase) pairs found in the residuals (fdi.hints)

    def __call__(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        """The cost: a problem of ``optim`` (``optim.core.Problem``), its hooks ``n_bits``,
        ``onehot``, ``structure``, ``family`` and ``free`` below."""
        return self.cost(real, bits)

    def _with_onset(self, real: np.ndarray) -> np.ndarray:
        real = np.atleast_2d(real)
        return np.hstack([real, np.full((real.shape[0], 1), self.t0)])

    @property
    def onehot(self):
        return encoding.onehot_groups(self.spaces)

    def structure(self, bits: np.ndarray):
        return encoding.structure(self.spaces, bits)

    def family(self, bits: np.ndarray):
        return encoding.family(self.spaces, bits)

    def bounds(self) -> np.ndarray:
        return encoding.bounds(self.spaces)

    def free(self, bits: np.ndarray) -> np.ndarray:
        """The reals a structure leaves to the search (the objective's, when it solves magnitudes)."""
        if self.objective is not None:
            return self.objective.free(bits)[:-1]
        return encoding.free(self.spaces, bits)

    def propose(self, bits: np.ndarray) -> np.ndarray:
        """Seeds for the intermittent faults of a structure, from the periods found in the residuals
        at the nominal hypothesis (:mod:`fdi.hints`); none without seeds."""
        if not self.seeds:
            return np.empty((0, encoding.N_REAL * len(self.spaces)))
        return hints.intermittent_rows(self.spaces, bits, self.seeds)

    def translate(self, real: np.ndarray, bits_from: np.ndarray, bits_to: np.ndarray) -> np.ndarray:
        """The fault profiles of ``real`` re-expressed in another structure (:func:`fdi.hints.translate`)."""
        return hints.translate(self.spaces, np.asarray(real, dtype=float), bits_from, bits_to, self.t, self.t0)

    def finish(self, real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        """The best individual with the magnitudes the objective solves written in."""
        if self.objective is not None:
            return self.objective.complete(self._with_onset(real), bits)[:-1]
        return real

    @property
    def n_bits(self) -> int:
        return encoding.N_BITS * len(self.spaces)


def recovered(spaces: list[FaultSpace], truth: list[dict], real: np.ndarray, bits: np.ndarray, t: np.ndarray,
              t0: float, tol: float = 0.02) -> bool:
    found = encoding.describe(spaces, real, bits)
    for s, f, want in zip(spaces, found, truth):
        if f["type"] != want["type"]:
            return False
        rel = lambda a, b: abs(a - b) <= tol * abs(b)
        if f["type"] == "abrupt" and not rel(f["value"], want["value"]):
            return False
        if f["type"] == "intermittent" and not (rel(f["value"], want["value"]) and rel(f["period"], want["period"])):
            return False
        if f["type"] == "incipient":
            if f["model"] != want["model"]:
                return False
            p = encoding.profiles([s], encoding.decode([s], *encoding.encode([s], [f])), t, t0)[0][0]
            q = encoding.profiles([s], encoding.decode([s], *encoding.encode([s], [want])), t, t0)[0][0]
            fin = np.isfinite(q) & (q != 0)
            if not np.all(np.isfinite(p[fin])) or np.max(np.abs(p[fin] - q[fin]) / np.abs(q[fin])) > tol:
                return False
    return True


def _excitation(t: np.ndarray, phase: float) -> np.ndarray:
    return 0.17 * (5 * np.sin(2 * t + phase) + 0.5 * np.sin(t + phase) + 0.2 * np.sin(0.5 * t) + np.sin(2.5 * t + phase))


def _g(space: FaultSpace, kind: str) -> Callable[[np.ndarray], np.ndarray]:
    if kind == "multiplier":
        return lambda p: p
    ref = space.reference
    return lambda p: np.where(np.isinf(p), 0.0, ref / np.where(p == 0, np.inf, p))


R_LIKE = dict(name="R", nominal=np.inf, bounds=(1.0e6, 1.0e9))
BETA = dict(name="beta", nominal=1.0, bounds=(0.05, 1.5))
MULT = dict(name="M", nominal=1.0, bounds=(0.2, 5.0))

CASES = {
    "abrupt+intermittent": ([R_LIKE, BETA], ["resistance", "efficiency"], [[0, 1], [1, 1], [0, 0]],
                            [{"type": "abrupt", "value": 2.5221e7},
                             {"type": "intermittent", "value": 0.62, "period": 5.3}]),
    "abrupt+incipient": ([R_LIKE, BETA], ["resistance", "efficiency"], [[0, 0], [1, 1], [0, 1]],
                         [{"type": "abrupt", "value": 2.5221e7},
                          {"type": "incipient", "model": 2, "b": [-0.03]}]),
    "intermittent+incipient": ([MULT, BETA], ["multiplier", "efficiency"], [[0, 0], [0, 1], [1, 1]],
                               [{"type": "intermittent", "value": 2.0, "period": 3.1},
                                {"type": "incipient", "model": 1, "b": [-0.04]}]),
    "abrupt+incipient18": ([MULT, BETA], ["multiplier", "efficiency"], [[1, 0], [0, 1], [1, 1]],
                           [{"type": "abrupt", "value": 1.8},
                            {"type": "incipient", "model": 3, "b": [-3.0, -1.01]}]),
    "intermittent+incipient19": ([BETA, MULT], ["efficiency", "multiplier"], [[1, 0], [1, 1], [0, 1]],
                                 [{"type": "intermittent", "value": 0.7, "period": 4.2},
                                  {"type": "incipient", "model": 4, "b": [0.5, -0.02, 0.03]}]),
}
CORE = ("abrupt+intermittent", "abrupt+incipient", "intermittent+incipient")
GROUPS = {"synthetic": CORE, "synthetic-all": tuple(CASES)}


NOISE = 0.01   # calibrated: exponential (16) vs true hyperbolic (17) fits differ by ~2 % on abrupt+incipient,
               # the same order as the 1.1 % measured on scenario-2 data


def problem(case: str, seed: int = 0, noise: float = NOISE) -> Problem:
    """One synthetic identification problem; ``seed`` draws its measurement noise."""
    specs, kinds, signature, truth = CASES[case]
    spaces = [FaultSpace.make(s["name"], s["nominal"], s["bounds"]) for s in specs]
    t = T0 + TS * np.arange(N)
    rng = np.random.default_rng(10_000 + seed)
    true_p = encoding.profiles(spaces, encoding.decode(spaces, *encoding.encode(spaces, truth)), t, T0)
    gs = [_g(s, k) for s, k in zip(spaces, kinds)]
    excite = [_excitation(t, 0.0), _excitation(t, 1.3)]
    C = np.asarray(signature, dtype=float)
    true_g = [g(p[0]) for g, p in zip(gs, true_p)]
    noise_g = noise * rng.standard_normal((3, N))

    def cost(real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        ps = encoding.profiles(spaces, encoding.decode(spaces, real, bits), t, T0)
        total = np.zeros(real.shape[0])
        for l in range(3):
            g_l = noise_g[l][None, :].copy()
            for f in range(len(spaces)):
                if C[l, f]:
                    with np.errstate(invalid="ignore", over="ignore"):
                        g_l = g_l + C[l, f] * excite[f][None, :] * (gs[f](ps[f]) - true_g[f][None, :])
            total += np.abs(g_l).sum(axis=1)
        return np.where(np.isfinite(total), total, np.inf)

    nominal = encoding.encode(spaces, [{"type": "abrupt", "value": s.nominal if np.isfinite(s.nominal) else s.bounds[1]}
                                       for s in spaces])
    seen = np.abs(np.vstack([noise_g[l] + sum(C[l, f] * excite[f] * (gs[f](np.full(N, spaces[f].nominal)) - true_g[f])
                                              for f in range(len(spaces)))
                             for l in range(3)]))
    mags = [seen[C[:, f] > 0].sum(axis=0) for f in range(len(spaces))]
    seeds = [hints.candidate_periods(x, TS, hints.square_waves(x, TS, *s.period), *s.period) for x, s in zip(mags, spaces)]
    del nominal
    return Problem(case, spaces, truth, t, T0, cost, f"synthetic {case}, seed {seed}", seeds=seeds)
