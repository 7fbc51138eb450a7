//! The paper's simulation (k = 5 terminal-link problem on the paper's robot).

use ivdyn_lab::repro::{Estimator, PaperSim, batch_estimates, recursive_traces};

/// Noise-free accelerations: every base combination is recovered exactly (1e-9 relative,
/// 1e-10 absolute where the truth is zero) by every estimator, batch and recursive.
#[test]
fn noise_free_recovers_every_base_parameter() {
    let mut sim = PaperSim::new(3).unwrap();
    sim.accel_noise = 0.0;
    sim.eq35 = sim.fit_eq35(77, 4000);
    assert_eq!(sim.base.base_count(), 18, "{:?}", sim.base.names);
    let est = batch_estimates(&sim, 5, &[4000]).unwrap();
    // the recursion starts from a prior (p0 I); with p0 = 1e12 its pull is ~1e-12 relative
    let rec = recursive_traces(&sim, 5, &[4000], 1e12).unwrap();
    for (k, e) in Estimator::ALL.iter().enumerate() {
        for (label, theta) in [("batch", &est[k][0]), ("recursive", &rec[k][0])] {
            for (b, (x, t)) in theta.iter().zip(&sim.truth_base).enumerate() {
                let tol = if t.abs() > 1e-12 { 1e-9 * t.abs() } else { 1e-10 };
                let tol = if label == "recursive" { tol.max(1e-9 * t.abs()) } else { tol };
                assert!((x - t).abs() <= tol, "{} {label} {}: {x:e} vs {t:e}", e.label(), sim.base.names[b]);
            }
        }
    }
}

/// The mass of link 6 has no effect on joints 5 and 6 (NOTES.md: frame 6's origin lies on
/// both axes): it must be reported as not identifiable, never estimated.
#[test]
fn payload_mass_is_not_identifiable_from_joints_5_and_6() {
    let sim = PaperSim::new(0).unwrap();
    let names = ivdyn_lab::repro::terminal_names(&sim.spec, 6);
    let zero: Vec<&str> = sim.base.zero_columns.iter().map(|&c| names[c].as_str()).collect();
    assert!(zero.contains(&"link6.m"), "{zero:?}");
    assert!(sim.base.names.iter().all(|n| !n.split(" ").any(|t| t == "link6.m")));
}

fn index(sim: &PaperSim, name: &str) -> usize {
    sim.base_index(name).unwrap_or_else(|| panic!("{name} not in {:?}", sim.base.names))
}

/// N = 1e5 on 10 seeds (nominal errors and noise drawn per seed): LSM is clearly biased
/// (NOTES.md's independent check: >= 30 % on ZZ6, >= 5 % on the larger first moment),
/// the IVM with the planned-acceleration instrument is within 5 % on m6cx, m6cy, Fc6 and
/// ZZ6 on every seed.
#[test]
fn ivm_consistent_where_lsm_is_biased_at_1e5_samples() {
    let seeds: Vec<u64> = (0..10).collect();
    let results: Vec<_> = std::thread::scope(|s| {
        let hs: Vec<_> = seeds
            .chunks(5)
            .map(|ch| {
                s.spawn(move || {
                    ch.iter()
                        .map(|&seed| {
                            let sim = PaperSim::new(seed).unwrap();
                            let e = batch_estimates(&sim, 1_000_000 + seed, &[100_000]).unwrap();
                            (sim, e)
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        hs.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    for (sim, e) in &results {
        let rel = |k: usize, name: &str| {
            let b = index(sim, name);
            (e[k][0][b] - sim.truth_base[b]) / sim.truth_base[b].abs()
        };
        let (lsm, planned) = (0, 3);
        assert!(rel(lsm, "link6.Izz").abs() >= 0.30, "LSM ZZ6 error {}", rel(lsm, "link6.Izz"));
        assert!(rel(lsm, "link6.m*cx").abs().max(rel(lsm, "link6.m*cy").abs()) >= 0.05);
        for name in ["link6.m*cx", "link6.m*cy", "joint6.fc", "link6.Izz"] {
            assert!(rel(planned, name).abs() < 0.05, "IVM planned {name}: {}", rel(planned, name));
        }
    }
}

/// On the paper's robot the k = 5 problem cannot see the payload mass: the conversion
/// refuses and names where the parameters went.
#[test]
fn unidentifiable_payload_is_reported_not_invented() {
    let sim = ivdyn_lab::repro::PaperSim::new(0).unwrap();
    let names = ivdyn_lab::repro::terminal_names(&sim.spec, 6);
    let fit = ivdyn::ident::FitReport {
        method: "LS".into(),
        names: sim.base.names.clone(),
        theta: sim.truth_base.clone(),
        std: vec![0.0; sim.base.base_count()],
        rel_std_pct: vec![0.0; sim.base.base_count()],
        covariance: nalgebra::DMatrix::zeros(sim.base.base_count(), sim.base.base_count()),
        sigma2: 0.0,
        rows: 0,
        rank: sim.base.base_count(),
        condition_number: 1.0,
        unexcited: vec![],
        dwh: None,
        theta_ls: None,
    };
    let link6: [usize; 10] = core::array::from_fn(|k| 12 + k); // link 6's 10 columns follow link 5's 12
    assert_eq!(names[12], "link6.m");
    let r = ivdyn::ident::payload_from_fit(&sim.base, &fit, &link6, &names).unwrap().unwrap_err();
    assert!(r.parameters.contains(&"link6.m".to_string()));
    let i = r.parameters.iter().position(|p| p == "link6.m").unwrap();
    assert_eq!(r.combined_in[i], "no effect on the data");
}
