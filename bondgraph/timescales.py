"""The model's own time scales: eigenvalues of its linearised state equations.

Every window, settle time, minimum period and integration step of bgfdi should follow the
system it monitors, not a constant in seconds: a DC-DC converter lives in microseconds, a
building in hours. The state equations of the simulator (:func:`bondgraph.simulation.build_system`)
are linearised by finite differences at a few operating points (the model's initial state, and
states drawn around it), in each mode combination asked for; the time constants are 1/|lambda|
of the non-zero eigenvalues (an oscillation of angular frequency w counts as 1/|lambda| too: its
period over 2 pi).

>>> from bondgraph.loader import load_model_text
>>> m = load_model_text('''
... parameters: {R: {value: 100.0, unit: Ohm}, C1: {value: 1.0e-3, unit: F}}
... inputs: {u: {column: u, expr: "1.0", unit: V}}
... elements: {src: {type: MSe, input: u}, res: {type: R, parameter: R}, cap: {type: C, parameter: C1}}
... junctions: {j1: {type: "1"}, j0: {type: "0"}}
... sensors: {v: {type: De, junction: j0, unit: V}}
... bonds: {1: [src, j1], 2: [j1, res], 3: [j1, j0], 4: [j0, cap]}
... ''')
>>> s = time_scales(m)
>>> round(s.fastest, 6), round(s.slowest, 6)
(0.1, 0.1)
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from itertools import product
from typing import Mapping

import numpy as np

from .model import Model

MAX_MODE_COMBINATIONS = 16
POINTS = 7          # operating points per mode: the model's initial state and six drawn around it
GROWTH = 1e-6       # an eigenvalue's real part above this share of the largest |lambda| grows (not a
                    # finite difference's error: every shipped and test model's stays under 1e-9 of it)


@dataclass(frozen=True)
class TimeScales:
    """``fastest`` and ``slowest`` time constants in s (inf when the model has no dynamics or only
    integrators); ``eigenvalues`` of every linearisation, in 1/s; ``notes`` say what could not be
    linearised."""
    fastest: float
    slowest: float
    eigenvalues: tuple[complex, ...] = ()
    notes: tuple[str, ...] = ()
    growing: tuple[tuple[tuple[tuple[str, int], ...], complex], ...] = ()   # (mode, eigenvalue): see growth_notes

    @property
    def known(self) -> bool:
        """Whether any time constant was found."""
        return math.isfinite(self.fastest)


def mode_combinations(model: Model, limit: int = MAX_MODE_COMBINATIONS) -> list[dict[str, int]]:
    """Every combination of the model's mode variables (nominal first), at most ``limit``."""
    names = list(model.modes)
    nominal = {m: model.modes[m].nominal for m in names}
    out = [nominal]
    for values in product((1, 0), repeat=len(names)):
        combo = dict(zip(names, values))
        if combo != nominal:
            out.append(combo)
        if len(out) >= limit:
            break
    return out


def not_linearised(failed: Mapping[str, list[dict]], asked: int) -> list[str]:
    """One note per reason a mode could not be linearised (``failed``: reason -> its modes, of
    ``asked`` modes tried): an ABS's four modes gave the same reason four times."""
    return [f"{'every mode' if len(ms) == asked > 1 else ', '.join(f'mode {m}' if m else 'the model' for m in ms)}: "
            f"not linearised ({why})" for why, ms in failed.items()]


