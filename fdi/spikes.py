"""One-sample spikes in a sensor's column: found, read as their neighbours' mean, and said.

A sensor that reads one sample far off and then reads on as before (an encoder's miscount, a bit
flipped on a bus, an ADC glitch) is not the plant: no physical quantity a sensor reads jumps and
comes back within one sampling period. Through the residuals' derivative filters such a sample
becomes an excursion as long as the filter and as high as the filter's gain times the jump
(divided by ts^2 for a second derivative), and the persistence rule, which weighs each sample by how
far it stands above the threshold, confirms it: one 0.5 rad miscount of the CyCab's motor encoder
was diagnosed as a drift of R4 (eq. 16). So before anything is computed, each sensor column is
searched for samples that stand apart from both neighbours while the neighbours agree:

    d_i = x_i - (x_{i-1} + x_{i+1}) / 2,   a spike where |d_i| > SPIKE_SIGMAS * s  and  |d_i| > AGREE * |x_{i+1} - x_{i-1}|

with s the column's robust spread of d (1.4826 times its median absolute deviation), never below
the sensor's declared noise (times sqrt(1.5), d's share of white noise), its resolution, or the
column's smallest step (the quantum of a quantised column that declares none); and the three samples
on each side must go on as one trajectory (one parabola within ``TREND_SIGMAS`` spreads). A step (a
sensor's offset, a valve that closes) is not a spike: after it the neighbours disagree; nor is an
event of the plant faster than the sampling that bends the trajectory (the CyCab's reference runs:
as the leak opens, p1 reads the tank's pressure for one sample and then rises on a new course). Two samples off in a
row are not found (the rule reads one). A column with more spikes than
``max(MIN_MANY, samples // MANY_PER)`` is left as recorded: so many excursions are the signal (a
switching current sampled below its switching rate), not glitches; the note says so.

A spike is read as the mean of its two neighbours (``Options(keep_spikes=True)``, ``--keep-spikes``:
as recorded) and named in the report's note with its time, its size and its size in noise. The first
and last ``REACH`` samples are not searched (the rule needs them on both sides). The streaming
monitor reads every sample as recorded (its filters carry state from block to block).

>>> import numpy as np
>>> t = np.arange(0.0, 1.0, 0.01)
>>> x = np.sin(t) + 0.001 * np.random.default_rng(0).standard_normal(t.size)
>>> x[40] += 0.5
>>> (s,) = find(t, {"theta": x})
>>> s.column, s.index, round(s.size, 2)
('theta', 40, 0.5)
>>> y = x.copy(); y[60:] += 0.5                                  # a step: not a spike
>>> y[40] -= 0.5
>>> find(t, {"theta": y})
()
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np

SPIKE_SIGMAS = 12.0   # |d| above this many robust spreads (Gaussian noise: once in 1e32 samples)
AGREE = 4.0           # ...and this many times the neighbours' own difference (a step's neighbours differ by it)
MIN_MANY = 3          # a column with more spikes than max(MIN_MANY, samples // MANY_PER) is left as recorded
MANY_PER = 2000
REACH = 3             # samples on each side that must go on as before (_continues)
TREND_SIGMAS = 4.0    # ...within this many spreads of one parabola
SHOWN = 3             # spikes named in the note (the rest counted)


@dataclass(frozen=True)
class Spike:
    """One sample of ``column`` (row ``index``, time ``time`` s) that stands ``size`` off the mean of
    its neighbours (in the column's unit), ``sigmas`` times the column's spread."""
    column: str
    index: int
    time: float
    size: float
    sigmas: float


@dataclass(frozen=True)
class Found:
    """The spikes to repair, and the columns left as recorded for having too many (with their count)."""
    spikes: tuple[Spike, ...]
    many: tuple[tuple[str, int], ...] = ()


def _spread(x: np.ndarray, d: np.ndarray, noise: float, resolution: float) -> float:
    """The scale a spike is measured in: d's robust spread, floored by the declared noise, the
    resolution and the column's smallest step (see the module docstring)."""
    mad = float(np.median(np.abs(d - np.median(d))))
    steps = np.abs(np.diff(x))
    steps = steps[steps > 0]
    # the quantum only where the column moves by it: on a flat column the few steps there are the
    # glitches' own (a steady quantised sensor's one glitch floored itself away)
    quantum = float(steps.min()) if steps.size > 2 * max(MIN_MANY, x.size // MANY_PER) + 2 else 0.0
    floor = max(noise * np.sqrt(1.5), resolution, quantum, np.finfo(float).tiny)
    return max(1.4826 * mad, floor)


def _continues(x: np.ndarray, i: int, s: float) -> bool:
    """Whether the column goes on after sample ``i`` as it went before it: the ``REACH`` samples on
    each side fit one parabola within ``TREND_SIGMAS`` spreads. A glitch leaves the trajectory as it
    was; an event of the plant faster than the sampling (the CyCab's reference runs: as the leak
    opens, p1 reads the tank's pressure for one sample, and the trajectory bends there) does not."""
    if i < REACH or i + REACH >= x.size:
        return False
    k = np.r_[-REACH:0, 1:REACH + 1].astype(float)
    y = np.r_[x[i - REACH:i], x[i + 1:i + REACH + 1]]
    fit = np.polyval(np.polyfit(k, y - y.mean(), 2), k) + y.mean()
    return bool(np.abs(y - fit).max() <= TREND_SIGMAS * s)


def search(t: np.ndarray, columns: Mapping[str, np.ndarray], noise: Mapping[str, float] | None = None,
           resolution: Mapping[str, float] | None = None) -> Found:
    """The one-sample spikes of ``columns`` (rows at the times ``t``), by the rule of the module
    docstring; ``noise`` and ``resolution`` are the sensors' declared ones, by column."""
    spikes: list[Spike] = []
    many: list[tuple[str, int]] = []
    with np.errstate(all="ignore"):          # a value near the double's limit: its ratios overflow to inf
        for name, values in columns.items():
            _search_column(t, name, values, noise, resolution, spikes, many)
    return Found(tuple(sorted(spikes, key=lambda s: (s.index, s.column))), tuple(many))


def _search_column(t, name, values, noise, resolution, spikes: list, many: list) -> None:
    """:func:`search` on one column, its spikes and its count of too many appended."""
    x = np.asarray(values, dtype=float)
    if x.size < 5 or not np.isfinite(x).all():
        return
    d = x[1:-1] - (x[:-2] + x[2:]) / 2
    s = _spread(x, d, (noise or {}).get(name, 0.0), (resolution or {}).get(name, 0.0))
    apart = np.abs(d)
    hit = np.flatnonzero((apart > SPIKE_SIGMAS * s) & (apart > AGREE * np.abs(x[2:] - x[:-2])))
    hit = np.array([i for i in hit if _continues(x, i + 1, s)], dtype=int)
    if hit.size > max(MIN_MANY, x.size // MANY_PER):
        many.append((name, int(hit.size)))
        return
    spikes.extend(Spike(name, int(i) + 1, float(t[i + 1]), float(d[i]), float(apart[i] / s)) for i in hit)


def find(t: np.ndarray, columns: Mapping[str, np.ndarray], noise: Mapping[str, float] | None = None,
         resolution: Mapping[str, float] | None = None) -> tuple[Spike, ...]:
    """:func:`search`'s spikes alone."""
    return search(t, columns, noise, resolution).spikes


def repaired(columns: Mapping[str, np.ndarray], spikes: tuple[Spike, ...]) -> dict[str, np.ndarray]:
    """``columns`` with each spike read as the mean of its two neighbours (the columns without a
    spike are the same arrays; a column with one is a copy).

    >>> import numpy as np
    >>> out = repaired({"x": np.array([0.0, 1.0, 9.0, 3.0])}, (Spike("x", 2, 0.2, 7.0, 50.0),))
    >>> out["x"].tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    out = dict(columns)
    for name in {s.column for s in spikes}:
        x = np.array(columns[name], dtype=float)
        for s in spikes:
            if s.column == name:
                x[s.index] = (x[s.index - 1] + x[s.index + 1]) / 2
        out[name] = x
    return out


KEEP = "--keep-spikes reads them as recorded"


def _times(x: float) -> str:
    """A ratio for the note: three digits, or "over 1e+300" where it overflowed (a value of 1e308)."""
    return f"{x:.3g}" if x < 1e300 else "over 1e+300"


def note(found: Found, units: Mapping[str, str] | None = None, advice: str = KEEP, kept: bool = False) -> str | None:
    """The report's words for what was found and done (None: nothing found); ``advice`` ends the
    spikes' sentence (how to read them as recorded instead); ``kept``: the spikes were read as
    recorded (named with their times only)."""
    if kept:
        return (f"{len(found.spikes)} one-sample spike(s) read as recorded: "
                + ", ".join(f"{s.column} at {s.time:.6g} s" for s in found.spikes[:SHOWN])
                + (" and more" if len(found.spikes) > SHOWN else "")) if found.spikes else None
    parts = []
    if found.spikes:
        shown = [f"{s.column} at {s.time:.6g} s ({s.size:+.4g}{' ' + units[s.column] if units and units.get(s.column) else ''}, "
                 f"{_times(s.sigmas)} times its spread)" for s in found.spikes[:SHOWN]]
        more = len(found.spikes) - SHOWN
        parts.append(f"{len(found.spikes)} one-sample spike(s) read as their neighbours' mean: " + ", ".join(shown)
                     + (f" and {more} more" if more > 0 else "")
                     + f" (a sensor's glitch, not the plant; {advice})")
    for name, count in found.many:
        parts.append(f"{name} has {count} one-sample excursions: read as recorded (so many are the signal, not "
                     f"glitches; sample faster if it switches between samples)")
    return "; ".join(parts) or None


def despiked(model, meas, keep: bool = False, advice: str = KEEP):
    """``meas`` (:class:`fdi.data.Measurements`) with the one-sample spikes of its sensor columns
    read as their neighbours' mean (none with ``keep``), and the note that says what was found,
    with the columns recorded far coarser than their declared noise (:func:`fdi.quantisation.coarse`)
    (None when nothing was). A column is a sensor's when its signal reads it (``sensors``)."""
    from .data import _signal_functions      # each sensor's columns, without sympy (a compiled model carries them)
    from .quantisation import coarse
    functions = _signal_functions(model)
    noise, resolution, units, names = {}, {}, {}, []
    for s in model.sensors.values():
        for c in functions[s.name][0]:
            if c in meas.columns and c not in names:
                names.append(c)
                noise[c], resolution[c] = float(s.noise.get(c, 0.0)), float(s.resolution.get(c, 0.0))
                if c == s.name:             # the sensor's own column: its unit
                    units[c] = s.unit
    found = search(meas.t, {c: meas.columns[c] for c in names}, noise, resolution)
    # (the columns recorded coarser than their declared noise are noted here too: this reads each
    # sensor column with its noise and resolution once, for calibrate and diagnose alike)
    rough = coarse({c: meas.columns[c] for c in names}, noise, resolution, units)
    if found.spikes and not keep:
        meas = replace(meas, columns={**meas.columns, **repaired(meas.columns, found.spikes)})
    return meas, "; ".join(x for x in (note(found, units, advice, kept=keep), rough) if x) or None
