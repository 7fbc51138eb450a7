//! `ivdyn identify --out-mcap`: measured, predicted and residual torques as JointState
//! topics on the same stamps, read back with ivdyn's reader; the prediction is checked
//! against `Y(q, qd, qdd) theta` computed here from the reported parameters (regressor, not
//! RNEA) at the state of an in-memory conditioning of the original log.
use crate::util;
use ivdyn::log::{ReadOptions, read_mcap};
use util::*;

struct Out {
    measured: ivdyn::log::JointLog,
    predicted: ivdyn::log::JointLog,
    /// residual, aligned to the measured stamps (read as the "command" of /ivdyn/measured)
    residual: Vec<f64>,
}

fn read_out(path: &std::path::Path, names: &[String]) -> Out {
    let o = ReadOptions::new(names).topic("/ivdyn/measured").command_topic("/ivdyn/residual");
    let measured = read_mcap(path, &o).unwrap();
    let predicted = read_mcap(path, &ReadOptions::new(names).topic("/ivdyn/predicted")).unwrap();
    let residual = measured.u.clone().unwrap();
    Out { measured, predicted, residual }
}

#[test]
fn identify_out_mcap_measured_predicted_residual() {
    let d = tmpdir("out_mcap");
    let (log, params, pred_s, pred_m) =
        (d.join("log.mcap"), d.join("params.json"), d.join("pred_stream.mcap"), d.join("pred_memory.mcap"));
    ok(&run(ur5_cmd(
        "simulate",
        &[
            "--noise",
            "0.05",
            "--duration",
            "12",
            "--seed",
            "9",
            "--fc",
            "2,2,1.5,0.6,0.6,0.4",
            "--fv",
            "0.8,0.8,0.5,0.2,0.2,0.1",
            "--out",
            log.to_str().unwrap(),
        ],
    )));
    let rep = d.join("rep.json");
    ok(&run(ur5_cmd(
        "identify",
        &[
            "--log",
            log.to_str().unwrap(),
            "--stream",
            "--out-params",
            params.to_str().unwrap(),
            "--out-mcap",
            pred_s.to_str().unwrap(),
            "--json",
            rep.to_str().unwrap(),
        ],
    )));
    assert_eq!(json(&rep)["streamed"], true);
    ok(&run(ur5_cmd(
        "identify",
        &["--log", log.to_str().unwrap(), "--in-memory", "--coulomb", "sign", "--out-mcap", pred_m.to_str().unwrap()],
    )));
    // only the finished files, no staging folder
    assert_eq!(files_in(&d), ["log.mcap", "params.json", "pred_memory.mcap", "pred_stream.mcap", "rep.json"]);

    let robot0 = ivdyn::Robot::from_urdf(fixture("ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
    let names = robot0.joint_names.clone();
    let n = names.len();
    let orig = read_mcap(&log, &ReadOptions::new(&names)).unwrap();
    let out = read_out(&pred_s, &names);
    let t = orig.len();
    // every sample, on the original stamps, the measured copy exact
    assert_eq!(out.measured.len(), t);
    assert_eq!(out.predicted.len(), t);
    assert_eq!(out.measured.t0_ns, orig.t0_ns);
    assert_eq!(out.predicted.t0_ns, orig.t0_ns);
    assert_eq!(out.measured.t, orig.t);
    assert_eq!(out.predicted.t, orig.t);
    assert_eq!(out.measured.q, orig.q);
    assert_eq!(out.measured.qd, orig.qd);
    assert_eq!(out.measured.tau, orig.tau);
    // residual = measured - predicted, exactly
    let (tau_m, tau_p) = (out.measured.tau.as_ref().unwrap(), out.predicted.tau.as_ref().unwrap());
    for k in 0..t * n {
        assert_eq!(out.residual[k], tau_m[k] - tau_p[k], "entry {k}");
    }
    // predicted = Y(q, qd, qdd) theta from the parameter file, at the conditioned state
    let pf: ivdyn::report::ParamsFile = serde_json::from_str(&std::fs::read_to_string(&params).unwrap()).unwrap();
    // (streamed: the log's velocity where it agrees with the positions, as in memory)
    let c = ivdyn::prep::condition(&orig, &ivdyn::prep::ConditionOptions::default()).unwrap();
    assert!(c.velocity.iter().all(|v| v.source == "log"), "{:?}", c.velocity);
    let p = robot0.num_params();
    let mut y = vec![0.0; t * n * p];
    ivdyn::batch::regressor_batch(&robot0, &c.d.q, &c.d.qd, &c.d.qdd, &mut y, false).unwrap();
    let scale = tau_m.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let (mut worst_tau, mut worst_q): (f64, f64) = (0.0, 0.0);
    for r in 0..t * n {
        let yt: f64 = y[r * p..(r + 1) * p].iter().zip(&pf.theta).map(|(a, b)| a * b).sum();
        worst_tau = worst_tau.max((yt - tau_p[r]).abs());
        worst_q = worst_q.max((c.d.q[r] - out.predicted.q[r]).abs());
    }
    eprintln!(
        "predicted vs Y theta: worst {worst_tau:.2e} N m (torques up to {scale:.1} N m); smoothed q worst {worst_q:.2e} rad"
    );
    assert!(worst_tau < 1e-9 * scale, "{worst_tau}");
    assert!(worst_q < 1e-10, "{worst_q}");
    // the model explains the data: away from the filter edges (1 % at each end), the
    // unfiltered residual is the 0.05 N m white torque noise (its RMS over ~6000 samples
    // is within 0.05 (1 +- 0.05) with > 99.9 % probability), plus little model error
    let edge = t / 100;
    for j in 0..n {
        let k = edge..t - edge;
        let rms = (k.clone().map(|k| out.residual[k * n + j].powi(2)).sum::<f64>() / k.len() as f64).sqrt();
        eprintln!("joint {j}: residual rms {rms:.4} N m");
        assert!(rms > 0.0475 && rms < 0.0525 + 0.005, "joint {j}: residual rms {rms}");
    }
    // the in-memory path with the streamed path's Coulomb sign (and the same velocity rule)
    // writes the same file content (to rounding)
    let mem = read_out(&pred_m, &names);
    assert_eq!(
        (&mem.measured.t, &mem.measured.q, &mem.measured.qd, &mem.measured.tau),
        (&out.measured.t, &out.measured.q, &out.measured.qd, &out.measured.tau)
    );
    let worst = mem.predicted.tau.as_ref().unwrap().iter().zip(tau_p).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-8 * scale, "stream vs memory prediction differ by {worst}");
    let _ = std::fs::remove_dir_all(&d);
}
