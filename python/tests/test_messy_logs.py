"""Identify on messy logs (python/tools/messy_log.py: jittered stamps, ~6 % repeated
messages, standstills at both ends, a gap, effort as current) against the same motion
logged cleanly, both validated on the same clean log: the validation RMS must stay
within 1.2x (issue 14's target), with the hygiene found and reported. (With the torque
constants 10 % off the ratio is a model error, not hygiene: printed, docs/real-logs.md.)"""

import os
import sys

import numpy as np
import pytest

import ivdyn

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import messy_log  # noqa: E402

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(os.path.join(ROOT, "fixtures", "ur5.urdf"), "base_link", "tool0")


@pytest.mark.parametrize("rate", [100.0, 1000.0])
def test_messy_log_costs_at_most_20_percent(ur5, rate):
    r = messy_log.compare(ur5, rate, seed=11)
    ratio = np.mean(r["messy"]) / np.mean(r["clean"])
    off = np.mean(r["messy_kt_off"]) / np.mean(r["clean"])
    print(f"{rate:.0f} Hz: messy/clean validation RMS {ratio:.3f}; k_t 10 % off (own units) {off:.3f}")
    assert ratio < 1.2
    c = r["conditioning"]
    # one gap, never interpolated across: two segments
    assert (c["gaps"], c["segments"]) == (1, 2)
    # the repeats inside motion are found; those in the standstills are identical rows
    # anyway (kept: MAX_REPEAT_RUN); 4 of the 34 s stand still
    assert 0.75 * r["repeats"] <= c["repeated"] <= r["repeats"]
    assert c["resampled"]
    # the exact velocity in the log agrees with the positions: taken on every joint
    assert [v["source"] for v in c["velocity"]] == ["log"] * 6


def test_window_and_exclude_from_python(ur5):
    log = ivdyn.simulate(ur5, duration=10.0, noise=0.05, fc=messy_log.FC, fv=messy_log.FV)["log"]
    rep = ivdyn.identify(ur5, log, window=(1.0, 9.0), exclude=[(4.0, 4.5)])
    h = rep["conditioning"]
    # the definition, on the log's own stamps (500 Hz: about 1000 outside, 251 excluded;
    # the stamps' rounding decides the ends)
    t = log["t"] - log["t"][0]
    inside = (t >= 1.0) & (t <= 9.0)
    excluded = inside & (t >= 4.0) & (t <= 4.5)
    assert (h["outside_window"], h["excluded"], h["segments"]) == ((~inside).sum(), excluded.sum(), 2)
    assert abs(h["outside_window"] - 1000) <= 1 and abs(h["excluded"] - 251) <= 1
    with pytest.raises(ValueError, match="exclude"):
        ivdyn.identify(ur5, log, exclude=[(3.0, 1.0)])
