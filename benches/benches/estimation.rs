//! Estimation hot paths: one recursive update of the paper's terminal-link problem
//! (k = 5, 18 base columns, rows of joints 5 and 6: dynamics + estimator; the reduced
//! update in covariance and information form, and the full-dynamics reference), one scalar-row
//! update of RLS and RIV over the paper robot's full base set, and a batch fit of 100 000
//! UR5 samples (regressor + streaming QR least squares).

use criterion::{Criterion, criterion_group, criterion_main};
use ivdyn::Robot;
use ivdyn::ident::{LsAccumulator, base::robot_base_params, fit_ls};
use ivdyn_core::estim::terminal::{Method, TerminalLink};
use ivdyn_core::estim::{Riv, RivInfo, Rls};
use ivdyn_core::rng::Rng;
use ivdyn_core::{Data, VecN};
use ivdyn_lab::repro::{Estimator, PaperSim};
use nalgebra::{Const, DVector, Dyn, SVector};
use std::hint::black_box;

fn terminal_link(c: &mut Criterion) {
    let sim = PaperSim::new(0).unwrap();
    assert_eq!(sim.base.base_count(), 18);
    let cols = SVector::<usize, 18>::from_iterator(sim.base.independent.iter().copied());
    let mut tl = TerminalLink::<6, Const<18>>::new(
        sim.nominal.clone(),
        sim.spec,
        cols,
        sim.row_weight,
        Method::Iv(Riv::new(SVector::<f64, 18>::zeros(), 1e4)),
    );
    let samples: Vec<_> = sim.samples(1, 4000).collect();
    let mut d = Data::<6>::new();
    let instr: Vec<VecN<6>> =
        samples.iter().map(|s| Estimator::IvmEq35.instrument(&sim, s, &mut d).unwrap().unwrap()).collect();
    let mut k = 0;
    c.bench_function("terminal_link_iv_update/paper_k5_18cols", |b| {
        b.iter(|| {
            k = (k + 1) % samples.len();
            let s = &samples[k];
            tl.update(&s.q, &s.qd, &s.qdd_meas, &s.tau, &instr[k]).unwrap();
            black_box(tl.theta()[0])
        })
    });
    // the same update from the full dynamics (full RNEA, two full regressors, dense rows):
    // the implementation before issue 19, kept as the reference of tests/terminal_update.rs
    let mut full = tl.clone();
    c.bench_function("terminal_link_iv_update_full/paper_k5_18cols", |b| {
        b.iter(|| {
            k = (k + 1) % samples.len();
            let s = &samples[k];
            full.update_full(&s.q, &s.qd, &s.qdd_meas, &s.tau, &instr[k]).unwrap();
            black_box(full.theta()[0])
        })
    });
    // the same estimate in information form (LU factors of R updated by Bennett's rank-one
    // algorithm, one estimate per sample)
    let mut info = TerminalLink::<6, Const<18>>::new(
        sim.nominal.clone(),
        sim.spec,
        cols,
        sim.row_weight,
        Method::IvInfo(RivInfo::new(SVector::<f64, 18>::zeros(), 1e4)),
    );
    c.bench_function("terminal_link_iv_info_update/paper_k5_18cols", |b| {
        b.iter(|| {
            k = (k + 1) % samples.len();
            let s = &samples[k];
            info.update(&s.q, &s.qd, &s.qdd_meas, &s.tau, &instr[k]).unwrap();
            black_box(info.theta()[0])
        })
    });
    let mut ls = TerminalLink::<6, Const<18>>::new(
        sim.nominal.clone(),
        sim.spec,
        cols,
        sim.row_weight,
        Method::Ls(Rls::new(SVector::<f64, 18>::zeros(), 1e4)),
    );
    c.bench_function("terminal_link_ls_update/paper_k5_18cols", |b| {
        b.iter(|| {
            k = (k + 1) % samples.len();
            let s = &samples[k];
            ls.update(&s.q, &s.qd, &s.qdd_meas, &s.tau, &s.qdd_meas).unwrap();
            black_box(ls.theta()[0])
        })
    });
}

fn full_base_set(c: &mut Criterion) {
    // the paper robot's full base set (inertial + drive)
    let robot = Robot::paper();
    let base = robot_base_params(&robot, 100, 1).unwrap();
    let b = base.base_count();
    let mut rng = Rng::new(3);
    let rows: Vec<DVector<f64>> = (0..1024).map(|_| DVector::from_fn(b, |_, _| rng.uniform(-1.0, 1.0))).collect();
    let mut rls = Rls::<Dyn>::new(DVector::zeros(b), 1e4);
    let mut riv = Riv::<Dyn>::new(DVector::zeros(b), 1e4);
    let mut k = 0;
    c.bench_function(&format!("rls_row_update/paper_full_base_{b}"), |bch| {
        bch.iter(|| {
            k = (k + 1) & 1023;
            rls.update(&rows[k], 0.5, 1.0).unwrap();
        })
    });
    c.bench_function(&format!("riv_row_update/paper_full_base_{b}"), |bch| {
        bch.iter(|| {
            k = (k + 1) & 1023;
            riv.update(&rows[k], &rows[(k + 7) & 1023], 0.5, 1.0).unwrap();
        })
    });
}