def time_scales(model: Model, modes: list[Mapping[str, int]] | None = None,
                values: Mapping[str, float] | None = None,
                failed: dict[str, list[dict]] | None = None) -> TimeScales:
    """The fastest and slowest time constants of ``model`` over ``modes`` (default: the nominal
    mode only), at its nominal parameter values updated by ``values``. ``failed`` (reason -> modes)
    collects why modes could not be linearised, for a caller that asks mode by mode."""
    from .errors import CausalityError
    from .simulation import SimulationError, _initial_state

    base = {k: float(v) for k, v in model.nominal_by_name().items()}
    base.update(values or {})
    model = _inputs_held(model)
    eigs: list[complex] = []
    failed = {} if failed is None else failed   # why a mode is not linearised -> the modes it keeps out
    growing: list[tuple[tuple[tuple[str, int], ...], complex]] = []
    fastest: list[float] = []
    slowest: list[float] = []
    for mode in modes or [{m: model.modes[m].nominal for m in model.modes}]:
        vals = dict(base, **{k: float(v) for k, v in mode.items()})
        try:
            system, c = _prepared(model, vals)
            x0 = _initial_state(system, model.initial, 0.0, vals)
        except (SimulationError, CausalityError, ValueError, KeyError) as exc:
            failed.setdefault(str(exc), []).append(dict(mode))
            continue
        if not len(x0):
            continue
        fastest_here: list[float] = []
        slowest_here: list[float] = []
        rng = np.random.default_rng(0)
        for k in range(POINTS):
            x = x0 if k == 0 else x0 * (1 + 0.5 * rng.standard_normal(len(x0))) + 1e-3 * rng.standard_normal(len(x0))
            try:
                lam = _eigenvalues(system, c, x)
            except NameError as exc:         # a function the compiled equations lack (besselj)
                failed.setdefault(f"its equations cannot be evaluated: {exc}", []).append(dict(mode))
                break
            if lam is None:
                continue
            eigs += lam
            if k == 0 and lam:              # at the initial state itself: does the plant grow there?
                top = max(lam, key=lambda v: v.real)
                if top.real > GROWTH * max(abs(v) for v in lam):
                    growing.append((tuple(sorted((str(n), int(v)) for n, v in mode.items())), top))
            mags = [abs(v) for v in lam if abs(v) > 1e-12]
            if mags:
                fastest_here.append(1.0 / max(mags))
                slowest_here.append(1.0 / min(mags))
        # the median over a mode's operating points: a point on a switching surface (Coulomb
        # friction at rest, sign(v) differenced across v = 0) gives a spurious near-infinite slope
        # at that point only; then the fastest and slowest over the modes (a converter's LC
        # resonance lives in one switch position only)
        if fastest_here:
            fastest.append(float(np.median(fastest_here)))
            slowest.append(float(np.median(slowest_here)))
    notes = not_linearised(failed, len(modes) if modes else 1)
    if not fastest:
        return TimeScales(math.inf, math.inf, tuple(eigs), tuple(notes), tuple(growing))
    return TimeScales(min(fastest), max(slowest), tuple(eigs), tuple(notes), tuple(growing))


def _prepared(model: Model, vals: Mapping[str, float]):
    """The simulator's state equations at ``vals`` (one mode's) and their parameter-only lines."""
    from .simulation import build_system
    system = build_system(model, vals)
    return system, system.prepare([vals[n] if n in vals else 0.0 for n in system.param_names])


def _eigenvalues(system, c, x) -> list[complex] | None:
    """The finite eigenvalues of the state equations linearised at ``x``; None at a point outside a
    law's domain: a gas spring's (p0/pa)^(1/n) at a perturbed pa < 0 is complex, which Python's math
    refuses with a TypeError (a user's accumulator model: check, calibrate, diagnose and simulate
    died with a traceback). A NameError (a function the compiled equations lack) is the caller's."""
    from .simulation import _jacobian
    try:
        with np.errstate(all="ignore"):
            lam = np.linalg.eigvals(_jacobian(system.f, 0.0, tuple(float(v) for v in x), c))
    except (ArithmeticError, ValueError, TypeError, np.linalg.LinAlgError):
        return None
    return [complex(v) for v in lam if np.isfinite(v)]


VISITED_POINTS = 24    # visited states linearised per mode (visited_fastest)


