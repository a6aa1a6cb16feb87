"""An identified incipient fault as a ProgPy ``PrognosticsModel`` (NASA's prognostics package), so
that ProgPy's predictors, state estimators and metrics work on what bgfdi identified.

The model of one incipient :class:`fdi.results.Fault` (degradation model eq. 16-19 with its
coefficients ``b``, onset ``t0`` and 95 % bands ``b_band``/``t0_band``) and the failure value its
prognosis runs to (``fdi.config``'s ``failure``, the same value ``fdi.prognose`` uses):

- **states**: the degraded parameter or efficiency ``P`` (named after the fault), its rate ``dP``
  for the second-order models (18) and (19), and the coefficients ``b1..bk`` of the model, held
  constant (dP/dt depends on them; as states they carry the fit's uncertainty through a
  prediction: each Monte Carlo sample keeps its own coefficients);
- **event**: ``failure``, met when ``P`` reaches the failure value (from above when the failure
  value is below the nominal one, as ``fdi.prognose``); event state 1 at the nominal value, 0 at
  the failure value;
- **no process noise by default**: the uncertainty bgfdi knows is the fit's, a band on constant
  coefficients and on the onset. White process noise on ``P`` would be a different claim (a random
  walk whose spread grows as sqrt(t) and averages out), so the band enters as the spread of the
  initial state (:meth:`initial_samples`: coefficients and onset drawn normal with the band as
  their 95 % interval, ``P`` and ``dP`` at ``now`` computed from each draw's profile); a user who
  believes in process noise passes ``process_noise`` as to any ProgPy model.

The steps are exact for (16) and (17) (P exp(b1 dt); 1/(1/P - b2 dt), infinite P included) and RK4
for (18) and (19) (as ``fdi.profiles`` integrates (19)), so a prediction's error is the event's
time resolution, ``dt``.

ProgPy is an optional extra (``pip install 'bgfdi[progpy]'``): this module imports it only when a
model is made, and says so in one line when it is absent.
"""
from __future__ import annotations

import functools
import math
import warnings
from typing import Any, Mapping

import numpy as np

from .profiles import N_COEFFICIENTS, incipient
from .results import Fault

Z95 = 1.959963984540054        # a 95 % interval is +- Z95 standard deviations of a normal


class ProgPyMissing(ImportError):
    """ProgPy is not installed: the message names the extra."""


def _progpy():
    try:
        import progpy
    except ImportError:
        raise ProgPyMissing("the ProgPy bridge needs ProgPy: pip install 'bgfdi[progpy]'") from None
    return progpy


def _fault(fault: Fault | Mapping) -> Fault:
    f = fault if isinstance(fault, Fault) else Fault.from_dict(fault)
    if f.type != "incipient" or f.model not in N_COEFFICIENTS or f.b is None or f.t0 is None:
        raise ValueError(f"{f.name}: only an incipient fault with a degradation model (1-4), coefficients b and an "
                         f"onset t0 has a degradation to predict (got type {f.type})")
    if len(f.b) != N_COEFFICIENTS[f.model]:
        raise ValueError(f"{f.name}: model {f.model} (eq. {15 + f.model}) has {N_COEFFICIENTS[f.model]} "
                         f"coefficient(s), b has {len(f.b)}")
    return f


