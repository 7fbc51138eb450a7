"""ivdyn.fleet on a real local Ray runtime (the session's `ray_runtime` of conftest.py, in its
own temporary directory, started once per xdist worker and shared by the modules that worker
runs): the Ray run equals the in-process statistics merged in another order (1e-12
relative), a corrupt or missing log marks its row failed by name and the run goes on, a
worker killed mid-run changes nothing, statistics of another model are refused."""
import os
import re
import signal
import threading
import time

import numpy as np
import pytest

import ivdyn
from ivdyn import fleet

import ray  # noqa: F401  (Ray must be installed: the tests fail, never skip)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
BASE, TIP = "base_link", "forearm_link"  # the UR5's first three joints: small and quick
ROBOTS, PERIODS, LOGS = 3, 2, 2
PLANTED = (2, 1)  # arm-2's elbow Coulomb friction rises 40 % (1.5 -> 2.1 N m) on day 1


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    """ROBOTS arms x PERIODS days x LOGS logs of 6 s at 250 Hz (MCAP), each arm with its
    own friction (Fourier excitation, 0.1 N m torque noise), one change planted (PLANTED)."""
    d = tmp_path_factory.mktemp("fleet")
    entries = []
    for a in range(ROBOTS):
        for p in range(PERIODS):
            for k in range(LOGS):
                path = d / f"arm-{a}_day{p}_{k}.mcap"
                elbow_fc = 2.1 if (a, p) == PLANTED else 1.5
                ivdyn.simulate(UR5, str(path), base=BASE, tip=TIP, duration=6.0, rate=250.0,
                               seed=100 * a + 10 * p + k + 1, fc=[2.0 + a, 2.0, elbow_fc], fv=[0.8, 0.8, 0.5],
                               noise=0.1)
                entries.append(fleet.LogEntry(log=str(path), robot=f"arm-{a}", model=UR5, period=f"day{p}",
                                              base=BASE, tip=TIP))
    return d, entries


def _theta_cov(f):
    theta = [np.nan if b["value"] is None else b["value"] for b in f["report"]["base"]]
    return np.array(theta, dtype=float), np.array(f["covariance"], dtype=float)


def _rel(a, b):
    ok = np.isfinite(b)
    assert np.array_equal(np.isfinite(a), ok)
    return np.linalg.norm(a[ok] - b[ok]) / np.linalg.norm(b[ok])


def _assert_same_fits(fits, reference, tol=1e-12):
    assert set(fits) == set(reference)
    for key in reference:
        (t, c), (t0, c0) = _theta_cov(fits[key]), _theta_cov(reference[key])
        assert _rel(t, t0) <= tol and _rel(c, c0) <= tol, (key, _rel(t, t0), _rel(c, c0))


def _in_process(entries):
    """Per (robot, period): every log's statistics here, merged in reverse order, fitted."""
    parts = {}
    for e in entries:
        parts.setdefault((e.robot, e.period), []).append(fleet.log_stats(e))
    return {key: fleet.fit(UR5, fleet.merge(p[::-1]), base=BASE, tip=TIP) for key, p in parts.items()}


def test_ray_run_equals_in_process_merge_and_reports_progress(fleet_dir, ray_runtime):
    _, entries = fleet_dir
    calls = []
    res = fleet.run(entries, engine="ray", progress=lambda done, total: calls.append((done, total)), fan_in=2)
    assert [r["status"] for r in res.rows] == ["ok"] * len(entries)
    assert calls[-1] == (len(entries), len(entries)) and len(calls) == len(entries)
    assert [c[0] for c in calls] == sorted(c[0] for c in calls)
    assert set(res.fits) == {(f"arm-{a}", f"day{p}") for a in range(ROBOTS) for p in range(PERIODS)}
    for key, f in res.fits.items():
        assert "error" not in f, f
        assert [lg["name"] for lg in f["logs"]] == sorted(e.log for e in entries if (e.robot, e.period) == key)
    _assert_same_fits(res.fits, _in_process(entries))
    # the engine-neutral path without Ray gives the same numbers
    _assert_same_fits(fleet.run(entries, engine="local", num_cpus=2).fits, res.fits)