fn batch_fit(c: &mut Criterion) {
    let robot =
        Robot::from_urdf(ivdyn_benches::root().join("fixtures/ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
    let base = robot_base_params(&robot, 60, 1).unwrap();
    let (n, p, b) = (robot.dof(), robot.num_params(), base.base_count());
    let states = ivdyn_benches::states::<6>(100_000);
    let mut g = c.benchmark_group("batch");
    g.sample_size(10);
    g.bench_function("ur5_100k_samples_regressor_plus_qr_ls", |bch| {
        bch.iter(|| {
            let mut acc = LsAccumulator::new(b);
            let (mut phi, mut y) = (Vec::with_capacity(4096 * b), Vec::with_capacity(4096));
            let mut row_b = vec![0.0; b];
            let mut yf = vec![0.0; n * p];
            let mut data = Data::<6>::new();
            let ivdyn::DynModel::N6(m) = &robot.model else { unreachable!() };
            for (q, qd, qdd) in &states {
                let tau = *ivdyn_core::rnea(m, &mut data, q, qd, qdd);
                ivdyn_core::regressor(m, &mut data, q, qd, qdd).write_row_major(&mut yf);
                for i in 0..n {
                    base.select_row(&yf[i * p..(i + 1) * p], &mut row_b).unwrap();
                    phi.extend_from_slice(&row_b);
                    y.push(tau[i]);
                }
                if y.len() >= 4096 {
                    acc.add_rows(&phi, &y, None).unwrap();
                    phi.clear();
                    y.clear();
                }
            }
            acc.add_rows(&phi, &y, None).unwrap();
            black_box(fit_ls(&acc, &base.names).unwrap().theta[0])
        })
    });
    // the fused, multi-threaded path (ivdyn::ident::fit_ls_batch): full base set and the
    // rigid-body base set (36 of 60 columns, as the Pinocchio + numpy anchor fits)
    let (mut q, mut qd, mut qdd) = (vec![], vec![], vec![]);
    for (a, b, c) in &states {
        q.extend_from_slice(a.as_slice());
        qd.extend_from_slice(b.as_slice());
        qdd.extend_from_slice(c.as_slice());
    }
    let tau = {
        let mut out = vec![0.0; q.len()];
        ivdyn::batch::rnea_batch(&robot, &q, &qd, &qdd, &mut out).unwrap();
        out
    };
    g.bench_function("ur5_100k_fused_fit_ls_batch_full_base", |bch| {
        bch.iter(|| black_box(ivdyn::ident::fit_ls_batch(&robot, &base, &q, &qd, &qdd, &tau, None).unwrap().theta[0]))
    });
    let rigid = {
        let mut phi = nalgebra::DMatrix::<f64>::zeros(6 * 200, 60);
        let mut yr = vec![0.0; 6 * 60];
        for (k, (a, b, c)) in states.iter().take(200).enumerate() {
            ivdyn::batch::regressor_batch(&robot, a.as_slice(), b.as_slice(), c.as_slice(), &mut yr, true).unwrap();
            for i in 0..6 {
                for j in 0..60 {
                    phi[(6 * k + i, j)] = yr[60 * i + j];
                }
            }
        }
        ivdyn::ident::BaseParams::from_rows(&phi, &robot.param_names()[..60])
    };
    assert_eq!(rigid.base_count(), 36);
    g.bench_function("ur5_100k_fused_fit_ls_batch_rigid_base_36", |bch| {
        bch.iter(|| black_box(ivdyn::ident::fit_ls_batch(&robot, &rigid, &q, &qd, &qdd, &tau, None).unwrap().theta[0]))
    });
    g.finish();
}

/// The parallel filter of `identify` (the zero-phase low-pass of the torque and of every
/// regressor column, `Butterworth::filtfilt_columns`): a UR5's 60 s at 1 kHz, 6 x 78
/// columns of the stacked regressor and torque, at the default cut-off; against the same
/// columns gathered and filtered one at a time (`filtfilt`: the loop `filtfilt_columns`
/// ran before it swept whole rows, with today's single-signal kernel).
fn parallel_filter(c: &mut Criterion) {
    let (t, m, fs) = (60_000, 6 * 13, 1000.0);
    let x: Vec<f64> = (0..t * m).map(|i| ((i % m) as f64 + 1.0) * (1e-3 * (i / m) as f64).sin()).collect();
    let f = ivdyn::dsp::Butterworth::default_for(fs).unwrap();
    let mut g = c.benchmark_group("parallel_filter");
    g.sample_size(10);
    g.bench_function("ur5_60s_1khz_78_columns_grouped", |b| {
        b.iter(|| black_box(f.filtfilt_columns(&x, m).unwrap()[0]))
    });
    g.bench_function("ur5_60s_1khz_78_columns_one_by_one", |b| {
        b.iter(|| {
            let mut s = 0.0;
            let mut col = vec![0.0; t];
            for j in 0..m {
                for k in 0..t {
                    col[k] = x[k * m + j];
                }
                s += f.filtfilt(&col)[0];
            }
            black_box(s)
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = terminal_link, full_base_set, batch_fit, parallel_filter
}
criterion_main!(benches);
