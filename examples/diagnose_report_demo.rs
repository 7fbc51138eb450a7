//! Writes a diagnosis report (`report.html`, `residuals.mcap`) for a synthetic UR5 log,
//! to look at the report's layout and to time its rendering.
//!
//!     cargo run --release -p ivdyn --example diagnose_report_demo -- [--seconds 60] [--out DIR]
//!
//! The "measured" torque is the UR5's inverse dynamics (fixtures/ur5.urdf) on a smooth
//! multi-sine motion at 1 kHz, plus Coulomb friction on `shoulder_lift_joint` (2.0 N m) and
//! `elbow_joint` (1.5 N m), a torque offset on `wrist_1_joint` (0.8 N m) and Gaussian noise
//! (0.05 N m). The `Diagnosis` is filled by a deliberately simple stand-in
//! for the real search (`ivdyn::diagnose::diagnose`): per joint, one- or two-column least
//! squares of the residual on the candidate's columns (training: first 70 % of the log),
//! an F test, the held-out gain on the last 30 %, greedy acceptance of the candidate that
//! removes the most held-out variance. Stribeck friction and payload are not scored here
//! (shown as "-"). The numbers are real fits of this data, but only the report is the
//! point of this example.

use std::path::PathBuf;
use std::time::Instant;

use ivdyn::diagnose::report::{write_html, write_mcap_stamped};
use ivdyn::diagnose::{
    CandidateScore, Diagnosis, DiagnosisJson, EffectJson, EffectKind, JointScore, LogInfo, Regimes, Step, Traces,
};
use ivdyn::ident::stats::f_sf;
use ivdyn::Robot;
use serde_json::json;

const RATE: f64 = 1000.0;
const NOISE: f64 = 0.05;
const T0_NS: i64 = 1_700_000_000_000_000_000;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Seeded standard normal numbers (xorshift64* + Box-Muller).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// The signals of one joint (columns of the row-major traces).
struct Cols {
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
}

/// Regressor columns of a per-joint candidate (None: not scored by this demo).
fn columns(e: EffectKind, c: &Cols, k: usize) -> Option<Vec<f64>> {
    Some(match e {
        EffectKind::Coulomb => vec![c.qd[k].signum()],
        EffectKind::Viscous => vec![c.qd[k]],
        EffectKind::Armature => vec![c.qdd[k]],
        EffectKind::TorqueOffset => vec![1.0],
        EffectKind::JointSpring => vec![c.q[k], 1.0],
        EffectKind::Stribeck | EffectKind::Payload => return None,
    })
}

/// Least squares of `r` on the columns over `range` (1 or 2 columns, normal equations).
fn lstsq(e: EffectKind, c: &Cols, r: &[f64], range: std::ops::Range<usize>) -> Vec<f64> {
    let p = columns(e, c, 0).map(|v| v.len()).unwrap_or(0);
    let (mut a, mut b) = (vec![0.0; p * p], vec![0.0; p]);
    for k in range {
        let x = columns(e, c, k).unwrap();
        for i in 0..p {
            b[i] += x[i] * r[k];
            for j in 0..p {
                a[i * p + j] += x[i] * x[j];
            }
        }
    }
    match p {
        1 => vec![if a[0] > 0.0 { b[0] / a[0] } else { 0.0 }],
        _ => {
            let det = a[0] * a[3] - a[1] * a[2];
            if det.abs() < 1e-12 { vec![0.0, 0.0] } else { vec![(a[3] * b[0] - a[1] * b[1]) / det, (a[0] * b[1] - a[2] * b[0]) / det] }
        }
    }
}