def test_drift_flags_exactly_the_planted_change(fleet_dir):
    """At a 1 % false-discovery rate only the planted change is flagged (it is tens of
    standard deviations; under the null a false flag has a chance of about 1 %)."""
    _, entries = fleet_dir
    rows = fleet.drift(fleet.run(entries, engine="local", num_cpus=2), q=0.01)
    flagged = [r for r in rows if r["flagged"]]
    assert [(r["robot"], r["period"], r["effect"], r["joint"]) for r in flagged] == [
        ("arm-2", "day1", "coulomb_friction", "elbow_joint")], [r["words"] for r in flagged]
    assert flagged[0]["words"].startswith("arm-2, elbow_joint: coulomb friction +")
    assert flagged[0]["words"].endswith("since day0")
    assert abs(flagged[0]["change"][0] - 0.6) < 4 * flagged[0]["std"][0]
    assert rows[0] is flagged[0] and len(rows) > 10


def test_corrupt_and_missing_logs_fail_their_rows_by_name(fleet_dir, ray_runtime):
    d, entries = fleet_dir
    bad = d / "arm-0_day0_corrupt.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n" + os.urandom(2000))
    missing = d / "arm-1_day0_gone.mcap"
    extra = [fleet.LogEntry(log=str(bad), robot="arm-0", model=UR5, period="day0", base=BASE, tip=TIP),
             fleet.LogEntry(log=str(missing), robot="arm-1", model=UR5, period="day0", base=BASE, tip=TIP)]
    res = fleet.run(entries[:4] + extra, engine="ray")
    failed = res.failed
    assert [r["log"] for r in failed] == [str(bad), str(missing)]
    for r in failed:
        assert r["log"] in r["error"], r["error"]
    assert all(r["status"] == "ok" for r in res.rows[:4])
    # the good logs of the same group are fitted as if the bad ones were not listed
    _assert_same_fits(res.fits, _in_process(entries[:4]))


def _kill_one_stats_worker(killed, stop):
    """SIGKILLs the first Ray worker seen running a statistics task (its process title is
    ``ray::_stats_parts`` while it runs one)."""
    while not stop.is_set():
        for pid in os.listdir("/proc"):
            if not pid.isdigit():
                continue
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as f:
                    cmd = f.read()
            except OSError:
                continue
            if cmd.startswith(b"ray::_stats_parts"):
                os.kill(int(pid), signal.SIGKILL)
                killed.append(int(pid))
                return
        time.sleep(0.005)


def test_a_worker_killed_mid_run_changes_nothing(fleet_dir, ray_runtime):
    _, entries = fleet_dir
    killed, stop = [], threading.Event()
    killer = threading.Thread(target=_kill_one_stats_worker, args=(killed, stop))
    killer.start()
    try:
        res = fleet.run(entries, engine="ray")
    finally:
        stop.set()
        killer.join()
    assert killed, "no statistics task was caught running"
    assert [r["status"] for r in res.rows] == ["ok"] * len(entries)
    _assert_same_fits(res.fits, _in_process(entries))


def test_statistics_of_another_model_are_refused_naming_both(fleet_dir):
    _, entries = fleet_dir
    a = fleet.log_stats(entries[0])
    other = fleet.LogEntry(log=entries[1].log, robot="x", model=UR5, base=BASE, tip=TIP)
    # the same log with the drive model of another fleet: another parameter layout
    b = fleet.log_stats(other, fleet.Options(offset=False))
    with pytest.raises(ValueError) as e:
        fleet.merge([a, b])
    msg = str(e.value)
    assert entries[0].log in msg and entries[1].log in msg
    assert "drive terms fc,fv,ia,tau0)" in msg and "drive terms fc,fv,ia)" in msg
    info = fleet.stats_info(a)
    assert info["logs"][0]["name"] == entries[0].log and info["model"]["joints"] == [
        "shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"]


