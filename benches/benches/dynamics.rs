//! Dynamics kernels on the bundled robots: rnea, regressor, mass_matrix, forward_dynamics
//! (and gravity). Each iteration runs one call on the next of 1024 states, with `Data`
//! reused, as the Pinocchio anchor (`shared/anchors/pinocchio/bench.cpp`) does.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use ivdyn_benches::{panda7, states, ur5};
use ivdyn_core::{Data, Model, forward_dynamics, gravity, mass_matrix, paper, regressor, rnea};
use std::hint::black_box;

fn bench_robot<const N: usize>(c: &mut Criterion, name: &str, model: &Model<N>) {
    let xs = states::<N>(1024);
    let mut data = Data::<N>::new();
    let taus: Vec<_> = xs.iter().map(|(q, qd, qdd)| *rnea(model, &mut data, q, qd, qdd)).collect();
    let mut g = c.benchmark_group(name);
    let mut k = 0usize;
    let mut next = || {
        k = (k + 1) & 1023;
        k
    };
    g.bench_function(BenchmarkId::new("rnea", N), |b| {
        b.iter(|| {
            let (q, qd, qdd) = &xs[next()];
            black_box(rnea(model, &mut data, q, qd, qdd)[0])
        })
    });
    g.bench_function(BenchmarkId::new("regressor", N), |b| {
        b.iter(|| {
            let (q, qd, qdd) = &xs[next()];
            black_box(regressor(model, &mut data, q, qd, qdd).link[0][0][0])
        })
    });
    g.bench_function(BenchmarkId::new("mass_matrix", N), |b| {
        b.iter(|| {
            let (q, _, _) = &xs[next()];
            black_box(mass_matrix(model, &mut data, q)[(0, 0)])
        })
    });
    g.bench_function(BenchmarkId::new("forward_dynamics", N), |b| {
        b.iter(|| {
            let i = next();
            let (q, qd, _) = &xs[i];
            black_box(forward_dynamics(model, &mut data, q, qd, &taus[i]).map(|x| x[0]).unwrap_or(0.0))
        })
    });
    g.bench_function(BenchmarkId::new("gravity", N), |b| {
        b.iter(|| {
            let (q, _, _) = &xs[next()];
            black_box(gravity(model, &mut data, q)[0])
        })
    });
    g.finish();
}

fn dynamics(c: &mut Criterion) {
    bench_robot(c, "ur5", &ur5());
    bench_robot(c, "paper", &paper::robot());
    bench_robot(c, "panda7", &panda7());
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = dynamics
}
criterion_main!(benches);
