"""Fault profiles and measurement noise for the independent simulators of tests/independent/.

Those simulators are the state equations of each domain model typed by hand from its textbook and
integrated with scipy's ``solve_ivp``; they never import ``bondgraph`` or ``fdi``. The profiles here
are written from their definitions (Yu & Wang 2014, eqs. 14 and 16), not taken from
``fdi.profiles``."""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

import numpy as np


@dataclass(frozen=True)
class Fault:
    """One fault: ``target`` is a parameter name or ``beta_<sensor or input>``.

    ``abrupt``: the target takes ``value`` from ``t0`` on. ``incipient``: exponential drift from
    the nominal value, P = P0 exp(rate (t - t0)) from ``t0`` on (eq. 16, b1 = rate)."""
    target: str
    kind: str
    t0: float
    value: float = math.nan
    rate: float = 0.0

    def at(self, t: float, nominal: float) -> float:
        if t < self.t0:
            return nominal
        if self.kind == "abrupt":
            return self.value
        if self.kind == "incipient":
            return nominal * math.exp(self.rate * (t - self.t0))
        raise ValueError(f"unknown fault kind {self.kind!r}")


def parameter_function(nominal: Mapping[str, float], faults: tuple[Fault, ...]) -> Callable[[float], dict]:
    """t -> every parameter and beta at time t (betas default to 1)."""
    def values(t: float) -> dict:
        p = dict(nominal)
        for f in faults:
            p[f.target] = f.at(t, p.get(f.target, 1.0))
        return p
    return values


def breakpoints(faults: tuple[Fault, ...], T: float) -> list[float]:
    """Times the integration restarts at: 0, every onset inside the run, T."""
    return sorted({0.0, T, *(f.t0 for f in faults if 0.0 < f.t0 < T)})


def sensor_gain(t: np.ndarray, name: str, faults: tuple[Fault, ...]) -> np.ndarray:
    """beta_<name>(t) over the samples."""
    out = np.ones_like(t)
    for f in faults:
        if f.target == f"beta_{name}":
            out = np.array([f.at(float(x), 1.0) for x in t])
    return out


def noisy(columns: dict[str, np.ndarray], noise: Mapping[str, float], seed: int) -> dict[str, np.ndarray]:
    """Add seeded white Gaussian noise (standard deviation by column) to the measured columns."""
    rng = np.random.default_rng(seed)
    out = dict(columns)
    for name, sigma in noise.items():
        out[name] = columns[name] + sigma * rng.standard_normal(columns[name].shape)
    return out


def write_csv(columns: dict[str, np.ndarray], order: list[str], path: str | Path) -> Path:
    """The columns as a CSV in the model's ``data.columns`` order."""
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(order)
        for row in zip(*(columns[c] for c in order)):
            w.writerow([repr(float(x)) for x in row])
    return path


def drift(nominal: float, model: int, b: list[float], tau: float) -> float:
    """An identified drift's value tau seconds after its onset, from eqs. (16) and (17) written out
    (P = P0 exp(b1 tau); 1/P = 1/P0 - b2 tau), to size a reported incipient fault against the
    designed one."""
    if model == 1:
        return nominal * math.exp(b[0] * tau)
    if model == 2:
        return 1.0 / (1.0 / nominal - b[0] * tau)
    raise ValueError(f"degradation model {model} not written out here")
