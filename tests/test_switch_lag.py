"""A command column a few samples ahead of the plant's switching (a logger's lag) sets a residual's
threshold by the transient at each switch: a user trial's PV disconnect gave ARR1 a threshold 3.4
times its peak elsewhere, and a 10 % current gain then went undetected, with nothing said.
`calibrate` now names a peak that lies at a commanded switch and stands SWITCH_PEAK times above the
residual's peak elsewhere. Designed: a braked shaft, J w' = tau - b w - brk Rb w, integrated by
scipy with the brake applied from 4 to 6 s; in one set of runs the brake acts 3 samples (30 ms)
after its command, in the other with it."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from fdi.calibrate import calibrate

from .test_held_still import SHAFT

J, B, RB = 0.5, 0.1, 1.0     # braked: a time constant of 0.45 s, 45 samples
MODEL = SHAFT.replace("KIND", "0c").replace("Rb: {value: 100.0", "Rb: {value: 1.0").replace("w: {type: Df, junction: shaft, column: w, unit: rad/s}",
                                              "w: {type: Df, junction: shaft, column: w, unit: rad/s, noise: 1.0e-3}")


def _run(path, seed: int, lag: float) -> None:
    t = np.arange(0.0, 10.0, 0.01)
    tau = lambda s: 2.0 + 0.5 * np.sin(1.3 * s)          # noqa: E731
    braked = lambda s: 4.0 + lag <= s < 6.0 + lag         # noqa: E731
    edges = [0.0, 4.0 + lag, 6.0 + lag, t[-1]]
    w, w0 = np.empty(t.size), 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        on = RB if braked((a + b) / 2) else 0.0
        m = (t >= a) & (t <= b)
        sol = solve_ivp(lambda s, x: [(tau(s) - B * x[0] - on * x[0]) / J], (a, b), [w0], t_eval=t[m],
                        rtol=1e-10, atol=1e-12, max_step=0.01)
        w[m], w0 = sol.y[0], sol.y[0, -1]
    rng = np.random.default_rng(seed)
    command = ((t >= 4.0) & (t < 6.0)).astype(float)
    rows = np.column_stack([t, tau(t), command, w + 1e-3 * rng.standard_normal(t.size)])
    np.savetxt(path, rows, delimiter=",", header="t,tau,brk,w", comments="", fmt="%.10g")


def test_a_threshold_set_at_a_lagging_switch_is_named(tmp_path):
    model = tmp_path / "shaft.yaml"
    model.write_text(MODEL + "diagnosis: {derivative_window: 0.1}\n", encoding="utf-8")
    for lag, named in ((0.03, True), (0.0, False)):
        runs = []
        for k in (1, 2):
            p = tmp_path / f"run{k}_{lag}.csv"
            _run(p, k, lag)
            runs.append(str(p))
        c = calibrate(str(model), runs)
        if named:
            (name, run, at, peak, away), = c.at_switches
            assert name == "ARR1" and peak > 3 * away
            assert min(abs(at - 4.0), abs(at - 6.0)) < 0.1          # at a commanded switch
            assert calibrate(str(model), runs, quantile=0.99).at_switches == ()   # a quantile's is not the peak's
        else:
            assert c.at_switches == ()
