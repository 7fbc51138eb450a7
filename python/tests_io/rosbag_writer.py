"""Writes a joint log as `ros2 bag record` would, with an independent writer: the
`rosbags` package (pure Python, its own CDR serialiser and its own mcap and sqlite3
storage), and the single-file reference with `mcap-ros2-support`.

rosbags' Writer does not split, so a split bag is made as rosbag2's recorder makes one:
consecutive pieces of the recording, one file each, named `<bag>_0`, `<bag>_1`, ... and
listed in order in one `metadata.yaml` (the pieces' metadata merged).
"""
import io
import os
import shutil

import numpy as np
from mcap_ros2.writer import Writer as McapRos2Writer
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.writer import CompressionFormat, CompressionMode
from rosbags.typesys import Stores, get_typestore
from ruamel.yaml import YAML

T0_NS = 1_700_000_000_000_000_000
TOPIC = "/joint_states"
TS = get_typestore(Stores.ROS2_HUMBLE)
JointState = TS.types["sensor_msgs/msg/JointState"]
Header = TS.types["std_msgs/msg/Header"]
Time = TS.types["builtin_interfaces/msg/Time"]

MSGDEF = """std_msgs/Header header
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


def stamps_ns(log):
    """The message stamps: T0 + t, rounded to the nanosecond."""
    return T0_NS + np.round(np.asarray(log["t"]) * 1e9).astype(np.int64)


def _rows(log):
    q, qd, tau = (np.asarray(log[k], dtype=np.float64) for k in ("q", "qd", "tau"))
    for k, s in enumerate(stamps_ns(log)):
        yield int(s), q[k], qd[k], tau[k]


def write_single_mcap(path, log):
    """The reference: one MCAP file (mcap-ros2-support), the same stamps and values."""
    names = list(log["joint_names"])
    with open(path, "wb") as f:
        w = McapRos2Writer(output=f)
        schema = w.register_msgdef("sensor_msgs/msg/JointState", MSGDEF)
        for s, q, qd, tau in _rows(log):
            msg = {"header": {"stamp": {"sec": s // 10**9, "nanosec": s % 10**9}, "frame_id": ""},
                   "name": names, "position": q.tolist(), "velocity": qd.tolist(), "effort": tau.tolist()}
            w.write_message(topic=TOPIC, schema=schema, message=msg, log_time=s, publish_time=s)
        w.finish()


def _write_piece(path, names, rows, storage, compression):
    w = Writer(path, version=9, storage_plugin=storage)
    if compression is not None:
        w.set_compression(compression, CompressionFormat.ZSTD)
    with w:
        conn = w.add_connection(TOPIC, JointState.__msgtype__, typestore=TS)
        # an unrelated topic, as real bags have (/tf, /rosout, ...): skipped by the reader
        other = w.add_connection("/rosout_count", "std_msgs/msg/Int32", typestore=TS)
        for k, (s, q, qd, tau) in enumerate(rows):
            msg = JointState(header=Header(stamp=Time(sec=s // 10**9, nanosec=s % 10**9), frame_id=""),
                             name=names, position=q, velocity=qd, effort=tau)
            w.write(conn, s, TS.serialize_cdr(msg, JointState.__msgtype__))
            if k % 100 == 0:
                w.write(other, s, TS.serialize_cdr(TS.types["std_msgs/msg/Int32"](data=k), "std_msgs/msg/Int32"))


def write_bag(path, log, storage="mcap", split=1, compression=None):
    """A rosbag2 directory at `path` (must not exist): `storage` "mcap" or "sqlite3",
    `split` files, `compression` None, "file" or "message" (zstd)."""
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    mode = {None: None, "file": CompressionMode.FILE, "message": CompressionMode.MESSAGE}[compression]
    names = list(log["joint_names"])
    rows = list(_rows(log))
    if split == 1:
        _write_piece(path, names, rows, plugin, mode)
        return
    yaml = YAML(typ="safe")
    os.makedirs(path)
    bag = os.path.basename(os.fspath(path))
    merged, files = None, []
    for i, piece in enumerate(np.array_split(np.arange(len(rows)), split)):
        tmp = os.fspath(path) + f".piece{i}"
        _write_piece(tmp, names, [rows[k] for k in piece], plugin, mode)
        with open(os.path.join(tmp, "metadata.yaml")) as f:
            meta = yaml.load(f)
        info = meta["rosbag2_bagfile_information"]
        (src,) = info["relative_file_paths"]
        dst = f"{bag}_{i}" + src[len(os.path.basename(tmp)):]   # keep .mcap / .db3 (+ .zstd)
        shutil.move(os.path.join(tmp, src), os.path.join(path, dst))
        shutil.rmtree(tmp)
        files.append(dst)
        if merged is None:
            merged = meta
        else:
            m = merged["rosbag2_bagfile_information"]
            m["message_count"] += info["message_count"]
            for a, b in zip(m["topics_with_message_count"], info["topics_with_message_count"]):
                assert a["topic_metadata"]["name"] == b["topic_metadata"]["name"]
                a["message_count"] += b["message_count"]
            m["files"] = m.get("files", []) + info.get("files", [])
    m = merged["rosbag2_bagfile_information"]
    m["relative_file_paths"] = files
    for f, name in zip(m.get("files", []), files):
        f["path"] = name
    out = io.StringIO()
    yaml.dump(merged, out)
    with open(os.path.join(path, "metadata.yaml"), "w") as f:
        f.write(out.getvalue())
