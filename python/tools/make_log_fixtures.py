#!/usr/bin/env python3
"""Write the small log fixtures in fixtures/logs/ with Python's mcap-ros2-support writer
(independent of ivdyn's own MCAP writer), so the Rust readers are tested against files
written the way `ros2 bag record -s mcap` writes them (profile ros2, zstd chunks, XCDR1
little endian).

Deterministic: fixed seed, fixed stamps, no wall-clock time. Run from the repository root:

    .venv/bin/python python/tools/make_log_fixtures.py

Files (joint names are those of fixtures/ur5.urdf, in a shuffled order, plus an extra
"gripper_joint" that the URDF does not have):

* ur5_500hz.mcap      2 s at 500 Hz on /joint_states (position + effort, velocity empty),
                      /tf (tf2_msgs/msg/TFMessage) at 50 Hz, and /joint_command
                      (JointState, effort = command) at 250 Hz, stamps offset by 1 ms.
                      zstd chunks of 16 KiB (uncompressed size).
* ur5_lz4.mcap        0.2 s (100 samples), lz4 chunks, position + velocity + effort.
* ur5_plain.mcap      0.1 s, uncompressed chunks, header stamps all zero:
                      only the log time is meaningful.
* ur5_truncated.mcap  the first 25 % of the bytes of ur5_500hz.mcap.
* ur5_nan.mcap        50 samples; sample 17 has a NaN position on elbow_joint.
* ur5_backwards.mcap  50 samples; sample 23 is stamped 5 ms before sample 22.
* ur5_short.csv       20 rows: t, <joint>.q, <joint>.tau for the six UR5 joints.
* ur5_db3_bag/        a rosbag2 directory in Humble's default sqlite3 storage, split in two
                      files (ur5_db3_bag_0.db3, ur5_db3_bag_1.db3) + metadata.yaml, 60
                      samples at 100 Hz (position, velocity, effort of the six UR5 joints),
                      written by the `rosbags` package (python/tests_io/rosbag_writer.py);
                      the seed of the `db3` and `bag` fuzz targets.

The signals: q_j(t) = a_j sin(2 pi f_j t + p_j) + c_j, tau_j = 3 cos(2 pi f_j t) + j
(f_j = 0.5 + 0.25 j Hz), and gripper_joint = 0.01. The Rust tests recompute them.
"""
import math
import os
import random
import sys

from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
OUT = os.path.join(ROOT, "fixtures", "logs")

UR5 = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
       "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]

JOINT_STATE = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""

TF_MESSAGE = """geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Transform
geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"""

T0_NS = 1_700_000_000_000_000_000  # ROS time of the first sample (2023-11-14)


def q_of(j, t):
    """Position of UR5 joint j (URDF order) at time t (s)."""
    f = 0.5 + 0.25 * j
    return 0.3 * (j + 1) / 6 * math.sin(2 * math.pi * f * t + 0.1 * j) + 0.05 * j


def tau_of(j, t):
    f = 0.5 + 0.25 * j
    return 3.0 * math.cos(2 * math.pi * f * t) + j


def qd_of(j, t):
    f = 0.5 + 0.25 * j
    return 0.3 * (j + 1) / 6 * 2 * math.pi * f * math.cos(2 * math.pi * f * t + 0.1 * j)


def shuffled_names():
    rng = random.Random(5)
    names = UR5 + ["gripper_joint"]
    rng.shuffle(names)
    return names


def joint_state(stamp_ns, names, t, velocity=False, effort=True, header_zero=False):
    pos, vel, eff = [], [], []
    for n in names:
        if n == "gripper_joint":
            pos.append(0.01)
            vel.append(0.0)
            eff.append(0.0)
        else:
            j = UR5.index(n)
            pos.append(q_of(j, t))
            vel.append(qd_of(j, t))
            eff.append(tau_of(j, t))
    sec, nsec = divmod(stamp_ns, 1_000_000_000)
    if header_zero:
        sec, nsec = 0, 0
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": ""},
        "name": names,
        "position": pos,
        "velocity": vel if velocity else [],
        "effort": eff if effort else [],
    }


