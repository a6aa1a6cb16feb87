"""Independent simulator of :func:`bondgraph.chains.fault_chain_yaml`: n tanks in series, typed
by hand from the mass balances (Samantaray & Ould Bouamama, Model-based Process Supervision,
ch. 5), never importing ``bondgraph`` or ``fdi``:

    dV_i/dt = q_{i-1} - q_i,   p_i = V_i / CT_i,   q_i = (p_i - p_{i+1}) / Rv_i,   p_{n+1} = 0

with q_0 the pump. The state is the stored volume of each tank: when a capacitance changes, the
volume is continuous and the pressure jumps (bgfdi's convention for storage faults). The system
is linear, dV/dt = A V + e_1 q0(t), integrated by scipy's BDF with A as its sparse Jacobian, piece
by piece between fault onsets, from the equilibrium of the mean pump flow.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.integrate import solve_ivp

from .faults import Fault, breakpoints, noisy

CT, RV, Q_MEAN, NOISE = 1.0e-5, 1.0e6, 1.0e-5, 0.1      # m^3/Pa, Pa*s/m^3, m^3/s, Pa


def pump(t):
    """The pump flow (m^3/s): the model's input expression, written out."""
    return Q_MEAN * (1 + 0.1 * np.sin(0.01 * t))


def simulate(n: int, faults: tuple[Fault, ...] = (), T: float = 300.0, dt: float = 0.5,
             seed: int = 0) -> dict[str, np.ndarray]:
    """Columns t, q0, p1..pn sampled every ``dt`` over [0, T], pressures with 0.1 Pa noise.
    ``faults`` target ``CT<i>`` (abrupt: the capacitance takes ``value`` from ``t0``)."""
    def capacities(t: float) -> np.ndarray:
        c = np.full(n, CT)
        for f in faults:
            c[int(f.target[2:]) - 1] = f.at(t, CT)
        return c

    def matrix(c: np.ndarray) -> sparse.csr_matrix:
        """dV/dt = A V + e_1 q0: A[i, i] = -(1/Rv_{i-1} + 1/Rv_i)/CT_i (first: -1/(Rv CT_1)),
        A[i, i+1] = 1/(Rv CT_{i+1}), A[i+1, i] = 1/(Rv CT_i)."""
        diag = -np.full(n, 2.0 / RV) / c
        diag[0] = -1.0 / (RV * c[0])
        return sparse.diags([diag, 1.0 / (RV * c[1:]), 1.0 / (RV * c[:-1])], [0, 1, -1], format="csr")

    t_out = np.arange(0.0, T + dt / 2, dt)
    v = CT * RV * Q_MEAN * np.arange(n, 0, -1, dtype=float)       # p_i = (n - i + 1) Rv q0
    pressures = np.empty((len(t_out), n))
    cuts = breakpoints(tuple(faults), T)
    for a, b in zip(cuts[:-1], cuts[1:]):
        c = capacities(a)
        A = matrix(c)
        last = b >= T
        idx = np.nonzero((t_out >= a) & ((t_out <= b) if last else (t_out < b)))[0]
        times = np.unique(np.append(t_out[idx], b))
        sol = solve_ivp(lambda t, y: A @ y + np.eye(1, n).ravel() * pump(t), (a, b), v, method="BDF",
                        t_eval=times, jac=A, rtol=1e-10, atol=1e-14, max_step=dt)
        y = sol.y[:, :len(idx)] if len(times) > len(idx) else sol.y
        pressures[idx] = (y / c[:, None]).T
        v = sol.y[:, -1]
    cols = {"t": t_out, "q0": pump(t_out)}
    cols.update({f"p{i + 1}": pressures[:, i] for i in range(n)})
    return noisy(cols, {f"p{i + 1}": NOISE for i in range(n)}, seed)
