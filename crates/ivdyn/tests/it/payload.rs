//! A 2 kg payload on the UR5's last link, estimated as a change of the terminal link from
//! every joint's residual against the unloaded model, and read as mass, COM and inertia.

use ivdyn::ident::{BaseParams, LsAccumulator, fit_ls, payload_from_fit};
use ivdyn::{DynModel, Robot};
use ivdyn_core::estim::TerminalSpec;
use ivdyn_core::rng::Rng;
use ivdyn_core::trajectory::Fourier;
use ivdyn_core::{Data, LinkInertia, Mat3, Model, Vec3, VecN, regressor, rnea};
use nalgebra::DMatrix;
use std::path::PathBuf;

fn ur5() -> Model<6> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    match Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap().model {
        DynModel::N6(m) => *m,
        _ => unreachable!(),
    }
}

const MASS: f64 = 2.0;
const COM: [f64; 3] = [0.01, -0.02, 0.06];
const IC: [f64; 3] = [4e-3, 5e-3, 3e-3];

fn payload() -> LinkInertia {
    LinkInertia::from_mass_com_inertia(
        MASS,
        &Vec3::new(COM[0], COM[1], COM[2]),
        &ivdyn_core::spatial::rpy_to_rot([0.2, -0.1, 0.3]),
        &Mat3::from_diagonal(&Vec3::new(IC[0], IC[1], IC[2])),
    )
}

fn names() -> Vec<String> {
    ivdyn_core::params::LINK_PARAM_NAMES.iter().map(|p| format!("payload.{p}")).collect()
}

/// Residual rows of the payload problem along a trajectory, torque noise `sigma`.
fn accumulate(nominal: &Model<6>, truth: &Model<6>, base: &BaseParams, sigma: f64, seed: u64) -> LsAccumulator {
    let spec = TerminalSpec::payload(6);
    let mut rng = Rng::new(seed);
    let mut f = Fourier::<6, 4> {
        omega: std::f64::consts::TAU / 8.0,
        q0: [0.0, -1.2, 1.0, -1.0, -1.5, 0.0],
        a: [[0.0; 4]; 6],
        b: [[0.0; 4]; 6],
    };
    let mut tr = Rng::new(4);
    for i in 0..6 {
        for l in 0..4 {
            f.a[i][l] = tr.uniform(-0.4, 0.4);
            f.b[i][l] = tr.uniform(-0.4, 0.4);
        }
    }
    let (mut d1, mut d2) = (Data::<6>::new(), Data::<6>::new());
    let mut acc = LsAccumulator::new(base.base_count());
    let (mut phi, mut y) = (vec![], vec![]);
    let mut full = [0.0; 10];
    let mut row_b = vec![0.0; base.base_count()];
    for k in 0..4000 {
        let (q, qd, qdd) = f.eval(k as f64 * 0.004);
        let tau = *rnea(truth, &mut d1, &q, &qd, &qdd);
        let tau_nom = *rnea(nominal, &mut d2, &q, &qd, &qdd);
        let yr = regressor(nominal, &mut d2, &q, &qd, &qdd);
        for row in spec.rows(6) {
            for (c, v) in full.iter_mut().enumerate() {
                *v = spec.entry(yr, row, c);
            }
            base.select_row(&full, &mut row_b).unwrap();
            phi.extend_from_slice(&row_b);
            y.push(tau[row] - tau_nom[row] + sigma * rng.normal());
        }
    }
    acc.add_rows(&phi, &y, None).unwrap();
    acc
}

fn base_of(nominal: &Model<6>) -> BaseParams {
    let spec = TerminalSpec::payload(6);
    let mut rng = Rng::new(1);
    let mut d = Data::<6>::new();
    let mut phi = DMatrix::zeros(200 * 6, 10);
    for s in 0..200 {
        let q = VecN::<6>::from_fn(|_, _| rng.uniform(-3.0, 3.0));
        let qd = VecN::<6>::from_fn(|_, _| rng.uniform(-1.0, 1.0));
        let qdd = VecN::<6>::from_fn(|_, _| rng.uniform(-2.0, 2.0));
        let y = regressor(nominal, &mut d, &q, &qd, &qdd);
        for row in 0..6 {
            for c in 0..10 {
                phi[(s * 6 + row, c)] = spec.entry(y, row, c);
            }
        }
    }
    BaseParams::from_rows(&phi, &names())
}

