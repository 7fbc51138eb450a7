//! The reduced terminal-link update (`TerminalLink::update`, issue 19: only the rows'
//! regressor entries and nominal torque, sparse estimator rows) against the full
//! computation (`TerminalLink::update_full`: full RNEA, full regressors, dense rows), on
//! random states of the paper's robot, a UR5-like arm (standard DH) and random chains with
//! general axes and prismatic joints.

mod common;
use common::{Rng, assert_close, random_model};
use ivdyn_core::dh::{DhRow, model_from_dh};
use ivdyn_core::estim::terminal::{Method, TerminalLink, TerminalSpec};
use ivdyn_core::estim::terminal_rows::{Needed, TerminalRows, terminal_rows};
use ivdyn_core::estim::{Riv, RivInfo, Rls};
use ivdyn_core::{Data, LINK_PARAMS, Model, VecN, paper, regressor, rnea};
use nalgebra::{DMatrix, DVector, Dyn};
use std::f64::consts::FRAC_PI_2;

/// A UR5-like arm: the UR5's standard DH table with random inertias and drives.
fn ur5_like(seed: u64) -> Model<6> {
    let a = [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0];
    let d = [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823];
    let alpha = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];
    let rows: [DhRow; 6] = std::array::from_fn(|i| DhRow { a: a[i], d: d[i], alpha: alpha[i], offset: 0.0 });
    let mut m = model_from_dh(&rows);
    let r = random_model::<6>(seed, false);
    m.inertia = r.inertia;
    m.drive = r.drive;
    m
}

/// A random state: angles anywhere, speeds and accelerations of a real arm.
fn state<const N: usize>(rng: &mut Rng) -> (VecN<N>, VecN<N>, VecN<N>) {
    (rng.vecn(-3.0, 3.0), rng.vecn(-2.0, 2.0), rng.vecn(-10.0, 10.0))
}

/// Every regressor entry of the unknown links on the rows used, and the nominal torque of
/// those rows, against the full regressor and RNEA.
fn check_rows<const N: usize>(model: &Model<N>, spec: &TerminalSpec, seed: u64, what: &str) {
    let mut rng = Rng(seed);
    let rows = spec.rows(N);
    let mut needed = Needed::<N> { first_row: rows.start, ..Needed::NONE };
    for row in rows.clone() {
        for l in spec.k.max(row)..N {
            needed.link[row][l] = (1 << LINK_PARAMS) - 1;
        }
        needed.drive[row] = [true; 4];
    }
    let mut out = TerminalRows::<N>::new();
    let (mut data, mut data_z) = (Data::<N>::new(), Data::<N>::new());
    for _ in 0..50 {
        let (q, qd, qdd) = state::<N>(&mut rng);
        let qdd_z = rng.vecn::<N>(-10.0, 10.0);
        terminal_rows(model, &needed, &mut out, &q, &qd, &qdd, Some(&qdd_z));
        let tau = *rnea(model, &mut data, &q, &qd, &qdd);
        let y = regressor(model, &mut data, &q, &qd, &qdd);
        let y_z = regressor(model, &mut data_z, &q, &qd, &qdd_z);
        for row in rows.clone() {
            assert_close(&[out.tau[row]], &[tau[row]], 1e-12, 1e-12, &format!("{what}: tau[{row}]"));
            for l in spec.k.max(row)..N {
                assert_close(&out.y.link[row][l], &y.link[row][l], 1e-12, 1e-12, &format!("{what}: Y[{row}][{l}]"));
                assert_close(
                    &out.y_z.link[row][l],
                    &y_z.link[row][l],
                    1e-12,
                    1e-12,
                    &format!("{what}: Yz[{row}][{l}]"),
                );
            }
            assert_close(&out.y.drive[row], &y.drive[row], 0.0, 0.0, &format!("{what}: drive[{row}]"));
            assert_close(&out.y_z.drive[row], &y_z.drive[row], 0.0, 0.0, &format!("{what}: drive_z[{row}]"));
        }
    }
}

