//! Batched dynamics over many samples (row-major arrays), multi-threaded.
//!
//! Every function takes `T` samples stacked row-major: `q`, `qd`, `qdd`, `tau` are
//! `T x N` (sample `t`, joint `j` at `t * N + j`), and writes into a caller-provided
//! `out` of the documented shape. `T` is `q.len() / N`. The samples are split into
//! contiguous chunks, one per thread (`std::thread::available_parallelism`), each
//! thread with its own [`ivdyn_core::Data`], writing a disjoint chunk of `out`; small
//! batches run on the calling thread. Results do not depend on the thread count.
//!
//! ```
//! let robot = ivdyn::Robot::paper();
//! let (t, n) = (100, robot.dof());
//! let q = vec![0.1; t * n];
//! let mut tau = vec![0.0; t * n];
//! ivdyn::batch::rnea_batch(&robot, &q, &q, &q, &mut tau).unwrap();
//! ```
//!
//! Also here: [`robot_from_dh`], a runtime-sized robot from a standard DH table.

use crate::error::Error;
use crate::robot::{MAX_DOF, Robot};
use ivdyn_core::dh::{DhRow, model_from_dh};
use ivdyn_core::params::{DRIVE_PARAMS, LINK_PARAMS, PARAMS_PER_JOINT};
use ivdyn_core::{self as core_, Data, Model, VecN};
use nalgebra::{SVector, Vector3};
use simba::simd::SimdValue;

/// Below this many samples per thread, spawning threads costs more than it saves.
pub const MIN_SAMPLES_PER_THREAD: usize = 64;

/// Result of the batch functions: errors name the failing sample
/// ([`Error::Sample`]) or the argument with the wrong length ([`Error::Dimension`]).
pub type BatchResult<T> = crate::error::Result<T>;

/// Number of worker threads used for `t` samples: at most
/// `std::thread::available_parallelism()` (read once: it parses cgroup files, ~50 us),
/// and at least [`MIN_SAMPLES_PER_THREAD`] samples per thread.
pub fn threads_for(t: usize) -> usize {
    if t < 2 * MIN_SAMPLES_PER_THREAD {
        return 1;
    }
    crate::par::available().min(t / MIN_SAMPLES_PER_THREAD).max(1)
}

pub(crate) fn dim_err(what: String, expected: usize, got: usize) -> Error {
    Error::Dimension { what, expected, got }
}

/// Checks the inputs (`names[k]` has `inputs[k]`, each `T x N`) and `out` (`T x out_row`),
/// with `T` taken from the first input. Returns `T`.
fn check_dims(
    n: usize,
    names: &[&str],
    inputs: &[&[f64]],
    out: &[f64],
    out_shape: &str,
    out_row: usize,
) -> BatchResult<usize> {
    let len0 = inputs[0].len();
    if !len0.is_multiple_of(n) {
        let t = len0 / n;
        return Err(dim_err(
            format!("{} (T x N with N = {n}; its length must be a multiple of {n})", names[0]),
            (t + 1) * n,
            len0,
        ));
    }
    let t = len0 / n;
    for (name, x) in names.iter().zip(inputs).skip(1) {
        if x.len() != t * n {
            return Err(dim_err(format!("{name} (T x N = {t} x {n})"), t * n, x.len()));
        }
    }
    if out.len() != t * out_row {
        return Err(dim_err(format!("out ({out_shape} with T = {t}, N = {n})"), t * out_row, out.len()));
    }
    Ok(t)
}

/// Row `s` of a `T x N` array as a vector, or `NonFinite` naming the joint index.
#[inline]
pub(crate) fn row<const N: usize>(what: &'static str, x: &[f64], s: usize) -> Result<VecN<N>, core_::Error> {
    let r = &x[N * s..N * (s + 1)];
    core_::error::check_finite(what, r)?;
    Ok(VecN::<N>::from_column_slice(r))
}

