"""Thresholds from fault-free runs (``bgfdi calibrate``).

A residual's threshold must stay above what noise, filter and model error make of it when
nothing is wrong, and as low as that allows so that faults are seen early. From nominal runs:

- ``peak`` (default): the largest |r| of each residual over all the runs, times a margin (1.5:
  the peak of a longer or noisier run exceeds the one seen);
- ``quantile``: the q-quantile of |r| over all samples, times the margin (for long records with
  rare spikes; a quantile below 1 accepts that fraction of samples above the threshold).

Only the samples detection looks at count: half a derivative window after each run's start and
before its end are left out (:func:`fdi.detect.trusted`, :mod:`fdi.scales`), where the
Savitzky-Golay filter is evaluated off its centre and its noise is several times the interior's
(measured: peaks taken at the last sample made thresholds 1.3 to 2.7 times too loose).

With two runs or more the false-alarm rate is estimated by leaving each run out: thresholds from
the others, and whether the left-out run crosses one. That is an estimate of the chance that a new
fault-free run, as long as these, raises an alarm with the thresholds of all of them; with n runs
it can only be a multiple of 1/n, and it is pessimistic (the thresholds used come from one run
fewer). Each left-out run's worst residual is reported with its ratio to the others' threshold.
Each residual's unit is given (:func:`fdi.arrs.arr_unit`): it depends on the variable it sums
(m^3/s for one residual of a hydraulic model, Pa or N*m for the next).

``bgfdi calibrate -o`` writes the thresholds into a copy of the model file, the rest untouched:

>>> c = Calibration("rc", ["ARR1"], ["A"], [[0.002]], [0.003], "peak", 1.5, None, ["nominal.csv"])
>>> print(with_thresholds("name: rc   # an RC node\\nthresholds:\\n  ARR1: 1.0\\nparameters: {}\\n", c), end="")
name: rc   # an RC node
thresholds: {ARR1: 0.003}   # bgfdi calibrate: peak of |r| x 1.5 over 1 nominal run(s)
parameters: {}
"""
from __future__ import annotations

import re
from dataclasses import asdict, dataclass

import numpy as np

from . import derivatives, scales
from .arrs import arr_unit
from .data import DataError, Measurements, commanded, read_csv, signals_from_data
from .monitor import compiled
from .detect import settling, trusted
from .residuals import evaluate

DEFAULT_MARGIN = 1.5


@dataclass
class Calibration:
    """Thresholds by residual, their units and the measurements behind them."""
    model: str
    names: list[str]
    units: list[str]
    peaks: list[list[float]]            # per run, per residual: max |r| between the filter's edges
    thresholds: list[float]
    rule: str
    margin: float
    false_alarms: list[bool] | None     # per run left out: did it cross a threshold of the others?
    runs: list[str]
    worst: list[tuple[str, float]] | None = None   # per run left out: its residual nearest (or furthest
                                                    # past) the others' threshold, and |r| / that threshold
    window: float | None = None         # the derivative window (s) the residuals were filtered with
    window_samples: int | None = None   # ... in samples of the first run
    window_given: bool = True           # from diagnosis.derivative_window (else the rule's, fdi.scales)
    highest_order: int = 0              # the highest derivative the residuals take

    @property
    def false_alarm_rate(self) -> float | None:
        return None if self.false_alarms is None else float(np.mean(self.false_alarms))

    def to_dict(self) -> dict:
        return {**asdict(self), "false_alarm_rate": self.false_alarm_rate}


def nominal_residuals(model_path: str, data: str | Measurements, settle: float | None = None) -> np.ndarray:
    """|r| of every residual on one run, on the samples detection looks at (the derivative
    filter's edges left out, at least ``settle`` s at the start): (residuals, samples)."""
    c = compiled(model_path)
    model = c.model
    meas = data if isinstance(data, Measurements) else read_csv(data)
    sc = scales.for_model(model, c.config, meas.ts)
    raw = signals_from_data(model, meas)
    r = evaluate(model, list(c.residuals), raw, meas.ts, window=sc.window, values=commanded(model, raw))
    keep = trusted(meas.t, settling(settle, sc.settle), sc.end_edge)
    return np.abs(np.asarray(r))[:, keep]


def _threshold(samples: list[np.ndarray], quantile: float | None, margin: float) -> np.ndarray:
    joined = np.concatenate(samples, axis=1)
    # NaN: samples with no residual (within half a derivative window of a commanded switch)
    level = np.nanmax(joined, axis=1) if quantile is None else np.nanquantile(joined, quantile, axis=1)
    return margin * level


