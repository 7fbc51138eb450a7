"""Issue 14's loaded/unloaded pair on messy logs (python/tools/messy_log.py: jittered
stamps, ~6 % repeats, standstills at both ends, a gap, effort as current through torque
constants the user believes 10 % off): the drive gains from the pair within 2 % of the
truth, the payload with those gains within 3 % in mass and 1 cm in COM, and its stated
std, which then includes the gains' covariance, covering the truth. 100 Hz here (about
3 s); `make messy` prints both rates and ten seeds (docs/real-logs.md has the table).
Every expected value is the generator's truth."""

import json
import os
import sys

import numpy as np
import pytest

import ivdyn

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import messy_log as M  # noqa: E402

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(os.path.join(ROOT, "fixtures", "ur5.urdf"), "base_link", "tool0")


@pytest.fixture(scope="module")
def study(ur5):
    return M.pair_study(ur5, 100.0, M.PAIR_SEED)


def test_gains_from_the_messy_pair_within_two_percent(study):
    # Issue 14's target, met on this seed at 100 Hz (all six within 0.5 %) and at 1 kHz on
    # every seed tried (within 0.6 %, seeds 21-30). Not on every seed at 100 Hz: over seeds
    # 21-30 the base joint and wrist 2 reach 4.8 % and 6.4 % (3.6 and 4.6 std), from the
    # generator's long intervals (up to 90 ms) that the resampling interpolates across
    # (docs/real-logs.md, "The messy pair"); the other four stay within 1.1 %.
    # every joint moves briskly in both logs: the pair determines all six
    assert study["not_identifiable"] == [], study["not_identifiable"]
    err = study["gain_err_pct"]
    assert np.all(np.abs(err) < 2.0), err
    # and the errors are what the stated std allow
    assert np.all(np.abs(err) <= M.COVER * study["gain_rel_std_pct"]), (err, study["gain_rel_std_pct"])


def test_payload_with_the_estimated_gains(study):
    p = study["with_gains"]
    assert abs(p["mass_err_pct"]) < 3.0 and p["com_err_cm"] < 1.0, p
    # the stated std include the gains' covariance, and cover the truth
    assert p["sources"] == ["noise", "before model", "torque constants"], p["sources"]
    assert p["covered"], p
    # the gains' covariance widens the std (the same estimate, a smaller |error|/std)
    exact = study["gains_exact"]
    assert exact["sources"] == ["noise", "before model"]
    assert p["mass_z"] < exact["mass_z"], (p, exact)


def test_payload_with_the_believed_constants(study):
    # Issue 14's 3 % mass target is for the gains from the pair. With the believed
    # constants (+-10 % per joint) as exact the mass comes out ~9.6 % off: the currents
    # are turned into torques 10 % wrong, and no before log can undo that (its model is
    # scaled by the same error). Asserted as measured: 5-12 % off, and the stated std
    # (noise and before model only) far from covering it.
    p = study["believed"]
    assert 5.0 < abs(p["mass_err_pct"]) < 12.0 and not p["covered"], p
    # the same constants with their 10 % std: the std say so
    q = study["believed_std"]
    assert q["sources"][-1] == "torque constants" and q["covered"], q


def test_gains_report_options_and_errors(ur5, tmp_path):
    """`gains=` as a file, `torque_constant_std` alone, and what is refused."""
    unloaded, loaded = M.make_pair(ur5, 100.0, M.PAIR_SEED, duration=10.0)
    g = ivdyn.drive_gains(ur5, unloaded, loaded, payload_mass=M.PAYLOAD_MASS)
    cov = np.array(g["gain_covariance"], dtype=float)
    std = np.array([x["std"] for x in g["gains"]], dtype=float)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), std, rtol=1e-9)
    path = tmp_path / "gains.json"
    path.write_text(json.dumps(g))
    a = ivdyn.payload(ur5, loaded, before=unloaded, gains=str(path))
    b = ivdyn.payload(ur5, loaded, before=unloaded, gains=g)
    assert a == b and a["uncertainty_sources"][-1] == "torque constants"
    with pytest.raises(ValueError, match="effort"):
        ivdyn.payload(ur5, loaded, before=unloaded, gains=g, effort="torque")
    # a gain the report leaves open needs a constant and a std
    g_open = json.loads(json.dumps(g))
    g_open["gains"][0]["value"] = None
    with pytest.raises(ValueError, match="torque_constant is needed for shoulder_pan_joint"):
        ivdyn.payload(ur5, loaded, before=unloaded, gains=g_open)
    with pytest.raises(ValueError, match="torque_constant_std is needed"):
        ivdyn.payload(ur5, loaded, before=unloaded, gains=g_open, torque_constant=M.kt_given())
    c = ivdyn.payload(ur5, loaded, before=unloaded, torque_constant=M.kt_given(), torque_constant_std=0.5)
    assert c["uncertainty_sources"] == ["noise", "before model", "torque constants"]
    with pytest.raises(ValueError, match="not this chain's"):
        ivdyn.payload(ur5, loaded, gains=dict(g, joints=["a"] * 6))
