"""Every time scale of a diagnosis, from the data's sampling time and the model's time constants.

bgfdi monitors a DC-DC converter sampled at 1 MHz and a building sampled at 1 Hz with the same
code, so no window, settling time, period bound or integration step is a constant in seconds.
Two scales are known without asking anyone: the sampling time ``ts`` of the data (read from the
data, :class:`fdi.data.Measurements`), and the fastest time constant ``tau`` of the model (the
eigenvalues of its linearised state equations in every mode, :mod:`bondgraph.timescales`). The
rules, each in one function below with its reason:

- derivative window W: ``tau / 2`` within [9 ts, 101 ts]; ``25 ts`` when the model has no
  time constant;
- settling time: ``W / 2`` after the data start (the filter's start edge), or ``7 tau_d`` when
  a mode turns more than a radian within W (tau_d: its decay time);
- end edge: ``W / 2`` before the data end (the filter's end edge);
- shortest intermittent period: ``max(2 W, 4 ts)``;
- waiting time T_wt: ``W``;
- persistence (the evidence a residual's excursions carry before it joins the coherence vector,
  :mod:`fdi.detect`): ``W`` threshold-seconds within a span of ``max(T_wt, 4 W)``;
- integration step (ROS2): ``min(ts, tau / 20)`` (:func:`bondgraph.timescales.integration_step`:
  the simulator cannot import fdi, so that one rule lives there).

A value the model file sets (``diagnosis: derivative_window``, ``waiting_time``) is used exactly
as given: every model bgfdi ships sets both, so these rules decide nothing for them but the
settling time, the end edge, the shortest period and the integration step, which give the
CyCab's earlier values (1 ms steps, periods from 0.5 s) and change no reference diagnosis.

>>> s = for_data(0.001, 0.1)          # an RC circuit, tau = 0.1 s, sampled at 1 kHz
>>> s.window, s.settle, s.min_period
(0.05, 0.025, 0.1)
>>> s = for_data(1e-6, 1e-5)          # the same circuit 10 000 times faster, sampled at 1 MHz
>>> round(s.window, 12), round(s.min_period, 12)
(9e-06, 1.8e-05)
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from bondgraph.errors import ModelError
from bondgraph.model import Model
from bondgraph.timescales import integration_step, model_time_scales

from .config import MonitorConfig

POLYORDER = 3                   # the Savitzky-Golay polynomial of fdi.derivatives (DEFAULT_ORDER)
WINDOW_PER_TIME_CONSTANT = 0.5  # W = tau / 2
UNKNOWN_SCALE_SAMPLES = 25      # W in samples when the model has no time constant
MAX_WINDOW_SAMPLES = 101        # W in samples at most
PERIOD_WINDOWS = 2.0            # an intermittent fault's period spans at least two windows ...
PERIOD_SAMPLES = 4              # ... and two samples in each of its phases
PERSISTENCE_WINDOWS = 1.0       # threshold-seconds of evidence per derivative window (see persistence())
EVIDENCE_WINDOWS = 4.0          # the shortest span the evidence is summed over, in derivative windows

__all__ = ["Scales", "derivative_window", "settle", "switch_settle", "end_edge", "min_period", "waiting_time", "persistence", "evidence_span", "detection_rule",
           "integration_step",
           "model_time_scales", "for_data", "for_model", "resolve"]


def min_window_samples(polyorder: int = POLYORDER) -> int:
    """The fewest samples of a derivative window: twice the polynomial's coefficients, plus one
    (odd, centred). A cubic through 5 samples interpolates them and passes their noise to the
    derivative whole; least squares over 9 averages it (the noise of a least-squares slope falls
    as N^-1.5).

    >>> min_window_samples(3)
    9
    """
    return 2 * (polyorder + 1) + 1


def derivative_window(ts: float, fastest: float, polyorder: int = POLYORDER) -> float:
    """The Savitzky-Golay window W (s) for data sampled every ``ts`` s of a model whose fastest
    time constant is ``fastest`` s (inf: none).

    W = tau / 2: a cubic fit over half a time constant differentiates e^(-t/tau) within 1e-5 of
    its slope (measured: 8e-6 at 100 samples per tau, 1.3e-4 at W = tau, 2e-3 at W = 2 tau), so
    the filter adds nothing the model does not explain, while the window is as long, and the
    derivative's noise as low, as that allows. At least ``min_window_samples`` samples: a time
    constant shorter than a few samples is not resolved by the data anyway. At most 101 samples:
    the noise of a cubic's slope falls as N^-1.5, so 101 samples already divide a 9-sample
    window's by 37, while a longer window only costs: a fault's onset is smeared over one window
    (a tenth of the 1000-sample identification window at 101: measured on a thermal RC sampled
    at 1 Hz, tau = 1 h, W = 1800 s, the abrupt R fault's fit cost twice a spurious pair's), the
    filter's edges hide more data, and a sensor fault's candidates are re-filtered per individual
    (1.5 min for three estimators at 1801 samples). A model with no time constant (integrators
    only) gets 25 samples, the CyCab's window (0.25 s at 100 Hz), the one tuned on real data.

    >>> derivative_window(0.01, 1.0), derivative_window(0.01, 0.02), derivative_window(0.01, math.inf)
    (0.5, 0.09, 0.25)
    >>> derivative_window(1.0, 3600.0)         # a thermal process sampled at 1 Hz: 101 samples
    101.0
    """
    floor = min_window_samples(polyorder) * ts
    if not math.isfinite(fastest) or fastest <= 0:
        return UNKNOWN_SCALE_SAMPLES * ts
    return min(max(WINDOW_PER_TIME_CONSTANT * fastest, floor), MAX_WINDOW_SAMPLES * ts)


STARTUP_DECAYS = 7.0           # decay times of a mode the window cannot follow, at the data start
MAX_QUALITY = 50.0              # an oscillation decays at least as fast as one of this quality factor


def decay_time(eigenvalue) -> float:
    """1/|Re lambda| of a mode, or of one of quality MAX_QUALITY where it rings longer (an
    undamped pair is not left ringing forever).

    >>> decay_time(-4.0), decay_time(100j)
    (0.25, 0.5)
    """
    v = complex(eigenvalue)
    return 1.0 / max(abs(v.real), abs(v) / MAX_QUALITY)


def settle(window: float, eigenvalues=()) -> float:
    """The seconds after the data start that detection and calibration ignore.

    Half the derivative window at least: a residual of an ARR holds through any transient of the
    system, but for the first half window the filter evaluates the first whole window's
    polynomial off its centre, where its noise gain is several times the interior's (measured on
    a thermal model with a 31 s window: 1085 W at the first sample for thresholds near 600 W,
    under them from the eighth).

    And 7 decay times 1/|Re lambda| of the modes the window cannot follow (|lambda| W > 1, from
    the model's ``eigenvalues``): a cubic over more than a radian of a mode does not
    differentiate it, so while a start-up transient of that mode lasts, the residual carries the
    filter's error (measured on an RLC circuit, W = 50 ms, lambda = -35 +- 99j: 830 times the
    threshold at the first sample, over it until 116 ms, four decay times; e^-7 brings a
    thousandfold transient under its threshold). A window the rules derive (tau / 2) follows every
    mode, so this only lengthens the settling of a window a model file sets long.

    >>> settle(0.25), round(settle(0.05, [-35 + 99j, -35 - 99j]), 3), settle(0.05, [-3.0])
    (0.125, 0.2, 0.025)
    """
    decays = sorted(decay_time(v) for v in eigenvalues if abs(complex(v)) * window > 1.0)
    startup = STARTUP_DECAYS * decays[len(decays) // 2] if decays else 0.0      # the median: no outlier point
    return max(window / 2, startup)


def switch_settle(ts: float, eigenvalues=()) -> float:
    """The seconds after a mode switch whose samples hold a transient too fast for the data: 7
    decay times of the slowest mode that decays within one sampling time (0 without one).

    Such a mode (a motor winding's L/R of 0.35 ms sampled at 1 kHz) settles between two samples:
    the sample at the switch still shows the state before it (the current 0 A as the ESC re-arms),
    the next one the state after it (80 A). No polynomial through both follows the new mode's
    trajectory, so every fit that reads those samples misreads the derivatives (a user trial's
    drone: 23 to 67 times the thresholds for three samples after a fault-free re-arm, a
    detection). A slower mode is resolved by the samples and, when the window cannot follow it,
    settles within the window's own edge rules (:func:`settle` at the data start).

    >>> round(switch_settle(0.001, [-2886.0, -5.0]), 6), switch_settle(0.001, [-5.0])
    (0.002426, 0.0)
    """
    fast = [d for d in map(decay_time, (v for v in eigenvalues if complex(v) != 0)) if d < ts]
    return STARTUP_DECAYS * max(fast) if fast else 0.0


def end_edge(window: float) -> float:
    """The seconds before the data end that detection and calibration ignore: half the window,
    the same off-centre fit at the other end (measured: calibrated peaks taken at the last sample
    were 1.3 to 2.7 times the interior's). A stream's residual is final only half a window after
    its sample (the monitor's lag), so a file is judged as its stream would have been."""
    return window / 2


def min_period(window: float, ts: float) -> float:
    """The shortest intermittent period searched: each phase (half the period) at least one
    derivative window, or the filter averages the fault's on and off phases into one level and
    its period cannot be told from a smaller abrupt fault; and at least two samples per phase.
    On the CyCab (W = 0.25 s): 0.5 s, the bound the search always had.

    >>> min_period(0.25, 0.01), min_period(1e-6, 1e-6)
    (0.5, 4e-06)
    """
    return max(PERIOD_WINDOWS * window, PERIOD_SAMPLES * ts)


def waiting_time(window: float) -> float:
    """The default waiting time T_wt (eq. 29) when the model file gives none: one derivative
    window. The centred filter spreads a step of the fault over [t0 - W/2, t0 + W/2]: a residual
    may cross its threshold half a window before the fault and another only reach its full
    response half a window after it, so the coherence vector is complete one window after t_D."""
    return window


def persistence(window: float) -> float:
    """The default persistence of detection (threshold-seconds, :mod:`fdi.detect`): one derivative
    window. The centred filter turns a step of a signal into an excursion about one window long, so
    a transient the diagnostic model does not describe (a valve or a leak opening, a mode switch)
    carries less than a window of evidence (measured: 0.12 threshold-seconds on ARR1 of the CyCab as
    a leak opens, for a window of 0.25 s), while a fault keeps its residual out: one at twice its
    threshold is confirmed after half a window, one at ten times after a tenth, and a weak one that
    crosses now and then in each cycle of the excitation once its crossings add up to a window
    (a 10 % current-sense gain fault of the boost converter: 21 µs in its first 200 µs, for a 10 µs
    window).

    >>> persistence(0.25)
    0.25
    """
    return PERSISTENCE_WINDOWS * window


def evidence_span(window: float, wait: float = 0.0) -> float:
    """The span (s) over which a residual's evidence is summed: the waiting time T_wt, the time
    the paper gives a fault to show itself before deciding (eq. 29), and at least four derivative
    windows; crossings further apart (noise touching a threshold now and then) do not add up.

    >>> evidence_span(0.25, 5.0), evidence_span(0.25)
    (5.0, 1.0)
    """
    return max(wait, EVIDENCE_WINDOWS * window)


def detection_rule(window: float, wait: float, *given: float | None) -> tuple[float, float]:
    """(persistence, span) of detection: the first persistence ``given`` that is not None (the
    run's options, then the model file), else :func:`persistence`; the span :func:`evidence_span`.

    >>> detection_rule(0.25, 5.0), detection_rule(0.25, 5.0, None, 0.0)
    ((0.25, 5.0), (0.0, 5.0))
    """
    chosen = next((float(g) for g in given if g is not None), persistence(window))
    return chosen, evidence_span(window, wait)


@dataclass(frozen=True)
class Scales:
    """The time scales of one diagnosis (all in s): ``ts`` of the data, ``fastest`` time constant
    of the model (inf: none known), and what the rules make of them."""
    ts: float
    fastest: float
    window: float
    settle: float
    end_edge: float
    min_period: float
    waiting_time: float
    step: float

    def min_samples(self) -> int:
        """The fewest identification samples N: N ts must reach the shortest period."""
        n = max(2, math.ceil(self.min_period / self.ts))
        while n * self.ts < self.min_period:
            n += 1
        return n


def for_data(ts: float, fastest: float, window: float | None = None, wait: float | None = None,
             eigenvalues=(), polyorder: int = POLYORDER) -> Scales:
    """The scales of data sampled every ``ts`` s of a model whose fastest time constant is
    ``fastest`` (and whose linearisations have ``eigenvalues``); a ``window`` or ``wait`` given
    (the model file's) is kept exactly."""
    w = derivative_window(ts, fastest, polyorder) if window is None else float(window)
    return Scales(ts, fastest, w, settle(w, eigenvalues), end_edge(w), min_period(w, ts),
                  waiting_time(w) if wait is None else float(wait), integration_step(ts, fastest))


def for_model(model: Model, config: MonitorConfig, ts: float) -> Scales:
    """The scales of ``model`` monitored with ``config`` on data sampled every ``ts`` s."""
    tau = model_time_scales(model)
    return for_data(ts, tau.fastest, config.derivative_window, config.waiting_time, tau.eigenvalues)


def resolve(config: MonitorConfig, model: Model, ts: float) -> MonitorConfig:
    """``config`` with every time the file left out filled in by the rules (the same object when
    the file gives them all)."""
    if config.derivative_window is not None and config.waiting_time is not None:
        return config
    s = for_model(model, config, ts)
    return replace(config, derivative_window=s.window, waiting_time=s.waiting_time)


def check_record_length(model: Model, window: float, need: int, ts: float, samples: int, data: str) -> None:
    """Refuse (DataError) a record of fewer ``samples`` than the ``need`` the derivative window of
    ``window`` s spans: no residual sample could be filtered (and calibrate's filter of a window 14
    times the record's length took two minutes to say so). A record sampled over 30 times faster
    than the model file's data.sampling_time is likely stamped in another unit (h or min for s):
    the message asks."""
    from .data import DataError
    if samples >= need:
        return
    given = model.sampling_time
    hint = (f" (sampled every {ts:g} s, 1/{given / ts:.4g} of the model file's data.sampling_time, {given:g} s: are "
            f"the time stamps in another unit, h or min for s? Time is in seconds, SI)" if given and ts < given / 30 else "")
    raise DataError(f"{data}: {samples} samples are too few: the derivative window of {model.name} ({window:g} s) "
                    f"needs at least {need}{hint}")


def check_derivative_window(model: Model, window: float | None, ts: float, data: str) -> None:
    """Refuse (ModelError on ``diagnosis.derivative_window``) a derivative window shorter than one
    sample of the record ``data``: the filter would be widened to its least (5 samples), a window the
    thresholds were not set for (1e-300 s gave a false fault). diagnose and calibrate ask alike."""
    if window is not None and window < ts:
        given = model.sampling_time
        if given and ts > 1.01 * given:     # the record, not the file, is likely wrong: name the record
            from .data import DataError
            raise DataError(f"{data}: sampled every {ts:g} s, {ts / given:.4g} times the model file's data.sampling_time "
                            f"({given:g} s) and longer than its derivative window ({window:g} s): are the time stamps "
                            f"in another unit (ms for s)? Time is in seconds (SI); if the record is right, give the "
                            f"model a window of a few of its samples (diagnosis.derivative_window: {5 * ts:g})")
        raise ModelError(f"{window:g} s is shorter than one sample of {data} ({ts:g} s): the derivatives would be "
                         "a 5-sample filter the thresholds were not set for; give at least a few samples "
                         f"({5 * ts:g} s), or leave it out (bgfdi calibrate --window auto chooses one)",
                         file=model.path, where="diagnosis.derivative_window")