/// Runs `f(data, sample, out_row)` for every sample, `out` split into rows of `out_row`
/// entries, over contiguous chunks on [`threads_for`] threads. On failure returns the
/// error of the lowest failing sample.
fn run<const N: usize, F>(t: usize, out: &mut [f64], out_row: usize, f: F) -> BatchResult<()>
where
    F: Fn(&mut Data<N>, usize, &mut [f64]) -> Result<(), core_::Error> + Sync,
{
    run_chunks(t, out, out_row, 1, |first, out| {
        let mut data = Box::new(Data::<N>::new());
        for (k, o) in out.chunks_exact_mut(out_row).enumerate() {
            let s = first + k;
            f(&mut data, s, o).map_err(|source| Error::Sample { index: s, source })?;
        }
        Ok(())
    })
}

/// Runs `f(first_sample, out_chunk)` over contiguous chunks of whole rows on
/// [`threads_for`] threads, every chunk but the last a multiple of `align` samples.
/// Chunks are in sample order, so the first error returned is the lowest failing sample's.
fn run_chunks<F>(t: usize, out: &mut [f64], out_row: usize, align: usize, f: F) -> BatchResult<()>
where
    F: Fn(usize, &mut [f64]) -> BatchResult<()> + Sync,
{
    if t == 0 || out_row == 0 {
        return Ok(());
    }
    let nthreads = threads_for(t);
    if nthreads == 1 {
        return f(0, out);
    }
    let per = t.div_ceil(nthreads).next_multiple_of(align);
    let results: Vec<BatchResult<()>> = std::thread::scope(|scope| {
        let handles: Vec<_> = out
            .chunks_mut(per * out_row)
            .enumerate()
            .map(|(c, o)| {
                let f = &f;
                scope.spawn(move || f(c * per, o))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
    });
    results.into_iter().collect()
}

/// Inverse dynamics with drive terms for `T` samples: `out[t] = rnea(q[t], qd[t], qdd[t])`.
/// `q`, `qd`, `qdd`, `out`: `T x N`.
pub fn rnea_batch(robot: &Robot, q: &[f64], qd: &[f64], qdd: &[f64], out: &mut [f64]) -> BatchResult<()> {
    let n = robot.dof();
    let t = check_dims(n, &["q", "qd", "qdd"], &[q, qd, qdd], out, "T x N", n)?;
    crate::with_model!(&robot.model, m => rnea_n(&**m, t, q, qd, qdd, out))
}

fn rnea_n<const N: usize>(
    m: &Model<N>,
    t: usize,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    out: &mut [f64],
) -> BatchResult<()> {
    packs_n(m, t, &States { q, qd: Some(qd), qdd: Some(qdd), what: What::Rnea { drive: true } }, out)
}

/// Gravity torques (no drive terms) for `T` samples. `q`, `out`: `T x N`.
pub fn gravity_batch(robot: &Robot, q: &[f64], out: &mut [f64]) -> BatchResult<()> {
    let n = robot.dof();
    let t = check_dims(n, &["q"], &[q], out, "T x N", n)?;
    crate::with_model!(&robot.model, m => gravity_n(&**m, t, q, out))
}

fn gravity_n<const N: usize>(m: &Model<N>, t: usize, q: &[f64], out: &mut [f64]) -> BatchResult<()> {
    packs_n(m, t, &States { q, qd: None, qdd: None, what: What::Rnea { drive: false } }, out)
}

/// Joint-torque regressors for `T` samples, row-major `T x N x 14N` (the full regressor,
/// `Y theta == rnea`), or `T x N x 10N` (the inertial part only, as Pinocchio's
/// `computeJointTorqueRegressor`) when `rigid_only`.
pub fn regressor_batch(
    robot: &Robot,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    out: &mut [f64],
    rigid_only: bool,
) -> BatchResult<()> {
    let n = robot.dof();
    let (cols, shape) =
        if rigid_only { (LINK_PARAMS * n, "T x N x 10N") } else { (PARAMS_PER_JOINT * n, "T x N x 14N") };
    let t = check_dims(n, &["q", "qd", "qdd"], &[q, qd, qdd], out, shape, n * cols)?;
    crate::with_model!(&robot.model, m => regressor_n(&**m, t, q, qd, qdd, out, rigid_only))
}

fn regressor_n<const N: usize>(
    m: &Model<N>,
    t: usize,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    out: &mut [f64],
    rigid_only: bool,
) -> BatchResult<()> {
    packs_n(m, t, &States { q, qd: Some(qd), qdd: Some(qdd), what: What::Regressor { rigid_only } }, out)
}

/// Runs the pack kernel over `T` samples in chunks of whole packs, so that a sample lands
/// in the same pack (and gets the same bits) whatever the thread count. Fewer samples than
/// a pack (e.g. one sample from Python) take the f64 path, which gives the same bits
/// without the pack buffers' set-up.
fn packs_n<const N: usize>(m: &Model<N>, t: usize, x: &States, out: &mut [f64]) -> BatchResult<()> {
    let row_len = N * x.what.cols::<N>();
    if t < LANES {
        return run::<N, _>(t, out, row_len, |data, s, o| x.sample(m, data, s, o));
    }
    run_chunks(t, out, row_len, LANES, |first, o| packs_chunk(m, first, x, o))
}

/// What a pack kernel computes per sample.
#[derive(Clone, Copy)]
enum What {
    /// The regressor, `N x 14N` (or `N x 10N` when `rigid_only`).
    Regressor { rigid_only: bool },
    /// Inverse dynamics, `N` torques, with or without the drive terms.
    Rnea { drive: bool },
}

impl What {
    /// Output columns per joint row.
    fn cols<const N: usize>(self) -> usize {
        match self {
            What::Regressor { rigid_only: true } => LINK_PARAMS * N,
            What::Regressor { rigid_only: false } => PARAMS_PER_JOINT * N,
            What::Rnea { .. } => 1,
        }
    }
}

/// The inputs of a pack kernel (`T x N` each; `qd`, `qdd` zero when absent) and its output.
#[derive(Clone, Copy)]
struct States<'a> {
    q: &'a [f64],
    qd: Option<&'a [f64]>,
    qdd: Option<&'a [f64]>,
    what: What,
}

impl States<'_> {
    /// Sample `s` on the f64 path (the same bits as in a pack).
    fn sample<const N: usize>(
        &self,
        m: &Model<N>,
        data: &mut Data<N>,
        s: usize,
        o: &mut [f64],
    ) -> Result<(), core_::Error> {
        let input = |name, a: Option<&[f64]>| a.map_or(Ok(VecN::<N>::zeros()), |a| row::<N>(name, a, s));
        let (q, qd, qdd) = (input("q", Some(self.q))?, input("qd", self.qd)?, input("qdd", self.qdd)?);
        match self.what {
            What::Regressor { rigid_only } => {
                let y = core_::regressor(m, data, &q, &qd, &qdd);
                if rigid_only {
                    y.write_rigid_row_major(o);
                } else {
                    y.write_row_major(o);
                }
            }
            What::Rnea { drive: true } => o.copy_from_slice(core_::rnea(m, data, &q, &qd, &qdd).as_slice()),
            What::Rnea { drive: false } => {
                o.copy_from_slice(core_::rnea::rnea_rigid(m, data, &q, &qd, &qdd).as_slice())
            }
        }
        Ok(())
    }
}

