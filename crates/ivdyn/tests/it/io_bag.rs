//! ROS 2 bags as logs (log/bag.rs, log/db3.rs): rosbag2 directories built here (MCAP
//! files from ivdyn's writer, sqlite3 files through rusqlite with rosbag2's schema,
//! metadata.yaml as rosbag2 writes it), each read against the same samples written as
//! one MCAP file. Independent writers (Python `rosbags`) are in python/tests_io/test_rosbag2.py.

use crate::scratch::ScratchFile;
use std::path::{Path, PathBuf};

use ivdyn::log::{self, JointLog, ReadOptions, for_each_sample, read_joint_log, read_mcap, write_mcap};

const T0_NS: i64 = 1_700_000_000_000_000_000;
const JOINTS: [&str; 2] = ["a", "b"];

/// A fresh bag directory for one test: `bag` in a scratch directory, so that the files
/// written beside it (`split_mcap`'s single file) go with it when the test passes.
fn dir(name: &str) -> ScratchFile {
    let d = ScratchFile::new("ivdyn-io-bag", name);
    std::fs::create_dir_all(&*d).unwrap();
    d
}

/// `t` samples at 100 Hz from `first`, with position, velocity and effort.
fn log_rows(first: usize, t: usize) -> JointLog {
    let n = JOINTS.len();
    let mut l = JointLog {
        joint_names: JOINTS.iter().map(|s| s.to_string()).collect(),
        t0_ns: T0_NS + first as i64 * 10_000_000,
        ..JointLog::default()
    };
    let (mut qd, mut tau) = (vec![], vec![]);
    for k in 0..t {
        let s = (first + k) as f64 * 0.01;
        l.t.push(k as f64 * 0.01);
        for j in 0..n {
            l.q.push((s + j as f64).sin());
            qd.push((s + j as f64).cos());
            tau.push(0.5 * j as f64 + s);
        }
    }
    l.qd = Some(qd);
    l.tau = Some(tau);
    l
}

fn opts() -> ReadOptions {
    ReadOptions::new(&JOINTS)
}

/// A rosbag2 `metadata.yaml` (version 9, as `ros2 bag record` writes it) listing `files`.
fn metadata(storage: &str, files: &[&str], count: u64, compression: &str) -> String {
    let list: String = files.iter().map(|f| format!("    - {f}\n")).collect();
    let mode = if compression.is_empty() { "" } else { "file" };
    format!(
        "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: {storage}\n  duration:\n    nanoseconds: 0\n  \
         starting_time:\n    nanoseconds_since_epoch: {T0_NS}\n  message_count: {count}\n  topics_with_message_count:\n    \
         - topic_metadata:\n        name: /joint_states\n        type: sensor_msgs/msg/JointState\n        \
         serialization_format: cdr\n        offered_qos_profiles: []\n        type_description_hash: RIHS01_00\n      \
         message_count: {count}\n  compression_format: \"{compression}\"\n  compression_mode: \"{mode}\"\n  \
         relative_file_paths:\n{list}  files: []\n  custom_data: ~\n  ros_distro: jazzy\n"
    )
}

/// 90 samples as one MCAP file, and as a bag split into three MCAP files `names`.
fn split_mcap(d: &Path, names: [&str; 3]) -> PathBuf {
    let single = d.with_extension("mcap");
    write_mcap(&single, &log_rows(0, 90), &[]).unwrap();
    for (i, name) in names.iter().enumerate() {
        write_mcap(d.join(name), &log_rows(30 * i, 30), &[]).unwrap();
    }
    single
}

#[test]
fn split_mcap_bag_reads_as_the_single_file() {
    let d = dir("split");
    let single = split_mcap(&d, ["run_0.mcap", "run_1.mcap", "run_2.mcap"]);
    std::fs::write(d.join("metadata.yaml"), metadata("mcap", &["run_0.mcap", "run_1.mcap", "run_2.mcap"], 90, ""))
        .unwrap();
    let want = read_mcap(&single, &opts()).unwrap();
    assert_eq!(want.len(), 90);
    assert_eq!(read_mcap(&d, &opts()).unwrap(), want);
    // the path every caller takes (`--log DIR`, Python): no more "Is a directory"
    assert_eq!(read_joint_log(&d, &want.joint_names, "/joint_states", None).unwrap(), want);
    assert_eq!(log::read_pipeline_log(&d, &opts()).unwrap(), want);
    // the streamed identify's count comes from metadata.yaml
    assert_eq!(log::message_count(&d, "/joint_states").unwrap(), Some(90));
    assert_eq!(log::message_count(&d, "/other").unwrap(), None);
    let files = log::log_files(&d).unwrap();
    assert_eq!(files.files.len(), 3);
    assert!(files.notes.is_empty());
}