def test_a_payload_the_logs_cannot_weigh_is_said_why(tmp_path):
    """A 1 kg payload on the upper arm of the UR5's first two joints: the drift flags the
    payload, but two joints' motion does not separate the link's mass from its first moment
    and Izz, so ``ivdyn payload`` (the reference day as the before-log) states no mass: the
    words say so, with the combination the mass is hidden in, and give no number."""
    entries = []
    for p in range(2):
        path = str(tmp_path / f"day{p}.mcap")
        pay = dict(payload_mass=1.0, payload_com=[0.1, 0.0, 0.0]) if p else {}
        ivdyn.simulate(UR5, path, base=BASE, tip="upper_arm_link", duration=6.0, rate=250.0, seed=p + 1,
                       fc=[2.0, 2.0], fv=[0.8, 0.8], noise=0.1, **pay)
        entries.append(fleet.LogEntry(log=path, robot="arm-0", model=UR5, period=f"day{p}", base=BASE,
                                      tip="upper_arm_link"))
    tests = fleet.drift(res := fleet.run(entries, engine="local"), q=0.01)
    assert [t["effect"] for t in tests if t["flagged"]] == ["payload"]
    [d] = fleet.diagnose(res, tests)
    assert d["payload"]["identifiable"] is False and d["payload"]["mass"] is None
    [said] = [w for w in d["words"] if w.startswith("arm-0: payload changed since day1")]
    assert said.startswith("arm-0: payload changed since day1; its mass is not determined: the logs' "
                           "motion determines upper_arm_link.m only in the combination upper_arm_link.m + ")
    assert not re.search(r"\bkg\b", said)
    # the payload is a change of the terminal link (upper_arm_link here): the diagnosis names
    # no look-alike for its torque (it named a joint spring before 2026-12-03)
    assert {e["name"] for e in d["effects"]} <= {"payload"}, d["effects"]


def test_a_torque_gain_is_a_ratio_a_spring_n_m_per_rad():
    """The words give each parameter its effect's unit (docs/diagnose.md): a torque gain's
    ``k`` is measured / true torque, no unit; a joint spring's ``k`` is N m/rad."""
    from ivdyn.fleet import diagnosis

    def said(name):
        e = {"name": name, "joints": ["elbow"], "parameters": {"k": [0.96]}, "parameters_std": {"k": [0.005]}}
        [w] = diagnosis.effect_words("arm-0", e, {}, {}, "day1")
        return w

    # 95 % interval: 1.96 x 0.005 = 0.0098, to two significant digits
    assert said("torque_gain") == "arm-0, elbow: torque gain +0.9600 ± 0.0098 on day1"
    assert said("joint_spring") == "arm-0, elbow: joint spring +0.9600 N m/rad ± 0.0098 N m/rad on day1"


def test_manifest_csv_and_json(tmp_path):
    (tmp_path / "m.csv").write_text("log,robot,model,time,payload\nlogs/a.mcap,arm-1,ur5.urdf,2026-11-02T10:00,box\n")
    (tmp_path / "m.json").write_text('{"logs": [{"log": "/x/b.mcap", "robot": "arm-2", "model": "/m/ur5.urdf",'
                                     ' "period": "w45"}]}')
    [c] = fleet.read_manifest(str(tmp_path / "m.csv"))
    assert c.log == str(tmp_path / "logs" / "a.mcap") and c.period == "2026-11-02" and c.payload == "box"
    [j] = fleet.read_manifest(str(tmp_path / "m.json"))
    assert (j.log, j.robot, j.model, j.period) == ("/x/b.mcap", "arm-2", "/m/ur5.urdf", "w45")
    (tmp_path / "bad.csv").write_text("log,robot\na.mcap,arm-1\n")
    with pytest.raises(ValueError, match=r"bad.csv: row 1: 'model' is missing"):
        fleet.read_manifest(str(tmp_path / "bad.csv"))


