"""The notebook API (issue 13): diagnose(model, data) -> Diagnosis."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from fdi.api import Diagnosis, diagnose, measurements
from fdi.app.cli import main
from fdi.data import DataError, read_csv

from .conftest import CYCAB, DATA, MODELS


class FrameLike:
    """What the API reads of a pandas DataFrame: column names and a float matrix."""

    def __init__(self, columns: dict):
        self.columns = list(columns)
        self._m = np.column_stack(list(columns.values()))

    def to_numpy(self, dtype=float):
        return self._m.astype(dtype)


def test_a_dataframe_gives_the_cli_json(capsys):
    m = read_csv(DATA / "scenario1.csv")
    d = diagnose(str(CYCAB), FrameLike(dict(m.columns)), workers=1)
    assert isinstance(d, Diagnosis) and d.detection.time == 31.88
    assert {f.name for f in d.faults} == {"R4", "beta_theta1"}
    assert main(["diagnose", str(CYCAB), str(DATA / "scenario1.csv"), "--json", "--workers", "1"]) == 0
    assert d.to_json() == capsys.readouterr().out
    assert "<table>" in d._repr_html_() and "R4" in d._repr_html_()


def test_dicts_and_structured_arrays_and_bad_data():
    m = read_csv(DATA / "nominal.csv")
    cols = {k: v[:1500] for k, v in m.columns.items()}
    assert diagnose(str(CYCAB), cols, workers=1).detection is None
    rec = np.rec.fromarrays(list(cols.values()), names=list(cols))
    assert measurements(rec).t.size == 1500
    with pytest.raises(DataError, match="no 't' column"):
        measurements({"time": [0.0, 1.0]})
    with pytest.raises(DataError, match="DataFrame"):
        measurements(42)


def test_a_compiled_monitor_takes_the_data_the_api_takes():
    """Found by trial3: ``fdi.Monitor(model).diagnose(data)`` (README: "derived once, for many
    diagnoses") raised a TypeError from os.stat with a dict of arrays, which fdi.api.diagnose takes.
    Every kind of data gives the report of the CSV file it came from."""
    import fdi
    m = read_csv(DATA / "scenario3.csv")
    monitor = fdi.Monitor(str(CYCAB))
    reference = monitor.diagnose(str(DATA / "scenario3.csv"), fdi.Options(workers=1)).to_json()
    rec = np.rec.fromarrays(list(m.columns.values()), names=list(m.columns))
    for data in (dict(m.columns), FrameLike(dict(m.columns)), rec):
        d = monitor.diagnose(data, fdi.Options(workers=1))
        assert [(f.name, f.type) for f in d.faults] == [("a1", "mode")]       # README: scenario3, burnt driver
        assert d.to_json() == reference                                      # the report names no file
    with pytest.raises(DataError, match="DataFrame"):
        monitor.diagnose(42)


def test_editing_the_model_file_changes_the_next_diagnosis(tmp_path):
    path = tmp_path / "tank.yaml"
    text = (MODELS / "two_tank_valve.yaml").read_text(encoding="utf-8")
    path.write_text(text, encoding="utf-8")
    data = {"t": np.arange(0, 200, 0.1)}
    data["Qin"] = 1e-4 * (1 + 0.5 * np.sin(0.01 * data["t"]))
    data["p1"] = np.full_like(data["t"], 5000.0)                  # not the model's equilibrium: residuals fire
    data["p2"] = np.full_like(data["t"], 2000.0)
    first = diagnose(str(path), data, workers=1)
    assert first.detection is not None
    path.write_text(text.replace("thresholds: {ARR1: 1.0e-4, ARR2: 1.0e-4, ARR3: 1.5e-4}",
                                 "thresholds: {ARR1: 1.0e3, ARR2: 1.0e3, ARR3: 1.0e3}"), encoding="utf-8")
    assert diagnose(str(path), data, workers=1).detection is None   # the new thresholds, not a stale cache


def test_an_edit_that_keeps_the_size_and_modification_time_is_not_served_stale(tmp_path):
    """Found by trial3: an in-process compiled model was keyed by (path, size, mtime), so an edit of
    the same length with the time put back (``touch -r``, or two saves within one clock tick)
    diagnosed with the old thresholds. The key is the file's bytes now."""
    import os
    path = tmp_path / "tank.yaml"
    text = (MODELS / "two_tank_valve.yaml").read_text(encoding="utf-8")
    path.write_text(text, encoding="utf-8")
    before = os.stat(path)
    data = {"t": np.arange(0, 200, 0.1)}
    data["Qin"] = 1e-4 * (1 + 0.5 * np.sin(0.01 * data["t"]))
    data["p1"] = np.full_like(data["t"], 5000.0)                  # not the model's equilibrium: residuals fire
    data["p2"] = np.full_like(data["t"], 2000.0)
    assert diagnose(str(path), data, workers=1).detection is not None
    edited = text.replace("thresholds: {ARR1: 1.0e-4, ARR2: 1.0e-4, ARR3: 1.5e-4}",
                          "thresholds: {ARR1: 1.0e+3, ARR2: 1.0e+3, ARR3: 1.5e+3}")
    assert edited != text and len(edited) == len(text)
    path.write_text(edited, encoding="utf-8")
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    after = os.stat(path)
    assert (after.st_size, after.st_mtime_ns) == (before.st_size, before.st_mtime_ns)
    assert diagnose(str(path), data, workers=1).detection is None   # thresholds of 1000: nothing crosses


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="POSIX FIFOs")
def test_a_model_given_as_a_named_fifo_is_refused_without_waiting(tmp_path):
    """Found by trial3: ``diagnose("m.yaml", ...)`` with m.yaml a FIFO nothing writes into waited
    forever (the command line refused it; the API opened it as a file)."""
    import os
    import threading

    from bondgraph.errors import ModelError
    fifo = tmp_path / "m.yaml"
    os.mkfifo(fifo)
    got = []

    def call():
        try:
            diagnose(str(fifo), {"t": [0.0, 0.1], "Qin": [0.0, 0.0], "p1": [0.0, 0.0], "p2": [0.0, 0.0]}, workers=1)
        except ModelError as exc:
            got.append(str(exc))
    worker = threading.Thread(target=call, daemon=True)
    worker.start()
    worker.join(20)
    if worker.is_alive():
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))     # releases the waiting open
        worker.join(5)
        pytest.fail("the model's FIFO was opened as a file: still waiting after 20 s")
    assert len(got) == 1 and "a named FIFO" in got[0] and "m.yaml" in got[0], got