#[test]
fn rows_and_nominal_torque_equal_the_full_regressor_and_rnea() {
    let paper = paper::robot();
    let specs = [TerminalSpec::PAPER, TerminalSpec::payload(6), TerminalSpec::new(2, [true; 4])];
    for (s, spec) in specs.iter().enumerate() {
        check_rows(&paper, spec, 10 + s as u64, "paper");
        check_rows(&ur5_like(3), spec, 20 + s as u64, "ur5-like");
        check_rows(&random_model::<6>(5, true), spec, 30 + s as u64, "random chain, prismatic joints");
        check_rows(&random_model::<6>(6, false), spec, 40 + s as u64, "random chain");
    }
    check_rows(&random_model::<3>(7, true), &TerminalSpec::payload(3), 50, "3-joint chain");
}

/// Columns of the terminal regressor that are independent on random states (greedy
/// Gram-Schmidt with a relative threshold): an identifiable set, found independently of
/// the code under test from the full regressor.
fn independent_columns<const N: usize>(model: &Model<N>, spec: &TerminalSpec, seed: u64) -> Vec<usize> {
    let mut rng = Rng(seed);
    let mut data = Data::<N>::new();
    let rows: Vec<usize> = spec.rows(N).collect();
    let samples = 60;
    let mut a = DMatrix::<f64>::zeros(samples * rows.len(), spec.cols(N));
    for s in 0..samples {
        let (q, qd, qdd) = state::<N>(&mut rng);
        let y = regressor(model, &mut data, &q, &qd, &qdd);
        for (r, &row) in rows.iter().enumerate() {
            for c in 0..spec.cols(N) {
                a[(s * rows.len() + r, c)] = spec.entry(y, row, c);
            }
        }
    }
    let mut basis: Vec<DVector<f64>> = vec![];
    let mut chosen = vec![];
    for c in 0..spec.cols(N) {
        let mut v = a.column(c).into_owned();
        let n0 = v.norm();
        for b in &basis {
            v -= b * b.dot(&v);
        }
        if n0 > 0.0 && v.norm() > 1e-6 * n0 {
            basis.push(v.normalize());
            chosen.push(c);
        }
    }
    chosen
}

/// Runs the reduced and the full update side by side over `samples` random samples
/// (torques of the nominal model with a changed last link, noisy accelerations, an
/// instrument of its own) and compares the estimates (and the IV `P`) after each.
/// `Kind::IvInfo` runs the reduced update with the information form against the full
/// update with the covariance form: two recursions of the same estimate.
fn compare_updates<const N: usize>(model: &Model<N>, spec: TerminalSpec, kind: Kind, seed: u64, what: &str) {
    let cols = independent_columns(model, &spec, seed);
    let d = cols.len();
    let method = |reference: bool| {
        let z = DVector::zeros(d);
        match kind {
            Kind::Ls => Method::Ls(Rls::<Dyn>::new(z, 1e4)),
            Kind::IvInfo if !reference => Method::IvInfo(RivInfo::<Dyn>::new(z, 1e4)),
            Kind::Iv | Kind::IvInfo => Method::Iv(Riv::<Dyn>::new(z, 1e4)),
        }
    };
    let weights = [1.0; N].map(|w| w * 0.5);
    let cv = DVector::from_vec(cols.clone());
    let mut reduced = TerminalLink::<N, Dyn>::new(model.clone(), spec, cv.clone(), weights, method(false));
    let mut full = TerminalLink::<N, Dyn>::new(model.clone(), spec, cv, weights, method(true));
    let mut truth = model.clone();
    truth.inertia[N - 1].0[0] += 0.5;
    truth.inertia[N - 1].0[1] += 0.02;
    truth.inertia[N - 1].0[9] += 0.003;
    let mut rng = Rng(seed + 1);
    let mut data = Data::<N>::new();
    for k in 0..300 {
        let (q, qd, qdd) = state::<N>(&mut rng);
        let tau = *rnea(&truth, &mut data, &q, &qd, &qdd) + rng.vecn::<N>(-0.05, 0.05);
        let qdd_meas = qdd + rng.vecn::<N>(-1.0, 1.0);
        let qdd_z = qdd + rng.vecn::<N>(-0.3, 0.3);
        reduced.update(&q, &qd, &qdd_meas, &tau, &qdd_z).unwrap();
        full.update_full(&q, &qd, &qdd_meas, &tau, &qdd_z).unwrap();
        let (a, b) = (reduced.theta(), full.theta());
        let scale = b.norm().max(1e-3);
        assert!(
            (a - b).norm() <= 1e-8 * scale,
            "{what}, sample {k}: |dtheta| {:e} vs |theta| {scale:e}",
            (a - b).norm()
        );
        match (&reduced.method, &full.method) {
            (Method::Iv(ra), Method::Iv(rb)) => {
                assert!((&ra.p - &rb.p).norm() <= 1e-8 * rb.p.norm(), "{what}, sample {k}: P")
            }
            (Method::IvInfo(ra), Method::Iv(rb)) if k % 50 == 0 => {
                assert!((ra.p() - &rb.p).norm() <= 1e-8 * rb.p.norm(), "{what}, sample {k}: P")
            }
            _ => {}
        }
    }
    assert_eq!(reduced.rows_used, full.rows_used);
}

