"""ivdyn.fleet reading s3:// logs from a real S3-compatible server (moto's, started here
as its own process on a free local port): the fleet run on a manifest of s3:// URIs
equals the run on the same files by local path exactly (the same bytes are read), in
this process and on a local Ray runtime; a missing object fails its row, naming the URI."""
import os
import socket
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest

import ivdyn
from ivdyn import fleet

import boto3
import moto.server  # noqa: F401  (the S3 server the tests start)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
BASE, TIP = "base_link", "forearm_link"
BUCKET = "fleet-logs"
ENV = {"AWS_ACCESS_KEY_ID": "testing", "AWS_SECRET_ACCESS_KEY": "testing", "AWS_DEFAULT_REGION": "us-east-1"}


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def s3_server():
    """moto's S3 server on a free port; the AWS variables point this process (and the Ray
    workers it starts) at it, and are restored afterwards."""
    port = _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p", str(port)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    try:
        for _ in range(300):
            try:
                urllib.request.urlopen(url, timeout=1)
                break
            except OSError:
                if proc.poll() is not None:
                    pytest.fail("moto_server exited at start")
                time.sleep(0.1)
        else:
            pytest.fail(f"moto_server did not answer on {url} in 30 s")
        saved = {k: os.environ.get(k) for k in [*ENV, "AWS_ENDPOINT_URL"]}
        os.environ.update(ENV, AWS_ENDPOINT_URL=url)
        fleet._s3._client = None  # a client made before would keep its endpoint
        try:
            yield url
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
            fleet._s3._client = None
    finally:
        proc.terminate()
        proc.wait(timeout=10)


@pytest.fixture(scope="module")
def logs(s3_server, tmp_path_factory):
    """Two arms x two days, one 6 s log at 250 Hz each, on disk and uploaded to the bucket:
    (local entries, the same entries by s3:// URI)."""
    d = tmp_path_factory.mktemp("s3fleet")
    s3 = boto3.client("s3")
    s3.create_bucket(Bucket=BUCKET)
    local, remote = [], []
    for a in range(2):
        for p in range(2):
            name = f"arm-{a}/day{p}.mcap"
            path = d / f"arm-{a}_day{p}.mcap"
            ivdyn.simulate(UR5, str(path), base=BASE, tip=TIP, duration=6.0, rate=250.0, seed=10 * a + p + 1,
                           fc=[2.0, 2.0, 1.5 + 0.2 * a], fv=[0.8, 0.8, 0.5], noise=0.1)
            s3.upload_file(str(path), BUCKET, name)
            row = dict(robot=f"arm-{a}", model=UR5, period=f"day{p}", base=BASE, tip=TIP)
            local.append(fleet.LogEntry(log=str(path), **row))
            remote.append(fleet.LogEntry(log=f"s3://{BUCKET}/{name}", **row))
    return local, remote


def _assert_identical(a, b):
    """The same fits bit for bit (the logs' names aside)."""
    assert set(a.fits) == set(b.fits) and a.fits
    for key in a.fits:
        fa, fb = a.fits[key], b.fits[key]
        assert "error" not in fa and "error" not in fb, (fa, fb)
        for field in ("covariance", "long_run"):
            assert np.array_equal(np.array(fa[field], dtype=float), np.array(fb[field], dtype=float),
                                  equal_nan=True), (key, field)
        va = [(v["name"], v["value"], v["std"]) for v in fa["report"]["base"]]
        assert va == [(v["name"], v["value"], v["std"]) for v in fb["report"]["base"]], key
        assert [lg["samples"] for lg in fa["logs"]] == [lg["samples"] for lg in fb["logs"]]


def test_s3_manifest_equals_the_local_run_and_names_a_missing_object(logs, tmp_path):
    local, remote = logs
    manifest = tmp_path / "s3.csv"
    manifest.write_text("log,robot,model,period,base,tip\n" + "".join(
        f"{e.log},{e.robot},{e.model},{e.period},{BASE},{TIP}\n" for e in remote))
    entries = fleet.read_manifest(str(manifest))
    assert [e.log for e in entries] == [e.log for e in remote]
    ref = fleet.run(local, engine="local", num_cpus=2)
    got = fleet.run(entries, engine="local", num_cpus=2)
    assert not got.failed, got.failed
    assert [lg["name"] for lg in got.fits[("arm-1", "day0")]["logs"]] == [f"s3://{BUCKET}/arm-1/day0.mcap"]
    _assert_identical(got, ref)
    gone = f"s3://{BUCKET}/arm-0/day9.mcap"
    res = fleet.run(entries + [fleet.LogEntry(log=gone, robot="arm-0", model=UR5, period="day0", base=BASE,
                                              tip=TIP)], engine="local", num_cpus=2)
    [failed] = res.failed
    assert failed["log"] == gone and failed["error"].startswith(f"{gone}: cannot read the log from S3"), failed
    _assert_identical(res, ref)


def test_s3_manifest_on_ray_equals_the_local_run(logs, ray_dir):
    """Ray workers read the objects themselves (they inherit the endpoint and credentials
    from the environment the runtime was started in)."""
    import ray
    local, remote = logs
    if ray.is_initialized():  # the shared runtime (conftest) was started without the S3 variables
        ray.shutdown()
    ray.init(num_cpus=2, include_dashboard=False, _temp_dir=ray_dir(), log_to_driver=False)
    try:
        got = fleet.run(remote, engine="ray")
    finally:
        ray.shutdown()
    assert not got.failed, got.failed
    _assert_identical(got, fleet.run(local, engine="local", num_cpus=2))
