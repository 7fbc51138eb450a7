//! A rosbag2 directory as `--log` and `--validate` (what `ros2 bag record` writes): the
//! same fit as the MCAP file inside it, in memory and streamed; a directory is no more
//! "Is a directory (os error 21)". Bags from an independent writer (Python `rosbags`,
//! mcap and sqlite3, split, compressed) are in python/tests_io/test_rosbag2.py.
use crate::util;
use util::*;

/// The `base` values of an identify JSON report.
fn base(p: &std::path::Path) -> Vec<f64> {
    json(p)["base"].as_array().unwrap().iter().map(|b| b["value"].as_f64().unwrap()).collect()
}

#[test]
fn identify_reads_a_bag_directory_as_its_file() {
    let d = tmpdir("bag");
    let log = d.join("log.mcap");
    ok(&run(ur5_cmd("simulate", &["--noise", "0.05", "--duration", "4", "--seed", "5", "--out", &s(&log)])));
    // the directory `ros2 bag record -s mcap -o rec` writes, one file
    let bag = d.join("rec");
    std::fs::create_dir(&bag).unwrap();
    std::fs::copy(&log, bag.join("rec_0.mcap")).unwrap();
    let meta = "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  message_count: 2000\n  \
                topics_with_message_count:\n    - topic_metadata:\n        name: /joint_states\n        \
                type: sensor_msgs/msg/JointState\n        serialization_format: cdr\n      message_count: 2000\n  \
                compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - rec_0.mcap\n";
    std::fs::write(bag.join("metadata.yaml"), meta).unwrap();
    for (extra, tag) in [(&[][..], "mem"), (&["--stream"][..], "stream")] {
        let identify = |input: &std::path::Path, out: &std::path::Path| {
            let mut args = vec!["--log", input.to_str().unwrap(), "--validate", input.to_str().unwrap()];
            args.extend(extra);
            args.extend(["--json", out.to_str().unwrap()]);
            run(ur5_cmd("identify", &args))
        };
        let (a, b) = (d.join(format!("file_{tag}.json")), d.join(format!("bag_{tag}.json")));
        ok(&identify(&log, &a));
        let out = identify(&bag, &b);
        assert!(!String::from_utf8_lossy(&out.stderr).contains("Is a directory"));
        ok(&out);
        assert_eq!(base(&a), base(&b), "{tag}");
        assert_eq!(json(&b)["streamed"], serde_json::json!(tag == "stream"), "{tag}");
        assert_eq!(json(&a)["streamed"], json(&b)["streamed"], "{tag}");
    }
    // without metadata.yaml: the same fit, and the report says how the files were found
    std::fs::remove_file(bag.join("metadata.yaml")).unwrap();
    let (a, c) = (d.join("file_alone.json"), d.join("bag_nometa.json"));
    ok(&run(ur5_cmd("identify", &["--log", log.to_str().unwrap(), "--json", a.to_str().unwrap()])));
    ok(&run(ur5_cmd("identify", &["--log", bag.to_str().unwrap(), "--json", c.to_str().unwrap()])));
    assert_eq!(base(&c), base(&a));
    let notes = json(&c)["notes"].to_string();
    assert!(notes.contains("metadata.yaml") && notes.contains("rec_0.mcap"), "{notes}");
}