def test_yaml_text_as_the_model():
    m = read_csv(DATA / "nominal.csv")
    text = CYCAB.read_text(encoding="utf-8")
    d = diagnose(text, {k: v[:1500] for k, v in m.columns.items()}, workers=1)
    assert d.detection is None and d.to_dict()["diagnosis"] == {"faults": [], "criterion_without": None}


@pytest.mark.skipif(importlib.util.find_spec("matplotlib") is None, reason="the plot extra is not installed")
def test_plot_returns_figures():
    m = read_csv(DATA / "scenario1.csv")
    d = diagnose(str(CYCAB), dict(m.columns), workers=1)
    figures = d.plot()
    assert {"residuals", "fitness", "profiles", "mode_estimate"} <= set(figures)
    # units from the model: ARR1 is a torque balance (N*m), R4's leak law sqrt|dp|/R4 gives Pa^0.5*s/m^3
    from matplotlib.ticker import EngFormatter
    labels = [ax.get_ylabel() for ax in figures["residuals"].axes]
    assert labels[0] == "ARR1"                         # the unit in the ticks, with an SI prefix: 10 N·m
    arr1 = figures["residuals"].axes[0].yaxis.get_major_formatter()
    assert isinstance(arr1, EngFormatter) and arr1.unit == "N\u00b7m" and arr1(2.2e-3) == "2.2 mN\u00b7m"
    arr2 = figures["residuals"].axes[1]              # m³/s takes no prefix: the prefix in the ticks, the unit in the label
    assert arr2.get_ylabel() == "ARR2 [m\u00b3/s]" and arr2.yaxis.get_major_formatter()(5e-4) == "500 \u00b5"
    time_axis = figures["residuals"].axes[-1]
    assert time_axis.get_xlabel() == "time t" and time_axis.xaxis.get_major_formatter().unit == "s"
    r4 = figures["profiles"].axes[0]
    assert r4.get_ylabel() == "R4 [Pa^0.5\u00b7s/m\u00b3]" and r4.yaxis.get_major_formatter()(2.5e7) == "25 M"
    beta = figures["profiles"].axes[1].yaxis.get_major_formatter()
    assert figures["profiles"].axes[1].get_ylabel() == "beta_theta1 [-]" and not isinstance(beta, EngFormatter)
    fitness = figures["fitness"].axes[0]
    assert fitness.get_xlabel().startswith("generation of the estimator's search")
    assert all("evaluations in" in label for label in fitness.get_legend_handles_labels()[1])
    # the fault-mode estimate (Fig. 8): coherence [1 1 0] suspects a broken belt; a2 = 1 costs least
    mode_axes = figures["mode_estimate"].axes[0]
    assert [t.get_text() for t in mode_axes.get_yticklabels()] == ["a2=0", "a2=1"]
    notes = [t.get_text().strip() for t in mode_axes.texts]    # the estimate labelled as the estimate
    assert notes == ["estimate (lowest cost): no mode change"]
    assert d.mode_fault.mode["a2"] == 1
    costs = {tuple(r["mode"].items()): r["cost"] for r in d.to_dict()["mode_costs"]}
    assert costs[(("a2", 1),)] < costs[(("a2", 0),)]
    import matplotlib.pyplot as plt
    for fig in figures.values():
        fig.canvas.draw()                      # renders, not only builds
        plt.close(fig)


