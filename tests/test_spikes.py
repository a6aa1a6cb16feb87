"""One-sample spikes of a sensor column (fdi.spikes): found where they were designed, not where the
plant moves fast, read as their neighbours' mean, and said.

The references: signals with a designed glitch (its sample, its size), designed non-glitches (a
step, a quantised ramp's dither, an excursion where the trajectory bends, a switching signal), the
paper's four CyCab runs (their only one-sample excursion is physical: as the leak opens at 32 s, p1
reads the tank's pressure for one sample and then rises on a new course), and those runs with a
designed 0.5 rad miscount of the motor encoder, which was diagnosed as a drift of R4 before."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bondgraph.loader import load_model
from fdi import spikes
from fdi.api import diagnose
from fdi.calibrate import calibrate
from fdi.data import read_csv
from fdi.options import Options

from .conftest import CYCAB, DATA

T = np.arange(0.0, 10.0, 0.01)


def _noisy(seed: int = 0, sigma: float = 0.01) -> np.ndarray:
    return np.sin(0.7 * T) + sigma * np.random.default_rng(seed).standard_normal(T.size)


def test_a_designed_glitch_is_found_at_its_sample_with_its_size():
    x = _noisy()
    x[400] -= 0.3
    (s,) = spikes.find(T, {"x": x}, noise={"x": 0.01})
    assert (s.column, s.index, s.time) == ("x", 400, T[400])
    assert s.size == pytest.approx(-0.3, abs=0.05) and s.sigmas > 12
    fixed = spikes.repaired({"x": x}, (s,))["x"]
    assert fixed[400] == pytest.approx((x[399] + x[401]) / 2)
    assert np.array_equal(np.delete(fixed, 400), np.delete(x, 400))


@pytest.mark.parametrize("seed", range(5))
def test_noise_alone_has_no_spike(seed):
    assert spikes.find(T, {"x": _noisy(seed)}) == ()


def test_a_step_is_not_a_spike():
    x = _noisy()
    x[500:] += 0.5                        # a sensor's offset, or a valve that shuts
    assert spikes.find(T, {"x": x}) == ()


def test_a_quantised_ramp_dithering_by_one_step_is_not_a_spike():
    q = 6.283185307179586e-4              # the CyCab's motor encoder, declaring no resolution here
    x = np.round(0.002 * T / q) * q
    x[300] += q                           # one count up and back
    assert spikes.find(T, {"theta": x}) == ()


def test_an_excursion_where_the_course_changes_is_the_plant():
    """As in the reference runs at 32 s (p1 reads 0.97 bar for one sample, then 0.44 bar below its
    course, 20 times its noise): one sample far off, and the signal goes on 30 noise levels away."""
    x = 1.0 + 0.1 * T + 0.001 * np.random.default_rng(1).standard_normal(T.size)
    x[501:] -= 0.03
    x[500] = 0.2
    assert spikes.find(T, {"x": x}) == ()
    x[501:] += 0.03                       # the same sample, the course unchanged: a glitch
    assert [s.index for s in spikes.find(T, {"x": x})] == [500]


def test_a_glitch_on_a_flat_quantised_column_is_found():
    """A steady sensor reads one value; its one glitch is the column's only step, and that step set
    the column's quantum, which floored the spread at the glitch's own size (the final review)."""
    x = np.full(T.size, 2.0)
    x[500] = 3.0
    (s,) = spikes.find(T, {"x": x})
    assert (s.index, s.size) == (500, 1.0)


def test_a_value_at_the_double_s_limit_is_found_without_a_warning():
    import warnings
    x = _noisy()
    x[500] = 1e308
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (s,) = spikes.find(T, {"x": x})
    assert s.index == 500 and "over 1e+300 times its spread" in spikes.note(spikes.Found((s,)))


def test_the_first_and_last_samples_are_not_searched():
    """The rule reads three samples on each side (documented): a glitch at 2 or n - 3 stays."""
    for i in (1, 2, T.size - 3, T.size - 2):
        x = _noisy()
        x[i] += 0.5
        assert spikes.find(T, {"x": x}) == (), i
    x = _noisy()
    x[3] += 0.5
    assert [s.index for s in spikes.find(T, {"x": x})] == [3]


def test_two_glitches_in_a_row_are_not_read_as_one():
    x = _noisy()
    x[400:402] += 0.5
    assert spikes.find(T, {"x": x}) == ()


def test_a_column_with_many_excursions_is_left_as_recorded():
    x = _noisy()
    x[100:900:40] += 1.0                  # 20 one-sample pulses: the signal (sampled below its switching), not glitches
    found = spikes.search(T, {"i": x})
    assert found.spikes == () and found.many == (("i", 20),)
    assert "i has 20 one-sample excursions: read as recorded" in spikes.note(found)


def test_the_reference_runs_have_no_spike():
    model = load_model(CYCAB)
    for name in ("nominal", "scenario1", "scenario2", "scenario3"):
        meas = read_csv(DATA / f"{name}.csv")
        out, note = spikes.despiked(model, meas)
        assert note is None and out is meas, name


def _glitched(tmp_path, name: str = "nominal", at: float = 20.0, size: float = 0.5):
    meas = read_csv(DATA / f"{name}.csv")
    i = int(np.argmin(np.abs(meas.t - at)))
    theta1 = meas.columns["theta1"].copy()
    theta1[i] += size
    return replace(meas, columns={**meas.columns, "theta1": theta1}), i


def test_a_miscount_of_the_motor_encoder_is_not_a_fault(tmp_path):
    glitched, i = _glitched(tmp_path)
    cheap = Options(pop=12, generations=5, seed=1)
    d = diagnose(str(CYCAB), glitched, cheap)
    assert d.detection is None and d.faults == ()
    assert d.note.startswith("1 one-sample spike(s) read as their neighbours' mean: theta1 at 20 s (+0.5")
    kept = diagnose(str(CYCAB), glitched, replace(cheap, keep_spikes=True))      # as recorded: what it did before
    assert kept.detection is not None and 19.5 < kept.detection.time < 20.5
    assert "1 one-sample spike(s) read as recorded: theta1 at 20 s" in kept.note


def test_a_fault_after_a_miscount_is_still_found(tmp_path):
    """Scenario 1 (R4 abrupt, beta_theta1 intermittent from 32 s) with a miscount at 20 s: the same
    detection as the recorded run, and the glitch named."""
    glitched, _ = _glitched(tmp_path, "scenario1")
    cheap = Options(pop=12, generations=5, seed=1)
    d = diagnose(str(CYCAB), glitched, cheap)
    clean = diagnose(str(CYCAB), DATA / "scenario1.csv", cheap)
    assert d.detection == clean.detection and "theta1 at 20 s" in d.note


def test_calibrate_reads_a_glitched_run_as_the_clean_one(tmp_path):
    glitched, _ = _glitched(tmp_path)
    got = calibrate(str(CYCAB), [glitched])
    clean = calibrate(str(CYCAB), [read_csv(DATA / "nominal.csv")])
    assert got.thresholds == clean.thresholds
    assert got.glitches and "theta1 at 20 s" in got.glitches[0][1] and clean.glitches == ()


def test_keep_spikes_must_be_a_bool():
    from fdi.errors import UsageError
    with pytest.raises(UsageError, match="Options.keep_spikes"):
        Options(keep_spikes="yes").check()