def visited_fastest(model: Model, modes: list[Mapping[str, int]], states: Mapping[str, np.ndarray],
                    quantile: float = 0.1, seed: int = 0) -> float:
    """The fastest ringing time constant at states a simulation visited (1/|lambda| of eigenvalues
    whose imaginary part is at least :data:`RINGING` of their real part): ``states`` (a state's
    name -> its samples, aligned), linearised at up to VISITED_POINTS of them per mode; per mode the
    ``quantile`` of the points' fastest (a low one: the fast end of what the runs visit, past a
    rare point whose difference quotient is spuriously steep), then the fastest over the modes; inf
    when none rings. A nonlinear law may ring faster away from the initial state than at it: a
    hardening spring k q + k3 q^3 at 3 cm was twice as stiff as :func:`time_scales` read at rest."""
    from .errors import CausalityError
    from .simulation import SimulationError

    base = {k: float(v) for k, v in model.nominal_by_name().items()}
    held = _inputs_held(model)
    size = min((len(v) for v in states.values()), default=0)
    if not size:
        return math.inf
    rng = np.random.default_rng(seed)
    at = rng.choice(size, size=min(VISITED_POINTS, size), replace=False)
    out = math.inf
    for mode in modes:
        vals = dict(base, **{k: float(v) for k, v in mode.items()})
        try:
            system, c = _prepared(held, vals)
        except (SimulationError, CausalityError, ValueError, KeyError):
            continue
        here = []
        for i in at:
            try:
                lam = _eigenvalues(system, c, [float(states[n][i]) if n in states else 0.0 for n in system.states])
            except NameError:
                lam = None
            # ringing modes only: a stiff real pole (an orifice's tiny volume, 1e-8 s on the CyCab)
            # decays at once and leaves the signals on the slow manifold; a ringing one shows in them
            mags = [abs(v) for v in lam or () if abs(v) > 1e-12 and abs(v.imag) > RINGING * abs(v.real)]
            if mags:
                here.append(1.0 / max(mags))
        if here:
            out = min(out, float(np.quantile(here, quantile)))
    return out


RINGING = 0.5       # an eigenvalue whose imaginary part is at least this share of its real part rings


def growth_notes(scales: TimeScales) -> list[str]:
    """What ``check`` says of the modes in which the state equations, linearised at the model's
    initial state, have an eigenvalue with a positive real part: a disturbance there grows instead
    of decaying. A passive plant (springs, masses, capacitors, tanks, resistors of positive values)
    cannot; a storage law whose parameter has the wrong sign can (a gas spring with a negative
    volume: every check passed, and a diagnosis read nominal data as a precharge fault). Some
    plants are unstable (an inverted pendulum): their residuals still hold, so this is a note.

    >>> growth_notes(TimeScales(0.016, 0.016, growing=(((), 61.8 + 0j),)))[0][:70]
    'the state equations grow at the initial state (eigenvalue +61.8 1/s: a'
    """
    out = []
    for mode, lam in scales.growing:
        where = f"in mode {', '.join(f'{n}={v}' for n, v in mode)}, " if mode else ""
        shown = f"{lam.real:+.3g}" + (f" {lam.imag:+.3g}j" if abs(lam.imag) > 1e-12 * abs(lam) else "")
        out.append(f"{where}the state equations grow at the initial state (eigenvalue {shown} 1/s: a disturbance "
                   f"doubles every {math.log(2) / lam.real:.3g} s; a passive plant's decays): a storage law's "
                   f"parameter of the wrong sign (a negative volume, compliance, inertia or resistance) or a sign "
                   f"in a law? (an unstable plant is possible: its residuals still hold)")
    return out