@pytest.mark.skipif(importlib.util.find_spec("matplotlib") is None, reason="the plot extra is not installed")
def test_a_diagnosed_fault_mode_is_labelled_the_estimate_and_the_mode_at_detection_apart():
    """Once a fault mode is diagnosed the report's mode is the estimate; the plot still marks the
    mode in force at t_D on the other bar, and the estimate as the estimate."""
    import matplotlib.pyplot as plt

    from fdi.plots import _mode_figure
    report = {"mode_costs": [{"mode": {"a2": 0}, "cost": 2.2e4}, {"mode": {"a2": 1}, "cost": 5.6e3}],
              "mode_estimate": {"a2": 1}, "mode": {"a2": 1},
              "diagnosis": {"faults": [{"name": "a2", "type": "mode", "value": 1}]}}
    fig = _mode_figure(plt, report)
    assert [t.get_text().strip() for t in fig.axes[0].texts] == ["mode at t_D", "estimate (lowest cost): a fault mode"]
    plt.close(fig)


def test_monitor_settings_given_in_a_notebook_replace_the_files():
    """A MonitorConfig passed as ``config`` is used instead of the file's (the file untouched):
    thresholds above every residual detect nothing; a shorter waiting time moves the decision."""
    from fdi.config import load
    _, config = load(CYCAB)
    data = read_csv(DATA / "scenario2.csv")
    quiet = config.replace(thresholds={"ARR1": 1e9, "ARR2": 1e9, "ARR3": 1e9})
    assert diagnose(str(CYCAB), data, quiet, workers=1).detection is None
    d = diagnose(str(CYCAB), data, config.replace(waiting_time=2.0), workers=1)
    assert abs(d.detection.decision_time - d.detection.alarm_time - 2.0) <= 0.011     # 2 s after the alarm, to a sample
    assert load(CYCAB)[1].waiting_time == 5.0


def test_a_model_built_in_memory_is_diagnosed_without_a_file():
    """A Model with no file behind it (built or read from text in a notebook) is diagnosed as the
    file is, with the settings given; nothing is written to disk."""
    from bondgraph.loader import load_model_text
    from fdi.config import load
    model = load_model_text(CYCAB.read_text(encoding="utf-8"), "<notebook>")
    _, config = load(CYCAB)
    d = diagnose(model, DATA / "scenario1.csv", config, workers=1)
    assert {f.name for f in d.faults} == {"R4", "beta_theta1"}      # the paper's scenario 1 (Table III)


def test_a_model_changed_in_memory_is_what_gets_diagnosed():
    """The motor inertia quadrupled in memory, the file untouched: the nominal run no longer fits the
    model, so its torque balance (ARR1: J1 d(omega)/dt among its terms) fires; the file's model
    detects nothing on the same data."""
    from dataclasses import replace

    from bondgraph.loader import load_model
    model = load_model(CYCAB)
    heavy = replace(model, parameters={**model.parameters, "J1": replace(model.parameters["J1"], value=8.0e-5)})
    data = DATA / "nominal.csv"
    assert diagnose(model, data, workers=1).detection is None
    d = diagnose(heavy, data, workers=1)
    assert d.detection is not None and d.detection.coherence[0] == 1


def test_a_model_of_another_kind_is_refused_in_one_line():
    with pytest.raises(TypeError, match="a model is a path to a YAML file, YAML text, a bondgraph Model"):
        diagnose(42, DATA / "nominal.csv")


@pytest.mark.skipif(importlib.util.find_spec("matplotlib") is None, reason="the plot extra is not installed")
def test_a_prognosis_without_an_end_of_life_is_plotted():
    """A drift that never reaches its failure value has no EOL (inf, null in JSON): its RUL plot
    says so instead of failing."""
    from dataclasses import replace

    import matplotlib.pyplot as plt

    from fdi.results import Prognosis
    d = diagnose(str(CYCAB), DATA / "scenario2.csv", workers=1)
    never = Prognosis("beta_theta2", 0.5, float("inf"), float("inf"), 41.98, float("inf"), float("inf"))
    figures = replace(d, prognosis=(never,)).plot()
    assert any("RUL inf s" in label for label in figures["rul_beta_theta2"].axes[0].get_legend_handles_labels()[1])
    for fig in figures.values():
        plt.close(fig)


