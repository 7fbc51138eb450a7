//! Random chains for property tests (deterministic from a seed).
#![allow(dead_code)]

use ivdyn_core::{DriveParams, Joint, LinkInertia, Mat3, Model, Transform, Vec3, VecN, spatial::axis_angle};

/// The crate's deterministic generator with helpers for random chains and states.
pub struct Rng {
    inner: ivdyn_core::rng::Rng,
}

/// `Rng(seed)`: a seeded generator (a function in the value namespace, so tests read
/// like a tuple-struct constructor).
#[allow(non_snake_case)]
pub fn Rng(seed: u64) -> Rng {
    Rng { inner: ivdyn_core::rng::Rng::new(seed) }
}

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.inner.next_u64()
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.inner.uniform(lo, hi)
    }
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.uniform(-1.0, 1.0), self.uniform(-1.0, 1.0), self.uniform(-1.0, 1.0));
            let n = v.norm();
            if n > 0.2 && n < 1.0 {
                return v / n;
            }
        }
    }
    pub fn vecn<const N: usize>(&mut self, lo: f64, hi: f64) -> VecN<N> {
        VecN::<N>::from_fn(|_, _| self.uniform(lo, hi))
    }
    pub fn rotation(&mut self) -> Mat3 {
        let a = self.unit();
        axis_angle(&a, self.uniform(-3.0, 3.0))
    }
    /// A physically valid body: mass, COM, principal moments obeying the triangle
    /// inequality, rotated.
    pub fn inertia(&mut self) -> LinkInertia {
        let m = self.uniform(0.2, 5.0);
        let c = Vec3::new(self.uniform(-0.2, 0.2), self.uniform(-0.2, 0.2), self.uniform(-0.2, 0.2));
        let (a, b) = (self.uniform(0.01, 0.1), self.uniform(0.01, 0.1));
        let d = Vec3::new(a, b, self.uniform((a - b).abs() + 1e-3, a + b));
        LinkInertia::from_mass_com_inertia(m, &c, &self.rotation(), &Mat3::from_diagonal(&d))
    }
}

/// Random chain: random joint placements, random axes, every third joint prismatic
/// (when `prismatic`), random inertias and drive parameters.
pub fn random_model<const N: usize>(seed: u64, prismatic: bool) -> Model<N> {
    let mut rng = Rng(seed);
    let mut joints = [Joint::revolute_z(); N];
    let mut x_tree = [Transform::IDENTITY; N];
    for i in 0..N {
        // every other joint on a signed coordinate axis (the fast rotation path)
        let axis = if i % 2 == 0 {
            let mut a = Vec3::zeros();
            a[(rng.next_u64() % 3) as usize] = if rng.next_u64().is_multiple_of(2) { 1.0 } else { -1.0 };
            a
        } else {
            rng.unit()
        };
        joints[i] = if prismatic && i % 3 == 1 { Joint::prismatic(axis) } else { Joint::revolute(axis) };
        x_tree[i] = Transform::new(
            rng.rotation(),
            Vec3::new(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)),
        );
    }
    let mut model = Model::new(joints, x_tree).unwrap();
    for i in 0..N {
        model.inertia[i] = rng.inertia();
        model.drive[i] = DriveParams {
            fc: rng.uniform(0.0, 2.0),
            fv: rng.uniform(0.0, 0.5),
            ia: rng.uniform(0.0, 0.1),
            tau0: rng.uniform(-0.5, 0.5),
            ..DriveParams::ZERO
        };
    }
    model.gravity = Vec3::new(rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), -9.81);
    model
}

/// |a - b| <= atol + rtol * max(|a|, |b|) entrywise, with a helpful message.
pub fn assert_close(a: &[f64], b: &[f64], rtol: f64, atol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: length");
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        let tol = atol + rtol * x.abs().max(y.abs());
        assert!((x - y).abs() <= tol, "{what}[{k}]: {x} vs {y} (diff {:e}, tol {tol:e})", (x - y).abs());
    }
}