def test_fleet_command_writes_json_and_reloadable_params(fleet_dir, tmp_path, ivdyn_bin):
    """``ivdyn fleet`` (running ``python -m ivdyn.fleet`` in this interpreter): fleet.json with the rows,
    fits, drift and the flagged change in words; one parameter file per robot and period
    that ``params=`` (``--params``) loads."""
    import json
    import subprocess
    import sys

    d, entries = fleet_dir
    manifest = tmp_path / "m.csv"
    manifest.write_text("log,robot,model,period,base,tip\n" + "".join(
        f"{e.log},{e.robot},{e.model},{e.period},{BASE},{TIP}\n" for e in entries))
    out = tmp_path / "out"
    r = subprocess.run([ivdyn_bin, "fleet", str(manifest), "--out", str(out), "--engine", "local",
                        "--fdr", "0.01", "--quiet"], capture_output=True, text=True, cwd=tmp_path, timeout=300,
                       env=dict(os.environ, IVDYN_PYTHON=sys.executable))
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "fleet.json").read_text())
    assert len(doc["rows"]) == len(entries) and len(doc["fits"]) == ROBOTS * PERIODS
    assert len(doc["flagged"]) == 1 and doc["flagged"][0].startswith("arm-2, elbow_joint: coulomb friction +")
    assert doc["flagged"][0] in r.stdout
    # the changed arm's latest log diagnosed against its first day's model: the elbow's
    # Coulomb friction, 0.6 N m more (within 4 std of the drift test's change)
    [named] = doc["diagnoses"]
    assert [(e["name"], e["joints"]) for e in named["effects"]] == [("coulomb_friction", ["elbow_joint"])]
    t = next(t for t in doc["drift"] if t["flagged"])
    assert abs(named["effects"][0]["parameters"]["fc"][0] - 0.6) < 4 * t["std"][0]
    assert doc["named"] == named["words"] and named["words"][0].startswith("arm-2, elbow_joint: coulomb friction +")
    assert f"named: {named['words'][0]}" in r.stdout
    params = out / "params" / "arm-2_day1.json"
    robot = ivdyn.Robot.from_urdf(UR5, base=BASE, tip=TIP)
    i = robot.param_names.index("elbow_joint.fc")
    # the file replaces the URDF's values: the elbow's friction is the fitted 2.1 N m
    sim = ivdyn.simulate(UR5, base=BASE, tip=TIP, params=str(params), duration=1.0)
    tp = sim["true_params"]
    fc = tp["theta"][tp["names"].index("elbow_joint.fc")]
    assert abs(robot.params[i] - 2.1) > 0.5 and abs(fc - 2.1) < 0.1, fc


def test_logs_are_streamed_by_default_with_the_logs_velocity(fleet_dir):
    """``Options()`` streams an MCAP log and takes its velocity where it agrees with the
    positions (the in-memory rule, with its notes); ``stream=False`` and ``ivdyn fleet
    --in-memory`` read it into memory. The two give the same fit to about 1e-6 of a
    standard deviation (the streamed filters run block by block)."""
    from ivdyn.fleet.__main__ import _parser

    _, entries = fleet_dir
    e = entries[0]
    infos = {}
    fits = {}
    for stream in (True, False):
        stats = fleet.log_stats(e, fleet.Options(stream=stream))
        [info] = fleet.stats_info(stats)["logs"]
        infos[stream] = info
        fits[stream] = fleet.fit(e.model, stats, base=e.base, tip=e.tip)
    assert infos[True]["streamed"] and not infos[False]["streamed"]
    for info in infos.values():
        assert "velocity from the log on 3 of 3 joints" in info["notes"], info["notes"]
    (t1, _), (t0, c0) = _theta_cov(fits[True]), _theta_cov(fits[False])
    ok = np.isfinite(t0)
    assert np.all(np.abs(t1[ok] - t0[ok]) <= 1e-6 * np.sqrt(np.diag(c0)[ok]))
    assert fleet.Options().stream
    assert _parser().parse_args(["m.csv", "--out", "o", "--in-memory"]).in_memory
    assert _parser().parse_args(["m.csv", "--out", "o"]).in_memory is False
