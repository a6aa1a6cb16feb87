"""An independent reference plant of the CyCab electro-hydraulic steering rig (``"plant": "cycab"``).

bgfdi's own simulator integrates the diagnostic bond graph; a suite simulated by it grades bgfdi
against itself. This module is a second simulator of the rig, written from the physics of Yu &
Wang (2014), eqs. (1)-(13), and the substitute parameter table of the reference data
(models/data/cycab/README.md), with scipy's ``solve_ivp``. It imports neither ``bondgraph`` nor
bgfdi's simulator and reads no model file: its constants are copied in below. As a real rig, it
has more physics than the diagnostic model:

- a **current-driven DC motor** whose driver delivers i = a1·k1·u_in only while the voltage it
  needs, R1·i + k2·ω_motor, stays within the **48 V supply** (else the current the supply can push
  against the back-emf); a burnt driver (a1 = 0) passes no current;
- gear k3, belt k4 (a rigid belt: motor, gear and pump are one body; a **broken belt**, a2 = 0,
  leaves the motor unloaded and the pump rotor on its own, held by its friction and the oil);
- pump k5 and a double-acting cylinder of area A with **finite oil stiffness** (effective bulk
  modulus BULK over the chamber volume V_CHAMBER each side: dΔp/dt = (2·BULK/V_CHAMBER)·(net flow));
  the rigid-oil constraint of the diagnostic model is its stiff limit;
- internal leakage Q = sign(Δp)·√|Δp|/R4 (eq. 1), with a **laminar** core below P_LAMINAR
  (Q = Δp/(R4·√(|Δp| + P_LAMINAR))), where the orifice law's infinite slope at Δp = 0 is no physics;
- steering linkage F1(θ2) = 1/(r_a·cos(β + θ2)) and Ackermann geometry F2(θ2), the wheels' inertia
  J3 seen through F2 (the term J3·F2·F2'·θ̇2² included);
- **smooth friction** everywhere: kf·ω + Fu·tanh(ω/V_SLIP) on the motor, the pump and the tyres
  (the R5 fault multiplies kf5 and Fu5);
- **sensors**: θ1 an incremental encoder (10 000 counts/rev), θ2 a 13-bit absolute encoder (both
  floor to their count), p1/p2 transducers at tank pressure 1e5 Pa on the low side
  (p1 = 1e5 + max(Δp, 0), p2 = 1e5 + max(−Δp, 0)) with 2 kPa noise each and a 12-bit ADC over
  40 bar (rounded and clipped to its range). A sensor fault multiplies the measurement by β(t).

Faults follow the scenario format (fdi/app/scenario.py): targets R4, R5, beta_theta1,
beta_theta2, beta_dp, a1, a2; types abrupt (eq. 14), intermittent (eq. 15: the faulty value
during the first half of each period), incipient models 1-4 (eqs. 16-19, P(t0) = nominal and,
for 18 and 19, dP/dt(t0) = 0; coded here from the equations, not from ``fdi.profiles``) and mode
(a1, a2 set to 0). Columns ``t,u_in,theta1,theta2,p1,p2``; one seed gives one run.

The integration is LSODA, piecewise between the instants where a parameter jumps (abrupt and
mode onsets, intermittent switches): a 70 s run takes about a second.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Protocol

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

# ---------------------------------------------------------------- rig constants (SI), copied in
K1, K2, R1, J1, KF2, FU2 = 5.0, 0.06, 1.2, 2.0e-5, 5.0e-6, 2.0e-3
K3, K4, J2, KF3, FU3, K5 = 0.02, 5.0, 2.0e-4, 5.0e-3, 0.02, 5.0e-6
A, R_A, L, W, J3, KF5, FU5 = 2.5e-3, 0.12, 1.20, 1.00, 0.5, 300.0, 3.0
BETA_K = math.atan(W / (2 * L))          # the Ackermann angle beta = atan(w / 2L)

# ---------------------------------------------------------------- the plant's extra physics
V_SUPPLY = 48.0            # V, the driver's supply
BULK = 1.0e9               # Pa, effective bulk modulus of the oil with hoses
V_CHAMBER = 2.0e-4         # m^3, oil volume on each side of the piston (chamber and hose)
C_OIL = V_CHAMBER / (2 * BULK)   # m^3/Pa, the compliance of the pressure difference
P_LAMINAR = 100.0          # Pa, below this the leak's flow is laminar (linear in dp)
V_SLIP = 1.0e-3            # rad/s, the velocity scale of the smooth Coulomb friction

RTOL, ATOL_SCALE, MAX_STEP = 1e-7, 1.0, 0.05   # LSODA: checked against 1e-10 and 0.005 s (tests)

# ---------------------------------------------------------------- sensors
P_TANK = 1.0e5                       # Pa, the low side's pressure
THETA1_STEP = 2 * math.pi / 10_000   # rad per count of the incremental encoder
THETA2_STEP = 2 * math.pi / 2 ** 13  # rad per code of the 13-bit absolute encoder
P_NOISE = 2000.0                     # Pa, each transducer's noise (standard deviation)
P_STEP = 4.0e6 / 2 ** 12             # Pa, 12-bit ADC over 40 bar
P_FULL = (2 ** 12 - 1) * P_STEP      # Pa, the ADC's highest code

NOMINAL = {"R4": math.inf, "R5": 1.0, "beta_theta1": 1.0, "beta_theta2": 1.0, "beta_dp": 1.0, "a1": 1.0, "a2": 1.0}
SENSORS = {"beta_theta1": "theta1", "beta_theta2": "theta2", "beta_dp": "dp"}
COLUMNS = ("t", "u_in", "theta1", "theta2", "p1", "p2")


class PlantError(ValueError):
    """A fault the rig does not have (a target or type outside the CyCab's)."""


class Fault(Protocol):
    """What the plant reads of a fault event (fdi.app.scenario.FaultEvent has these fields)."""
    target: str
    type: str
    t0: float
    value: float | None
    period: float | None
    model: int | None
    b: tuple[float, ...]


@dataclass(frozen=True)
class Event:
    """A fault event of the rig (the scenario format's fields)."""
    target: str
    type: str
    t0: float
    value: float | None = None
    period: float | None = None
    model: int | None = None
    b: tuple[float, ...] = ()
    failure: float | None = None


@dataclass(frozen=True)
class Trajectory:
    """The rig's true states at the sample times (before the sensors), and its parameters."""
    t: np.ndarray
    u: np.ndarray
    theta1: np.ndarray      # rad, gear output shaft
    omega1: np.ndarray      # rad/s
    omega_p: np.ndarray     # rad/s, pump rotor
    theta2: np.ndarray      # rad, steering angle
    omega2: np.ndarray      # rad/s
    dp: np.ndarray          # Pa, p1 - p2
    leak: np.ndarray        # m^3/s, the internal leakage flow
    current: np.ndarray     # A, the motor current the driver delivers


def command(t):
    """The command voltage of the current amplifier (paper eq. 32), V."""
    return 0.17 * (5 * np.sin(2 * t) + 0.5 * np.sin(t) + 0.2 * np.sin(0.5 * t) + np.sin(2.5 * t))


def f2(theta2: float) -> float:
    """Ackermann geometry: wheel speed over steering rate."""
    tn = math.tan(theta2)
    d = (L + W / 2 * tn) ** 2 + L ** 2 * tn ** 2
    return L ** 2 * (1 + tn ** 2) / d


def df2(theta2: float) -> float:
    """dF2/dθ2, by the chain rule through tan θ2."""
    tn = math.tan(theta2)
    d = (L + W / 2 * tn) ** 2 + L ** 2 * tn ** 2
    dd = 2 * (L + W / 2 * tn) * (W / 2) + 2 * L ** 2 * tn
    return L ** 2 * (2 * tn * d - (1 + tn ** 2) * dd) / d ** 2 * (1 + tn ** 2)


# ---------------------------------------------------------------- fault profiles P(t), eqs. (14)-(19)

def _second_order(p0: float, acc, horizon: float):
    """P(τ) of d²P/dτ² = acc(P, dP/dτ) with P(0) = p0, dP/dτ(0) = 0, as a dense solution to ``horizon``
    (None past a blow-up: the profile is then infinite there)."""
    def rhs(_, y):
        return [y[1], acc(y[0], y[1])]

    def blow(_, y):
        return 1e12 - abs(y[0]) * 1e-3 if math.isfinite(y[0]) else -1.0
    blow.terminal = True
    sol = solve_ivp(rhs, (0.0, max(horizon, 1e-9)), [p0, 0.0], method="DOP853", dense_output=True,
                    rtol=1e-10, atol=1e-12 * max(1.0, abs(p0)), events=blow)
    return sol.sol, float(sol.t[-1])


def profile_function(e: Fault, horizon: float):
    """P(t) of one fault (vectorised over t), from its nominal value (R4: infinite; R5 and the
    sensors' efficiency factors: 1; modes: 1)."""
    p0 = NOMINAL[e.target]
    t0 = float(e.t0)
    if e.type in ("abrupt", "mode"):
        v = 0.0 if e.type == "mode" and e.value is None else float(e.value)
        return lambda t: np.where(np.asarray(t) >= t0, v, p0)
    if e.type == "intermittent":
        v, period = float(e.value), float(e.period)

        def inter(t):
            t = np.asarray(t, dtype=float)
            k = np.floor(2 * (t - t0) / period + 1e-9)
            return np.where((t >= t0) & (k % 2 == 0), v, p0)
        return inter
    if e.type != "incipient":
        raise PlantError(f"fault type '{e.type}' (use abrupt, intermittent, incipient, mode)")
    b = [float(x) for x in e.b]
    if e.model == 1:                                    # (16) dP/dt = b1 P
        return lambda t: np.where(np.asarray(t) >= t0, p0 * np.exp(b[0] * np.maximum(np.asarray(t) - t0, 0)), p0)
    if e.model == 2:                                    # (17) dP/dt = b2 P^2: 1/P = 1/P0 - b2 tau
        def inverse(t):
            tau = np.maximum(np.asarray(t, dtype=float) - t0, 0.0)
            den = (0.0 if math.isinf(p0) else 1.0 / p0) - b[0] * tau
            with np.errstate(divide="ignore"):
                p = np.where(den > 0, 1.0 / np.where(den > 0, den, 1.0), math.inf)
            return np.where(np.asarray(t) > t0, p, p0)
        return inverse
    if math.isinf(p0):                                  # (18), (19) never leave an infinite P0
        return lambda t: np.full(np.shape(t), p0)
    if e.model == 3:                                    # (18) P'' = b3 P' + P + b4
        sol, end = _second_order(p0, lambda p, v: b[0] * v + p + b[1], horizon - t0)
    elif e.model == 4:                                  # (19) P'' = b5 P'^2 + b6 P + b7
        sol, end = _second_order(p0, lambda p, v: b[0] * v * v + b[1] * p + b[2], horizon - t0)
    else:
        raise PlantError(f"degradation model {e.model} (use 1-4: eqs. 16-19)")

    def second(t):
        t = np.asarray(t, dtype=float)
        tau = np.clip(t - t0, 0.0, end)
        p = np.asarray(sol(np.atleast_1d(tau).ravel())[0]).reshape(np.shape(t))
        return np.where(t < t0, p0, np.where(t - t0 > end, math.inf, p))
    return second


def end_of_life(e: Fault, failure: float, horizon: float = 1.0e4) -> float:
    """The first time the fault's profile reaches ``failure`` (inf if never before ``horizon``)."""
    if e.type != "incipient":
        return math.inf
    p = profile_function(e, e.t0 + horizon)
    p0 = NOMINAL[e.target]
    side = np.sign(p0 - failure)
    grid = e.t0 + np.concatenate([np.linspace(0, 10, 2001)[1:], np.linspace(10, horizon, 20001)[1:]])
    vals = p(grid)
    crossed = np.flatnonzero(np.sign(vals - failure) != side)
    if not crossed.size:
        return math.inf
    k = crossed[0]
    lo = e.t0 if k == 0 else grid[k - 1]
    if not math.isfinite(float(p(np.array([grid[k]]))[0])):
        return float(grid[k])
    return float(brentq(lambda x: float(p(np.array([x]))[0]) - failure, lo, grid[k], xtol=1e-9))


# ---------------------------------------------------------------- the rig's dynamics

def _rhs(t, y, r4_of, r5_of, a1: float, a2: float):
    th1, w1, wp, th2, w2, dp = y
    u = 0.17 * (5 * math.sin(2 * t) + 0.5 * math.sin(t) + 0.2 * math.sin(0.5 * t) + math.sin(2.5 * t))
    g4 = r4_of(t)                              # leak conductance 1/R4
    m5 = r5_of(t)
    wm = w1 / K3                               # motor speed
    if a1:
        emf = K2 * wm
        i = min(max(K1 * u, (-V_SUPPLY - emf) / R1), (V_SUPPLY - emf) / R1)
    else:
        i = 0.0
    motor = (K2 * i - KF2 * wm - FU2 * math.tanh(wm / V_SLIP)) / K3          # torque on the gear output shaft
    pump_load = KF3 * wp + FU3 * math.tanh(wp / V_SLIP) + K5 * dp             # torque the pump rotor needs
    if a2:
        dw1 = (motor - K4 * pump_load) / (J1 / K3 ** 2 + K4 ** 2 * J2)
        dwp = K4 * dw1
        wp = K4 * w1
    else:
        dw1 = motor / (J1 / K3 ** 2)
        dwp = -pump_load / J2
    c = math.cos(BETA_K + th2)
    leak = g4 * dp / math.sqrt(abs(dp) + P_LAMINAR) if g4 else 0.0
    ddp = (K5 * wp - leak - A * R_A * c * w2) / C_OIL
    fq, dfq = f2(th2), df2(th2)
    ww = fq * w2                                                              # wheel speed
    tyre = m5 * (KF5 * ww + FU5 * math.tanh(ww / V_SLIP))
    dw2 = (A * R_A * c * dp - fq * (J3 * dfq * w2 * w2 + tyre)) / (J3 * fq * fq)
    return [w1, dw1, dwp, w2, dw2, ddp]


def _pieces(faults: list[Fault], T: float) -> list[float]:
    """The instants where a parameter of the dynamics jumps (abrupt and mode onsets, intermittent switches)."""
    out = {0.0, T}
    for e in faults:
        if e.target not in ("R4", "R5", "a1", "a2") or e.type == "incipient":
            continue
        out.add(float(e.t0))
        if e.type == "intermittent":
            k = 1
            while e.t0 + k * e.period / 2 < T:
                out.add(e.t0 + k * e.period / 2)
                k += 1
    return sorted(x for x in out if 0 <= x <= T)


def check_faults(faults: Iterable[Fault]) -> list[Fault]:
    faults = list(faults)
    for e in faults:
        if e.target not in NOMINAL:
            raise PlantError(f"the CyCab plant has no fault '{e.target}' (use {', '.join(NOMINAL)})")
        if (e.type == "mode") != (e.target in ("a1", "a2")):
            raise PlantError(f"fault '{e.target}': type '{e.type}' does not fit (modes a1, a2 take type mode)")
    return faults


def trajectory(T: float = 60.0, fs: float = 100.0, faults: Iterable[Fault] = (), theta2_0: float = -0.15,
               theta1_0: float = 0.0) -> Trajectory:
    """The rig's true response to the command over [0, T], sampled at fs (no sensors)."""
    faults = check_faults(faults)
    n = int(round(T * fs))
    ts = np.arange(n + 1) / fs
    by = {e.target: e for e in faults}           # one fault per target (the scenario format's rule)
    fns = {name: profile_function(e, T) for name, e in by.items()}

    def scalar(name: str):
        if name not in fns:
            v = NOMINAL[name]
            return lambda t: v
        fn = fns[name]
        return lambda t: float(fn(np.array([t]))[0])
    r4 = scalar("R4")
    r5 = scalar("R5")

    def conductance(r):
        return lambda t: (0.0 if math.isinf(x := r(t)) else 1.0 / x)
    y = np.array([theta1_0, 0.0, 0.0, theta2_0, 0.0, 0.0])
    out = np.empty((6, n + 1))
    cuts = _pieces(faults, T)
    atol = np.array([1e-8, 1e-6, 1e-5, 1e-9, 1e-7, 1e-1])
    for a, b in zip(cuts[:-1], cuts[1:]):
        mid = (a + b) / 2
        a1, a2 = (float(fns[m](np.array([mid]))[0]) if m in fns else 1.0 for m in ("a1", "a2"))
        r4p = conductance(r4) if "R4" in by and by["R4"].type == "incipient" else (lambda g: (lambda t: g))(
            conductance(r4)(mid))
        r5p = r5 if "R5" in by and by["R5"].type == "incipient" else (lambda m: (lambda t: m))(r5(mid))
        if a2:
            y[2] = K4 * y[1]                     # a rigid belt: the pump turns with the gear shaft
        inside = np.flatnonzero((ts >= a) & ((ts < b) if b < T else (ts <= b)))
        t_eval = ts[inside] if inside.size and ts[inside[-1]] == b else np.append(ts[inside], b)
        try:
            sol = solve_ivp(_rhs, (a, b), y, method="LSODA", t_eval=t_eval, args=(r4p, r5p, a1, a2),
                            rtol=RTOL, atol=atol * ATOL_SCALE, max_step=MAX_STEP)
        except (ArithmeticError, ValueError) as exc:       # a profile gone infinite, a state gone NaN
            raise PlantError(f"the integration failed between t = {a:g} and {b:g} s ({exc}); "
                             "check the fault values") from None
        if not sol.success or not np.all(np.isfinite(sol.y)):
            raise PlantError(f"the integration failed at t = {sol.t[-1] if sol.t.size else a:g} s: {sol.message}")
        out[:, inside] = sol.y[:, :inside.size]
        y = sol.y[:, -1].copy()
    a2s = fns["a2"](ts) if "a2" in fns else np.ones_like(ts)
    out[2] = np.where(a2s > 0, K4 * out[1], out[2])
    g = np.array([0.0 if math.isinf(r) else 1.0 / r for r in (fns["R4"](ts) if "R4" in fns else np.full(ts.shape, math.inf))])
    leak = g * out[5] / np.sqrt(np.abs(out[5]) + P_LAMINAR)
    a1s = fns["a1"](ts) if "a1" in fns else np.ones_like(ts)
    u = command(ts)
    emf = K2 * out[1] / K3
    current = np.where(a1s > 0, np.clip(K1 * u, (-V_SUPPLY - emf) / R1, (V_SUPPLY - emf) / R1), 0.0)
    return Trajectory(ts, u, out[0], out[1], out[2], out[3], out[4], out[5], leak, current)


def measure(traj: Trajectory, faults: Iterable[Fault] = (), seed: int = 0, noise: dict | None = None,
            resolution: dict | None = None) -> dict[str, np.ndarray]:
    """The sensors' readings of a trajectory: columns t, u_in, theta1, theta2, p1, p2 (SI).
    ``noise`` / ``resolution`` by column override the transducers' 2 kPa and the ADC's step."""
    faults = check_faults(faults)
    noise, resolution = dict(noise or {}), dict(resolution or {})
    t = traj.t
    beta = {s: np.ones_like(t) for s in SENSORS.values()}
    for e in faults:
        if e.target in SENSORS:
            beta[SENSORS[e.target]] = profile_function(e, float(t[-1]))(t)
    rng = np.random.default_rng(seed)

    def quantised(x, col, step, how):
        q = resolution.get(col, step)
        return how(x / q) * q if q else x
    theta1 = quantised(beta["theta1"] * traj.theta1, "theta1", THETA1_STEP, np.floor)
    theta2 = quantised(beta["theta2"] * traj.theta2, "theta2", THETA2_STEP, np.floor)
    dp = beta["dp"] * traj.dp
    cols = {"t": t, "u_in": traj.u, "theta1": theta1, "theta2": theta2}
    for col, side in (("p1", np.maximum(dp, 0.0)), ("p2", np.maximum(-dp, 0.0))):
        p = P_TANK + side + noise.get(col, P_NOISE) * rng.standard_normal(t.shape)
        cols[col] = np.clip(quantised(p, col, P_STEP, np.round), 0.0, P_FULL)
    return cols


def simulate(T: float = 60.0, fs: float = 100.0, faults: Iterable[Fault] = (), seed: int = 0,
             theta2_0: float = -0.15, theta1_0: float = 0.0, noise: dict | None = None,
             resolution: dict | None = None) -> dict[str, np.ndarray]:
    """One run of the rig: the data columns t, u_in, theta1, theta2, p1, p2."""
    faults = check_faults(faults)
    return measure(trajectory(T, fs, faults, theta2_0, theta1_0), faults, seed, noise, resolution)


def run_scenario(scenario) -> dict[str, np.ndarray]:
    """A parsed scenario (fdi.app.scenario.Scenario: T, fs, seed, initial, faults, noise, resolution)
    run on the rig."""
    init = dict(scenario.initial)
    unknown = set(init) - {"theta1", "theta2"}
    if unknown:
        raise PlantError(f"the CyCab plant sets only theta1_0 and theta2_0, not {', '.join(sorted(unknown))}")
    return simulate(scenario.T, scenario.fs, scenario.faults, scenario.seed, init.get("theta2", -0.15),
                    init.get("theta1", 0.0), scenario.noise, scenario.resolution)