@functools.lru_cache(maxsize=1)
def _model_class():
    """The PrognosticsModel subclass, made once ProgPy is imported (it cannot be defined before)."""
    progpy = _progpy()

    class IncipientFaultModel(progpy.PrognosticsModel):
        """One incipient fault of a bgfdi diagnosis: see :mod:`fdi.progpy_bridge`. Parameters
        ``model`` (1-4, eqs. 16-19), ``nominal``, ``failure``, ``fault`` (its name) and ``x0``."""
        inputs: list[str] = []
        states: list[str] = ["P"]
        outputs: list[str] = ["P"]
        events: list[str] = ["failure"]
        is_vectorized = True
        default_parameters = {"process_noise": 0.0, "measurement_noise": 0.0, "model": 2, "nominal": 1.0,
                              "failure": 0.5, "fault": "P", "x0": {"P": 1.0, "b1": 0.0}}

        def __init__(self, **kwargs: Any) -> None:
            k = N_COEFFICIENTS[int(kwargs.get("model", 2))]
            # the states of this instance: P, dP for the second-order models, the coefficients
            self.states = ["P"] + (["dP"] if int(kwargs.get("model", 2)) in (3, 4) else []) + \
                [f"b{i + 1}" for i in range(k)]
            super().__init__(**kwargs)

        def next_state(self, x, u, dt: float):
            m = int(self.parameters["model"])
            p = np.asarray(x["P"], dtype=float)
            out = {s: np.asarray(x[s], dtype=float) for s in self.states}
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                if m == 1:
                    out["P"] = p * np.exp(out["b1"] * dt)
                elif m == 2:
                    den = 1.0 / p - out["b1"] * dt
                    out["P"] = np.where(den > 0, 1.0 / np.where(den > 0, den, 1.0), np.inf)
                else:
                    b = [out[f"b{i + 1}"] for i in range(N_COEFFICIENTS[m])]
                    if m == 3:
                        def acc(pp, vv):
                            return b[0] * vv + pp + b[1]
                    else:
                        def acc(pp, vv):
                            return b[0] * vv * vv + b[1] * pp + b[2]
                    v = np.asarray(x["dP"], dtype=float)
                    k1p, k1v = v, acc(p, v)
                    k2p, k2v = v + dt / 2 * k1v, acc(p + dt / 2 * k1p, v + dt / 2 * k1v)
                    k3p, k3v = v + dt / 2 * k2v, acc(p + dt / 2 * k2p, v + dt / 2 * k2v)
                    k4p, k4v = v + dt * k3v, acc(p + dt * k3p, v + dt * k3v)
                    out["P"] = p + dt / 6 * (k1p + 2 * k2p + 2 * k3p + k4p)
                    out["dP"] = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            return self.StateContainer(out)

        def output(self, x):
            return self.OutputContainer({"P": x["P"]})

        def _down(self) -> bool:
            return self.parameters["failure"] < self.parameters["nominal"]

        def threshold_met(self, x) -> dict:
            p, failure = np.asarray(x["P"], dtype=float), self.parameters["failure"]
            return {"failure": (p <= failure) if self._down() else (p >= failure)}

        def event_state(self, x) -> dict:
            p = np.asarray(x["P"], dtype=float)
            nominal, failure = self.parameters["nominal"], self.parameters["failure"]
            with np.errstate(divide="ignore", invalid="ignore"):
                if math.isinf(nominal):          # a leakage resistance from infinity: by conductance
                    es = 1.0 - failure / p
                else:
                    es = (p - failure) / (nominal - failure)
            return {"failure": np.clip(np.nan_to_num(es, nan=0.0), 0.0, 1.0)}

    return IncipientFaultModel


def degradation_model(fault: Fault | Mapping, nominal: float, failure: float, now: float, **kwargs: Any):
    """A ProgPy model of ``fault`` (a :class:`fdi.results.Fault` or its report dict) with ``x0`` its
    identified state at ``now`` (s, on the data's time axis: usually the last sample, the time
    bgfdi's RUL is given at); ``kwargs`` go to ProgPy (``process_noise`` ...). Predictions start at
    time 0 = ``now``: a predicted time of event is an RUL."""
    f = _fault(fault)
    cls = _model_class()
    x0 = _state_at(f.model, np.asarray([f.b], dtype=float), np.asarray([f.t0], dtype=float), nominal, now)
    m = cls(model=int(f.model), nominal=float(nominal), failure=float(failure), fault=f.name,
            x0={k: float(v[0]) for k, v in x0.items()}, **kwargs)
    m.bgfdi_fault, m.bgfdi_now = f, float(now)
    return m