def write(path, samples, rate_hz, compression=CompressionType.ZSTD, chunk_size=64 * 1024,
          velocity=False, with_tf=False, with_command=False, mutate=None, header_zero=False):
    names = shuffled_names()
    with open(path, "wb") as f:
        w = Writer(output=f, chunk_size=chunk_size, compression=compression)
        js = w.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE)
        tf = w.register_msgdef("tf2_msgs/msg/TFMessage", TF_MESSAGE) if with_tf else None
        dt_ns = round(1e9 / rate_hz)
        for k in range(samples):
            stamp = T0_NS + k * dt_ns
            t = k * dt_ns * 1e-9
            msg = joint_state(stamp, names, t, velocity=velocity, header_zero=header_zero)
            if mutate:
                stamp = mutate(k, msg, stamp)
            w.write_message("/joint_states", js, msg, log_time=stamp, publish_time=stamp, sequence=k)
            if with_command and k % 2 == 0:
                # command: 250 Hz, stamped 1 ms after the measurement, effort = 2 * tau
                cs = stamp + 1_000_000
                cmd = joint_state(cs, UR5, t + 1e-3)
                cmd["position"] = []
                cmd["effort"] = [2 * v for v in cmd["effort"]]
                w.write_message("/joint_command", js, cmd, log_time=cs, publish_time=cs, sequence=k // 2)
            if with_tf and k % 10 == 0:
                sec, nsec = divmod(stamp, 1_000_000_000)
                tfm = {"transforms": [{
                    "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": "base_link"},
                    "child_frame_id": "tool0",
                    "transform": {"translation": {"x": 0.1, "y": 0.0, "z": 0.5},
                                  "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}]}
                w.write_message("/tf", tf, tfm, log_time=stamp, publish_time=stamp, sequence=k // 10)
        w.finish()
    return os.path.getsize(path)


def write_db3_bag(path):
    """ur5_db3_bag/ (see the module doc); returns its size in bytes."""
    import shutil

    import numpy as np

    sys.path.insert(0, os.path.join(ROOT, "python", "tests_io"))
    from rosbag_writer import write_bag

    t = np.arange(60) / 100.0
    log = {"t": t, "joint_names": UR5,
           "q": np.array([[q_of(j, x) for j in range(6)] for x in t]),
           "qd": np.array([[qd_of(j, x) for j in range(6)] for x in t]),
           "tau": np.array([[tau_of(j, x) for j in range(6)] for x in t])}
    shutil.rmtree(path, ignore_errors=True)
    write_bag(path, log, storage="sqlite3", split=2)
    return sum(os.path.getsize(os.path.join(path, f)) for f in os.listdir(path))


def main():
    os.makedirs(OUT, exist_ok=True)
    p = lambda name: os.path.join(OUT, name)
    sizes = {}
    sizes["ur5_500hz.mcap"] = write(p("ur5_500hz.mcap"), 1000, 500.0, with_tf=True, with_command=True,
                                    chunk_size=16 * 1024)
    sizes["ur5_lz4.mcap"] = write(p("ur5_lz4.mcap"), 100, 500.0, compression=CompressionType.LZ4,
                                  velocity=True)
    sizes["ur5_plain.mcap"] = write(p("ur5_plain.mcap"), 50, 500.0, compression=CompressionType.NONE,
                                    header_zero=True)

    data = open(p("ur5_500hz.mcap"), "rb").read()
    with open(p("ur5_truncated.mcap"), "wb") as f:
        f.write(data[: int(len(data) * 0.25)])
    sizes["ur5_truncated.mcap"] = os.path.getsize(p("ur5_truncated.mcap"))

    def nan(k, msg, stamp):
        if k == 17:
            msg["position"][msg["name"].index("elbow_joint")] = float("nan")
        return stamp

    sizes["ur5_nan.mcap"] = write(p("ur5_nan.mcap"), 50, 500.0, mutate=nan)

    def back(k, msg, stamp):
        if k == 23:
            stamp -= 7_000_000  # 5 ms before sample 22
            sec, nsec = divmod(stamp, 1_000_000_000)
            msg["header"]["stamp"] = {"sec": sec, "nanosec": nsec}
        return stamp

    sizes["ur5_backwards.mcap"] = write(p("ur5_backwards.mcap"), 50, 500.0, mutate=back)

    with open(p("ur5_short.csv"), "w") as f:
        f.write("# 20 samples at 100 Hz of the fixture signals (see make_log_fixtures.py)\n")
        cols = ["t"] + [f"{j}.q" for j in UR5] + [f"{j}.tau" for j in UR5] + ["gripper_joint.q"]
        f.write(",".join(cols) + "\n")
        for k in range(20):
            t = k * 0.01
            row = [t] + [q_of(j, t) for j in range(6)] + [tau_of(j, t) for j in range(6)] + [0.01]
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    sizes["ur5_short.csv"] = os.path.getsize(p("ur5_short.csv"))

    sizes["ur5_db3_bag/"] = write_db3_bag(p("ur5_db3_bag"))

    for k, v in sizes.items():
        print(f"{k:22s} {v:8d} bytes")
    print(f"{'total':22s} {sum(sizes.values()):8d} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