fn fitted(e: EffectKind, c: &Cols, theta: &[f64], k: usize) -> f64 {
    columns(e, c, k).unwrap().iter().zip(theta).map(|(x, t)| x * t).sum()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Noise std from sample-to-sample differences (a smooth structure barely changes them).
fn noise_std(r: &[f64]) -> f64 {
    let d: Vec<f64> = r.windows(2).map(|w| w[1] - w[0]).collect();
    rms(&d) / 2f64.sqrt()
}

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

fn regimes(r: &[f64], c: &Cols) -> Regimes {
    let t = r.len();
    let w = (0.02 * RATE) as usize;
    let rev: Vec<usize> = (1..t).filter(|&k| c.qd[k] * c.qd[k - 1] < 0.0).collect();
    let mut near = vec![false; t];
    for &k in &rev {
        near[k.saturating_sub(w)..(k + w).min(t)].fill(true);
    }
    let mut acc: Vec<f64> = c.qdd.iter().map(|a| a.abs()).collect();
    acc.sort_by(f64::total_cmp);
    let thr = acc[(0.8 * t as f64) as usize];
    let pick = |f: &dyn Fn(usize) -> bool| -> f64 {
        let v: Vec<f64> = (0..t).filter(|&k| f(k)).map(|k| r[k]).collect();
        if v.is_empty() { f64::NAN } else { rms(&v) }
    };
    let jumps: Vec<f64> = rev.iter().filter(|&&k| k > w && k + w < t).map(|&k| (r[k + w] - r[k - w - 1]) * c.qd[k + w].signum()).collect();
    Regimes {
        rms: rms(r),
        rms_reversal: pick(&|k| near[k]),
        rms_high_acc: pick(&|k| c.qdd[k].abs() >= thr),
        rms_rest: pick(&|k| !near[k] && c.qdd[k].abs() < thr),
        reversal_jump: if jumps.is_empty() { f64::NAN } else { jumps.iter().sum::<f64>() / jumps.len() as f64 },
        reversals: rev.len(),
        corr_q: corr(r, &c.q),
        corr_qd: corr(r, &c.qd),
        corr_qdd: corr(r, &c.qdd),
        mean: r.iter().sum::<f64>() / t as f64,
    }
}

struct Fit {
    score: CandidateScore,
    /// Parameters per significant joint, refitted on the whole log.
    theta: Vec<(usize, Vec<f64>)>,
}

/// Scores one candidate on every joint's residual.
fn score(e: EffectKind, cols: &[Cols], res: &[Vec<f64>], sigma: &[f64]) -> Fit {
    let t = res[0].len();
    let split = (0.7 * t as f64) as usize;
    let mut per_joint = vec![];
    let mut joints = vec![];
    let mut total = 0.0;
    let mut theta = vec![];
    for (j, (c, r)) in cols.iter().zip(res).enumerate() {
        let Some(x0) = columns(e, c, 0) else {
            let nan = f64::NAN;
            per_joint.push(JointScore { f: nan, p: nan, heldout_gain: nan, effect_rms: nan, significant: false });
            continue;
        };
        let p = x0.len();
        let th = lstsq(e, c, r, 0..split);
        let rss = |range: std::ops::Range<usize>, th: Option<&[f64]>| -> f64 {
            range.map(|k| (r[k] - th.map(|th| fitted(e, c, th, k)).unwrap_or(0.0)).powi(2)).sum()
        };
        let (rss0, rss1) = (rss(0..split, None), rss(0..split, Some(&th)));
        let dof2 = (split - p) as f64;
        let f = ((rss0 - rss1) / p as f64) / (rss1 / dof2).max(1e-300);
        let pv = f_sf(f, p as f64, dof2);
        let (h0, h1) = (rss(split..t, None), rss(split..t, Some(&th)));
        // Excess over the noise, floored at 10 % of the noise energy (a residual that is
        // already noise gives gains near 0, not huge ratios of tiny numbers).
        let noise = (t - split) as f64 * sigma[j] * sigma[j];
        let above_noise = (h0 - noise).max(0.1 * noise).max(1e-300);
        let gain = (h0 - h1) / above_noise;
        let eff: Vec<f64> = (0..t).map(|k| fitted(e, c, &th, k)).collect();
        let significant = pv < 1e-6 && gain > 0.05;
        if significant {
            joints.push(j);
            total += (h0 - h1) / (t - split) as f64;
            theta.push((j, lstsq(e, c, r, 0..t)));
        }
        per_joint.push(JointScore { f, p: pv, heldout_gain: gain, effect_rms: rms(&eff), significant });
    }
    let reason = if columns(e, &cols[0], 0).is_none() { "not scored by this demo".to_string() } else { String::new() };
    Fit { score: CandidateScore { effect: e, per_joint, joints, score: total, accepted: false, reason }, theta }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (mut seconds, mut out) = (60.0, root().join("out/diagnose_report_demo"));
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seconds" => seconds = args.next().ok_or("--seconds needs a value")?.parse()?,
            "--out" => out = PathBuf::from(args.next().ok_or("--out needs a value")?),
            _ => return Err(format!("unknown argument {a}; usage: diagnose_report_demo [--seconds S] [--out DIR]").into()),
        }
    }
    let urdf = root().join("fixtures/ur5.urdf");
    let robot = Robot::from_urdf(&urdf, Some("base_link"), Some("tool0"))?;
    let n = robot.dof();
    let t_n = (seconds * RATE) as usize + 1;
    let t: Vec<f64> = (0..t_n).map(|k| k as f64 / RATE).collect();

    // Motion: two sines per joint (analytic derivatives).
    let tw = 2.0 * std::f64::consts::PI;
    let (mut q, mut qd, mut qdd) = (vec![0.0; t_n * n], vec![0.0; t_n * n], vec![0.0; t_n * n]);
    for k in 0..t_n {
        for j in 0..n {
            let (a, f) = (0.8 - 0.08 * j as f64, 0.11 + 0.023 * j as f64);
            let (w1, w2, ph) = (tw * f, tw * 2.3 * f, 0.7 * j as f64);
            let (s1, c1, s2, c2) = ((w1 * t[k] + ph).sin(), (w1 * t[k] + ph).cos(), (w2 * t[k]).sin(), (w2 * t[k]).cos());
            q[k * n + j] = a * (s1 + 0.4 * s2);
            qd[k * n + j] = a * (w1 * c1 + 0.4 * w2 * c2);
            qdd[k * n + j] = -a * (w1 * w1 * s1 + 0.4 * w2 * w2 * s2);
        }
    }
    let fc = [0.0, 2.0, 1.5, 0.0, 0.0, 0.0];
    let tau0 = [0.0, 0.0, 0.0, 0.8, 0.0, 0.0];
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    let mut nominal = Vec::with_capacity(t_n * n);
    let mut tau = Vec::with_capacity(t_n * n);
    for k in 0..t_n {
        let row = k * n..(k + 1) * n;
        let rigid = robot.rnea(&q[row.clone()], &qd[row.clone()], &qdd[row])?;
        for j in 0..n {
            let v = qd[k * n + j];
            nominal.push(rigid[j]);
            tau.push(rigid[j] + fc[j] * v.signum() + tau0[j] + NOISE * rng.normal());
        }
    }
    let col = |a: &[f64], j: usize| -> Vec<f64> { a.iter().skip(j).step_by(n).copied().collect() };
    let cols: Vec<Cols> = (0..n).map(|j| Cols { q: col(&q, j), qd: col(&qd, j), qdd: col(&qdd, j) }).collect();

    // Greedy search (stand-in, see the header).
    let mut predicted = vec![nominal.clone()];
    let mut steps = vec![];
    let mut effects = vec![];
    let final_candidates;
    loop {
        let pred = predicted.last().unwrap();
        let res: Vec<Vec<f64>> = (0..n).map(|j| (0..t_n).map(|k| tau[k * n + j] - pred[k * n + j]).collect()).collect();
        let sigma: Vec<f64> = res.iter().map(|r| noise_std(r)).collect();
        let rms_before: Vec<f64> = res.iter().map(|r| rms(r)).collect();
        let mut fits: Vec<Fit> = EffectKind::ALL.iter().map(|&e| score(e, &cols, &res, &sigma)).collect();
        let best = (0..fits.len()).filter(|&i| fits[i].score.score > 0.0).max_by(|&a, &b| fits[a].score.score.total_cmp(&fits[b].score.score));
        // Look-alike rule: a spring k (q - q0) contains an offset; prefer the offset (one
        // parameter) when it does nearly as well.
        let idx = |e: EffectKind| EffectKind::ALL.iter().position(|&x| x == e).unwrap();
        let best = best.map(|b| {
            let off = idx(EffectKind::TorqueOffset);
            if b == idx(EffectKind::JointSpring) && fits[off].score.score >= 0.95 * fits[b].score.score { off } else { b }
        });
        let Some(best) = best.filter(|_| steps.len() < 4) else {
            for f in &mut fits {
                if f.score.reason.is_empty() {
                    f.score.reason = "not significant on any joint".into();
                }
            }
            final_candidates = fits.into_iter().map(|f| f.score).collect::<Vec<_>>();
            break;
        };
        let e = fits[best].score.effect;
        for (i, f) in fits.iter_mut().enumerate() {
            if i == best {
                f.score.accepted = true;
                f.score.reason = format!("removes the most held-out variance ({:.3} N m\u{b2} summed over joints)", f.score.score);
            } else if f.score.reason.is_empty() {
                f.score.reason = if f.score.effect == EffectKind::JointSpring && e == EffectKind::TorqueOffset && f.score.score > 0.0 {
                    "a spring contains an offset and does not explain clearly more: the offset is preferred".into()
                } else if f.score.score > 0.0 {
                    format!("explains less than {}", e.label())
                } else {
                    "not significant on any joint".into()
                };
            }
        }
        let theta = fits[best].theta.clone();
        let mut next = pred.clone();
        for (j, th) in &theta {
            for k in 0..t_n {
                next[k * n + j] += fitted(e, &cols[*j], th, k);
            }
        }
        let rms_after: Vec<f64> = (0..n).map(|j| rms(&(0..t_n).map(|k| tau[k * n + j] - next[k * n + j]).collect::<Vec<_>>())).collect();
        let js: Vec<usize> = theta.iter().map(|(j, _)| *j).collect();
        let names: Vec<String> = js.iter().map(|&j| robot.joint_names[j].clone()).collect();
        let first: Vec<f64> = theta.iter().map(|(_, th)| th[0]).collect();
        let parameters = match e {
            EffectKind::Coulomb => json!({ "fc": first }),
            EffectKind::Viscous => json!({ "fv": first }),
            EffectKind::Armature => json!({ "ia": first }),
            EffectKind::TorqueOffset => json!({ "tau0": first }),
            EffectKind::JointSpring => json!({ "k": first, "q0": theta.iter().map(|(_, th)| -th[1] / th[0]).collect::<Vec<_>>() }),
            EffectKind::Stribeck | EffectKind::Payload => unreachable!("not scored"),
        };
        let evidence = js
            .iter()
            .zip(&theta)
            .map(|(&j, (_, th))| {
                let g = regimes(&res[j], &cols[j]);
                let name = &robot.joint_names[j];
                match e {
                    EffectKind::Coulomb => format!(
                        "{name}: the residual jumps by {:.2} N m at its {} velocity reversals (mean), in the direction of the new velocity: Coulomb friction of about {:.2} N m.",
                        g.reversal_jump, g.reversals, th[0]
                    ),
                    EffectKind::Viscous => format!(
                        "{name}: the residual grows with velocity (correlation {:+.2}): viscous friction of {:.3} N m s/rad.",
                        g.corr_qd, th[0]
                    ),
                    EffectKind::TorqueOffset => format!(
                        "{name}: the residual has a constant mean of {:+.2} N m whatever the motion: a torque offset.",
                        g.mean
                    ),
                    _ => format!("{name}: {} explains {:.0} % of the held-out residual above the noise.", e.label(), 100.0 * fits[best].score.per_joint[j].heldout_gain),
                }
            })
            .collect();
        effects.push(EffectJson {
            name: e.name().into(),
            joints: names,
            parameters: parameters.as_object().unwrap().clone(),
            rms_before: rms_before.clone(),
            rms_after: rms_after.clone(),
        });
        steps.push(Step { effect: e, joints: js, evidence, candidates: fits.into_iter().map(|f| f.score).collect(), rms_before, rms_after });
        predicted.push(next);
    }

    let last = predicted.last().unwrap();
    let res = |p: &[f64], j: usize| -> Vec<f64> { (0..t_n).map(|k| tau[k * n + j] - p[k * n + j]).collect() };
    let verdict = if steps.is_empty() {
        "Nothing significant missing".to_string()
    } else {
        let parts: Vec<String> = effects.iter().map(|e| format!("{} on {}", e.name.replace('_', " "), e.joints.join(", "))).collect();
        format!("Missing: {}", parts.join("; "))
    };
    let d = Diagnosis {
        json: DiagnosisJson {
            effects,
            baseline_rms: (0..n).map(|j| rms(&res(&nominal, j))).collect(),
            final_rms: (0..n).map(|j| rms(&res(last, j))).collect(),
            joints: robot.joint_names.clone(),
        },
        steps,
        final_candidates,
        noise_std: (0..n).map(|j| noise_std(&res(last, j))).collect(),
        regimes_before: (0..n).map(|j| regimes(&res(&nominal, j), &cols[j])).collect(),
        regimes_after: (0..n).map(|j| regimes(&res(last, j), &cols[j])).collect(),
        verdict,
        traces: Traces { t: t.clone(), q, qd, qdd, tau: tau.clone(), predicted: predicted.clone() },
        info: LogInfo {
            file: format!("synthetic UR5 log ({seconds} s, diagnose_report_demo)"),
            urdf: "fixtures/ur5.urdf".into(),
            samples: t_n,
            duration: t[t_n - 1],
            rate: RATE,
            velocity_in_log: true,
        },
    };

    let clock = Instant::now();
    write_html(&d, &out)?;
    let html_s = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    write_mcap_stamped(&d, &robot.joint_names, T0_NS, &out)?;
    let mcap_s = clock.elapsed().as_secs_f64();
    let size = |f: &str| std::fs::metadata(out.join(f)).map(|m| m.len()).unwrap_or(0);
    println!("{}", d.verdict);
    println!("report.html    {:>9} bytes in {html_s:.3} s", size("report.html"));
    println!("residuals.mcap {:>9} bytes in {mcap_s:.3} s", size("residuals.mcap"));
    println!("written to {}", out.display());
    Ok(())
}
