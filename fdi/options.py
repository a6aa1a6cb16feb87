"""The run options of a diagnosis (engine, seed, workers, overrides of the monitor settings),
checked before any work: a misspelt or out-of-range option is one line, not a worker's crash."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from optim import DEFAULT_ENGINE, ENGINES

from .config import MonitorConfig
from .errors import UsageError

MIN_POP = 4                # DE's mutation takes three other members of the population
MAX_POP = 100_000          # a population is held in memory: 100 000 members is far past the paper's 100
MAX_GENERATIONS = 1_000_000
MIN_SAMPLES = 2            # N samples from t_D: fewer leave nothing to fit
# Estimator processes by default, for the CLI and the library alike: two where the machine has them
# (the results do not depend on it: each estimator is seeded by its index)
DEFAULT_WORKERS = max(1, min(2, os.cpu_count() or 1))
MIN_WINDOW_S = 0.5         # s: the CyCab's shortest period (scales.min_period of its 0.25 s window), for callers without a model


@dataclass
class Options:
    """How to run a diagnosis. ``thresholds``, ``waiting_time``, ``samples`` and ``failures``
    override the monitor settings by name; ``settings`` replaces them whole; ``mode`` fixes the
    mode variables instead of reading the commands at t_D; ``settle``: seconds ignored after the
    data start (None: the data's settling time, :func:`fdi.scales.settle`)."""
    thresholds: Mapping[str, float] = field(default_factory=dict)
    waiting_time: float | None = None
    exoneration: bool = True
    max_set: int = 3                   # largest candidate set identified; larger ones are counted and reported
    engine: str = DEFAULT_ENGINE
    pop: int = 100
    generations: int = 150
    samples: int | None = None
    seed: int = 0
    workers: int = DEFAULT_WORKERS
    failures: Mapping[str, float] = field(default_factory=dict)
    weights: str = "thresholds"
    settle: float | None = None
    persistence: float | None = None   # threshold-seconds before a residual is latched (None: the model's)
    mode: Mapping[str, int] | None = None
    settings: MonitorConfig | None = None   # the monitor settings to use instead of the model file's
    keep_spikes: bool = False          # read one-sample spikes of sensor columns as recorded (fdi.spikes)

    def check(self) -> None:
        """Refuse settings that would crash a worker or give a nonsense diagnosis (a population
        too small for DE's mutation, no generation, a negative waiting time or threshold), with one
        line naming the field; the CLI checks its options the same way while parsing them."""
        if self.engine not in ENGINES:
            raise UsageError(f"Options.engine: unknown engine '{self.engine}' (use {', '.join(ENGINES)})")
        _whole("pop", self.pop, MIN_POP, MAX_POP)
        _whole("generations", self.generations, 1, MAX_GENERATIONS)
        _whole("workers", self.workers, 1)
        _whole("seed", self.seed, 0)
        _whole("max_set", self.max_set, 1, 6)
        if self.samples is not None:
            _whole("samples", self.samples, MIN_SAMPLES)
        if self.waiting_time is not None:
            _real("waiting_time", self.waiting_time, 0.0)
        if self.persistence is not None:
            _real("persistence", self.persistence, 0.0)
        for name, value in self.thresholds.items():
            _real(f"thresholds[{name}]", value, 0.0, strict=True)
        for name, value in self.failures.items():
            _real(f"failures[{name}]", value)
        if not isinstance(self.keep_spikes, bool):
            raise UsageError(f"Options.keep_spikes: must be True or False, got {self.keep_spikes!r}")
        if self.weights not in ("thresholds", "none"):
            raise UsageError(f"Options.weights: must be 'thresholds' or 'none', got {self.weights!r}")


def min_samples(ts: float, min_period: float = MIN_WINDOW_S) -> int:
    """The fewest identification samples N for data sampled every ``ts`` s: N * ts must reach the
    shortest intermittent period searched (:func:`fdi.scales.min_period`), or the period's search
    interval would be empty."""
    n = max(MIN_SAMPLES, math.ceil(min_period / ts))
    while n * ts < min_period:
        n += 1
    return n


def check_samples(samples: int | None, ts: float, option: str = "Options.samples",
                  min_period: float = MIN_WINDOW_S) -> None:
    """``samples`` (None: the model's) spans at least ``min_period`` of data sampled every ``ts`` s."""
    if samples is not None and samples < min_samples(ts, min_period):
        raise UsageError(f"{option}: must be at least {min_samples(ts, min_period)} for data sampled every {ts:g} s "
                         f"(N * t_s >= {min_period:g} s, the shortest intermittent period identified), got {samples}")


def _whole(name: str, value, low: int, high: int | None = None) -> None:
    """``value`` is an int in [low, high]; else a UsageError naming ``Options.<name>``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
            or (high is not None and value > high):
        span = f">= {low}" if high is None else f"from {low} to {high}"
        raise UsageError(f"Options.{name}: must be an integer {span}, got {value!r}")


def _real(name: str, value, low: float | None = None, strict: bool = False) -> None:
    """``value`` is a finite number, >= ``low`` (> with ``strict``); else a UsageError."""
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.number)) and bool(np.isfinite(value))
    if ok and low is not None:
        ok = value > low if strict else value >= low
    if not ok:
        bound = "" if low is None else f" {'>' if strict else '>='} {low:g}"
        raise UsageError(f"Options.{name}: must be a finite number{bound}, got {value!r}")