/// Samples computed in lock step by the pack kernels (one per SIMD lane).
pub const LANES: usize = 4;
type Pack = simba::simd::AutoF64x4;

/// The samples `first..` that fill `out` (whole rows), four at a time. With AVX2 the same
/// generic code is compiled for 256-bit registers (one pack = one register); the
/// arithmetic and its order are the same on both paths (no FMA contraction in Rust), so
/// the results are too.
fn packs_chunk<const N: usize>(m: &Model<N>, first: usize, x: &States, out: &mut [f64]) -> BatchResult<()> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { packs_chunk_avx2(m, first, x, out) };
    }
    packs_chunk_portable(m, first, x, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn packs_chunk_avx2<const N: usize>(m: &Model<N>, first: usize, x: &States, out: &mut [f64]) -> BatchResult<()> {
    packs_chunk_portable(m, first, x, out)
}

#[inline(always)]
fn packs_chunk_portable<const N: usize>(m: &Model<N>, first: usize, x: &States, out: &mut [f64]) -> BatchResult<()> {
    let lc = LINK_PARAMS * N;
    let cols = x.what.cols::<N>();
    let row_len = N * cols;
    let count = out.len() / row_len;
    let mut kin = Box::new(core_::kinematics::Kinematics::<Pack, N>::new());
    let mut y = Box::new(core_::Regressor::<N, Pack>::zeros());
    let zero = Pack::splat(0.0);
    let (mut f, mut n, mut tau) =
        ([Vector3::<Pack>::zeros(); N], [Vector3::<Pack>::zeros(); N], SVector::<Pack, N>::repeat(zero));
    let mut ins = [SVector::<Pack, N>::repeat(zero); 3];
    let arrays = [("q", Some(x.q)), ("qd", x.qd), ("qdd", x.qdd)];
    for p0 in (0..count).step_by(LANES) {
        let valid = LANES.min(count - p0);
        // a short last pack repeats its last sample in the spare lanes
        for k in 0..LANES {
            let s = first + p0 + k.min(valid - 1);
            for ((name, a), v) in arrays.iter().zip(ins.iter_mut()) {
                if let Some(a) = a {
                    let r = row::<N>(name, a, s).map_err(|e| Error::Sample { index: s, source: e })?;
                    for j in 0..N {
                        v[j].0[k] = r[j];
                    }
                }
            }
        }
        let [qp, qdp, qddp] = &ins;
        match x.what {
            What::Regressor { rigid_only } => {
                core_::regressor::regressor_links(m, &mut kin, &mut y, qp, qdp, qddp);
                for k in 0..valid {
                    let o = &mut out[(p0 + k) * row_len..(p0 + k + 1) * row_len];
                    for i in 0..N {
                        let oi = &mut o[i * cols..(i + 1) * cols];
                        // fixed-size blocks: unrolled stores, no per-entry bounds checks
                        let (links, _) = oi.as_chunks_mut::<LINK_PARAMS>();
                        for (j, blk) in links[..N].iter_mut().enumerate() {
                            *blk =
                                if j < i { [0.0; LINK_PARAMS] } else { core::array::from_fn(|c| y.link[i][j][c].0[k]) };
                        }
                        if !rigid_only {
                            // drive columns: joint i's [c(qd), qd, qdd, 1], zero elsewhere
                            let d = &mut oi[lc..];
                            d.fill(0.0);
                            let (v, a) = (qdp[i].0[k], qddp[i].0[k]);
                            d[DRIVE_PARAMS * i..DRIVE_PARAMS * (i + 1)]
                                .copy_from_slice(&m.drive[i].regressor_row(v, a));
                        }
                    }
                }
            }
            What::Rnea { drive } => {
                core_::kinematics::joint_transforms(m, &mut kin, qp);
                core_::kinematics::forward_pass(m, &mut kin, qdp, qddp);
                core_::rnea::backward_pass_in(m, &kin, &mut f, &mut n, &mut tau);
                for k in 0..valid {
                    let o = &mut out[(p0 + k) * N..(p0 + k + 1) * N];
                    for i in 0..N {
                        // as core_::rnea: the rigid-body torque, then the drive terms added
                        o[i] = if drive {
                            tau[i].0[k] + m.drive[i].torque(qdp[i].0[k], qddp[i].0[k])
                        } else {
                            tau[i].0[k]
                        };
                    }
                }
            }
        }
    }
    Ok(())
}

/// Mass matrices (with armature) for `T` samples. `q`: `T x N`, `out`: `T x N x N`.
pub fn mass_matrix_batch(robot: &Robot, q: &[f64], out: &mut [f64]) -> BatchResult<()> {
    let n = robot.dof();
    let t = check_dims(n, &["q"], &[q], out, "T x N x N", n * n)?;
    crate::with_model!(&robot.model, m => mass_matrix_n(&**m, t, q, out))
}

fn mass_matrix_n<const N: usize>(m: &Model<N>, t: usize, q: &[f64], out: &mut [f64]) -> BatchResult<()> {
    run::<N, _>(t, out, N * N, |data, s, o| {
        let q = row::<N>("q", q, s)?;
        // symmetric: column-major storage equals row-major
        o.copy_from_slice(core_::mass_matrix(m, data, &q).as_slice());
        Ok(())
    })
}

/// Forward dynamics for `T` samples: `out[t] = qdd` with `rnea(q[t], qd[t], qdd) == tau[t]`.
/// `q`, `qd`, `tau`, `out`: `T x N`. A mass matrix that is not positive definite fails
/// with the sample's index.
pub fn forward_dynamics_batch(robot: &Robot, q: &[f64], qd: &[f64], tau: &[f64], out: &mut [f64]) -> BatchResult<()> {
    let n = robot.dof();
    let t = check_dims(n, &["q", "qd", "tau"], &[q, qd, tau], out, "T x N", n)?;
    crate::with_model!(&robot.model, m => forward_dynamics_n(&**m, t, q, qd, tau, out))
}

fn forward_dynamics_n<const N: usize>(
    m: &Model<N>,
    t: usize,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    out: &mut [f64],
) -> BatchResult<()> {
    run::<N, _>(t, out, N, |data, s, o| {
        let (q, qd, tau) = (row::<N>("q", q, s)?, row::<N>("qd", qd, s)?, row::<N>("tau", tau, s)?);
        o.copy_from_slice(core_::forward_dynamics(m, data, &q, &qd, &tau)?.as_slice());
        Ok(())
    })
}

/// A revolute chain from a standard DH table (`T_{i-1,i} = Rz(q_i + offset_i) Tz(d_i)
/// Tx(a_i) Rx(alpha_i)`, see [`ivdyn_core::dh`]), all parameters zero, gravity
/// `(0, 0, -9.81)`; joints `joint1..`, links `link1..`. Lengths in m, angles in rad;
/// `offset` defaults to zeros.
pub fn robot_from_dh(a: &[f64], d: &[f64], alpha: &[f64], offset: Option<&[f64]>) -> crate::error::Result<Robot> {
    let n = a.len();
    let zeros = vec![0.0; n];
    let offset = offset.unwrap_or(&zeros);
    for (what, x) in [("d", d), ("alpha", alpha), ("offset", offset)] {
        if x.len() != n {
            return Err(Error::Dimension {
                what: format!("{what} (one per joint, as a: N = {n})"),
                expected: n,
                got: x.len(),
            });
        }
    }
    for (what, x) in [("a", a), ("d", d), ("alpha", alpha), ("offset", offset)] {
        core_::error::check_finite(what, x)?;
    }
    let rows: Vec<DhRow> = (0..n).map(|i| DhRow { a: a[i], d: d[i], alpha: alpha[i], offset: offset[i] }).collect();
    fn build<const N: usize>(rows: &[DhRow]) -> Robot {
        let rows: &[DhRow; N] = rows.try_into().expect("length checked by the caller");
        Robot::from_model_named("dh", model_from_dh(rows))
    }
    Ok(match n {
        1 => build::<1>(&rows),
        2 => build::<2>(&rows),
        3 => build::<3>(&rows),
        4 => build::<4>(&rows),
        5 => build::<5>(&rows),
        6 => build::<6>(&rows),
        7 => build::<7>(&rows),
        8 => build::<8>(&rows),
        9 => build::<9>(&rows),
        10 => build::<10>(&rows),
        11 => build::<11>(&rows),
        12 => build::<12>(&rows),
        dof => return Err(Error::TooManyJoints { dof, max: MAX_DOF }),
    })
}

/// Base regressor rows (`T x n x b`) at the given states, in chunks, with progress.
pub fn stack_rows(
    robot: &Robot,
    cols: &[usize],
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    st: Option<&crate::progress::Stage>,
) -> crate::error::Result<Vec<f64>> {
    let (n, p, b) = (robot.dof(), robot.num_params(), cols.len());
    let t = q.len() / n;
    let mut out = Vec::with_capacity(t * n * b);
    const CHUNK: usize = 2048;
    let mut full = vec![];
    for s in (0..t).step_by(CHUNK) {
        let e = (s + CHUNK).min(t);
        full.resize((e - s) * n * p, 0.0);
        let r = s * n..e * n;
        regressor_batch(robot, &q[r.clone()], &qd[r.clone()], &qdd[r], &mut full, false).map_err(|e| match e {
            Error::Sample { index, source } => Error::Sample { index: index + s, source },
            e => e,
        })?;
        for row in full.chunks_exact(p) {
            out.extend(cols.iter().map(|&c| row[c]));
        }
        if let Some(st) = st {
            st.advance((e - s) as u64);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixtures() -> std::path::PathBuf {
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
    }

    /// Deterministic pseudo-random numbers in [-2, 2) (xorshift), some exact zeros.
    fn samples(len: usize, seed: u64) -> Vec<f64> {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..len)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let u = (s >> 11) as f64 / (1u64 << 53) as f64;
                if u < 0.05 { 0.0 } else { 4.0 * u - 2.0 }
            })
            .collect()
    }

    fn robots() -> Vec<Robot> {
        let mut ur5 = Robot::from_urdf(fixtures().join("ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
        // nonzero drive parameters so the drive columns and armature are exercised
        let mut theta = ur5.params();
        let n = ur5.dof();
        for (k, v) in theta[10 * n..].iter_mut().enumerate() {
            *v = 0.1 + 0.01 * k as f64;
        }
        ur5.set_params(&theta).unwrap();
        // shaped Coulomb friction on some joints (smooth, direction-dependent)
        let mut shaped = ur5.coulomb_shapes();
        shaped[1] = ivdyn_core::CoulombShape { v_scale: 0.05, asym: 0.0 };
        shaped[3] = ivdyn_core::CoulombShape { v_scale: 0.2, asym: -0.3 };
        shaped[4] = ivdyn_core::CoulombShape { v_scale: 0.0, asym: 0.4 };
        ur5.set_coulomb_shapes(&shaped).unwrap();
        vec![
            Robot::paper(),
            ur5,
            Robot::from_urdf(fixtures().join("panda.urdf"), Some("panda_link0"), Some("panda_hand")).unwrap(),
            Robot::from_urdf(fixtures().join("test_arm.urdf"), Some("base_link"), Some("tool")).unwrap(),
        ]
    }

    // enough samples to use several threads on a multi-core machine, and not a multiple of them
    const T: usize = 1001;

    #[test]
    fn batch_equals_per_sample() {
        for robot in robots() {
            let n = robot.dof();
            let (q, qd, qdd) = (samples(T * n, 1), samples(T * n, 2), samples(T * n, 3));
            let mut tau = vec![0.0; T * n];
            rnea_batch(&robot, &q, &qd, &qdd, &mut tau).unwrap();
            let mut g = vec![0.0; T * n];
            gravity_batch(&robot, &q, &mut g).unwrap();
            let mut y = vec![f64::NAN; T * n * 14 * n];
            regressor_batch(&robot, &q, &qd, &qdd, &mut y, false).unwrap();
            let mut yr = vec![f64::NAN; T * n * 10 * n];
            regressor_batch(&robot, &q, &qd, &qdd, &mut yr, true).unwrap();
            // fewer samples than a pack take the f64 path: same bits
            for t in [1, 3, 5] {
                let mut ys = vec![f64::NAN; t * n * 14 * n];
                regressor_batch(&robot, &q[..t * n], &qd[..t * n], &qdd[..t * n], &mut ys, false).unwrap();
                assert_eq!(ys, y[..t * n * 14 * n]);
            }
            let mut mm = vec![0.0; T * n * n];
            mass_matrix_batch(&robot, &q, &mut mm).unwrap();
            let mut fd = vec![0.0; T * n];
            forward_dynamics_batch(&robot, &q, &qd, &tau, &mut fd).unwrap();
            for s in 0..T {
                let r = |x: &[f64]| x[n * s..n * (s + 1)].to_vec();
                let (qs, qds, qdds) = (r(&q), r(&qd), r(&qdd));
                assert_eq!(robot.rnea(&qs, &qds, &qdds).unwrap(), r(&tau));
                assert_eq!(robot.gravity(&qs).unwrap(), r(&g));
                let y1 = robot.regressor(&qs, &qds, &qdds).unwrap();
                assert_eq!(y1, y[14 * n * n * s..14 * n * n * (s + 1)]);
                let y1r: Vec<f64> = y1.chunks(14 * n).flat_map(|c| c[..10 * n].to_vec()).collect();
                assert_eq!(y1r, yr[10 * n * n * s..10 * n * n * (s + 1)]);
                assert_eq!(robot.mass_matrix(&qs).unwrap(), mm[n * n * s..n * n * (s + 1)]);
                assert_eq!(robot.forward_dynamics(&qs, &qds, &r(&tau)).unwrap(), r(&fd));
            }
            // the round trip: forward dynamics of rnea's torques gives back qdd
            let worst = fd.iter().zip(&qdd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(worst < 1e-8, "{}: fd(rnea(qdd)) - qdd = {worst:e}", robot.name);
        }
    }

    #[test]
    fn empty_batch() {
        let robot = Robot::paper();
        let mut out = [];
        rnea_batch(&robot, &[], &[], &[], &mut out).unwrap();
        regressor_batch(&robot, &[], &[], &[], &mut out, true).unwrap();
    }

    #[test]
    fn dimension_errors_say_what() {
        let robot = Robot::paper();
        let q = vec![0.0; 600];
        let mut out = vec![0.0; 600];
        let e = rnea_batch(&robot, &q, &q[..594], &q, &mut out).unwrap_err().to_string();
        assert_eq!(e, "qd (T x N = 100 x 6): expected length 600, got 594");
        let e = rnea_batch(&robot, &q[..599], &q, &q, &mut out).unwrap_err().to_string();
        assert!(e.starts_with("q (T x N with N = 6"), "{e}");
        let e = regressor_batch(&robot, &q, &q, &q, &mut out, true).unwrap_err().to_string();
        assert_eq!(e, "out (T x N x 10N with T = 100, N = 6): expected length 36000, got 600");
        let e = mass_matrix_batch(&robot, &q, &mut out).unwrap_err().to_string();
        assert!(e.contains("expected length 3600"), "{e}");
        assert!(matches!(
            gravity_batch(&robot, &q, &mut out[..6]),
            Err(Error::Dimension { expected: 600, got: 6, .. })
        ));
    }

    #[test]
    fn pack_kernels_without_avx2_give_the_same_bits() {
        // the portable build of the pack kernel (what a CPU without AVX2 runs) against the
        // dispatched one and the f64 path
        let robot = Robot::from_urdf(fixtures().join("ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
        let (t, n) = (37, 6);
        let (q, qd, qdd) = (samples(t * n, 11), samples(t * n, 12), samples(t * n, 13));
        let mut y = vec![f64::NAN; t * n * 84];
        regressor_batch(&robot, &q, &qd, &qdd, &mut y, false).unwrap();
        let mut yp = vec![f64::NAN; t * n * 84];
        let x = States { q: &q, qd: Some(&qd), qdd: Some(&qdd), what: What::Regressor { rigid_only: false } };
        crate::with_model!(&robot.model, m => packs_chunk_portable(&**m, 0, &x, &mut yp)).unwrap();
        assert_eq!(y, yp);
        let mut tau = vec![f64::NAN; t * n];
        rnea_batch(&robot, &q, &qd, &qdd, &mut tau).unwrap();
        let mut taup = vec![f64::NAN; t * n];
        let x = States { q: &q, qd: Some(&qd), qdd: Some(&qdd), what: What::Rnea { drive: true } };
        crate::with_model!(&robot.model, m => packs_chunk_portable(&**m, 0, &x, &mut taup)).unwrap();
        assert_eq!(tau, taup);
        for s in 0..t {
            let r = |v: &[f64]| v[n * s..n * (s + 1)].to_vec();
            assert_eq!(robot.regressor(&r(&q), &r(&qd), &r(&qdd)).unwrap(), y[84 * n * s..84 * n * (s + 1)]);
            assert_eq!(robot.rnea(&r(&q), &r(&qd), &r(&qdd)).unwrap(), r(&tau));
        }
    }

    #[test]
    fn non_finite_names_the_sample() {
        let robot = Robot::paper();
        let t = 1000;
        let mut q = samples(t * 6, 5);
        let qd = samples(t * 6, 6);
        let mut qdd = samples(t * 6, 7);
        q[6 * 700 + 2] = f64::NAN;
        qdd[6 * 613 + 5] = f64::INFINITY;
        let mut out = vec![0.0; t * 6];
        let e = rnea_batch(&robot, &q, &qd, &qdd, &mut out).unwrap_err();
        assert_eq!(e.to_string(), "sample 613: non-finite value in qdd[5]");
        assert!(matches!(e, Error::Sample { index: 613, source: core_::Error::NonFinite { what: "qdd", index: 5 } }));
        let e = gravity_batch(&robot, &q, &mut out).unwrap_err();
        assert_eq!(e.to_string(), "sample 700: non-finite value in q[2]");
        let e = forward_dynamics_batch(&robot, &q, &qd, &qdd, &mut out).unwrap_err();
        assert_eq!(e.to_string(), "sample 613: non-finite value in tau[5]");
        // the regressor's pack kernel: 700 and 613 sit in different packs of four
        let mut y = vec![0.0; t * 6 * 60];
        let e = regressor_batch(&robot, &q, &qd, &qdd, &mut y, true).unwrap_err();
        assert_eq!(e.to_string(), "sample 613: non-finite value in qdd[5]");
        // the last, short pack (999 = 4 * 249 + 3 samples) repeats its last sample in the
        // spare lane: a bad last sample is named once, as itself
        let (t, mut q) = (999, samples(999 * 6, 5));
        q[6 * 998] = f64::NAN;
        let (qd, qdd) = (samples(t * 6, 6), samples(t * 6, 7));
        let mut y = vec![0.0; t * 6 * 84];
        let e = regressor_batch(&robot, &q, &qd, &qdd, &mut y, false).unwrap_err();
        assert_eq!(e.to_string(), "sample 998: non-finite value in q[0]");
    }

    #[test]
    fn forward_dynamics_names_the_singular_sample() {
        // a zero-mass DH chain has M = 0 (no armature): not positive definite
        let robot = robot_from_dh(&[0.1, 0.1], &[0.0, 0.0], &[0.0, 0.0], None).unwrap();
        let mut out = vec![0.0; 4];
        let e = forward_dynamics_batch(&robot, &[0.0; 4], &[0.0; 4], &[0.0; 4], &mut out).unwrap_err();
        assert_eq!(e.to_string(), "sample 0: mass matrix is not positive definite (pivot at joint 0)");
    }

    #[test]
    fn dh_robot_matches_core() {
        let rows = [
            DhRow { a: 0.1, d: 0.2, alpha: 0.5, offset: 0.3 },
            DhRow { a: -0.2, d: 0.0, alpha: -1.0, offset: 0.0 },
            DhRow { a: 0.0, d: 0.15, alpha: std::f64::consts::FRAC_PI_2, offset: -0.2 },
        ];
        let want = Robot::from_model_named("dh", model_from_dh(&rows));
        let (a, d, al, off): (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) = (
            rows.iter().map(|r| r.a).collect(),
            rows.iter().map(|r| r.d).collect(),
            rows.iter().map(|r| r.alpha).collect(),
            rows.iter().map(|r| r.offset).collect(),
        );
        assert_eq!(robot_from_dh(&a, &d, &al, Some(&off)).unwrap(), want);
        assert_eq!(robot_from_dh(&a, &d, &al, None).unwrap().dof(), 3);
        let e = robot_from_dh(&a, &d[..2], &al, None).unwrap_err().to_string();
        assert_eq!(e, "d (one per joint, as a: N = 3): expected length 3, got 2");
        assert!(robot_from_dh(&[], &[], &[], None).is_err());
        assert!(robot_from_dh(&[0.0; 13], &[0.0; 13], &[0.0; 13], None).is_err());
        assert!(robot_from_dh(&[f64::NAN], &[0.0], &[0.0], None).is_err());
    }
}
