//! The paper's robot: DH kinematics, Table 2 conversions and the paper's grouping.

mod common;
use common::{Rng, assert_close};
use ivdyn_core::dh::{from_paper_grouping, inertia_to_dh_frame, to_paper_grouping};
use ivdyn_core::kinematics::tool_pose;
use ivdyn_core::{Data, LinkInertia, Mat3, Vec3, VecN, paper, rnea};

/// Plain standard-DH product `prod Rz(q) Tz(d) Tx(a) Rx(alpha)` as 4x4 matrices.
fn dh_forward(q: &VecN<6>) -> nalgebra::Matrix4<f64> {
    let mut t = nalgebra::Matrix4::identity();
    for (i, r) in paper::DH.iter().enumerate() {
        let (st, ct) = q[i].sin_cos();
        let (sa, ca) = r.alpha.sin_cos();
        #[rustfmt::skip]
        let a = nalgebra::Matrix4::new(
            ct, -st * ca, st * sa, r.a * ct,
            st, ct * ca, -ct * sa, r.a * st,
            0.0, sa, ca, r.d,
            0.0, 0.0, 0.0, 1.0);
        t *= a;
    }
    t
}

#[test]
fn tool_frame_matches_plain_dh_product() {
    let model = paper::robot();
    let mut data = Data::<6>::new();
    let mut rng = Rng(3);
    for _ in 0..20 {
        let q = rng.vecn::<6>(-3.0, 3.0);
        let x = tool_pose(&model, &mut data, &q);
        let t = dh_forward(&q);
        let r = t.fixed_view::<3, 3>(0, 0).into_owned();
        let p = t.fixed_view::<3, 1>(0, 3).into_owned();
        assert!((x.rot - r).norm() < 1e-14 && (x.trans - p).norm() < 1e-14);
    }
}

#[test]
fn table2_parameters_round_trip_into_dh_frames() {
    let model = paper::robot();
    for i in 0..6 {
        let back = inertia_to_dh_frame(&paper::DH[i], &model.inertia[i]);
        let (m, c, ic) = back.to_mass_com_inertia(i).unwrap();
        let row = &paper::TABLE2[i];
        assert!((m - row.m).abs() < 1e-15);
        assert_close(c.as_slice(), &row.s, 1e-12, 1e-15, "com");
        let d = Mat3::from_diagonal(&Vec3::new(row.i_diag[0], row.i_diag[1], row.i_diag[2]));
        assert_close(ic.as_slice(), d.as_slice(), 1e-10, 1e-15, "inertia about com");
    }
}

#[test]
fn urdf_style_inertial_round_trip() {
    let mut rng = Rng(11);
    for _ in 0..50 {
        let p = rng.inertia();
        let (m, c, ic) = p.to_mass_com_inertia(0).unwrap();
        let q = LinkInertia::from_mass_com_inertia(m, &c, &Mat3::identity(), &ic);
        assert_close(&p.0, &q.0, 1e-12, 1e-14, "10-vector");
        assert!(p.is_physically_consistent(0.0));
    }
    assert!(LinkInertia::ZERO.to_mass_com_inertia(3).is_err());
}

/// The grouping carries everything the torques depend on: links rebuilt from the
/// grouping with *different* masses give the same torques (up to rounding).
#[test]
fn torques_depend_only_on_the_paper_grouping() {
    let model = paper::robot();
    let x = to_paper_grouping(&paper::DH, &model.inertia, &model.drive);
    let masses = [0.3, 1.7, 0.05, 0.9, 0.4, 0.011];
    let (inertia, drive) = from_paper_grouping(&paper::DH, &x, &masses);
    let mut other = model.clone();
    other.inertia = inertia;
    other.drive = drive;
    let (mut d1, mut d2) = (Data::<6>::new(), Data::<6>::new());
    let mut rng = Rng(5);
    for _ in 0..50 {
        let (q, qd, qdd) = (rng.vecn::<6>(-3.0, 3.0), rng.vecn::<6>(-2.0, 2.0), rng.vecn::<6>(-5.0, 5.0));
        let t1 = *rnea(&model, &mut d1, &q, &qd, &qdd);
        let t2 = *rnea(&other, &mut d2, &q, &qd, &qdd);
        assert_close(t1.as_slice(), t2.as_slice(), 1e-10, 1e-12, "tau");
    }
    // and the round trip with the true masses restores the parameters
    let true_m = core::array::from_fn::<f64, 6, _>(|i| paper::TABLE2[i].m);
    let (back, _) = from_paper_grouping(&paper::DH, &x, &true_m);
    for i in 0..6 {
        assert_close(&back[i].0, &model.inertia[i].0, 1e-12, 1e-15, "link");
    }
    // 11 numbers per link: alpha(3) beta(6) F d
    assert!((x[5][9] - 0.1).abs() < 1e-15);
}