def test_n_as_an_option_and_n_in_the_settings_are_one_diagnosis():
    """The identification window N: given as an option (``samples=``) it set the window but left the
    unit of the degradation coefficients' bounds (W = N ts) at the file's N, so the search differed
    from N given in the settings (a user trial: eq. (16) against eq. (17), end of life 83 841 s
    against 86 420 s). Now the two are one diagnosis, to the last digit. The record: scipy's RC
    circuit (tests/independent/rc.py) read by a voltage sensor whose gain drifts as exp(-0.05 tau)
    from 1 s (eq. 16)."""
    from pathlib import Path

    from fdi.config import load

    from .independent import rc
    run = rc.simulate(4.0, 11)
    tau = np.maximum(run["t"] - 1.0, 0.0)
    run["v"] = run["v"] * np.exp(-0.05 * tau)
    model = str(Path(__file__).parent / "data" / "rc_two_sensors.yaml")
    fast = dict(workers=1, pop=10, generations=4, max_set=1, seed=2, thresholds={"ARR1": 0.01, "ARR2": 0.002})
    _, settings = load(model)
    by_option = diagnose(model, run, samples=2000, **fast)
    by_settings = diagnose(model, run, settings.replace(samples=2000), **fast)
    assert by_option.detection is not None
    assert [f.to_dict() for f in by_option.faults] == [f.to_dict() for f in by_settings.faults]


def test_a_stuck_sensor_is_never_fitted_in_a_later_decision():
    """A frozen sensor is confirmed by its signal, never fitted; a later decision (a residual joining
    after t_D) took its candidate sets from the signature matrix without that rule and fitted the
    voltage sensor's stuck fault as a drift: "stuck_v: incipient, eq. (16)". The record: scipy's RC
    circuit, its voltage sensor's gain drifting as exp(-0.05 tau) from 1 s; a search too small to fit
    the first decision's sets well (10 x 4) sends the diagnosis through the later decision."""
    from pathlib import Path

    from .independent import rc
    run = rc.simulate(4.0, 11)
    run["v"] = run["v"] * np.exp(-0.05 * np.maximum(run["t"] - 1.0, 0.0))
    model = str(Path(__file__).parent / "data" / "rc_two_sensors.yaml")
    d = diagnose(model, run, samples=2000, workers=1, pop=10, generations=4, max_set=1, seed=2,
                 thresholds={"ARR1": 0.01, "ARR2": 0.002})
    assert d.faults and all(f.type == "stuck" for f in d.faults if f.name == "stuck_v")
    assert [f.name for f in d.faults] == ["beta_v"]


def test_thresholds_given_in_the_options_name_residuals_of_the_model():
    """Options(thresholds=...) naming no residual of the model was ignored silently (the command
    line's --threshold refuses it, and the model file's thresholds are refused): a UsageError now,
    naming it and the model's residuals."""
    from pathlib import Path

    from fdi.errors import UsageError

    from .independent import rc
    model = str(Path(__file__).parent / "data" / "rc_two_sensors.yaml")
    with pytest.raises(UsageError, match=r"^thresholds: ARR9 name\(s\) no residual of the model \(its residuals: "
                                         r"ARR1, ARR2\)$"):
        diagnose(model, rc.simulate(0.5, 1), workers=1, thresholds={"ARR1": 0.01, "ARR2": 0.002, "ARR9": 1.0})


@pytest.mark.skipif(importlib.util.find_spec("matplotlib") is None, reason="the plot extra is not installed")
@pytest.mark.parametrize("estimate, red", [({"s": 1}, 1), ({"s": "commanded"}, 2)])
def test_the_mode_figure_marks_the_estimator_s_answer(estimate, red):
    """A switch commanded to switch has a "commanded" row: the bar marked is the estimator's answer
    (held at 1, or following), not one read from the final diagnosis (which a component fault won)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from fdi.plots import _mode_figure
    report = {"mode_costs": [{"mode": {"s": 0}, "cost": 100.0}, {"mode": {"s": 1}, "cost": 50.0},
                             {"mode": {"s": "commanded"}, "cost": 500.0}],
              "mode_estimate": estimate, "mode": {"s": 1},
              "diagnosis": {"faults": [{"name": "rL", "type": "abrupt", "value": 2.0, "t0": 1.0}]}}
    fig = _mode_figure(plt, report)
    bars = fig.axes[0].patches
    assert [k for k, b in enumerate(bars) if b.get_facecolor() == to_rgba("C3")] == [red]
    plt.close(fig)
