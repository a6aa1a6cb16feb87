"""A law that leaves its domain on every sample of a record (a user trial's elevator: a rope damper
written c f sqrt(f - 1000), whose velocity never reaches 1000 m/s) made its residual NaN
everywhere: `diagnose` read it as silent, isolated on the others and reported a wrong fault with
exit 0, and `calibrate` blamed the derivative window. Both now refuse the record in one line that
names the residual and the law. The data: an RC circuit with a load, integrated by scipy from
Kirchhoff's laws (R i = u - v, C dv/dt = i - v / RL), written apart from bgfdi."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fdi.app.cli import main

R, C, RL = 100.0, 1.0e-3, 200.0
MODEL = ((Path(__file__).parent / "data" / "rc_two_sensors.yaml").read_text(encoding="utf-8")
         + "thresholds: {ARR1: 0.05, ARR2: 0.02}\n")


def _record(path: Path, seed: int) -> None:
    t = np.arange(0.0, 2.0, 1e-3)
    u = lambda s: 5 + 2 * np.sin(3 * s)          # noqa: E731
    sol = solve_ivp(lambda s, v: [((u(s) - v[0]) / R - v[0] / RL) / C], (0, t[-1]), [0.0], t_eval=t,
                    rtol=1e-10, atol=1e-12, max_step=1e-3)
    v = sol.y[0]
    i = (u(t) - v) / R
    rng = np.random.default_rng(seed)
    rows = np.column_stack([t, u(t), i + rng.normal(0, 1e-5, t.size), v + rng.normal(0, 1e-3, t.size)])
    np.savetxt(path, rows, delimiter=",", header="t,u,i,v", comments="", fmt="%.10g")


def test_a_residual_no_sample_of_which_is_finite_refuses_the_record(tmp_path, capsys):
    model = tmp_path / "rc.yaml"
    model.write_text(MODEL.replace("res: {type: R, parameter: R}",
                                   'res: {type: R, effort: "R*f*sqrt(f - 1000)"}'), encoding="utf-8")
    assert main(["check", str(model)]) == 0           # the law is real at some current: check cannot tell
    capsys.readouterr()
    runs = [tmp_path / "a.csv", tmp_path / "b.csv"]
    for k, p in enumerate(runs):
        _record(p, k)
    for argv, named in ((["diagnose", str(model), str(runs[0]), "--workers", "1"], runs[0]),
                        (["calibrate", str(model), *map(str, runs)], model)):
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
        assert f"{named}: ARR1 is not finite on any sample" in err
        assert "res's effort R*f*sqrt(f - 1000)" in err and "derivative window" not in err
    # the same circuit with its law real on the data (sqrt(f + 1000)) is judged: the plain law's
    # residual at the identical record, scaled by sqrt(1000 + i) ~ 31.6, stays far under a threshold
    model.write_text(MODEL.replace("res: {type: R, parameter: R}",
                                   'res: {type: R, effort: "R*f*sqrt(f + 1000)/sqrt(1000)"}'),
                     encoding="utf-8")
    assert main(["diagnose", str(model), str(runs[0]), "--workers", "1"]) == 0
    assert "nothing detected" in capsys.readouterr().out


def test_a_stream_with_such_a_residual_is_refused_before_it_ends(tmp_path):
    """`bgfdi monitor` on the same record ran silently to its end (the check was the summary's):
    a live stream could run blind for hours. A model without modes (no switch leaves samples out
    by design) refuses the stream once ten derivative windows, and an identification window's N
    samples, have some residual finite and one never: here N = 1000 samples (1 s) into a 2 s
    record, fed three quarters of it."""
    from fdi.data import DataError, read_csv
    from fdi.monitor import compiled
    from fdi.options import Options
    model = tmp_path / "rc.yaml"
    model.write_text(MODEL.replace("res: {type: R, parameter: R}", 'res: {type: R, effort: "R*f*sqrt(f - 1000)"}'),
                     encoding="utf-8")
    run = tmp_path / "a.csv"
    _record(run, 0)
    m = read_csv(run)
    header = list(m.columns)
    table = np.column_stack([m.columns[h] for h in header])
    mon = compiled(str(model)).stream(lambda e: None, Options(workers=1))
    with pytest.raises(DataError, match=r"ARR1 is not finite on any sample, .*res's effort R\*f\*sqrt\(f - 1000\)"):
        for a in range(0, 1500, 50):                 # three quarters of the record: refused before its end
            mon.feed(header, table[a:a + 50])
    mon.stop(now=True)