#[test]
fn without_metadata_the_files_are_read_by_split_index() {
    // names whose text order (run_10 < run_2) is not the recording order
    let d = dir("nometa");
    let single = split_mcap(&d, ["run_2.mcap", "run_7.mcap", "run_10.mcap"]);
    std::fs::write(d.join("notes.txt"), "not a bag file").unwrap();
    let want = read_mcap(&single, &opts()).unwrap();
    assert_eq!(read_mcap(&d, &opts()).unwrap(), want);
    let summary = for_each_sample(&d, &opts(), |_| Ok(())).unwrap();
    assert_eq!(summary.measured, 90);
    assert_eq!(summary.notes.len(), 1);
    assert!(
        summary.notes[0].contains("metadata.yaml") && summary.notes[0].contains("run_2.mcap, run_7.mcap, run_10.mcap")
    );
    // summed from the files' MCAP summaries
    assert_eq!(log::message_count(&d, "/joint_states").unwrap(), Some(90));
    // an unreadable metadata.yaml is treated as missing
    std::fs::write(d.join("metadata.yaml"), "rosbag2_bagfile_information: [not, a, map]").unwrap();
    assert_eq!(read_mcap(&d, &opts()).unwrap(), want);
    assert!(log::log_files(&d).unwrap().notes[0].contains("not rosbag2 metadata"));
    // a folder of unrelated logs is not one recording: refused, not concatenated
    write_mcap(d.join("other.mcap"), &log_rows(0, 10), &[]).unwrap();
    let e = read_mcap(&d, &opts()).unwrap_err().to_string();
    assert!(e.contains("not the split files") && e.contains("other.mcap"), "{e}");
    let lone = dir("lone");
    write_mcap(lone.join("anything.mcap"), &log_rows(0, 90), &[]).unwrap();
    assert_eq!(read_mcap(&lone, &opts()).unwrap(), want);
}

#[test]
fn files_out_of_order_are_refused_naming_the_file() {
    let d = dir("order");
    split_mcap(&d, ["run_0.mcap", "run_1.mcap", "run_2.mcap"]);
    std::fs::write(d.join("metadata.yaml"), metadata("mcap", &["run_0.mcap", "run_2.mcap", "run_1.mcap"], 90, ""))
        .unwrap();
    let e = read_mcap(&d, &opts()).unwrap_err().to_string();
    assert!(e.contains("run_1.mcap") && e.contains("goes back"), "{e}");
}

#[test]
fn bad_metadata_is_named() {
    let d = dir("badmeta");
    split_mcap(&d, ["run_0.mcap", "run_1.mcap", "run_2.mcap"]);
    let cases = [
        (
            metadata("mcap", &["run_0.mcap", "run_1.mcap", "run_9.mcap"], 90, ""),
            "run_9.mcap listed in relative_file_paths is missing",
        ),
        (metadata("rosbag_v2", &["run_0.mcap"], 30, ""), "storage_identifier 'rosbag_v2'"),
        (metadata("mcap", &["run_0.mcap"], 30, "lz4"), "compression_format 'lz4'"),
        (metadata("mcap", &[], 30, ""), "relative_file_paths lists no file"),
        // a path out of the bag is looked up by its file name inside it only
        (
            metadata("mcap", &["../outside/run_5.mcap"], 30, ""),
            "../outside/run_5.mcap listed in relative_file_paths is missing",
        ),
    ];
    for (yaml, want) in cases {
        std::fs::write(d.join("metadata.yaml"), yaml).unwrap();
        let e = read_mcap(&d, &opts()).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("metadata.yaml"), "{e}");
    }
    // ../outside/run_5.mcap exists beside the bag: it is not read
    let outside = d.parent().unwrap().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::copy(d.join("run_0.mcap"), outside.join("run_5.mcap")).unwrap();
    std::fs::write(d.join("metadata.yaml"), metadata("mcap", &["../outside/run_5.mcap"], 30, "")).unwrap();
    let e = read_mcap(&d, &opts()).unwrap_err().to_string();
    assert!(e.contains("run_5.mcap listed in relative_file_paths is missing"), "{e}");
    std::fs::write(d.join("metadata.yaml"), metadata("mcap", &["../outside/run_0.mcap"], 30, "")).unwrap();
    assert_eq!(read_mcap(&d, &opts()).unwrap().t.len(), 30, "by its file name, inside the bag");
    let empty = dir("empty");
    let e = read_mcap(&empty, &opts()).unwrap_err().to_string();
    assert!(e.contains("no .mcap or .db3 file"), "{e}");
}

