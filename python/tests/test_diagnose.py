"""ivdyn.diagnose from Python: the same content as the command line's diagnosis.json, on
the MuJoCo hidden-effect logs (truth from fixtures/diagnose/cases.json, the generator's)."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import ivdyn

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
CASES = os.path.join(ROOT, "fixtures", "diagnose")


def _manifest():
    with open(os.path.join(CASES, "cases.json")) as f:
        return json.load(f)


def _robot(case, m):
    return ivdyn.Robot.from_urdf(os.path.join(ROOT, case["urdf"]), base=m["base"], tip=m["tip"])


def _case(name):
    m = _manifest()
    return next(c for c in m["cases"] if c["name"] == name), m


def test_diagnose_names_the_hidden_coulomb_friction(tmp_path):
    case, m = _case("coulomb")
    d = ivdyn.diagnose(_robot(case, m), os.path.join(CASES, case["log"]), out=tmp_path)
    assert set(d) == {"effects", "baseline_rms", "final_rms", "joints", "next_command", "detectable"}
    assert d["next_command"].startswith("ivdyn identify --urdf ") and "--friction coulomb" in d["next_command"]
    assert d["joints"] == m["joints"]
    (e,) = d["effects"]
    truth = case["effects"][0]
    assert e["name"] == "coulomb_friction" and e["joints"] == truth["joints"]
    np.testing.assert_allclose(e["parameters"]["fc"], truth["parameters"]["fc"], rtol=0.1)
    # a standard error for every parameter, same shape (docs/diagnose.md, "Uncertainty")
    assert set(e["parameters_std"]) == set(e["parameters"]) and len(e["parameters_std"]["fc"]) == len(e["joints"])
    assert all(0 < s < 0.1 * f for s, f in zip(e["parameters_std"]["fc"], e["parameters"]["fc"]))
    assert np.all(np.asarray(d["final_rms"]) <= 1.5 * np.asarray(case["oracle"]["oracle_rms_exact"]))
    # the output directory holds the same JSON, the report and the residual log
    with open(tmp_path / "diagnosis.json") as f:
        assert json.load(f) == d
    assert (tmp_path / "report.html").stat().st_size > 10_000
    assert (tmp_path / "residuals.mcap").stat().st_size > 0


def test_clean_log_names_nothing_from_arrays():
    case, m = _case("clean_b")
    robot = _robot(case, m)
    log = ivdyn.read_joint_states(os.path.join(CASES, case["log"]), robot.joint_names)
    d = ivdyn.diagnose(robot, {"t": log["t"], "q": log["q"], "qd": log["qd"], "tau": log["tau"]})
    assert d["effects"] == []
    assert len(d["baseline_rms"]) == 6


def test_python_and_cli_agree(tmp_path):
    case, m = _case("torque_offset")
    exe = os.path.join(ROOT, "target", "release", "ivdyn")
    if not os.path.exists(exe):
        exe = os.path.join(ROOT, "target", "debug", "ivdyn")
    assert os.path.exists(exe), "build the ivdyn binary first (make test does)"
    # the command line on two threads, Python on one (this short log's default): the
    # diagnosis does not depend on the thread count (DiagnoseOptions::threads)
    subprocess.run([exe, "diagnose", "--urdf", os.path.join(ROOT, case["urdf"]), "--base", m["base"], "--tip", m["tip"],
                    "--log", os.path.join(CASES, case["log"]), "--out", str(tmp_path), "--no-report", "--quiet",
                    "--threads", "2"],
                   check=True, capture_output=True)
    with open(tmp_path / "diagnosis.json") as f:
        cli = json.load(f)
    py = ivdyn.diagnose(_robot(case, m), os.path.join(CASES, case["log"]), threads=1)
    assert [e["name"] for e in py["effects"]] == [e["name"] for e in cli["effects"]] == ["torque_offset"]
    np.testing.assert_allclose(py["final_rms"], cli["final_rms"], rtol=1e-12)
    assert py["effects"] == cli["effects"] and py["final_rms"] == cli["final_rms"]


def test_a_memory_cap_diagnoses_blocks_of_the_log():
    """Under an 8 MiB cap for the candidate columns the UR5 Coulomb log (1974 conditioned
    samples, ~6.1 kB of columns each) keeps two of its four blocks of 500 samples and says so
    (docs/reliability.md); the friction is still named, each fc within 10 % of the truth."""
    case, m = _case("coulomb")
    d = ivdyn.diagnose(_robot(case, m), os.path.join(CASES, case["log"]), max_dictionary_gib=8 / 1024,
                       report=False, verdict=True)
    assert any(x.startswith("log diagnosed on 1000 of its 1974 samples") for x in d["details"]), d["details"]
    (e,) = d["effects"]
    assert e["name"] == "coulomb_friction" and e["joints"] == case["effects"][0]["joints"]
    np.testing.assert_allclose(e["parameters"]["fc"], case["effects"][0]["parameters"]["fc"], rtol=0.1)
    for bad in (0.0, 1e-4, 2000.0, float("nan")):
        with pytest.raises(ValueError, match="max_dictionary_gib"):
            ivdyn.diagnose(_robot(case, m), os.path.join(CASES, case["log"]), max_dictionary_gib=bad)


def test_bad_input_raises_with_the_problem():
    case, m = _case("clean_a")
    robot = _robot(case, m)
    with pytest.raises(Exception, match="effort|tau"):
        ivdyn.diagnose(robot, {"t": np.arange(100) * 1e-3, "q": np.zeros((100, 6))})
    log = os.path.join(CASES, case["log"])
    for bad in (0, -1, 2000):
        with pytest.raises(ValueError, match=f"threads.*{bad}"):
            ivdyn.diagnose(robot, log, threads=bad)
    with pytest.raises(TypeError):
        ivdyn.diagnose(robot, log, threads=1.5)
