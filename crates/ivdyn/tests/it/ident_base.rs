//! Base parameters found numerically: the defining identity `Y θ = Y_base project(θ)`,
//! stability of the rank, physically zero columns, and the known UR5 result (36).

use ivdyn::Robot;
use ivdyn::ident::{BaseParams, robot_base_params};
use ivdyn_core::rng::Rng;
use nalgebra::DMatrix;

/// Random state (q in ±π, qd in ±1.5, qdd in ±3) from `rng`.
fn state(rng: &mut Rng, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let pi = std::f64::consts::PI;
    let q = (0..n).map(|_| rng.uniform(-pi, pi)).collect();
    let qd = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
    let qdd = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
    (q, qd, qdd)
}

/// Max over fresh states of `|Y θ - Y_base project(θ)|` for random `θ` (first `cols`
/// columns of the regressor), relative to `max |Y θ|`.
fn identity_error(robot: &Robot, base: &BaseParams, cols: usize, seed: u64) -> f64 {
    let (n, p) = (robot.dof(), robot.num_params());
    let mut rng = Rng::new(seed);
    let theta: Vec<f64> = (0..cols).map(|_| rng.normal()).collect();
    let theta_b = base.project(&theta).unwrap();
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for _ in 0..50 {
        let (q, qd, qdd) = state(&mut rng, n);
        let y = robot.regressor(&q, &qd, &qdd).unwrap();
        let rows: Vec<f64> = (0..n).flat_map(|r| y[r * p..r * p + cols].to_vec()).collect();
        let yb = base.select_rows(&rows, n).unwrap();
        let b = base.base_count();
        for r in 0..n {
            let tau: f64 = (0..cols).map(|c| rows[r * cols + c] * theta[c]).sum();
            let tau_b: f64 = (0..b).map(|c| yb[r * b + c] * theta_b[c]).sum();
            worst = worst.max((tau - tau_b).abs());
            scale = scale.max(tau.abs());
        }
    }
    worst / scale.max(1.0)
}

#[test]
fn paper_robot_base_parameters() {
    let robot = Robot::paper();
    let p = robot.num_params();
    let t = std::time::Instant::now();
    let base = robot_base_params(&robot, 100, 1).unwrap();
    println!("base parameters of the paper's robot ({} of {p}, {:?}):", base.base_count(), t.elapsed());
    for name in &base.names {
        println!("  {name}");
    }
    let names = robot.param_names();
    println!("zero columns: {:?}", base.zero_columns.iter().map(|&j| &names[j]).collect::<Vec<_>>());

    // The rank does not depend on the seed or the number of samples.
    for (samples, seed) in [(40, 2), (100, 3), (300, 4)] {
        let other = robot_base_params(&robot, samples, seed).unwrap();
        assert_eq!(other.base_count(), base.base_count(), "samples {samples}, seed {seed}");
        assert_eq!(other.zero_columns, base.zero_columns);
    }
    // partition of the columns
    assert_eq!(base.independent.len() + base.dependent.len(), p);
    assert_eq!(base.k.shape(), (base.base_count(), base.dependent.len()));

    // The defining identity on fresh random states.
    let err = identity_error(&robot, &base, p, 99);
    println!("identity error (relative to max |tau|): {err:.2e}");
    assert!(err < 1e-10, "{err}");

    // Link 1 turns about the fixed vertical base axis z through its frame origin: only
    // its Izz acts (about the axis); m, m*c (the origin does not move and gravity is
    // parallel to the axis) and the other inertia entries have no effect at all.
    for what in ["m", "m*cx", "m*cy", "m*cz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz"] {
        let j = names.iter().position(|n| n == &format!("link1.{what}")).unwrap();
        assert!(base.zero_columns.contains(&j), "link1.{what} should be a zero column");
    }
    let izz1 = names.iter().position(|n| n == "link1.Izz").unwrap();
    assert!(!base.zero_columns.contains(&izz1));
    // ... and link1.Izz and joint1's armature act identically (both multiply qdd1 on
    // tau1 only), so they enter every base parameter with the same coefficient.
    let ia1 = names.iter().position(|n| n == "joint1.ia").unwrap();
    let unit = |j: usize| (0..p).map(|i| (i == j) as u8 as f64).collect::<Vec<_>>();
    let (a, b) = (base.project(&unit(izz1)).unwrap(), base.project(&unit(ia1)).unwrap());
    assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12), "{a:?} vs {b:?}");
    assert!(a.iter().any(|x| x.abs() > 0.5));

    // round trip
    let x: Vec<f64> = (0..base.base_count()).map(|i| i as f64 * 0.1 - 1.0).collect();
    let back = base.project(&base.to_full(&x).unwrap()).unwrap();
    assert!(back.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-15));
    assert!(base.project(&[0.0; 3]).is_err());
}

#[test]
fn ur5_rigid_body_base_count_is_36() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
    let robot = Robot::from_urdf(path, Some("base_link"), Some("tool0")).unwrap();
    let (n, p) = (robot.dof(), robot.num_params());
    assert_eq!(n, 6);
    let cols = 10 * n; // the inertial columns, drive columns excluded
    let names = robot.param_names()[..cols].to_vec();
    let mut counts = vec![];
    for (samples, seed) in [(60, 5), (150, 6)] {
        let mut rng = Rng::new(seed);
        let mut phi = DMatrix::zeros(samples * n, cols);
        for s in 0..samples {
            let (q, qd, qdd) = state(&mut rng, n);
            let y = robot.regressor(&q, &qd, &qdd).unwrap();
            for r in 0..n {
                for c in 0..cols {
                    phi[(s * n + r, c)] = y[r * p + c];
                }
            }
        }
        let base = BaseParams::from_rows(&phi, &names);
        counts.push(base.base_count());
        let err = identity_error(&robot, &base, cols, 7);
        assert!(err < 1e-10, "identity error {err}");
        if samples == 150 {
            println!("UR5 base parameters ({}):", base.base_count());
            for name in &base.names {
                println!("  {name}");
            }
        }
    }
    assert_eq!(counts, vec![36, 36]);
    // with the drive columns (identity only; the count is printed)
    let full = robot_base_params(&robot, 100, 8).unwrap();
    let all = robot.param_names();
    let dep: Vec<&String> = full.dependent.iter().filter(|&&j| j >= cols).map(|&j| &all[j]).collect();
    println!("UR5 with drive parameters: {} base parameters; dependent drive columns {dep:?}", full.base_count());
    assert!(identity_error(&robot, &full, p, 9) < 1e-10);
}

/// Issue 16: the sampled regressor is sized by `samples`: bounded, with the argument named,
/// and neither the allocation nor `samples * dof` is attempted beyond it.
#[test]
fn base_params_samples_bounded() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
    let robot = Robot::from_urdf(path, Some("base_link"), Some("tool0")).unwrap();
    for samples in [ivdyn::ident::base::MAX_BASE_SAMPLES + 1, usize::MAX] {
        let e = robot_base_params(&robot, samples, 1).unwrap_err().to_string();
        assert!(e.contains("samples must be at most 20000"), "{e}");
    }
    let e = ivdyn::ident::arrays::RecursiveLs::new(30000, 1e4, 1.0).err().unwrap().to_string();
    assert!(e.contains("p must be in 1..=4096, got 30000"), "{e}");
}