#[derive(Clone, Copy)]
enum Kind {
    Ls,
    Iv,
    IvInfo,
}

const KINDS: [Kind; 3] = [Kind::Iv, Kind::Ls, Kind::IvInfo];

#[test]
fn reduced_update_equals_full_update_paper_robot() {
    let paper = paper::robot();
    // the bench's configuration: rows of joints 5 and 6, links 5 and 6 with (fc, fv)
    for iv in KINDS {
        compare_updates(&paper, TerminalSpec::PAPER, iv, 1, "paper k=5");
        compare_updates(&paper, TerminalSpec::payload(6), iv, 2, "paper payload");
    }
    let cols = independent_columns(&paper, &TerminalSpec::PAPER, 1);
    // NOTES.md: 24 columns of rank 18
    assert_eq!(cols.len(), 18, "{cols:?}");
}

#[test]
fn reduced_update_equals_full_update_ur5_like_and_random_chains() {
    for iv in KINDS {
        let ur5 = ur5_like(11);
        compare_updates(&ur5, TerminalSpec::new(4, [true, true, false, false]), iv, 3, "ur5-like k=5");
        compare_updates(&ur5, TerminalSpec::payload(6), iv, 4, "ur5-like payload");
        let chain = random_model::<6>(12, true);
        compare_updates(&chain, TerminalSpec::new(3, [true; 4]), iv, 5, "random chain k=4");
        compare_updates(
            &chain,
            TerminalSpec { first_row: 1, ..TerminalSpec::new(4, [true, false, true, false]) },
            iv,
            6,
            "random chain rows 2..6",
        );
    }
}

/// Skipped slow rows and refused input behave as in the full update.
#[test]
fn skipped_rows_and_refused_input_as_in_the_full_update() {
    let paper = paper::robot();
    let cols = DVector::from_vec(independent_columns(&paper, &TerminalSpec::PAPER, 1));
    for info in [false, true] {
        skipped_rows_and_refused_input(&paper, &cols, info);
    }
}

