"""residuals.mcap of `ivdyn diagnose` (crates/ivdyn/src/diagnose/report.rs) -> Python's
mcap_ros2 reader (the independent decoder).

Runs `ivdyn diagnose` on the MuJoCo log fixtures/diagnose/viscous_payload.mcap (UR5,
2 s at 1 kHz, header stamps 1.7e9 s + k ms) and decodes its residuals.mcap: the topics of
docs/diagnose.md, JointState messages on the log's own stamps on every topic, residual =
measured effort - predicted effort, `final` equal to the last step's prediction, and the
measured effort equal to the log's.
"""
import os
import re
import subprocess

import numpy as np
import pytest

import mcap.reader as mcap_reader
import mcap_ros2.decoder as mcap_ros2_decoder

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
T0 = 1_700_000_000_000_000_000  # the log's first stamp (docs/diagnose-data.md)
LOG = os.path.join(ROOT, "fixtures", "diagnose", "viscous_payload.mcap")
UR5 = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
VOCABULARY = {"coulomb_friction", "viscous_friction", "stribeck_friction", "armature", "payload",
              "torque_offset", "joint_spring"}
FIXED = ["/ivdyn/measured", "/ivdyn/predicted/nominal", "/ivdyn/predicted/final",
         "/ivdyn/residual/nominal", "/ivdyn/residual/final"]


@pytest.fixture(scope="module")
def decoded(tmp_path_factory, ivdyn_bin):
    out = tmp_path_factory.mktemp("diag")
    args = ["diagnose", "--urdf", os.path.join(ROOT, "fixtures", "ur5.urdf"), "--base", "base_link", "--tip", "tool0",
            "--log", LOG, "--out", str(out), "--quiet"]
    subprocess.run([ivdyn_bin, *args], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    path = out / "residuals.mcap"
    msgs = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        for _, channel, message, ros in reader.iter_decoded_messages():
            assert list(ros.name) == UR5
            stamp = ros.header.stamp.sec * 1_000_000_000 + ros.header.stamp.nanosec
            assert message.log_time == stamp
            msgs.setdefault(channel.topic, []).append((stamp, list(ros.position), list(ros.velocity), list(ros.effort)))
    assert (out / "report.html").exists()
    return schemas, msgs


def test_topics(decoded):
    schemas, msgs = decoded
    assert set(schemas.values()) == {"sensor_msgs/msg/JointState"}
    steps = sorted(t for t in schemas if t not in FIXED)
    assert set(FIXED) <= set(schemas)
    for i, topic in enumerate(sorted(steps, key=lambda t: int(re.search(r"step(\d+)_", t).group(1))), start=1):
        m = re.fullmatch(r"/ivdyn/predicted/step(\d+)_([a-z_]+)", topic)
        assert m, topic
        assert int(m.group(1)) == i and m.group(2) in VOCABULARY, topic


def test_stamps_and_fields(decoded):
    _, msgs = decoded
    n = len(msgs["/ivdyn/measured"])
    # the diagnosis drops the filters' edge samples at both ends; what is left keeps the
    # log's own stamps, 1 ms apart
    assert 1500 < n < 2000
    first = msgs["/ivdyn/measured"][0][0]
    assert (first - T0) % 1_000_000 == 0 and 0 < first - T0 < 250_000_000
    want = [first + k * 1_000_000 for k in range(n)]
    for topic, rows in msgs.items():
        assert [r[0] for r in rows] == want, topic
        if topic == "/ivdyn/measured":
            assert all(len(r[1]) == 6 and len(r[2]) == 6 and len(r[3]) == 6 for r in rows)
        else:
            assert all(len(r[1]) == 0 and len(r[2]) == 0 and len(r[3]) == 6 for r in rows), topic


def test_residual_is_measured_minus_predicted(decoded):
    _, msgs = decoded
    effort = {t: np.array([r[3] for r in rows]) for t, rows in msgs.items()}
    tau = effort["/ivdyn/measured"]
    for which in ["nominal", "final"]:
        res = tau - effort[f"/ivdyn/predicted/{which}"]
        np.testing.assert_allclose(effort[f"/ivdyn/residual/{which}"], res, rtol=0, atol=1e-12)
    steps = sorted((t for t in effort if t.startswith("/ivdyn/predicted/step")),
                   key=lambda t: int(re.search(r"step(\d+)_", t).group(1)))
    last = effort[steps[-1]] if steps else effort["/ivdyn/predicted/nominal"]
    np.testing.assert_array_equal(effort["/ivdyn/predicted/final"], last)
    # the measured effort is the log's own (read independently with mcap_ros2)
    k0 = (msgs["/ivdyn/measured"][0][0] - T0) // 1_000_000
    with open(LOG, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        logged = np.array([list(ros.effort) for _, _, _, ros in reader.iter_decoded_messages(topics=["/joint_states"])])
    np.testing.assert_array_equal(tau, logged[k0:k0 + len(tau)])
    # the nominal model misses something in this log, and the final model removes part of it
    rms = lambda x: np.sqrt(np.mean(x ** 2, axis=0))
    assert rms(effort["/ivdyn/residual/final"]).sum() < rms(effort["/ivdyn/residual/nominal"]).sum()
