//! Fuzz targets of ivdyn's readers (issue 16): each takes arbitrary bytes and must return
//! (an `Ok` or an `Err`), never panic, hang or allocate without bound. One body per
//! target, run two ways:
//!
//! - `tests/smoke.rs` (stable, in `make test`): the seeds of [`seeds`] mutated by
//!   [`mutate`] for a few seconds per target;
//! - `fuzz/` (cargo-fuzz, nightly, coverage-guided): `make fuzz` runs each target for
//!   `FUZZ_SECS` (docs/reliability.md has the command and the last long run).
//!
//! The readers are fed what a user hands ivdyn: an MCAP file (`mcap`: the MCAP and CDR
//! decoders), a CSV log (`csv`: the reader, then the conditioning the log goes through),
//! a URDF (`urdf`: the loader, then inverse dynamics on the model), a parameter file
//! (`params`: applied to the UR5), a rosbag2 SQLite file (`db3`: SQLite, the rosbag2
//! tables, then the CDR decoder) and a rosbag2 `metadata.yaml` in front of a valid split
//! bag (`bag`: the YAML, the file list, the split reading). The last two go through a file
//! in a scratch directory of the process (SQLite and the bag reader read paths).

use std::path::Path;
use std::sync::OnceLock;

use ivdyn::Robot;
use ivdyn::log::ReadOptions;
use ivdyn_core::rng::Rng;

/// The targets, by name.
pub const TARGETS: [&str; 6] = ["mcap", "csv", "urdf", "params", "db3", "bag"];

const UR5_URDF: &str = include_str!("../../../fixtures/ur5.urdf");

/// The UR5 of the fixtures, loaded once (the logs and the parameter files are its).
fn ur5() -> &'static Robot {
    static R: OnceLock<Robot> = OnceLock::new();
    R.get_or_init(|| {
        ivdyn::robot::urdf::load_str(UR5_URDF, Path::new("ur5.urdf"), Some("base_link"), Some("tool0")).unwrap()
    })
}

/// Runs target `name` on `data`.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "mcap" => mcap(data),
        "csv" => csv(data),
        "urdf" => urdf(data),
        "params" => params(data),
        "db3" => db3(data),
        "bag" => bag(data),
        _ => panic!("no fuzz target '{name}' (targets: {TARGETS:?})"),
    }
}

/// An MCAP file, streamed as `identify --stream` reads it (truncation allowed or not).
pub fn mcap(data: &[u8]) {
    for truncated in [false, true] {
        let mut opts = ReadOptions::new(&ur5().joint_names);
        opts.allow_truncated = truncated;
        let mut sum = 0.0;
        let _ = ivdyn::log::for_each_sample_from(data, Path::new("fuzz.mcap"), &opts, |s| {
            sum += s.q.unwrap_or(&[]).iter().chain(s.tau.unwrap_or(&[])).sum::<f64>();
            Ok(())
        });
        std::hint::black_box(sum);
    }
}

/// A CSV log, read, then conditioned as every job conditions it (hygiene, stamps,
/// segments, resampling, differentiation).
pub fn csv(data: &[u8]) {
    if let Ok(log) = ivdyn::log::read_csv_from(data, Path::new("fuzz.csv"), &ur5().joint_names) {
        let _ = ivdyn::prep::condition_segments(&log, &Default::default());
    }
}

/// A URDF, loaded with the default chain, then its inverse dynamics at rest.
pub fn urdf(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    if let Ok(r) = ivdyn::robot::urdf::load_str(&text, Path::new("fuzz.urdf"), None, None) {
        let z = vec![0.1; r.dof()];
        let _ = r.rnea(&z, &z, &z);
    }
}

/// A parameter file applied to the UR5.
pub fn params(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let mut r = ur5().clone();
    if ivdyn::robot::load::apply_params_json(&mut r, &text, Path::new("fuzz.json")).is_ok() {
        let z = vec![0.1; r.dof()];
        let _ = r.rnea(&z, &z, &z);
    }
}

/// The fixture bag the `db3` and `bag` targets start from (fixtures/logs/ur5_db3_bag).
fn fixture_bag() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/logs/ur5_db3_bag")
}

/// The scratch directory of this process, once made.
static SCRATCH: OnceLock<std::path::PathBuf> = OnceLock::new();

/// A scratch directory of this process (created once): `bag/` holds the fixture bag's
/// files, where the `bag` target writes its metadata.yaml.
fn scratch() -> &'static Path {
    SCRATCH.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("ivdyn-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(d.join("bag")).unwrap();
        for f in ["ur5_db3_bag_0.db3", "ur5_db3_bag_1.db3"] {
            std::fs::copy(fixture_bag().join(f), d.join("bag").join(f)).unwrap();
        }
        d
    })
}

