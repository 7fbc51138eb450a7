//! Readers for the two real-arm recordings of the development data
//! (`../shared/data/real/`, each folder with a README giving source, licence and units):
//!
//! * [`load_tx40`]: Stäubli TX40 (FIGAROH example, Apache-2.0): motor-side encoder
//!   positions and motor torques at 5 kHz, 45 000 rows, CSV without a time column; the
//!   transmission is [`tx40_transmission`].
//! * [`load_lwr_run`] / [`load_lwr_robot`]: KUKA LWR4+ (FloBaRoID, LGPL-3.0, read in
//!   place, never copied): `.npz` files with joint positions, velocities, accelerations
//!   and torques, already filtered by their authors, about 200 Hz.
//!
//! Nothing here is needed at run time by the rest of the crate; the example
//! `examples/real_data.rs` and the tests use it.

use std::path::{Path, PathBuf};

use super::npz::read_npz;
use ivdyn::Robot;
use ivdyn::error::{Error, Result};
use ivdyn::ident::transmission::Transmission;

/// Folder of the TX40 data below the data root.
pub const TX40_DIR: &str = "staubli_tx40_figaroh";
/// Folder of the LWR4+ data below the data root.
pub const LWR_DIR: &str = "kuka_lwr4p_flobaroid";
/// TX40 sample time (s): 5 kHz (`ts: 0.0002` in FIGAROH's `TX40_config.yaml`).
pub const TX40_DT: f64 = 0.0002;
/// TX40 gear ratios, motor turns per joint turn (FIGAROH `staubli_tx40_tools.py`; the
/// negative ratio of axis 4 reverses it).
pub const TX40_GEARS: [f64; 6] = [32.0, 32.0, 45.0, -48.0, 45.0, 32.0];
/// TX40 joint offsets added after `K⁻¹` so that the angles match the URDF
/// (`q2 -= π/2`, `q3 += π/2`: the log starts at `q = 0` in URDF convention).
pub const TX40_OFFSET: [f64; 6] = [0.0, -std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0];

/// The TX40 transmission: `K = diag(TX40_GEARS)` plus the coupled wrist
/// `K[5][4] = N6` (motor 6 turns with `N6 (q5 + q6)`), joint offsets [`TX40_OFFSET`].
pub fn tx40_transmission() -> Transmission {
    Transmission::gears(&TX40_GEARS)
        .and_then(|t| t.with_coupling(5, 4, TX40_GEARS[5]))
        .and_then(|t| t.with_offset(&TX40_OFFSET))
        .expect("constant, invertible K")
}

/// The TX40 recording.
#[derive(Debug, Clone)]
pub struct Tx40Data {
    /// The robot (URDF `tx40_mdh_modified.urdf`, chain `base_link` .. `tool0`).
    pub robot: Robot,
    /// Sample time (s).
    pub dt: f64,
    /// Motor positions (rad, motor side), `T x 6`.
    pub q_m: Vec<f64>,
    /// Motor torques (N m, motor side, from the drive currents), `T x 6`.
    pub tau_m: Vec<f64>,
}

impl Tx40Data {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.q_m.len() / 6
    }
    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.q_m.is_empty()
    }
}

/// Reads a numeric CSV with one header line (`expected` column names, in order):
/// a `T x expected.len()` row-major array. Errors name the file, line and column.
pub fn read_matrix_csv(path: &Path, expected: &[&str]) -> Result<Vec<f64>> {
    let err = |msg: String| Error::Log { file: path.to_path_buf(), msg };
    let text = std::fs::read_to_string(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, head) = lines.next().ok_or_else(|| err("empty file".into()))?;
    let cols: Vec<&str> = head.split(',').map(|c| c.trim().trim_matches('"')).collect();
    if cols != expected {
        return Err(err(format!("line 1: header {cols:?}, expected {expected:?}")));
    }
    let m = expected.len();
    let mut out = Vec::with_capacity(text.len() / 8);
    for (ln, line) in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != m {
            return Err(err(format!("line {}: {} values, expected {m}", ln + 1, cells.len())));
        }
        for (j, c) in cells.iter().enumerate() {
            let v: f64 = c.trim().parse().map_err(|_| {
                err(format!("line {}, column '{}': '{}' is not a number", ln + 1, expected[j], c.trim()))
            })?;
            if !v.is_finite() {
                return Err(err(format!("line {}, column '{}': value is {v}", ln + 1, expected[j])));
            }
            out.push(v);
        }
    }
    Ok(out)
}

/// Loads the TX40 recording from `root/staubli_tx40_figaroh` (`pos_read_data.csv`,
/// `curr_data.csv`, `tx40_mdh_modified.urdf`).
pub fn load_tx40(root: &Path) -> Result<Tx40Data> {
    let dir = root.join(TX40_DIR);
    let cols = ["Joint_1", "Joint_2", "Joint_3", "Joint_4", "Joint_5", "Joint_6"];
    let q_m = read_matrix_csv(&dir.join("pos_read_data.csv"), &cols)?;
    let tau_m = read_matrix_csv(&dir.join("curr_data.csv"), &cols)?;
    if q_m.len() != tau_m.len() {
        return Err(Error::Log {
            file: dir.join("curr_data.csv"),
            msg: format!("{} rows, but pos_read_data.csv has {}", tau_m.len() / 6, q_m.len() / 6),
        });
    }
    let robot = Robot::from_urdf(dir.join("tx40_mdh_modified.urdf"), Some("base_link"), Some("tool0"))?;
    Ok(Tx40Data { robot, dt: TX40_DT, q_m, tau_m })
}

