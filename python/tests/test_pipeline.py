"""ivdyn.identify / payload / simulate / excite (the command line's jobs from Python)
against the `ivdyn` command line's files on the same input, the known truth of the
simulated logs (physics), and their error paths; progress callbacks and their abort.

Both front ends call the same `ivdyn::app` job; these tests show Python reaches it with
every option (the binary is the `ivdyn_bin` fixture of the root conftest.py).
"""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
CHAIN = ["--urdf", UR5, "--base", "base_link", "--tip", "tool0"]
FC = [2.0, 2.0, 1.5, 0.6, 0.6, 0.4]
FV = [0.8, 0.8, 0.5, 0.2, 0.2, 0.1]
# same code in two builds: agreement to rounding (the pipelines are deterministic)
RTOL = 1e-9


@pytest.fixture(scope="module")
def cli(ivdyn_bin):
    """Path of the `ivdyn` binary (python/conftest.py)."""
    return ivdyn_bin


def run_cli(cli, *args, code=0):
    r = subprocess.run([cli, "--quiet", *args], capture_output=True, text=True)
    assert r.returncode == code, r.stderr
    return r


def same(a, b, path="$"):
    """Deep equality of two JSON documents, floats to RTOL."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), (path, sorted(a), sorted(b))
        for k in a:
            same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a is not None and b is not None and math.isclose(a, b, rel_tol=RTOL, abs_tol=1e-300), (path, a, b)
    else:
        assert a == b, (path, a, b)


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


@pytest.fixture(scope="module")
def logs(tmp_path_factory, cli):
    """An unloaded and a loaded (2 kg) simulated log, written by the command line."""
    d = tmp_path_factory.mktemp("logs")
    common = [*CHAIN, "--duration", "8", "--fc", ",".join(map(str, FC)), "--fv", ",".join(map(str, FV)),
              "--noise", "0.05"]
    run_cli(cli, "simulate", *common, "--seed", "1", "--out", str(d / "before.mcap"), "--json", str(d / "before.json"))
    run_cli(cli, "simulate", *common, "--seed", "2", "--payload-mass", "2", "--payload-com", "0.01,-0.02,0.05",
            "--out", str(d / "after.mcap"), "--json", str(d / "after.json"))
    return d


def test_simulate_matches_cli(ur5, logs, tmp_path):
    out = tmp_path / "after.mcap"
    res = ivdyn.simulate(ur5, out, duration=8, fc=FC, fv=FV, noise=0.05, seed=2, payload_mass=2,
                         payload_com=[0.01, -0.02, 0.05])
    with open(logs / "after.json") as f:
        ref = json.load(f)
    log = res.pop("log")
    assert res.pop("out") == str(out) and ref.pop("out") == str(logs / "after.mcap")
    same(res, ref)
    # the same samples as the command line's file, read back by the independent reader
    back = ivdyn.read_joint_states(logs / "after.mcap", ur5)
    mine = ivdyn.read_joint_states(out, ur5)
    for k in ("q", "qd", "tau"):
        np.testing.assert_array_equal(back[k], mine[k])
        np.testing.assert_array_equal(log[k], mine[k])
    # physics: the recorded torque minus the noise is the true model's inverse dynamics
    truth = ur5.copy()
    truth.params = np.array(res["true_params"]["theta"])
    tau = truth.rnea(log["q"], log["qd"], np.gradient(log["qd"], log["t"], axis=0))
    resid = (log["tau"] - tau)[5:-5]
    assert abs(resid.std() - 0.05) < 0.005  # 30 000 N(0, 0.05) draws: std within 10 %


def test_simulate_csv_traj_and_no_velocity(ur5, tmp_path):
    t = np.arange(200) / 100.0
    q = 0.2 * np.sin(np.outer(t, np.arange(1, 7)))
    res = ivdyn.simulate(ur5, tmp_path / "x.csv", traj={"t": t, "q": q}, velocity=False)
    assert res["samples"] == 200 and res["log"]["qd"] is None
    back = ivdyn.read_joint_states(tmp_path / "x.csv", ur5)
    np.testing.assert_allclose(back["q"], q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", ["ols", "wls", "iv"])
def test_identify_matches_cli(ur5, logs, cli, tmp_path, method):
    js = tmp_path / "id.json"
    run_cli(cli, "identify", *CHAIN, "--log", str(logs / "before.mcap"), "--method", method, "--json", str(js))
    with open(js) as f:
        ref = json.load(f)
    rep = ivdyn.identify(UR5, logs / "before.mcap", method, base="base_link", tip="tool0")
    same(rep, ref)


def test_identify_from_arrays_equals_file(ur5, logs):
    log = ivdyn.read_joint_states(logs / "before.mcap", ur5)
    # arrays are identified in memory, a streamed MCAP path the same way (the Coulomb sign
    # kept: the stream cannot choose a shape): the same numbers, with the velocity
    # differentiated from the positions and with the log's velocity taken where it agrees
    # (the stream checks it on its first samples, the in-memory path on the whole log)
    for velocity, sources in (("positions", ["positions"] * 6), ("auto", ["log"] * 6)):
        a = ivdyn.identify(ur5, log, velocity=velocity, coulomb="sign")
        b = ivdyn.identify(ur5, logs / "before.mcap", stream=True, velocity=velocity, coulomb="sign")
        assert a.pop("streamed") is False and b.pop("streamed") is True
        ca, cb = a.pop("conditioning"), b.pop("conditioning")
        assert [v["source"] for v in ca["velocity"]] == [v["source"] for v in cb["velocity"]] == sources
        same(a, b)
    # by default a small MCAP log is read whole and its velocity checked
    c = ivdyn.identify(ur5, logs / "before.mcap")
    assert c["streamed"] is False and len(c["conditioning"]["velocity"]) == 6
    # physics: the identified model predicts the measured torque to the noise level
    assert max(a["validation"]["rms"]) < 0.05 * 1.3


def test_identify_params_roundtrip(ur5, logs):
    """A parameter file (a previous report's "params") replaces the nominal model: the
    base values reported as nominal are then the previous estimates."""
    a = ivdyn.identify(ur5, logs / "before.mcap", "ols")
    b = ivdyn.identify(ur5, logs / "before.mcap", "ols", params=a["params"])
    for x, y in zip(a["base"], b["base"]):
        assert math.isclose(y["nominal"], x["value"], rel_tol=1e-9, abs_tol=1e-9)


def test_payload_matches_cli_and_truth(ur5, logs, cli, tmp_path):
    js = tmp_path / "pl.json"
    run_cli(cli, "payload", *CHAIN, "--log", str(logs / "after.mcap"), "--before", str(logs / "before.mcap"),
            "--json", str(js))
    with open(js) as f:
        ref = json.load(f)
    rep = ivdyn.payload(ur5, logs / "after.mcap", logs / "before.mcap")
    same(rep, ref)
    # the simulated truth: 2 kg at (0.01, -0.02, 0.05) m, within 4 standard deviations
    assert rep["identifiable"]
    assert abs(rep["mass"] - 2.0) < 4 * rep["mass_std"] + 1e-3
    for c, s, want in zip(rep["com"], rep["com_std"], [0.01, -0.02, 0.05]):
        assert abs(c - want) < 4 * s + 1e-3


def test_progress_callback_and_abort(ur5, logs):
    calls = []
    ivdyn.identify(ur5, logs / "before.mcap", progress=lambda done, total: calls.append((done, total)))
    assert calls, "no progress reported"
    assert all(0 <= d and (t == 0 or d <= t) for d, t in calls)
    assert any(t > 0 and d == t for d, t in calls), "a counted step never completed"

    class Stop(Exception):
        pass

    seen = []

    def stop(done, total):
        seen.append(done)
        if done > 0:
            raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        ivdyn.payload(ur5, logs / "after.mcap", progress=stop)
    n = len(seen)
    # the call stopped at the first raise, and the module still works afterwards
    assert seen[-1] > 0 and all(s == 0 for s in seen[:-1])
    ivdyn.payload(ur5, logs / "after.mcap", progress=True)  # tqdm if installed, else silent
    assert len(seen) == n


def test_pipeline_errors(ur5, logs, tmp_path):
    log = ivdyn.read_joint_states(logs / "before.mcap", ur5)
    with pytest.raises(ValueError, match="method must be"):
        ivdyn.identify(ur5, log, "magic")
    with pytest.raises(FileNotFoundError, match="nope.mcap"):
        ivdyn.identify(ur5, tmp_path / "nope.mcap")
    bad = dict(log, q=log["q"][:, :5])
    with pytest.raises(ValueError, match=r"log\['q'\] must have shape \(T, 6\)"):
        ivdyn.identify(ur5, bad)
    nan = dict(log, tau=log["tau"].copy())
    nan["tau"][7, 2] = np.nan
    with pytest.raises(ValueError, match="sample 7: joint 'elbow_joint' tau is NaN"):
        ivdyn.identify(ur5, nan)
    with pytest.raises(ValueError, match="only 5 samples"):
        ivdyn.identify(ur5, {k: log[k][:5] for k in ("t", "q", "tau")})
    with pytest.raises(RuntimeError, match="no effort"):
        ivdyn.identify(ur5, {"t": log["t"], "q": log["q"]})
    with pytest.raises(ValueError, match="not the robot's"):
        ivdyn.identify(ur5, dict(log, joint_names=list(reversed(log["joint_names"]))))
    with pytest.raises(ValueError, match="holdout"):
        ivdyn.identify(ur5, log, holdout=1.5)
    with pytest.raises(ValueError, match="progress must be"):
        ivdyn.identify(ur5, log, progress="yes")
    with pytest.raises(TypeError, match="URDF path"):
        ivdyn.payload(42, log)
    with pytest.raises(ValueError, match="params: not a parameter file"):
        ivdyn.payload(ur5, log, params={"robot": "x"})
    with pytest.raises(ValueError, match="payload_mass must be positive"):
        ivdyn.simulate(ur5, payload_mass=-1.0)
    with pytest.raises(ValueError, match="payload_com needs 3 finite values"):
        ivdyn.simulate(ur5, payload_mass=1.0, payload_com=[0.0, 0.1])
    with pytest.raises(ValueError, match="need payload_mass"):
        ivdyn.simulate(ur5, payload_com=[0.0, 0.1, 0.0])
    with pytest.raises(ValueError, match="fc"):
        ivdyn.simulate(ur5, fc=[1.0, 2.0])
    with pytest.raises(ValueError, match="unknown output format"):
        ivdyn.simulate(ur5, tmp_path / "x.bag", duration=1)
    assert not list(tmp_path.glob("*.tmp")) and not (tmp_path / "x.bag").exists()


def read_json(p):
    with open(p) as f:
        return json.load(f)


def test_identify_writes_the_cli_outputs(ur5, logs, cli, tmp_path):
    """Python reaches every output and option of `ivdyn identify` (the same app job): the
    parameter file, the URDF write-back and its side file, the JSON report and the prediction
    MCAP, with --consistent --friction coulomb --no-offset."""
    c, p = tmp_path / "cli", tmp_path / "py"
    c.mkdir(), p.mkdir()
    run_cli(cli, "identify", *CHAIN, "--log", str(logs / "before.mcap"), "--consistent", "--friction", "coulomb",
            "--no-offset", "--json", str(c / "id.json"), "--out-params", str(c / "p.json"),
            "--write-urdf", str(c / "w.urdf"), "--out-mcap", str(c / "pred.mcap"))
    rep = ivdyn.identify(ur5, logs / "before.mcap", consistent=True, friction=["coulomb"], offset=False,
                         out_json=p / "id.json", out_params=p / "p.json", write_urdf=p / "w.urdf",
                         out_mcap=p / "pred.mcap")
    assert sorted(os.listdir(c)) == sorted(os.listdir(p)) == ["id.json", "p.json", "pred.mcap", "w.urdf", "w.urdf.json"]
    same(read_json(p / "id.json"), read_json(c / "id.json"))
    same(rep, read_json(c / "id.json"))
    same(read_json(p / "p.json"), read_json(c / "p.json"))
    assert rep["drive_terms"] == ["fc", "ia"] and "consistent" in rep
    with open(p / "w.urdf") as f1, open(c / "w.urdf") as f2:
        assert f1.read() == f2.read()
    # the written URDF reloads with its side file (armature) from Python as from the CLI
    back = ivdyn.Robot.from_urdf(p / "w.urdf", base="base_link", tip="tool0")
    ia = [back.params[back.param_names.index(f"{j}.ia")] for j in back.joint_names]
    want = [read_json(p / "p.json")["theta"][read_json(p / "p.json")["names"].index(f"{j}.ia")] for j in back.joint_names]
    assert ia == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_identify_option_errors(ur5, logs):
    with pytest.raises(ValueError, match="friction none cannot be combined"):
        ivdyn.identify(ur5, logs / "before.mcap", friction=["none", "coulomb"])
    with pytest.raises(ValueError, match="write_urdf needs a robot loaded from a URDF"):
        ivdyn.identify(ivdyn.Robot.paper(), {"t": np.arange(50) * 0.01, "q": np.zeros((50, 6)),
                                              "tau": np.zeros((50, 6))}, write_urdf="x.urdf")


def test_payload_and_excite_write_the_cli_outputs(ur5, logs, cli, tmp_path):
    c, p = tmp_path / "cli", tmp_path / "py"
    c.mkdir(), p.mkdir()
    run_cli(cli, "payload", *CHAIN, "--log", str(logs / "after.mcap"), "--before", str(logs / "before.mcap"),
            "--json", str(c / "pl.json"), "--write-urdf", str(c / "pl.urdf"), "--payload-as", "merge")
    pl = ivdyn.payload(ur5, logs / "after.mcap", before=logs / "before.mcap", out_json=p / "pl.json",
                       write_urdf=p / "pl.urdf", payload_as="merge")
    same(read_json(p / "pl.json"), read_json(c / "pl.json"))
    same(pl, read_json(c / "pl.json"))
    with open(p / "pl.urdf") as f1, open(c / "pl.urdf") as f2:
        assert f1.read() == f2.read()
    args = ["--duration", "5", "--starts", "1", "--iterations", "20", "--random", "5"]
    run_cli(cli, "excite", *CHAIN, *args, "--out", str(c / "x.csv"), "--json", str(c / "x.json"))
    ex = ivdyn.excite(ur5, p / "x.csv", out_json=p / "x.json", duration=5, starts=1, iterations=20, random=5)
    same(read_json(p / "x.json"), read_json(c / "x.json"))
    with open(p / "x.csv") as f1, open(c / "x.csv") as f2:
        assert f1.read() == f2.read()
    assert ex["trajectory"]["q"].shape == (len(ex["trajectory"]["t"]), 6)