/// Removes this process's scratch directory (statics are not dropped at exit, so a run
/// that made it removes it when done); the `db3` and `bag` targets read nothing after it.
pub fn remove_scratch() {
    if let Some(d) = SCRATCH.get() {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Streams the log at `path` as `identify --stream` reads it.
fn stream(path: &Path) {
    let mut sum = 0.0;
    let _ = ivdyn::log::for_each_sample(path, &ReadOptions::new(&ur5().joint_names), |s| {
        sum += s.q.unwrap_or(&[]).iter().chain(s.tau.unwrap_or(&[])).sum::<f64>();
        Ok(())
    });
    std::hint::black_box(sum);
}

/// A rosbag2 SQLite file, read as `--log run.db3`.
pub fn db3(data: &[u8]) {
    let path = scratch().join("fuzz.db3");
    if std::fs::write(&path, data).is_ok() {
        stream(&path);
    }
}

/// A rosbag2 `metadata.yaml` in front of the fixture's two `.db3` files, read as
/// `--log bag/`.
pub fn bag(data: &[u8]) {
    let dir = scratch().join("bag");
    if std::fs::write(dir.join("metadata.yaml"), data).is_ok() {
        stream(&dir);
    }
}

/// Seeds of target `name`: valid inputs (written here, or the committed fixtures).
pub fn seeds(name: &str) -> Vec<Vec<u8>> {
    let fixture =
        |p: &str| std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(p)).unwrap();
    match name {
        "mcap" => ["logs/ur5_500hz.mcap", "logs/ur5_lz4.mcap", "logs/ur5_nan.mcap"].map(fixture).to_vec(),
        "csv" => vec![csv_seed()],
        "urdf" => ["ur5.urdf", "panda.urdf", "test_arm.urdf"].map(fixture).to_vec(),
        "params" => vec![params_seed()],
        "db3" => ["ur5_db3_bag_0.db3", "ur5_db3_bag_1.db3"].map(|f| fixture(&format!("logs/ur5_db3_bag/{f}"))).to_vec(),
        "bag" => vec![fixture("logs/ur5_db3_bag/metadata.yaml")],
        _ => panic!("no fuzz target '{name}'"),
    }
}

/// A 0.2 s, 500 Hz UR5 log as CSV.
fn csv_seed() -> Vec<u8> {
    let o = ivdyn::app::SimulateOptions { duration_s: 0.2, noise_tau: 0.01, ..Default::default() };
    let log = ivdyn::app::simulate(ur5(), &ivdyn::app::Trajectory::Fourier, &o).unwrap();
    let path = std::env::temp_dir().join(format!("ivdyn-fuzz-seed-{}.csv", std::process::id()));
    ivdyn::log::write_csv(&path, &log).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    bytes
}

/// The UR5's parameter file, with a Coulomb shape on one joint.
fn params_seed() -> Vec<u8> {
    let r = ur5();
    let mut shapes = r.coulomb_shapes();
    shapes[1] = ivdyn_core::CoulombShape { v_scale: 0.05, asym: 0.1 };
    let pf = ivdyn::report::ParamsFile::new("ur5", r.joint_names.clone(), r.param_names(), r.params(), &shapes);
    serde_json::to_vec_pretty(&pf).unwrap()
}

/// Text that breaks numbers and lengths: spliced in where a mutation puts text.
const NASTY: [&[u8]; 12] = [
    b"nan",
    b"-inf",
    b"1e300",
    b"-1e-320",
    b"0",
    b"-0",
    b"18446744073709551615",
    b"9999999999",
    b"\"",
    b"<",
    b"]",
    b"\x00",
];

/// One random mutation of `data` (deterministic in `rng`): bit flips, bytes set to
/// boundary values, little-endian lengths overwritten, ranges deleted or duplicated,
/// numbers replaced by [`NASTY`] text, a splice of `other`.
pub fn mutate(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8]) {
    let mut pick = |n: usize| (rng.next_u64() % n.max(1) as u64) as usize;
    let len = data.len();
    match pick(7) {
        0 if len > 0 => {
            let i = pick(len);
            data[i] ^= 1 << pick(8);
        }
        1 if len > 0 => {
            let i = pick(len);
            data[i] = [0x00, 0xff, 0x7f, 0x80, 0x01][pick(5)];
        }
        2 if len >= 8 => {
            // a length field: 4 or 8 bytes little-endian set to a boundary value
            let i = pick(len - 8);
            let v: u64 = [0, 1, u32::MAX as u64, u64::MAX, 1 << 31, 1 << 40][pick(6)];
            let w = if pick(2) == 0 { 4 } else { 8 };
            data[i..i + w].copy_from_slice(&v.to_le_bytes()[..w]);
        }
        3 if len > 0 => {
            let (a, b) = (pick(len), pick(len));
            data.drain(a.min(b)..a.max(b).min(a.min(b) + 4096));
        }
        4 if len > 0 && len < 1 << 22 => {
            let (a, n) = (pick(len), 1 + pick(512));
            let chunk: Vec<u8> = data[a..(a + n).min(len)].to_vec();
            let at = pick(len);
            data.splice(at..at, chunk);
        }
        5 if len > 0 => {
            // a run of digits (a number in text) replaced by nasty text
            let i = pick(len);
            let s = data[i..].iter().position(u8::is_ascii_digit).map(|p| i + p).unwrap_or(i);
            let e = data[s..].iter().position(|c| !c.is_ascii_digit() && *c != b'.').map_or(len, |p| s + p);
            let nasty = NASTY[pick(NASTY.len())];
            data.splice(s..e, nasty.iter().copied());
        }
        _ if !other.is_empty() => {
            let (a, b) = (pick(len + 1), pick(other.len()));
            data.truncate(a);
            data.extend_from_slice(&other[b..(b + 4096).min(other.len())]);
        }
        _ => data.push(pick(256) as u8),
    }
}