def _inputs_held(model: Model) -> Model:
    """``model`` with each input given by its data column only held at 0 for the linearisation (the
    simulator needs an expression of t), when the model is linear: every element law linear in its
    own variable with constant coefficients, every modulus and source value constant. Its time
    constants then depend on no input. A nonlinear model's may (a conductance e^3 downstream of a
    measured source: 2.1 ms at u = 5, 33 ms at u = 0), so it is returned as it is and stays
    unknown (the rule's 25 samples; calibrate says so). Without this, a linear model whose inputs
    are all measured (the usual case on a plant) had no time constant and the rule's 25 samples
    whatever its pace: an RC filter of 0.1 s sampled at 1 kHz got 25 ms instead of 50 ms."""
    held = [name for name, i in model.inputs.items() if i.expr is None]
    if not held or not _linear(model):
        return model
    import sympy as sp                  # here: the warm diagnosis path imports this module, not sympy
    return replace(model, inputs={**model.inputs, **{n: replace(model.inputs[n], expr=sp.Integer(0)) for n in held}})


def _linear(model: Model) -> bool:
    """Whether every element law is a polynomial of degree at most 1 in its own variable (e, f, p or
    q) with the model's parameters as coefficients, and every modulus and source value a constant
    of the parameters: the state equations are then linear."""
    import sympy as sp

    from .model import LAW_VARIABLES
    constants = set(model.parameters)
    local = set(LAW_VARIABLES.values())
    for e in model.elements.values():
        for law in e.laws.values():
            xs = [x for x in law.free_symbols if x in local]
            if {str(s) for s in law.free_symbols if s not in local} - constants:
                return False
            if xs and not (law.is_polynomial(*xs) and sp.Poly(law, *xs).total_degree() <= 1):
                return False
        for expr in (e.modulus, e.value):
            if expr is not None and {str(s) for s in expr.free_symbols} - constants:
                return False
    return True


STEPS_PER_TIME_CONSTANT = 20


def integration_step(ts: float, fastest: float) -> float:
    """The fixed step of ROS2 for output every ``ts`` s of a model whose fastest time constant is
    ``fastest`` s (not finite: none known): ``min(ts, fastest / 20)``. ROS2 is L-stable, so a
    longer step never diverges, but its error on a mode of time constant tau is O((h/tau)^3) per
    step: at h = tau/20 about 2e-5 per step, 4e-4 over one time constant, below any sensor's
    noise. The step also lands on every output sample (at most ``ts``). On the CyCab (tau =
    20.2 ms, 100 Hz) the step is 1.01 ms, which the output grid makes exactly 1 ms: the step it
    always had; a 10 us converter sampled at 1 kHz gets 0.5 us, not 1 ms, and a thermal process
    sampled at 1 Hz steps once a sample, not 1000 times.

    >>> [float(f"{integration_step(ts, tau):.3g}") for ts, tau in ((0.01, 0.0202), (1.0, 3600.0), (1e-3, 1e-5))]
    [0.00101, 1.0, 5e-07]
    """
    if not math.isfinite(fastest) or fastest <= 0:
        return ts
    return min(ts, fastest / STEPS_PER_TIME_CONSTANT)


_CACHE: dict[int, tuple[Model, TimeScales]] = {}


def model_time_scales(model: Model) -> TimeScales:
    """The model's time constants over its mode combinations: the fastest mode's fastest and the
    slowest mode's slowest (each mode's own median over operating points), computed once per model
    object (the simulator, the scenario checks and the diagnosis all ask)."""
    hit = _CACHE.get(id(model))
    if hit is not None and hit[0] is model:
        return hit[1]
    failed: dict[str, list[dict]] = {}
    modes = list(mode_combinations(model))
    per_mode = [time_scales(model, [mode], failed=failed) for mode in modes]
    known = [s for s in per_mode if s.known] or per_mode
    scales = TimeScales(min(s.fastest for s in known), max(s.slowest for s in known),
                        tuple(v for s in per_mode for v in s.eigenvalues), tuple(not_linearised(failed, len(modes))),
                        tuple(g for s in per_mode for g in s.growing))
    if len(_CACHE) > 32:
        _CACHE.clear()
    _CACHE[id(model)] = (model, scales)
    return scales


def model_integration_step(model: Model, ts: float) -> float:
    """:func:`integration_step` with the model's fastest time constant over its modes."""
    return integration_step(ts, model_time_scales(model).fastest)