/// `info`: the reduced update in the information form (against the covariance form).
fn skipped_rows_and_refused_input(paper: &Model<6>, cols: &DVector<usize>, info: bool) {
    let m = |info: bool| {
        let z = DVector::zeros(cols.len());
        if info { Method::IvInfo(RivInfo::<Dyn>::new(z, 1e4)) } else { Method::Iv(Riv::<Dyn>::new(z, 1e4)) }
    };
    let w = [0.0, 0.0, 0.0, 0.0, 0.01, 1.0];
    let mut a = TerminalLink::<6, Dyn>::new(paper.clone(), TerminalSpec::PAPER, cols.clone(), w, m(info));
    let mut b = TerminalLink::<6, Dyn>::new(paper.clone(), TerminalSpec::PAPER, cols.clone(), w, m(false));
    a.min_speed = 0.5;
    b.min_speed = 0.5;
    let mut rng = Rng(9);
    for _ in 0..100 {
        let (q, qd, qdd) = state::<6>(&mut rng);
        let tau = rng.vecn::<6>(-1.0, 1.0);
        a.update(&q, &qd, &qdd, &tau, &qdd).unwrap();
        b.update_full(&q, &qd, &qdd, &tau, &qdd).unwrap();
    }
    assert!(a.rows_skipped > 0);
    assert_eq!((a.rows_used, a.rows_skipped), (b.rows_used, b.rows_skipped));
    assert!((a.theta() - b.theta()).norm() <= 1e-8 * b.theta().norm());
    let (q, qd, qdd) = state::<6>(&mut rng);
    let mut bad = qdd;
    bad[2] = f64::NAN;
    let before = a.theta().clone();
    assert_eq!(a.update(&q, &qd, &bad, &qdd, &qdd), b.update_full(&q, &qd, &bad, &qdd, &qdd));
    assert_eq!(a.update(&q, &qd, &qdd, &qdd, &bad), b.update_full(&q, &qd, &qdd, &qdd, &bad));
    assert_eq!(a.theta(), &before);
}

/// The same code in `f32` (a small controller's build): the rows agree with `f64` to the
/// precision of `f32` (a few ulps per operation over a few hundred operations: 1e-4 of the
/// rows' scale), and the estimator runs.
#[test]
fn f32_rows_match_f64_and_the_estimator_runs() {
    use nalgebra::{Const, SVector};
    let paper = paper::robot();
    let spec = TerminalSpec::PAPER;
    let mut needed = Needed::<6> { first_row: spec.k, ..Needed::NONE };
    for row in spec.k..6 {
        for l in row..6 {
            needed.link[row][l] = (1 << LINK_PARAMS) - 1;
        }
        needed.drive[row] = [true; 4];
    }
    let (mut o64, mut o32) = (TerminalRows::<6>::new(), TerminalRows::<6, f32>::new());
    let mut rng = Rng(77);
    for _ in 0..50 {
        let (q, qd, qdd) = state::<6>(&mut rng);
        let c = |v: &VecN<6>| v.map(|x| x as f32);
        terminal_rows(&paper, &needed, &mut o64, &q, &qd, &qdd, None);
        terminal_rows(&paper, &needed, &mut o32, &c(&q), &c(&qd), &c(&qdd), None);
        for row in spec.k..6 {
            let scale = (row..6).flat_map(|l| o64.y.link[row][l]).fold(0.0f64, |a, x| a.max(x.abs()));
            for l in row..6 {
                let a: Vec<f64> = o32.y.link[row][l].iter().map(|&x| x as f64).collect();
                assert_close(&a, &o64.y.link[row][l], 0.0, 1e-4 * scale, "f32 block");
            }
            assert_close(&[o32.tau[row] as f64], &[o64.tau[row]], 1e-4, 1e-4 * o64.tau.amax(), "f32 tau");
        }
    }
    let cols = SVector::<usize, 18>::from_iterator(independent_columns(&paper, &spec, 1));
    let z = SVector::<f32, 18>::zeros();
    let mut tl = TerminalLink::<6, Const<18>, f32>::new(
        paper.clone(),
        spec,
        cols,
        [0.0, 0.0, 0.0, 0.0, 0.01, 1.0],
        Method::Ls(Rls::new(z, 1e4)),
    );
    for _ in 0..100 {
        let (q, qd, qdd) = state::<6>(&mut rng);
        let c = |v: &VecN<6>| v.map(|x| x as f32);
        tl.update(&c(&q), &c(&qd), &c(&qdd), &c(&rng.vecn::<6>(-1.0, 1.0)), &c(&qdd)).unwrap();
    }
    assert_eq!(tl.rows_used, 200);
    assert!(tl.theta().iter().all(|x| x.is_finite()));
}
