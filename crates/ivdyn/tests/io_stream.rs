//! Streaming: a log larger than the memory the reader may use is read with bounded
//! memory (resident set measured from /proc/self/status while the callback runs).

use ivdyn::log::{Compression, McapWriter, ReadOptions, for_each_sample};

#[path = "../../../tests/scratch.rs"]
mod scratch;
use scratch::Scratch;

fn rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[test]
fn streams_a_large_file_with_bounded_memory() {
    let names: Vec<String> = (0..7).map(|j| format!("joint_with_a_long_name_{j}")).collect();
    let dir = Scratch::new("ivdyn-io-stream");
    let path = dir.join("big.mcap");
    // uncompressed, ~450 bytes a message: 120k messages ~ 55 MB on disk
    let count = 120_000usize;
    {
        let mut w = McapWriter::create_with(&path, Compression::None).unwrap();
        let id = w.add_joint_state_topic("/joint_states").unwrap();
        let mut row = vec![0.0; 7];
        for k in 0..count {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (k as f64 * 1e-3 + j as f64).sin();
            }
            w.write(id, 1_000_000 * k as i64, &names, &row, &row, &row).unwrap();
        }
        w.finish().unwrap();
    }
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(size > 40_000_000, "{size}");
    let before = rss_kib();
    let mut peak = 0u64;
    let mut seen = 0usize;
    let mut sum = 0.0;
    let opts = ReadOptions::new(&names[2..5]); // a subset, in the file's order
    let s = for_each_sample(&path, &opts, |s| {
        seen += 1;
        sum += s.q.unwrap()[0];
        if seen.is_multiple_of(5000) {
            peak = peak.max(rss_kib().unwrap_or(0));
        }
        Ok(())
    })
    .unwrap();
    assert_eq!((seen, s.measured), (count, count));
    assert!(sum.is_finite());
    std::fs::remove_file(&path).unwrap();
    if let Some(before) = before {
        let grew_mib = peak.saturating_sub(before) as f64 / 1024.0;
        eprintln!("streamed {size} bytes; resident memory grew by {grew_mib:.1} MiB");
        // the whole file is ~55 MB; the reader holds one chunk and a 256 KiB buffer
        assert!(
            grew_mib < 24.0,
            "resident memory grew by {grew_mib:.1} MiB while streaming a {} MB file",
            size / 1_000_000
        );
    }
}
