//! Shared set-up for the criterion benchmarks: the bundled robots as fixed-size models
//! and deterministic sample states.

use ivdyn::{DynModel, Robot};
use ivdyn_core::{Model, VecN};
use std::path::PathBuf;

/// Repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// UR5 from `fixtures/ur5.urdf` (base_link -> tool0).
pub fn ur5() -> Model<6> {
    let r = Robot::from_urdf(root().join("fixtures/ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
    match r.model {
        DynModel::N6(m) => *m,
        _ => unreachable!(),
    }
}

/// Panda arm from `fixtures/panda.urdf` (fingers locked).
pub fn panda7() -> Model<7> {
    let r = Robot::from_urdf(root().join("fixtures/panda.urdf"), Some("panda_link0"), Some("panda_hand")).unwrap();
    match r.model {
        DynModel::N7(m) => *m,
        _ => unreachable!(),
    }
}

/// `count` deterministic states (q, qd, qdd), as the Pinocchio anchor draws them:
/// q in +-pi, qd and qdd in +-1.
pub fn states<const N: usize>(count: usize) -> Vec<(VecN<N>, VecN<N>, VecN<N>)> {
    let mut s: u64 = 0x1234_5678;
    let mut u = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    (0..count)
        .map(|_| {
            let q = VecN::<N>::from_fn(|_, _| std::f64::consts::PI * u());
            let qd = VecN::<N>::from_fn(|_, _| u());
            let qdd = VecN::<N>::from_fn(|_, _| u());
            (q, qd, qdd)
        })
        .collect()
}
