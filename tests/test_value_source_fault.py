"""A fault on a source with a fixed value (Sf/Se with ``value:``, no input column): its efficiency
factor beta_<name> is a parameter of the residuals, and identification must move it. Reference: the
circuits typed by hand and integrated by scipy (never importing bondgraph or fdi)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from .independent import measurements, thresholds

I0, V0, R, C, RL, TS, T, T0 = 0.05, 5.0, 100.0, 1.0e-3, 200.0, 1.0e-3, 2.0, 1.0

MODELS = {
    # a current source I0 into C || R:  beta I0 - C dv/dt - v/R = 0
    "Sf": """name: sf_rc
parameters: {I0: {value: 0.05, unit: A}, C: {value: 1.0e-3, unit: F}, R: {value: 100.0, unit: Ohm}}
data: {columns: [t, v], sampling_time: 0.001}
elements: {src: {type: Sf, value: I0}, cap: {type: C, parameter: C}, res: {type: R, parameter: R}}
junctions: {j0: {type: "0"}}
sensors: {v: {type: De, junction: j0, column: v, unit: V, noise: 1.0e-3}}
bonds: {1: [src, j0], 2: [j0, cap], 3: [j0, res]}
faults: {R: {kind: parametric, parameters: [R]}, src: {kind: source, source: src}}
diagnosis: {waiting_time: 0.3, derivative_window: 0.05, samples: 800}
""",
    # a voltage source V0 through R into C || RL:  (beta V0 - v)/R - C dv/dt - v/RL = 0
    "Se": """name: se_rc
parameters: {V0: {value: 5.0, unit: V}, R: {value: 100.0, unit: Ohm}, C: {value: 1.0e-3, unit: F},
             RL: {value: 200.0, unit: Ohm}}
data: {columns: [t, v], sampling_time: 0.001}
elements: {src: {type: Se, value: V0}, res: {type: R, parameter: R}, cap: {type: C, parameter: C},
           load: {type: R, parameter: RL}}
junctions: {j1: {type: "1"}, j0: {type: "0"}}
sensors: {v: {type: De, junction: j0, column: v, unit: V, noise: 1.0e-3}}
bonds: {1: [src, j1], 2: [j1, res], 3: [j1, j0], 4: [j0, cap], 5: [j0, load]}
faults: {RL: {kind: parametric, parameters: [RL]}, src: {kind: source, source: src}}
diagnosis: {waiting_time: 0.3, derivative_window: 0.05, samples: 800}
""",
}


def simulator(kind: str):
    def simulate(seed: int, t0: float = np.inf, factor: float = 1.0, which: str = "src") -> dict:
        beta = lambda s: factor if s >= t0 else 1.0
        if kind == "Sf":
            rhs, v0 = (lambda s, x: [(beta(s) * I0 - x[0] / R) / C]), I0 * R
        else:
            rhs, v0 = (lambda s, x: [((beta(s) * V0 - x[0]) / R - x[0] / RL) / C]), V0 * RL / (R + RL)
        t = np.arange(0.0, T, TS)
        sol = solve_ivp(rhs, (0.0, T), [v0], t_eval=t, max_step=1e-4, rtol=1e-10, atol=1e-12)
        return {"t": t, "v": sol.y[0] + np.random.default_rng(seed).normal(0.0, 1e-3, t.size)}
    return simulate


@pytest.mark.parametrize("kind", ["Sf", "Se"])
def test_a_fixed_value_source_fault_moves_the_cost_and_is_identified(kind, tmp_path):
    from fdi.api import Options, diagnose
    from fdi.monitor import compiled
    from fdi.objective import Objective, window
    model = tmp_path / f"{kind}.yaml"
    model.write_text(MODELS[kind])
    simulate = simulator(kind)
    th = thresholds(str(model), simulate)
    meas = measurements(simulate, "loss", 7, t0=T0, factor=0.7)
    # the objective: the efficiency factor at 1, 0.7 (the truth) and 0.3 gives three different costs
    c, _ = compiled(str(model)).scaled(meas.ts)
    from fdi.data import signals_from_data
    win = window(meas.t, signals_from_data(c.model, meas), T0 - 0.1, c.config.samples, c.config.derivative_window)
    obj = Objective(c.model, c.residuals, win, ("src",), 1.0 / np.array([th[r.name] for r in c.residuals]),
                    c.config.derivative_window, config=c.config)
    rows = [obj.encode([{"name": "src", "type": "abrupt", "value": b, "t0": T0}]) for b in (1.0, 0.7, 0.3)]
    cost = obj(np.vstack([r[0] for r in rows]), np.vstack([r[1] for r in rows]))
    assert cost[1] < 0.3 * min(cost[0], cost[2])
    # end to end: the source fault, abrupt, at 0.7 of its value, from T0
    report = diagnose(str(model), meas, Options(workers=1, seed=0, thresholds=th)).to_dict()
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("src", "abrupt")
    assert found["value"] == pytest.approx(0.7, abs=0.02)
    assert found["t0"] == pytest.approx(T0, abs=0.02)
