"""A storage water heater with its electrical side, simulated apart from bgfdi (a user trial's
plant, session 42, reduced): C dT/dt = s U^2/Rh - G (T - Tamb) - qm cp (T - Tin), the current
I = s U/Rh, a thermostat with hysteresis on the true temperature (on below 55 C, off above 60 C)
whose contact s is logged. The model is tests/data/water_heater_relay.yaml."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

C, CP, RH, G = 150 * 4186.0, 4186.0, 17.6, 2.0
T_ON, T_OFF = 273.15 + 55, 273.15 + 60
HEAD = ["t", "U", "I", "s", "Tamb", "Tin", "qm", "T"]


def U(t):
    return 230 + 1.5 * np.sin(2 * np.pi * t / 3700)


def simulate(t_end: float, draws: list[tuple[float, float, float]], element: tuple[float, float] | None = None,
             seed: int = 0, T0: float = 331.0, s0: int = 0, relay: tuple[float, int] | None = None) -> np.ndarray:
    """Rows of HEAD at 1 Hz. ``draws``: (start, duration, kg/s); ``element``: (onset, factor on Rh);
    ``relay``: (onset, 0 stuck open or 1 welded closed): the contact then ignores the thermostat,
    whose command s is still logged."""

    def contact(t, s):
        return relay[1] if relay and t >= relay[0] else s
    def qm(t):
        return next((q for a, d, q in draws if a <= t < a + d), 0.0)

    def rh(t):
        return RH * element[1] if element and t >= element[0] else RH
    breaks = sorted({0.0, t_end} | {float(x) for a, d, _ in draws for x in (a, a + d) if x < t_end}
                    | ({float(element[0])} if element else set()) | ({float(relay[0])} if relay else set()))
    segments, t, T, s = [], 0.0, T0, s0
    while t < t_end - 1e-9:
        stop = next(b for b in breaks if b > t + 1e-9)
        q = qm(t + 1e-6)

        def rhs(tt, y, s=s, q=q):
            return [(contact(tt, s) * U(tt) ** 2 / rh(tt) - G * (y[0] - 293.15) - q * CP * (y[0] - 284.15)) / C]

        def switch(tt, y, s=s):
            return y[0] - (T_OFF if s else T_ON)
        switch.terminal, switch.direction = True, 1 if s else -1
        sol = solve_ivp(rhs, (t, stop), [T], method="DOP853", rtol=1e-10, atol=1e-9, events=switch,
                        dense_output=True, max_step=30)
        segments.append((t, sol.t[-1], s, sol.sol))
        t, T = sol.t[-1], sol.y[0, -1]
        if sol.status == 1:
            s = 1 - s
    grid = np.arange(0.0, t_end + 1e-9, 1.0)
    T_true, s_of = np.empty_like(grid), np.empty_like(grid)
    for i, tt in enumerate(grid):
        a, b, si, f = next(x for x in segments if x[0] <= tt <= x[1])
        T_true[i], s_of[i] = f(tt)[0], si
    rng = np.random.default_rng(seed)
    n = grid.size
    u = U(grid)
    current = np.array([contact(x, si) for x, si in zip(grid, s_of)]) * u / np.array([rh(x) for x in grid])
    return np.column_stack([grid, u + rng.normal(0, 0.5, n), current + rng.normal(0, 0.02, n), s_of,
                            293.15 + rng.normal(0, 0.1, n), 284.15 + rng.normal(0, 0.1, n),
                            np.array([qm(x) for x in grid]) * (1 + rng.normal(0, 0.01, n)),
                            T_true + rng.normal(0, 0.05, n)])