/// One LWR4+ run (`measurements_<k>.npz`), `T x 7` arrays in joint order
/// `lwr_0_joint .. lwr_6_joint`.
#[derive(Debug, Clone)]
pub struct LwrRun {
    /// The file.
    pub file: PathBuf,
    /// Stamps (s since the first sample; from the ROS header stamps, uneven: 3.2-6.8 ms).
    pub t: Vec<f64>,
    /// Positions (rad), zero-phase 3 Hz low-pass by the authors.
    pub q: Vec<f64>,
    /// Velocities (rad/s).
    pub qd: Vec<f64>,
    /// Accelerations (rad/s^2).
    pub qdd: Vec<f64>,
    /// Measured joint torques (N m), link-side sensors.
    pub tau: Vec<f64>,
}

impl LwrRun {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }
    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The run as a joint log of the joints `names` (velocities and torques as logged).
    pub fn joint_log(&self, names: &[String]) -> ivdyn::log::JointLog {
        ivdyn::log::JointLog {
            joint_names: names.to_vec(),
            t0_ns: 0,
            t: self.t.clone(),
            q: self.q.clone(),
            qd: Some(self.qd.clone()),
            tau: Some(self.tau.clone()),
            u: None,
            current: None,
            truncated: false,
        }
    }
}

/// Loads `root/kuka_lwr4p_flobaroid/measurements_<k>.npz` (`k` in 1..=3). The
/// `target_*` arrays are ignored (README: wrongly scaled and not time-aligned).
pub fn load_lwr_run(root: &Path, k: usize) -> Result<LwrRun> {
    let file = root.join(LWR_DIR).join(format!("measurements_{k}.npz"));
    let mut z = read_npz(&file)?;
    let err = |msg: String| Error::Log { file: file.clone(), msg };
    let mut take = |key: &str, cols: usize| -> Result<Vec<f64>> {
        let a = z.remove(key).ok_or_else(|| err(format!("no array '{key}'")))?;
        match a.rows_cols() {
            Some((_, c)) if c == cols => {}
            _ => return Err(err(format!("array '{key}' has shape {:?}, expected (T, {cols})", a.shape))),
        }
        if let Some(i) = a.data.iter().position(|v| !v.is_finite()) {
            return Err(err(format!("array '{key}': sample {}, column {} is {}", i / cols, i % cols, a.data[i])));
        }
        Ok(a.data)
    };
    let times = take("times", 1)?;
    let (q, qd, qdd, tau) =
        (take("positions", 7)?, take("velocities", 7)?, take("accelerations", 7)?, take("torques", 7)?);
    let t0 = times.first().copied().unwrap_or(0.0);
    let t: Vec<f64> = times.iter().map(|v| v - t0).collect();
    for (key, a) in [("positions", &q), ("velocities", &qd), ("accelerations", &qdd), ("torques", &tau)] {
        if a.len() != 7 * t.len() {
            return Err(err(format!("array '{key}' has {} rows, 'times' has {}", a.len() / 7, t.len())));
        }
    }
    if let Some(k) = (1..t.len()).find(|&k| t[k] < t[k - 1]) {
        return Err(err(format!("sample {k}: time goes back")));
    }
    Ok(LwrRun { file, t, q, qd, qdd, tau })
}

/// Loads `kuka_lwr4.urdf` (chain from the root `box` to `lwr_7_link`).
///
/// The file gives the fixed joint `box_lwr_base_joint` two `<origin>` elements, which
/// urdf-rs rejects ("duplicate field `origin`"). ROS's parser (urdfdom) reads the first
/// `<origin>` of a joint and ignores the rest; this loader does the same (the second one
/// is the identity), and only inside `<joint>` elements.
pub fn load_lwr_robot(root: &Path) -> Result<Robot> {
    let file = root.join(LWR_DIR).join("kuka_lwr4.urdf");
    let text = std::fs::read_to_string(&file).map_err(|e| Error::Io { file: file.clone(), source: e })?;
    ivdyn::robot::urdf::load_str(&text, &file, None, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tx40_map_matches_readme() {
        // README: θm = R q with R = diag(N), R[6,5] = N6; τ = Rᵀ τm
        let t = tx40_transmission();
        let q = [0.1, 0.2 - std::f64::consts::FRAC_PI_2, 0.3 + std::f64::consts::FRAC_PI_2, 0.4, 0.5, 0.6];
        let qm = t.motor_positions(&q).unwrap();
        let want = [3.2, 6.4, 13.5, -19.2, 22.5, 32.0 * 1.1];
        for i in 0..6 {
            assert!((qm[i] - want[i]).abs() < 1e-12, "motor {i}: {} vs {}", qm[i], want[i]);
        }
        let tau = t.joint_torques(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]).unwrap();
        assert_eq!(tau, vec![32.0, 32.0, 45.0, -48.0, 45.0 + 32.0, 32.0]);
    }
}