def calibrate(model_path: str, runs: list, margin: float = DEFAULT_MARGIN, quantile: float | None = None,
              settle: float | None = None) -> Calibration:
    """Thresholds from nominal ``runs`` (paths or Measurements); see the module doc."""
    c = compiled(model_path)
    model, arrs = c.model, c.arrs
    names = [a.name for a in arrs]
    data = [run if isinstance(run, Measurements) else read_csv(run) for run in runs]
    for meas in data:
        if all(np.ptp(v) == 0 for k, v in meas.columns.items() if k != "t"):
            raise DataError(f"{meas.path}: every column is constant: no sensor noise and nothing moving, so no "
                            "threshold can be learnt from it (it would be 0, or miss the noise every real run "
                            "has); calibrate on fault-free runs recorded from the plant, noise included")
    samples = [nominal_residuals(model_path, meas, settle) for meas in data]
    thresholds = _threshold(samples, quantile, margin)
    blank = [n for n, v in zip(names, thresholds) if not np.isfinite(v)]
    if blank:
        raise DataError(f"{model_path}: {', '.join(blank)} have no sample to calibrate on: every stretch between "
                        f"two mode switches is shorter than the derivative window ({c.config.derivative_window:g} s); "
                        "shorten diagnosis.derivative_window or sample faster")
    zero = [n for n, v in zip(names, thresholds) if not v > 0]
    if zero:
        raise DataError(f"{model_path}: {', '.join(zero)} would get a threshold of 0 (the residual is exactly 0 on "
                        "every sample of the runs: noise-free data?); a zero threshold alarms on any noise: "
                        "calibrate on runs recorded with the sensors' noise")
    false_alarms = worst = None
    if len(samples) > 1:
        false_alarms, worst = [], []
        for i, left in enumerate(samples):
            others = _threshold(samples[:i] + samples[i + 1:], quantile, margin)
            ratio = np.nanmax(left, axis=1) / others
            false_alarms.append(bool((left > others[:, None]).any()))
            worst.append((names[int(np.argmax(ratio))], float(ratio.max())))
    sc = scales.for_model(model, c.config, data[0].ts)
    return Calibration(model.name, names, [arr_unit(model, a) for a in arrs],
                       [[float(x) for x in np.nanmax(s, axis=1)] for s in samples], [float(x) for x in thresholds],
                       "peak" if quantile is None else f"quantile {quantile:g}", margin, false_alarms,
                       [m.path for m in data], worst, float(sc.window),
                       int(derivatives.window_samples(sc.window, data[0].ts, derivatives.DEFAULT_ORDER)),
                       c.config.derivative_window is not None,
                       max((r.highest_order() for r in c.residuals), default=0))


def format_calibration(c: Calibration) -> str:
    lines = [f"thresholds of {c.model} from {len(c.runs)} nominal run(s): {c.rule} of |r| x {c.margin:g}",
             f"{'residual':<10}{'unit':<10}{'largest |r|':>14}{'threshold':>14}"]
    for i, name in enumerate(c.names):
        peak = max(p[i] for p in c.peaks)
        lines.append(f"{name:<10}{c.units[i]:<10}{peak:>14.4g}{c.thresholds[i]:>14.4g}")
    if c.false_alarms is None:
        lines.append("false alarms: give two runs or more to estimate them (each is left out in turn)")
    else:
        n = len(c.false_alarms)
        lines.append(f"false alarms, each run left out in turn: {sum(c.false_alarms)} of {n} "
                     f"({100 * c.false_alarm_rate:.0f} %): how often a fault-free run alarms with thresholds "
                     f"calibrated without it,")
        lines.append(f"  an estimate of the chance that a new fault-free run as long as these alarms (in steps of "
                     f"1/{n}; pessimistic: one run fewer)")
        for run, alarmed, (name, ratio) in zip(c.runs, c.false_alarms, c.worst or ()):
            lines.append(f"  {run}: {name} reaches {ratio:.2f} x the others' threshold"
                         + (" (an alarm)" if alarmed else ""))
    if c.window is not None:
        lines.append(f"derivative window: {c.window:.4g} s ({c.window_samples} samples), "
                     + ("diagnosis.derivative_window" if c.window_given else
                        "the rule's (half the model's fastest time constant, docs/diagnosis.md)"
                        + (": the residuals take second derivatives, whose noise falls as the window's "
                           "length to the power 2.5; if faults go undetected, a longer diagnosis.derivative_window"
                           if c.highest_order >= 2 else "")))
    lines.append("thresholds: {" + ", ".join(f"{n}: {t:.4g}" for n, t in zip(c.names, c.thresholds)) + "}")
    return "\n".join(lines) + "\n"


def with_thresholds(text: str, c: Calibration) -> str:
    """The model file's text with its top-level ``thresholds`` replaced by the calibrated ones (the
    rest of the file, comments included, untouched); added at the end when there is none."""
    line = "thresholds: {" + ", ".join(f"{n}: {t:.4g}" for n, t in zip(c.names, c.thresholds)) + "}"
    line += f"   # bgfdi calibrate: {c.rule} of |r| x {c.margin:g} over {len(c.runs)} nominal run(s)\n"
    pattern = re.compile(r"^thresholds:.*\n(?:[ \t]+.*\n)*", re.M)      # the key and its indented lines
    if pattern.search(text):
        return pattern.sub(lambda _: line, text, count=1)
    return text.rstrip("\n") + "\n\n" + line