/// A rosbag2 sqlite3 file with `rows` on /joint_states (CDR from ivdyn's encoder) and a
/// second topic; the messages inserted out of time order (the reader sorts).
fn write_db3(path: &Path, l: &JointLog) {
    let db = rusqlite::Connection::open(path).unwrap();
    db.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
         serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         INSERT INTO topics VALUES (1, '/rosout', 'rcl_interfaces/msg/Log', 'cdr', '');
         INSERT INTO topics VALUES (2, '/joint_states', 'sensor_msgs/msg/JointState', 'cdr', '');",
    )
    .unwrap();
    let n = l.dof();
    let mut order: Vec<usize> = (0..l.len()).collect();
    order.reverse();
    for k in order {
        let stamp = l.t0_ns + (l.t[k] * 1e9).round() as i64;
        let m = log::cdr::JointState {
            sec: (stamp / 1_000_000_000) as i32,
            nanosec: (stamp % 1_000_000_000) as u32,
            frame_id: String::new(),
            name: l.joint_names.clone(),
            position: l.q[k * n..(k + 1) * n].to_vec(),
            velocity: l.qd.as_ref().unwrap()[k * n..(k + 1) * n].to_vec(),
            effort: l.tau.as_ref().unwrap()[k * n..(k + 1) * n].to_vec(),
        };
        let data = log::cdr::encode_joint_state(&m);
        db.execute(
            "INSERT INTO messages(topic_id, timestamp, data) VALUES (2, ?1, ?2)",
            rusqlite::params![stamp, data],
        )
        .unwrap();
        db.execute("INSERT INTO messages(topic_id, timestamp, data) VALUES (1, ?1, x'00')", [stamp]).unwrap();
    }
}

#[test]
fn db3_file_and_split_db3_bag_read_as_the_mcap() {
    let d = dir("db3");
    let single = d.with_extension("mcap");
    write_mcap(&single, &log_rows(0, 60), &[]).unwrap();
    let want = read_mcap(&single, &opts()).unwrap();
    write_db3(&d.join("rec_0.db3"), &log_rows(0, 20));
    write_db3(&d.join("rec_1.db3"), &log_rows(20, 40));
    // one file
    let first = read_mcap(d.join("rec_0.db3"), &opts()).unwrap();
    assert_eq!(first, want.rows(&(0..20).collect::<Vec<_>>()));
    // the bag
    std::fs::write(d.join("metadata.yaml"), metadata("sqlite3", &["rec_0.db3", "rec_1.db3"], 60, "")).unwrap();
    assert_eq!(read_joint_log(&d, &want.joint_names, "/joint_states", None).unwrap(), want);
    // compressed as a whole (compression_mode: file)
    for f in ["rec_0.db3", "rec_1.db3"] {
        let raw = std::fs::read(d.join(f)).unwrap();
        std::fs::write(d.join(format!("{f}.zstd")), zstd::encode_all(&raw[..], 3).unwrap()).unwrap();
        std::fs::remove_file(d.join(f)).unwrap();
    }
    std::fs::write(d.join("metadata.yaml"), metadata("sqlite3", &["rec_0.db3.zstd", "rec_1.db3.zstd"], 60, "zstd"))
        .unwrap();
    assert_eq!(read_mcap(&d, &opts()).unwrap(), want);
}

#[test]
fn db3_with_another_schema_names_the_table() {
    let d = dir("db3schema");
    let no_topics = d.join("a.db3");
    rusqlite::Connection::open(&no_topics).unwrap().execute_batch("CREATE TABLE t(x INTEGER);").unwrap();
    let e = read_mcap(&no_topics, &opts()).unwrap_err().to_string();
    assert!(e.contains("a.db3") && e.contains("table 'topics'"), "{e}");
    let no_messages = d.join("b.db3");
    rusqlite::Connection::open(&no_messages)
        .unwrap()
        .execute_batch(
            "CREATE TABLE topics(id INTEGER, name TEXT, type TEXT, serialization_format TEXT);
             INSERT INTO topics VALUES (1, '/joint_states', 'sensor_msgs/msg/JointState', 'cdr');
             CREATE TABLE messages(id INTEGER, topic INTEGER, stamp INTEGER);",
        )
        .unwrap();
    let e = read_mcap(&no_messages, &opts()).unwrap_err().to_string();
    assert!(e.contains("b.db3") && e.contains("table 'messages'"), "{e}");
    // the wanted topic absent: named, with what the file has
    let other = d.join("c.db3");
    write_db3(&other, &log_rows(0, 10));
    let e = read_mcap(&other, &opts().topic("/arm/joint_states")).unwrap_err().to_string();
    assert!(
        e.contains("/arm/joint_states not found") && e.contains("/joint_states (sensor_msgs/msg/JointState)"),
        "{e}"
    );
}
