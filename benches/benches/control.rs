//! One control step of the online loop: the computed-torque controller (one RNEA) plus
//! the payload estimator's update (one RNEA, two regressors, `N` scalar IV updates over
//! the last link's 10 parameters), fixed sizes, no allocation. Paper's robot (N = 6) and
//! the Panda (N = 7). Each iteration uses the next of 1024 states, `Data` reused.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use ivdyn_benches::{panda7, states};
use ivdyn_core::control::{ComputedTorque, Gains, PayloadEstimator, Reference};
use ivdyn_core::estim::Riv;
use ivdyn_core::estim::terminal::Method;
use ivdyn_core::{Data, Model, paper};
use nalgebra::{Const, SVector};
use std::hint::black_box;

fn bench_robot<const N: usize>(c: &mut Criterion, name: &str, model: &Model<N>) {
    let xs = states::<N>(1024);
    let mut data = Data::<N>::new();
    let ct = ComputedTorque::new(Gains::<N>::critically_damped(20.0));
    let cols = SVector::<usize, 10>::from_fn(|i, _| i);
    let mk = || {
        PayloadEstimator::new(
            model.clone(),
            cols,
            [1.0; N],
            0.0,
            Method::Iv(Riv::<Const<10>>::new(SVector::zeros(), 1e3)),
        )
        .unwrap()
    };
    let mut est = mk();
    let mut ctrl_model = model.clone();
    let mut g = c.benchmark_group(format!("control_{name}"));
    let mut k = 0usize;
    let mut next = || {
        k = (k + 1) & 1023;
        k
    };
    g.bench_function(BenchmarkId::new("computed_torque", N), |b| {
        b.iter(|| {
            let (q, qd, qdd) = &xs[next()];
            let r = Reference { q: *q * 0.99, qd: *qd, qdd: *qdd };
            black_box(ct.torque(model, &mut data, q, qd, &r).unwrap()[0])
        })
    });
    g.bench_function(BenchmarkId::new("estimator_update", N), |b| {
        b.iter(|| {
            let i = next();
            let (q, qd, qdd) = &xs[i];
            let tau = xs[(i + 7) & 1023].2;
            est.update(q, qd, qdd, &tau, &(qdd * 0.9)).unwrap();
            black_box(est.theta()[0])
        })
    });
    let mut est = mk();
    g.bench_function(BenchmarkId::new("control_step", N), |b| {
        b.iter(|| {
            let i = next();
            let (q, qd, qdd) = &xs[i];
            let r = Reference { q: *q * 0.99, qd: *qd, qdd: *qdd };
            let u = *ct.torque(&ctrl_model, &mut data, q, qd, &r).unwrap();
            est.update(q, qd, qdd, &u, &r.qdd).unwrap();
            est.write_model_if_consistent(&mut ctrl_model, 1e-12);
            black_box(u[0])
        })
    });
    g.finish();
}

fn control(c: &mut Criterion) {
    bench_robot(c, "paper", &paper::robot());
    bench_robot(c, "panda7", &panda7());
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(50).warm_up_time(std::time::Duration::from_millis(500)).measurement_time(std::time::Duration::from_secs(2));
    targets = control
}
criterion_main!(benches);