#[test]
fn noise_free_payload_is_recovered_exactly() {
    let nominal = ur5();
    let mut truth = nominal.clone();
    truth.inertia[5] = truth.inertia[5].add(&payload());
    let base = base_of(&nominal);
    assert_eq!(base.base_count(), 10, "all 10 payload parameters are identifiable from the 6 rows");
    let fit = fit_ls(&accumulate(&nominal, &truth, &base, 0.0, 0), &base.names).unwrap();
    let cols: [usize; 10] = core::array::from_fn(|k| k);
    let p = payload_from_fit(&base, &fit, &cols, &names()).unwrap().unwrap();
    assert!((p.mass - MASS).abs() < 1e-9, "{}", p.mass);
    for k in 0..3 {
        assert!((p.com[k] - COM[k]).abs() < 1e-9);
    }
    let (_, _, ic) = payload().to_mass_com_inertia(0).unwrap();
    // ivdyn's order [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]
    let want = [ic[(0, 0)], ic[(0, 1)], ic[(1, 1)], ic[(0, 2)], ic[(1, 2)], ic[(2, 2)]];
    for k in 0..6 {
        assert!((p.inertia[k] - want[k]).abs() < 1e-9, "{k}: {} vs {}", p.inertia[k], want[k]);
    }
}

/// With torque noise sigma = 0.5 N m, the mass's 95 % interval covers the truth in
/// 95 % of 200 seeds (binomial s.e. 1.5 %; accept 90-99 %), and the COM std is honest too.
#[test]
fn payload_uncertainty_covers_the_truth() {
    let nominal = ur5();
    let mut truth = nominal.clone();
    truth.inertia[5] = truth.inertia[5].add(&payload());
    let base = base_of(&nominal);
    let cols: [usize; 10] = core::array::from_fn(|k| k);
    let (mut in_m, mut in_c) = (0, 0);
    let trials = 200;
    for seed in 0..trials {
        let fit = fit_ls(&accumulate(&nominal, &truth, &base, 0.5, 10 + seed), &base.names).unwrap();
        let p = payload_from_fit(&base, &fit, &cols, &names()).unwrap().unwrap();
        if (p.mass - MASS).abs() <= 1.96 * p.mass_std {
            in_m += 1;
        }
        if (p.com[2] - COM[2]).abs() <= 1.96 * p.com_std[2] {
            in_c += 1;
        }
    }
    let (rm, rc) = (in_m as f64 / trials as f64, in_c as f64 / trials as f64);
    eprintln!("coverage: mass {rm}, com z {rc}");
    assert!((0.90..=0.99).contains(&rm) && (0.90..=0.99).contains(&rc), "mass {rm} com {rc}");
}

/// A point mass on noise-free data: the LS fit is the truth, on the boundary of the rigid
/// bodies (zero inertia about the COM), with a covariance of rounding size. The projection
/// must still land on a possible body (the margin) at the truth's mass and COM. (The
/// Mahalanobis distance is no statistic here: the fit's std and its error are both rounding,
/// of unrelated sizes; it came out 6e3.)
#[test]
fn noise_free_point_mass_stays_at_the_truth_and_is_possible() {
    let nominal = ur5();
    let mut truth = nominal.clone();
    let point =
        LinkInertia::from_mass_com_inertia(MASS, &Vec3::new(COM[0], COM[1], COM[2]), &Mat3::identity(), &Mat3::zeros());
    truth.inertia[5] = truth.inertia[5].add(&point);
    let base = base_of(&nominal);
    let fit = fit_ls(&accumulate(&nominal, &truth, &base, 0.0, 0), &base.names).unwrap();
    let cols: [usize; 10] = core::array::from_fn(|k| k);
    let p = payload_from_fit(&base, &fit, &cols, &names()).unwrap().unwrap();
    assert!((p.mass - MASS).abs() < 1e-6 * MASS, "{}", p.mass);
    for k in 0..3 {
        assert!((p.com[k] - COM[k]).abs() < 1e-6, "{:?}", p.com);
    }
    let v = &p.physical.violation;
    assert!(v.possible && v.min_principal_moment.unwrap() > 0.0 && v.triangle_margin.unwrap() > 0.0, "{v:?}");
    // the inertia is the margin's: 2e-6 of m (5 cm)^2 = 1e-8 kg m^2 per second moment
    assert!(p.inertia.iter().all(|i| i.abs() < 1e-7), "{:?}", p.inertia);
}
