"""`ivdyn identify --out-mcap` read by Python's mcap / mcap-ros2-support (an independent
decoder), the prediction checked with the independent NumPy reference (python/reference).

The binary is the one `make test` builds (its Rust test build, first); otherwise it is
built here. Checked: three JointState topics on the same stamps with the URDF joint names,
residual == measured - predicted exactly, the measured copy equal to the input log, and
predicted == rnea_ref(q, qd, qdd; theta) with theta from the reported parameter file, q
and qd the smoothed state the prediction carries and qdd its second difference (the
formula ivdyn's conditioning uses).
"""
import json
import os
import subprocess
import sys

import numpy as np

import mcap.reader as mcap_reader
import mcap_ros2.decoder as mcap_ros2_decoder

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "python", "reference"))
from ivdyn_ref.model import from_urdf  # noqa: E402
from ivdyn_ref.dynamics import rnea  # noqa: E402

UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
CHAIN = ["--urdf", UR5, "--base", "base_link", "--tip", "tool0"]




def read_topics(path):
    out = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        summary = reader.get_summary()
        schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        for _, channel, message, ros in reader.iter_decoded_messages():
            stamp = ros.header.stamp.sec * 1_000_000_000 + ros.header.stamp.nanosec
            assert message.log_time == stamp
            out.setdefault(channel.topic, []).append(
                (stamp, list(ros.name), np.array(ros.position), np.array(ros.velocity), np.array(ros.effort)))
    return schemas, out


def test_out_mcap_read_by_python(tmp_path, ivdyn_bin):
    exe = ivdyn_bin
    log, params, pred = tmp_path / "log.mcap", tmp_path / "params.json", tmp_path / "pred.mcap"
    subprocess.run([exe, "simulate", *CHAIN, "--duration", "6", "--seed", "12", "--noise", "0.05",
                    "--fc", "2,2,1.5,0.6,0.6,0.4", "--fv", "0.8,0.8,0.5,0.2,0.2,0.1",
                    "--out", str(log), "--quiet"], check=True, capture_output=True)
    # velocities from positions: the check below rebuilds qdd from the predicted q
    subprocess.run([exe, "identify", *CHAIN, "--log", str(log), "--velocity", "positions", "--out-params",
                    str(params), "--out-mcap", str(pred), "--quiet"], check=True, capture_output=True)

    schemas, topics = read_topics(pred)
    assert schemas == {t: "sensor_msgs/msg/JointState" for t in ["/ivdyn/measured", "/ivdyn/predicted", "/ivdyn/residual"]}
    _, source = read_topics(log)
    meas, prd, res = topics["/ivdyn/measured"], topics["/ivdyn/predicted"], topics["/ivdyn/residual"]
    model = from_urdf(UR5, "base_link", "tool0")
    assert len(meas) == len(prd) == len(res) == len(source["/joint_states"]) == 3000
    for m, p, r, s in zip(meas, prd, res, source["/joint_states"]):
        assert m[0] == p[0] == r[0] == s[0]                      # same stamps as the input log
        assert m[1] == p[1] == r[1] == model.joint_names
        assert np.array_equal(m[2], s[2]) and np.array_equal(m[4], s[4])   # measured copy
        assert len(r[2]) == 0 and len(r[3]) == 0
        assert np.array_equal(r[4], m[4] - p[4])                  # residual, exactly

    # predicted == reference inverse dynamics with the identified parameters
    pf = json.load(open(params))
    theta = np.array(pf["theta"])
    # the Coulomb shapes identify chose (absent: the sign on every joint)
    coulomb = None if pf.get("coulomb") is None else [(c["v_scale"], c["asym"]) for c in pf["coulomb"]]
    stamps = np.array([p[0] for p in prd], dtype=np.int64)
    dt = np.median(np.diff(stamps)) * 1e-9
    Q = np.array([p[2] for p in prd])
    QD = np.array([p[3] for p in prd])
    QDD = (Q[2:] - 2.0 * Q[1:-1] + Q[:-2]) / (dt * dt)
    tau_pred = np.array([p[4] for p in prd])[1:-1]
    every = slice(0, None, 7)   # the plain NumPy reference is slow; 428 samples suffice
    Q, QD, QDD, tau_pred = Q[1:-1][every], QD[1:-1][every], QDD[every], tau_pred[every]
    ref = np.array([rnea(model, q, qd, qdd, theta=theta, coulomb=coulomb) for q, qd, qdd in zip(Q, QD, QDD)])
    scale = np.abs(tau_pred).max()
    err = np.abs(ref - tau_pred).max()
    assert err < 1e-8 * scale, (err, scale)