def _state_at(model_no: int, bs: np.ndarray, t0s: np.ndarray, nominal: float, now: float) -> dict[str, np.ndarray]:
    """P (and dP) at ``now`` of each row of coefficients with its onset, from fdi.profiles."""
    h = 1e-4
    if model_no in (3, 4):
        t = np.array([now - h, now, now + h])
        p = np.stack([incipient(t, t0, nominal, model_no, b[None, :])[0] for b, t0 in zip(bs, t0s)])
        out = {"P": p[:, 1], "dP": np.where(now - h > t0s, (p[:, 2] - p[:, 0]) / (2 * h), 0.0)}
    else:
        out = {"P": np.array([incipient(np.array([now]), t0, nominal, model_no, b[None, :])[0, 0]
                              for b, t0 in zip(bs, t0s)])}
    out.update({f"b{i + 1}": bs[:, i] for i in range(bs.shape[1])})
    return out


def initial_samples(model, n: int = 200, seed: int = 0):
    """``n`` ProgPy state samples (``UnweightedSamples``) of the fault's state at ``now``: each
    coefficient and the onset drawn normal with its 95 % band as +- 1.96 sigma (a band absent: the
    fit's value), P and dP computed from the draw's own profile. Seeded: the same draws each call."""
    progpy = _progpy()
    from progpy.uncertain_data import UnweightedSamples

    f: Fault = model.bgfdi_fault
    rng = np.random.default_rng(seed)
    b = np.asarray(f.b, dtype=float)
    sigma = np.array([(hi - lo) / (2 * Z95) for lo, hi in f.b_band]) if f.b_band else np.zeros_like(b)
    bs = b[None, :] + sigma[None, :] * rng.standard_normal((n, b.size))
    t_sigma = (f.t0_band[1] - f.t0_band[0]) / (2 * Z95) if f.t0_band else 0.0
    t0s = np.minimum(f.t0 + t_sigma * rng.standard_normal(n), model.bgfdi_now)
    x = _state_at(int(f.model), bs, t0s, model.parameters["nominal"], model.bgfdi_now)
    del progpy
    return UnweightedSamples([model.StateContainer({k: float(v[i]) for k, v in x.items()}) for i in range(n)])


def predict_rul(fault: Fault | Mapping, nominal: float, failure: float, now: float, *, n: int = 200,
                dt: float = 0.05, horizon: float = 3600.0, seed: int = 0) -> dict:
    """The RUL distribution at ``now`` by ProgPy's MonteCarlo predictor over :func:`initial_samples`:
    ``median``, ``mean``, ``low``/``high`` (2.5 and 97.5 percentiles), ``samples`` (s, every sample's
    time of event; inf where it does not fail within ``horizon``). ``dt``: the step, the resolution
    of each time of event."""
    _progpy()
    from progpy.predictors import MonteCarlo

    m = degradation_model(fault, nominal, failure, now)
    x0 = initial_samples(m, n, seed)
    with warnings.catch_warnings():      # ProgPy 1.9's own MonteCarlo calls its deprecated SimResult.pop
        warnings.simplefilter("ignore", DeprecationWarning)
        result = MonteCarlo(m).predict(x0, dt=dt, horizon=horizon, save_freq=horizon, events=["failure"])
    toe = np.array([np.inf if s["failure"] is None else float(s["failure"]) for s in result.time_of_event],
                   dtype=float)
    finite = toe[np.isfinite(toe)]
    q = np.percentile(toe, [2.5, 50.0, 97.5]) if finite.size == toe.size else [np.inf] * 3
    return {"name": m.parameters["fault"], "at": float(now), "median": float(np.median(toe)),
            "mean": float(finite.mean()) if finite.size else math.inf, "low": float(q[0]), "high": float(q[2]),
            "samples": toe}


__all__ = ["degradation_model", "initial_samples", "predict_rul", "ProgPyMissing"]
