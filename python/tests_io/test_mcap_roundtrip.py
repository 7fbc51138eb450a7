"""ivdyn's MCAP writer -> Python's mcap_ros2 reader (the independent decoder).

Builds and runs the Rust example `write_log` (crates/ivdyn/examples/write_log.rs), then
decodes its output with mcap-ros2-support (both required: `make test` installs them). The reverse direction (Python writer -> Rust reader) is covered by the Rust tests
on fixtures/logs/ (python/tools/make_log_fixtures.py).
"""
import math
import os
import shutil
import subprocess

import pytest

import mcap.reader as mcap_reader
import mcap_ros2.decoder as mcap_ros2_decoder

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
T0 = 1_700_000_000_000_000_000


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("mcap") / "ivdyn_out.mcap"
    # `make test` builds the example beside the Rust tests (Makefile, rust-build); reuse it
    # (a `cargo run -p ivdyn` here would rebuild with another feature set).
    exe = os.path.join(ROOT, "target", "debug", "examples", "write_log")
    if os.path.exists(exe):
        subprocess.run([exe, str(out), "250"], cwd=ROOT, check=True)
    else:
        cargo = shutil.which("cargo")
        assert cargo is not None, "cargo must be on PATH to build the writer example"
        subprocess.run([cargo, "run", "-q", "-p", "ivdyn", "--example", "write_log", "--", str(out), "250"],
                       cwd=ROOT, check=True)
    return out


def test_python_decodes_ivdyn_output(written):
    with open(written, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        header = reader.get_header()
        assert header.profile == "ros2"
        summary = reader.get_summary()
        topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        assert topics == {t: "sensor_msgs/msg/JointState"
                          for t in ["/joint_states", "/ivdyn/predicted", "/ivdyn/residual"]}
        counts = {t: 0 for t in topics}
        for schema, channel, message, ros in reader.iter_decoded_messages():
            k = counts[channel.topic]
            counts[channel.topic] += 1
            stamp = T0 + k * 1_000_000
            assert message.log_time == stamp
            assert ros.header.stamp.sec * 1_000_000_000 + ros.header.stamp.nanosec == stamp
            assert list(ros.name) == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"]
            tau = [2.0 * j + 0.001 * k for j in range(3)]
            if channel.topic == "/joint_states":
                assert list(ros.position) == pytest.approx([math.sin(0.01 * k + j) for j in range(3)], rel=0, abs=1e-15)
                assert list(ros.velocity) == pytest.approx([math.cos(0.01 * k + j) for j in range(3)], rel=0, abs=1e-15)
                assert list(ros.effort) == tau
            else:
                assert len(ros.position) == 0 and len(ros.velocity) == 0
                scale = 0.9 if channel.topic == "/ivdyn/predicted" else 0.1
                assert list(ros.effort) == pytest.approx([scale * v for v in tau], rel=1e-15, abs=1e-15)
        assert counts == {t: 250 for t in topics}
