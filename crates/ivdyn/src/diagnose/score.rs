//! What a candidate is compared with, and its score on one joint: the F test, the held-out
//! share, the size and the physical sign of rules 1-4 of [`super::rules`] (docs/diagnose.md,
//! Method item 4). The look-alike rules and the candidates themselves are in
//! [`super::rules`] and [`super::drive_rules`], which both build on this.

use super::dictionary::{C_BASE, C_DELAY, C_LOAD, C_PAYLOAD, C_Q, C_QD, C_QDD, C_SIGN, C_STUCK, Grams, RIPPLE_N};
use super::model::{
    Fit, Model, Param, all_model, beyond_refit_rms, effect_rms, fit, joint_index, noise_of_all_model, rss_joint,
};
use super::prepare::Prepared;
use super::{DiagnoseOptions, EffectKind, JointScore};
use crate::Robot;
use crate::batch;
use crate::error::{Error, Result};
use crate::ident::stats::f_sf;

/// Smallest armature (payload) named, as a fraction of the nominal inertia on the joint
/// (of the terminal link's nominal mass).
const NOMINAL_UNCERTAINTY: f64 = 0.1;

/// The held-out share asked of a refinement of Coulomb friction, as a fraction of
/// `min_share` (0.6 at the default 0.75). The refinement is scored against a model that
/// already has Coulomb friction on the joint: what is left there is the difference of two
/// friction shapes, a function of `qd` alone that no link inertial makes, near reversals
/// (smooth, Stribeck) or in one direction (direction-dependent), and its physics rules
/// (`fs > 0`, both levels positive within `ASYMMETRY_MAX`, the smooth shape's size against
/// the sign) stay. (Tuning part of the 5-12 s random arms: 0.5 and 0.6 of the 0.75 share
/// alike, true pairs 195 -> 202, extra 34 -> 33, no case lost; 0.35 turned 3 true Coulomb
/// frictions into smooth or direction-dependent ones; the CAD tuning part unchanged;
/// docs/diagnose.md, "A refinement's held-out share".)
const REFINEMENT_SHARE: f64 = 0.8;

/// The held-out share asked of Stribeck friction, which refines Coulomb friction found on
/// the joint: it must lower the held-out residual, by at least this share of what the whole
/// vocabulary explains there. Its other rules stay (F test, `fs > 0`, `fs` at least
/// `STRIBECK_MIN_RISE` of the Coulomb level, its peak at least `min_effect` noise std).
/// The whole vocabulary's five smooth shapes beside the sign follow the filtered velocity's
/// smear of a reversal more closely than one Stribeck bump does, so on logs with true
/// Stribeck friction (F 97-111, p < 1e-16) its share of that was 7-53 % against the
/// refinement share's 60 %. (Tuning parts at 0.05 against `refinement_share`: Stribeck as
/// an applied force 23 -> 24 of 48 right, true pairs 103 -> 107, extra 21 -> 17; as the
/// joint's `frictionloss` 23 -> 25, 105 -> 108, 19 -> 16; MuJoCo's default soft friction
/// 190 -> 191 pairs, 59 -> 58 extra; the six sets without Stribeck friction unchanged, no
/// Stribeck named there; 0.0 and 0.15 one pair fewer on the applied set; docs/diagnose.md.)
const STRIBECK_SHARE: f64 = 0.05;

/// Smallest torque gain error `|k - 1|` named: a few % of a joint's rigid-body torque is
/// what CAD inertial errors and the conditioning leave too. (Tuning parts with `--drives`,
/// exactly right on random arms 2 s / 20-60 s: 0.1 12 / 16 of 48, 0.05 13 / 17, 0.03 14 /
/// 19; but at 0.05 and below the UR5 drive fixture, exact inertials, gets a spurious gain
/// 0.93 on `shoulder_pan_joint` and an offset beside its true gains; docs/diagnose.md.)
const GAIN_MARGIN: f64 = 0.1;

/// The same margin when the search runs on the nominal re-fit of a log of at least
/// `GAIN_MARGIN_REFIT_MIN_DURATION_S`: the links' inertials are then fitted beside the gain column from
/// enough data that their CAD error no longer scales the joint's torque unseen; what is left
/// is the conditioning's share. (Tuning parts, default options, random arms 20-60 s: 19 -> 22
/// of 48 right at 0.03, 20 at 0.05. On the 2 s UR5 drive fixture, exact inertials, true
/// gains 0.85 / 1.15 on two joints, the re-fit trades a few % of the shoulder pan's torque
/// against them and 0.03 named a gain 0.93 there: short logs keep `GAIN_MARGIN`.)
const GAIN_MARGIN_REFIT: f64 = 0.03;

/// Shortest log (seconds of samples used) on which `GAIN_MARGIN_REFIT` applies, that of the
/// drive effects' default (`DRIVES_MIN_DURATION_S`) but kept apart, as it was measured apart:
/// on the 5-12 s tuning parts 0.03 instead of 0.1 found gains on 11 instead of 1 of 17 joints
/// of the random arms (13 -> 16 of 48 cases right) and named 2 extra on the CAD arms; the 2 s
/// UR5 fixture's spurious gain (above) keeps short logs at `GAIN_MARGIN`.
const GAIN_MARGIN_REFIT_MIN_DURATION_S: f64 = 4.0;

/// Largest relative error of a CAD model's link inertials: they are typically 20-50 % off
/// (issue 15; FIGAROH's documentation), so anything per-link scales up to the top of that
/// range explain is not told from the CAD error.
pub(super) const CAD_ERROR_MAX: f64 = 0.5;

/// Smallest payload named on top of the nominal re-fit, as a share of the torque the
/// terminal link's nominal inertials make on the joint: a link whose mass, COM and inertia
/// are each up to `CAD_ERROR_MAX` off has its first moment `m c` up to
/// `(1 + CAD_ERROR_MAX)^2 - 1` = 125 % off, which no payload below it is told from. (At
/// `CAD_ERROR_MAX`, 50 %, a payload was named on 2 of the 42 effect-free tuning logs of the
/// four case sets, shares 0.50 and 0.78; true payloads there make 2.8-200;
/// docs/diagnose.md.)
pub(super) const CAD_TERMINAL_MARGIN: f64 = (1.0 + CAD_ERROR_MAX) * (1.0 + CAD_ERROR_MAX) - 1.0;

/// A typical relative error of the nominal link inertials (the middle of CAD's 20-50 %): the
/// payload's mass uncertainty on top of the re-fit takes it as 2 standard errors, and the
/// verdict calls the nominal model "off" below it and "far off" above.
pub(super) const LINK_SCALE_MAX: f64 = 0.25;

/// What the rules compare a candidate with: the Gram matrices, the noise, the nominal
/// inertias, and the options' thresholds.
#[derive(Clone)]
pub(super) struct Ctx<'a> {
    pub(super) gr: &'a Grams,
    /// Mean diagonal of the nominal mass matrix over the log (kg m^2 or kg).
    m_diag: Vec<f64>,
    /// Nominal mass of the terminal link (kg).
    pub(super) terminal_mass: f64,
    /// Nominal inertial parameters of the terminal link (`m, h, I` about its origin).
    pub(super) terminal_p10: [f64; 10],
    /// RMS per joint of the torque of the terminal link's nominal inertials (N m).
    pub(super) terminal_rms: Vec<f64>,
    /// The same of the part of that torque the re-fitted links cannot make
    /// (`beyond_refit_rms`; `terminal_rms` without the re-fit): what the payload's margin on
    /// top of the re-fit compares with.
    terminal_beyond: Vec<f64>,
    /// Nominal mass of the link before the terminal one (kg; 0 for one link): a payload's
    /// mass regroups into it.
    pub(super) prev_link_mass: f64,
    /// The search runs on top of the nominal re-fit.
    pub(super) refit: bool,
    /// Smallest torque gain error `|k - 1|` named (`GAIN_MARGIN`, `GAIN_MARGIN_REFIT`).
    gain_margin: f64,
    pub(super) w: Vec<f64>,
    pub(super) sigma: Vec<f64>,
    /// The noise std the size rule measures against: the larger of `sigma` and the noise
    /// on the log's own samples where its stamps were resampled (`Signals::sample_noise`).
    /// What matters is judged against the sensor's noise, not the interpolated grid's: on
    /// jittered logs the grid's residual shows 0.70-0.83 of it, and two of six jittered
    /// effect-free logs of the arms rarm36-47 named a viscous friction 0.7-1 grid noise std
    /// large (docs/diagnose.md).
    sigma_size: Vec<f64>,
    /// Held-out RSS per joint of the all-candidates model (two-fold; with the nominal
    /// re-fit when there is one).
    h_all: Vec<f64>,
    /// The same of the basic vocabulary's all-candidates model: the floor of an armature's
    /// held-out share. The drive columns built from the nominal torque (gain, load-dependent
    /// friction, delay) hold its inertial part, acceleration-proportional as an armature's
    /// torque is: with them in the floor, a rotor inertia shares what it explains with its
    /// look-alikes. On the real TX40 log (8.9 s) the armatures the literature has on joints
    /// 3 and 4 fell from named to a 34 % share when the drive effects were searched; on the
    /// 20-60 s and 5-12 s tuning parts this floor for every basic effect doubled the extra
    /// viscous friction and offsets, for the armature alone it changes nothing but +1 true
    /// pair on three of the four sets (docs/diagnose.md).
    h_all_basic: Vec<f64>,
    /// Integrated autocorrelation time of the residual per joint (samples).
    pub(super) tau: Vec<f64>,
    /// The ripple harmonic of each slot per joint (`Dictionary::ripple_h`).
    pub(super) ripple_h: Vec<[f64; RIPPLE_N.len()]>,
    /// Range of motion per joint over the log (rad or m): a position-periodic torque is told
    /// from a slow position-dependent one only over at least one of its periods.
    pub(super) q_span: Vec<f64>,
    /// Sample time of the conditioned log (s).
    dt: f64,
    pub(super) n: usize,
    pub(super) opts: &'a DiagnoseOptions,
    /// Whether the effects of real drives are searched (`Prepared::drives`).
    pub(super) drives: bool,
    /// Threads for the candidates' scores (`DiagnoseOptions::threads_for`).
    pub(super) threads: usize,
}

/// Range of motion per joint: `max q - min q` over the log (samples interleaved by joint).
fn q_span(q: &[f64], n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let qj = q.iter().skip(j).step_by(n);
            qj.clone().fold(f64::NEG_INFINITY, |a, &b| a.max(b)) - qj.fold(f64::INFINITY, |a, &b| a.min(b))
        })
        .collect()
}

/// Mean over (a subsample of) the log of the nominal mass matrix's diagonal.
fn mean_mass_diag(robot: &Robot, q: &[f64], n: usize) -> Result<Vec<f64>> {
    let t_len = q.len() / n;
    let step = (t_len / 200).max(1);
    let qs: Vec<f64> = (0..t_len).step_by(step).flat_map(|k| q[k * n..(k + 1) * n].to_vec()).collect();
    let m = qs.len() / n;
    let mut out = vec![0.0; m * n * n];
    batch::mass_matrix_batch(robot, &qs, &mut out).map_err(|e| Error::during("mass matrix", e))?;
    Ok((0..n).map(|j| (0..m).map(|k| out[k * n * n + j * n + j]).sum::<f64>() / m as f64).collect())
}

/// A direction-dependent refinement of Coulomb friction on joint `j` is scored with the stick
/// column (`C_STUCK`) in both models, as Stribeck friction is against Coulomb friction: the
/// levels it tells apart are those of the joint moving either way, and a stuck joint's
/// samples (friction anywhere within the static level, at a noisy `sign(qd)`) and the
/// reversals' stick-slip otherwise count as structure it leaves, which no friction level
/// holds, so a clear asymmetry failed the refinement's share. Not on the terminal joint: the
/// terminal link's own CAD error (the re-fit leaves that link out) makes a near-constant torque
/// there, which with the stuck samples apart read as an asymmetry (a true Coulomb friction on
/// the terminal joint of 2 tuning cases). (Arms rarm24-87, 720 cases, 5-60 s: 3 cases more
/// exactly right, 6 true pairs more, 5 extra fewer, none fewer right; docs/diagnose.md.) The
/// named effect is fitted without the column. `None` when this is no such refinement.
fn rest_apart(smaller: &Model, larger: &Model, j: usize) -> Option<(Model, Model)> {
    let terminal = j + 1 == smaller.per_joint.len();
    let refines = !terminal
        && smaller.has(j, EffectKind::Coulomb)
        && !smaller.has(j, EffectKind::AsymmetricCoulomb)
        && larger.has(j, EffectKind::AsymmetricCoulomb);
    refines.then(|| {
        let (mut s, mut l) = (smaller.clone(), larger.clone());
        s.stick[j] = true;
        l.stick[j] = true;
        (s, l)
    })
}

impl<'a> Ctx<'a> {
    /// Both models with the terminal link's own CAD error free (`Model::terminal_cad`: its 10
    /// inertial parameters on every row, pulled toward the nominal by the re-fit's ridge) when
    /// a friction or a delay is scored on top of the re-fit and neither model holds a
    /// payload. The re-fit leaves that link out (a change there is what a payload is), so its
    /// CAD error stays in the residual, and the all-candidates floor the held-out share is
    /// measured against holds it (the payload's columns): a friction on the terminal joint
    /// removed 19-53 % of the "explainable" residual there and was not named (Coulomb friction
    /// missed on 9 of its 14 terminal joints of rarm76-111). A friction or a delay is nothing
    /// a change of that link makes, so it is scored beside it; not a direction-dependent
    /// friction, whose constant on a moving joint is what a change of the link makes (with it
    /// scored so, 3 true ones on terminal joints of rarm76-87 went for one false one), nor the
    /// inertia-like effects, which the look-alike rules decide (docs/diagnose.md, "Frictions
    /// scored beside the terminal link's CAD error").
    fn terminal_cad_in(
        &self,
        smaller: &Model,
        larger: &Model,
        added: &dyn Fn(&Param) -> bool,
    ) -> Option<(Model, Model)> {
        use EffectKind::*;
        let friction = |p: &Param| {
            added(p) && matches!(p.kind, Some(Coulomb | Viscous | Stribeck | SmoothCoulomb | LoadDependent | TimeDelay))
        };
        let on = self.refit && !smaller.payload && !larger.payload && larger.params().iter().any(friction);
        on.then(|| (Model { terminal_cad: true, ..smaller.clone() }, Model { terminal_cad: true, ..larger.clone() }))
    }

    /// The noise (weights), autocorrelation times, held-out floor and nominal inertias of
    /// the prepared log; `refit`: the search runs on top of the nominal re-fit (this many
    /// base columns, 0: without).
    pub(super) fn new(robot: &Robot, p: &'a Prepared, opts: &'a DiagnoseOptions, refit: usize) -> Result<Self> {
        let n = robot.dof();
        let (s, d, gr) = (&p.s, &p.d, &p.gr);
        let t_len = s.t.len();
        let (sigma, rho, _) = noise_of_all_model(d, gr, n, t_len, refit, p.drives);
        let sigma_size = match &s.sample_noise {
            Some(raw) => sigma.iter().zip(raw).map(|(a, b)| a.max(*b)).collect(),
            None => sigma.clone(),
        };
        let w: Vec<f64> = sigma.iter().map(|s| 1.0 / (s * s)).collect();
        let m_diag = mean_mass_diag(robot, &s.q, n)?;
        let terminal_mass = robot.params()[10 * (n - 1)];
        let mut terminal_p10 = [0.0; 10];
        terminal_p10.copy_from_slice(&robot.params()[10 * (n - 1)..10 * n]);
        let terminal = Fit {
            params: (0..10)
                .map(|k| Param { kind: Some(EffectKind::Payload), joint: None, col: C_PAYLOAD + k })
                .collect(),
            theta: robot.params()[10 * (n - 1)..10 * n].to_vec(),
        };
        let terminal_rms: Vec<f64> = (0..n).map(|j| effect_rms(&terminal, gr, j, &|_| true)).collect();
        let base: Vec<usize> = (C_BASE..C_BASE + refit).collect();
        let terminal_beyond = (0..n).map(|j| beyond_refit_rms(&terminal, gr, &base, j, &|_| true)).collect();
        let prev_link_mass = if n > 1 { robot.params()[10 * (n - 2)] } else { 0.0 };
        let heldout_all = |drives: bool| -> Vec<f64> {
            let mut all = all_model(n, drives);
            all.refit = refit;
            let pa = all.params();
            let (f0, f1) = (fit(&pa, gr, &w, &[0]), fit(&pa, gr, &w, &[1]));
            (0..n).map(|j| rss_joint(&f0, gr, j, &[1]) + rss_joint(&f1, gr, j, &[0])).collect()
        };
        let h_all_basic = heldout_all(false);
        let h_all = if p.drives { heldout_all(true) } else { h_all_basic.clone() };
        Ok(Ctx {
            gr,
            m_diag,
            terminal_mass,
            terminal_p10,
            terminal_rms,
            terminal_beyond,
            prev_link_mass,
            refit: refit > 0,
            gain_margin: if refit > 0 && s.duration() >= GAIN_MARGIN_REFIT_MIN_DURATION_S {
                GAIN_MARGIN_REFIT
            } else {
                GAIN_MARGIN
            },
            w,
            sigma,
            sigma_size,
            h_all,
            h_all_basic,
            tau: rho,
            ripple_h: d.ripple_h.iter().map(|r| r.map(|x| x.0)).collect(),
            q_span: q_span(&s.q, n),
            dt: s.dt,
            n,
            opts,
            drives: p.drives,
            threads: opts.threads_for(s.t.len()),
        })
    }
}

impl<'a> Ctx<'a> {
    /// The same context under other options (the backward step's exit threshold).
    pub(super) fn with_opts<'b>(&self, opts: &'b DiagnoseOptions) -> Ctx<'b>
    where
        'a: 'b,
    {
        Ctx { opts, ..self.clone() }
    }

    fn n_eff(&self, j: usize) -> f64 {
        let rows = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        (rows / self.tau[j]).max(10.0)
    }

    /// Scores `larger` against `smaller` (nested) on joint `j`; `added` selects the new
    /// parameters (for the effect's RMS).
    pub(super) fn joint_score(
        &self,
        smaller: &Model,
        larger: &Model,
        j: usize,
        added: &dyn Fn(&Param) -> bool,
    ) -> JointScore {
        let apart = rest_apart(smaller, larger, j);
        let (smaller, larger) = apart.as_ref().map_or((smaller, larger), |(s, l)| (s, l));
        let (ps, pl) = (smaller.params(), larger.params());
        let (fs, fl) = (fit(&ps, self.gr, &self.w, &[0, 1]), fit(&pl, self.gr, &self.w, &[0, 1]));
        let (r0, r1) = (rss_joint(&fs, self.gr, j, &[0, 1]), rss_joint(&fl, self.gr, j, &[0, 1]));
        let k_small = joint_index(&ps, j).len();
        let k_large = joint_index(&pl, j).len();
        let d1 = (k_large.saturating_sub(k_small)).max(1) as f64;
        let rows = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        let n_eff = self.n_eff(j);
        let d2 = (n_eff - k_large as f64).max(1.0);
        // a correlated residual inflates the explained sum by its autocorrelation time
        // (r0 - r1 ~ tau sigma^2 chi2(d1)) but not the per-sample variance r1 / (rows - k):
        // the former divided by tau = rows / n_eff over the latter is the F statistic, its
        // denominator on d2 effective degrees of freedom (dividing both by tau, as before
        // 2026-12-03, divided the statistic by tau once too often)
        let f_stat = ((r0 - r1).max(0.0) / d1) / (r1 / (rows - k_large as f64).max(1.0)).max(1e-300) * (n_eff / rows);
        let p = f_sf(f_stat, d1, d2);
        // two-fold cross-validation (beside the terminal link's CAD error for a friction; not
        // the F test, whose degrees of freedom on a short log its 10 columns would take)
        let cad = self.terminal_cad_in(smaller, larger, added);
        let (hps, hpl) = cad.as_ref().map_or_else(|| (ps.clone(), pl.clone()), |(s, l)| (s.params(), l.params()));
        let mut h0 = 0.0;
        let mut h1 = 0.0;
        for (train, test) in [(0usize, 1usize), (1, 0)] {
            let a = fit(&hps, self.gr, &self.w, &[train]);
            let b = fit(&hpl, self.gr, &self.w, &[train]);
            h0 += rss_joint(&a, self.gr, j, &[test]);
            h1 += rss_joint(&b, self.gr, j, &[test]);
        }
        // the share of the held-out residual *above the noise* the candidate removes: a
        // missing effect explains (nearly) all of the structure it leaves on its joint; a
        // look-alike (e.g. an offset standing in for a wrong link mass) only part of it
        let n_test = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        // "structure" = what is above the noise, or what the vocabulary can explain at all
        // (held-out residual of the all-candidates model) when that is less, e.g. when a
        // friction model leaves stick-slip bursts at reversals that nothing explains
        // an armature against the basic vocabulary's floor (`h_all_basic`)
        let armature = fl.params.iter().any(|p| added(p) && p.kind == Some(EffectKind::Armature));
        let h_all = if armature { self.h_all_basic[j] } else { self.h_all[j] };
        let explainable = (h0 - h_all).min(h0 - n_test * self.sigma[j].powi(2));
        let structure = explainable.max(0.05 * h0);
        let heldout_gain = if h0 > 0.0 { ((h0 - h1) / structure).min(1.0) } else { 0.0 };
        let e_rms = effect_rms(&fl, self.gr, j, added);
        // what it removes beyond the others (the size rule's second half). Not for a gain:
        // its column `tau_nom,j = Y_j pi_nominal` lies in the re-fit's span but for the
        // terminal link's part by construction, so beyond a re-fit it "explains" only that
        // part; its look-alike and CAD-margin rules decide it
        let gain = fl.params.iter().any(|p| added(p) && p.kind == Some(EffectKind::TorqueGain));
        let explained_rms = if gain { e_rms } else { ((r0 - r1).max(0.0) / rows).sqrt() };
        let (e_rms, explained_rms) = stribeck_peak(&fl, j, added, e_rms, explained_rms);
        let mut sc = JointScore {
            f: f_stat,
            p,
            heldout_gain,
            effect_rms: e_rms,
            explained_rms,
            significant: false,
            rejected_by: None,
        };
        let refines = smaller.has(j, EffectKind::Coulomb)
            && fl.params.iter().any(|p| {
                added(p)
                    && matches!(
                        p.kind,
                        Some(EffectKind::SmoothCoulomb | EffectKind::AsymmetricCoulomb | EffectKind::Stribeck)
                    )
            });
        let stribeck = fl.params.iter().any(|p| added(p) && p.kind == Some(EffectKind::Stribeck));
        let share = match (refines, stribeck) {
            (true, true) => STRIBECK_SHARE,
            (true, false) => self.refinement_share(),
            _ => self.opts.min_share,
        };
        sc.rejected_by = self
            .statistical_rule(&sc, j, share)
            .or_else(|| Self::unphysical(&fl, j, added))
            .or_else(|| self.within_nominal_uncertainty(&fl, j, added))
            .or_else(|| self.delay_within_a_sample(&fl, j, added));
        sc.significant = sc.rejected_by.is_none();
        sc
    }

    /// A time delay of at most one sample is the sampling's, not a drive's: a torque held
    /// over its sample while the motion is stamped within it (a zero-order hold, re-stamped
    /// messages) lags by a fraction of a sample on every joint, which the conditioning's
    /// torque-to-motion alignment stands for (item 1 of docs/diagnose.md; issue 15 asks for a
    /// delay beyond a sample). The rule, in words, when it applies.
    fn delay_within_a_sample(&self, f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> Option<String> {
        f.params.iter().zip(&f.theta).find_map(|(p, &v)| {
            (added(p) && p.joint == Some(j) && p.kind == Some(EffectKind::TimeDelay) && v > 0.0 && v <= self.dt).then(
                || {
                    format!(
                        "size: delay {:.2} ms is within one sample ({:.2} ms): the sampling's lag, which the torque-to-motion alignment stands for",
                        1e3 * v,
                        1e3 * self.dt
                    )
                },
            )
        })
    }

    /// The noise standard deviation per joint the size rule measures against (`sigma_size`).
    pub(super) fn sigma_size(&self) -> &[f64] {
        &self.sigma_size
    }

    /// The held-out share a refinement of Coulomb friction (smooth, direction-dependent;
    /// Stribeck's is `STRIBECK_SHARE`) must remove on a joint that already has Coulomb
    /// friction (`REFINEMENT_SHARE` of `min_share`).
    pub(super) fn refinement_share(&self) -> f64 {
        REFINEMENT_SHARE * self.opts.min_share
    }

    /// The first statistical rule (F test, held-out share at least `min_share`, size) a
    /// score fails on joint `j`, in words with its numbers.
    pub(super) fn statistical_rule(&self, sc: &JointScore, j: usize, min_share: f64) -> Option<String> {
        let o = self.opts;
        if sc.p >= o.alpha {
            Some(format!("F test: F {:.3}, p {:.1e} >= alpha {:.0e}", sc.f, sc.p, o.alpha))
        } else if sc.heldout_gain < min_share {
            Some(format!(
                "held-out share: removes {:.0} % of the explainable held-out residual, needs {:.0} %",
                100.0 * sc.heldout_gain,
                100.0 * min_share
            ))
        } else if sc.effect_rms < o.min_effect * self.sigma_size[j] {
            Some(format!(
                "size: adds {:.3} N m RMS, {:.2} noise std, needs {:.2}",
                sc.effect_rms,
                sc.effect_rms / self.sigma_size[j],
                o.min_effect
            ))
        } else if sc.explained_rms < o.min_effect * self.sigma_size[j] {
            Some(format!(
                "size: adds {:.3} N m RMS but removes {:.3} N m RMS of the residual beyond the other effects, {:.2} noise std, needs {:.2}",
                sc.effect_rms,
                sc.explained_rms,
                sc.explained_rms / self.sigma_size[j],
                o.min_effect
            ))
        } else {
            None
        }
    }

    /// An armature below `NOMINAL_UNCERTAINTY` of the inertia the nominal model already
    /// puts on the joint, or a payload lighter than that share of the terminal link, is
    /// indistinguishable from an error of the links' own (CAD) inertias, which are rarely
    /// better than that: not named as a missing effect (the rule, in words, when it applies).
    fn within_nominal_uncertainty(&self, f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> Option<String> {
        f.params.iter().zip(&f.theta).find_map(|(p, &v)| {
            if !added(p) {
                return None;
            }
            if p.joint == Some(j) && p.kind == Some(EffectKind::Armature) && v < NOMINAL_UNCERTAINTY * self.m_diag[j] {
                return Some(format!(
                    "CAD-uncertainty margin: ia {v:.4} kg m^2 is below {:.0} % of the nominal inertia on the joint ({:.4})",
                    100.0 * NOMINAL_UNCERTAINTY,
                    self.m_diag[j]
                ));
            }
            let gm = self.gain_margin;
            if p.joint == Some(j) && p.kind == Some(EffectKind::TorqueGain) && v.abs() < gm {
                // measured = (1 + v) x true: a few % of the joint's rigid-body torque is what
                // CAD inertial errors leave too
                return Some(format!(
                    "CAD-uncertainty margin: gain k {:.4} is within {:.0} % of 1",
                    1.0 + v,
                    100.0 * gm
                ));
            }
            let payload = p.kind == Some(EffectKind::Payload) && p.col == C_PAYLOAD;
            if payload && self.refit {
                return self.payload_below_terminal_torque(f, j);
            }
            (payload && v < NOMINAL_UNCERTAINTY * self.terminal_mass).then(|| {
                format!(
                    "CAD-uncertainty margin: payload mass {v:.3} kg is below {:.0} % of the terminal link's {:.3} kg",
                    100.0 * NOMINAL_UNCERTAINTY,
                    self.terminal_mass
                )
            })
        })
    }

    /// The payload part of `f`'s torque on joint `j` as a share of the terminal link's
    /// nominal torque there.
    pub(super) fn terminal_share(&self, f: &Fit, j: usize) -> f64 {
        let rms = effect_rms(f, self.gr, j, &|p| p.kind == Some(EffectKind::Payload));
        match self.terminal_rms[j] {
            t if t > 0.0 => rms / t,
            _ if rms > 0.0 => f64::INFINITY,
            _ => 0.0,
        }
    }

    /// The payload's margin on top of the nominal re-fit, where its mass is not separable
    /// from the re-fitted links' (it regroups into the previous link's parameters, which the
    /// re-fit holds): its torque on joint `j` below `CAD_TERMINAL_MARGIN` of the terminal
    /// link's nominal torque there, as a terminal link that much off would make, or the part
    /// of it the re-fitted links cannot make below that share of the same part of the
    /// terminal link's (the rule, in words, when it applies). The second because,
    /// unpenalised, the payload's mass takes over the previous links' mass errors, which the
    /// re-fit's ridge holds back: a clean log with links 5 and 6 30 % light named a 1.8 kg
    /// payload on a 1.6 kg terminal link, 0.87 N m on joint 5, of which 0.008 N m no
    /// re-fitted link makes (0.45 of the terminal link's part; true payloads of the random
    /// sets 1.6-180x on a joint they pass on, docs/diagnose.md).
    fn payload_below_terminal_torque(&self, f: &Fit, j: usize) -> Option<String> {
        let payload = |p: &Param| p.kind == Some(EffectKind::Payload);
        let (mut rms, mut t, mut what) = (effect_rms(f, self.gr, j, &payload), self.terminal_rms[j], "");
        if rms >= CAD_TERMINAL_MARGIN * t {
            let base: Vec<usize> =
                f.params.iter().filter(|p| p.kind.is_none() && p.col >= C_BASE).map(|p| p.col).collect();
            rms = beyond_refit_rms(f, self.gr, &base, j, &payload);
            (t, what) = (self.terminal_beyond[j], "beyond what the re-fitted links can make, ");
        }
        (rms < CAD_TERMINAL_MARGIN * t).then(|| {
            format!(
                "CAD-uncertainty margin: {what}the payload adds {rms:.3} N m RMS, below {:.0} % of the terminal link's nominal {t:.3} N m on the joint",
                100.0 * CAD_TERMINAL_MARGIN,
            )
        })
    }

    /// The added parameter touching joint `j` without its physical sign, in words (none
    /// when all have it): friction, armature and spring stiffness dissipate or store
    /// energy only when positive, and a payload has a positive mass. A negative fit is how
    /// differentiation lag or a model error imitates an effect, never the effect itself.
    pub(super) fn unphysical(f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> Option<String> {
        f.params.iter().zip(&f.theta).find_map(|(p, &v)| {
            if !added(p) || p.joint.is_some_and(|x| x != j) {
                return None;
            }
            if p.kind == Some(EffectKind::TorqueGain) {
                // measured = k x true with k = 1 + theta: a sensor cannot flip the sign
                return (v <= -1.0).then(|| format!("sign: gain k = {:.4} is not positive", 1.0 + v));
            }
            let name = match (p.kind, p.col) {
                // on top of the re-fit the mass holds the previous links' mass errors too
                (Some(EffectKind::Payload), C_PAYLOAD) if !has_refit(f) => "payload mass",
                (kind, col) => level(kind, col)?,
            };
            (v <= 0.0).then(|| format!("sign: {name} = {v:.4} is not positive"))
        })
    }

    /// The same context on other Gram matrices (a column replaced: `ripple_period`).
    pub(super) fn on<'b>(&self, gr: &'b Grams) -> Ctx<'b>
    where
        'a: 'b,
    {
        Ctx { gr, ..self.clone() }
    }

    /// The held-out residual of model `m` on every joint, weighted by the joints' noise
    /// (two-fold cross-validation, as `joint_score`'s held-out share).
    pub(super) fn heldout_rss(&self, m: &Model) -> f64 {
        let p = m.params();
        let (f0, f1) = (fit(&p, self.gr, &self.w, &[0]), fit(&p, self.gr, &self.w, &[1]));
        (0..self.n).map(|j| self.w[j] * (rss_joint(&f0, self.gr, j, &[1]) + rss_joint(&f1, self.gr, j, &[0]))).sum()
    }

    /// Noise-weighted RSS reduction of `larger` over `smaller` (all joints, all data).
    pub(super) fn gain(&self, smaller: &Model, larger: &Model) -> f64 {
        let (fs, fl) =
            (fit(&smaller.params(), self.gr, &self.w, &[0, 1]), fit(&larger.params(), self.gr, &self.w, &[0, 1]));
        (0..self.n)
            .map(|j| self.w[j] * (rss_joint(&fs, self.gr, j, &[0, 1]) - rss_joint(&fl, self.gr, j, &[0, 1])))
            .sum()
    }
}

/// The size of an added Stribeck shape (else `e_rms`, `explained_rms` as they are): its peak
/// `|fs|` at breakaway, and what it removes beyond the others scaled alike. The shape acts
/// only below a few `vs`, a few % of the log, so its RMS over the log is a fraction of its
/// peak however clear it is (Stribeck tuning part, sizes by RMS: 6 of 23 true Stribeck
/// frictions failed the size rule at 0.24-0.45 noise std with F 25-160).
fn stribeck_peak(f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool, e_rms: f64, explained_rms: f64) -> (f64, f64) {
    let shape = |p: &Param| p.joint == Some(j) && p.kind == Some(EffectKind::Stribeck) && p.col != C_STUCK;
    let fs = f.params.iter().zip(&f.theta).find_map(|(p, &v)| (added(p) && shape(p)).then_some(v.abs()));
    match fs {
        Some(fs) if e_rms > 0.0 => (fs, explained_rms * fs / e_rms),
        _ => (e_rms, explained_rms),
    }
}

/// The name of the level physics keeps positive that column `col` of effect `kind` holds
/// (`fc` of Coulomb friction is `fc_neg` beside direction-dependent friction).
fn level(kind: Option<EffectKind>, col: usize) -> Option<&'static str> {
    match (kind?, col) {
        (EffectKind::Coulomb, C_SIGN) | (EffectKind::SmoothCoulomb, _) => Some("fc"),
        (EffectKind::LoadDependent, C_LOAD) => Some("mu"),
        (EffectKind::TimeDelay, C_DELAY) => Some("delay_s"),
        (EffectKind::Viscous, C_QD) => Some("fv"),
        (EffectKind::Armature, C_QDD) => Some("ia"),
        (EffectKind::JointSpring, C_Q) => Some("k"),
        _ => None,
    }
}

/// The levels on joint `j` that physics keeps positive (friction levels, both of a
/// direction-dependent friction's, `fv`, `ia`, `k`, `mu`, a delay), named
/// "<effect> <parameter>".
pub(super) fn signed_levels(f: &Fit, j: usize) -> Vec<(String, f64)> {
    let coulomb =
        f.params.iter().zip(&f.theta).find(|(p, _)| p.joint == Some(j) && p.kind == Some(EffectKind::Coulomb));
    let on_j = f.params.iter().zip(&f.theta).filter(|(p, _)| p.joint == Some(j));
    on_j.filter_map(|(p, &v)| match (p.kind, level(p.kind, p.col)) {
        // direction-dependent friction: fc_pos = fc_neg (Coulomb's fc) + its column's coefficient
        (Some(EffectKind::AsymmetricCoulomb), _) => {
            Some(("direction-dependent Coulomb friction fc_pos".into(), v + coulomb.map_or(0.0, |c| *c.1)))
        }
        (Some(kind), Some(name)) => Some((format!("{} {name}", kind.label()), v)),
        _ => None,
    })
    .collect()
}

/// Whether the fit has the nominal re-fit's base columns.
pub(super) fn has_refit(f: &Fit) -> bool {
    f.params.iter().any(|p| p.kind.is_none() && p.col >= C_BASE)
}

/// The score of a candidate that cannot go on a joint (already there, or its
/// precondition missing).
pub(super) fn not_scored(why: &str) -> JointScore {
    JointScore {
        f: 0.0,
        p: 1.0,
        heldout_gain: 0.0,
        effect_rms: 0.0,
        explained_rms: 0.0,
        significant: false,
        rejected_by: Some(format!("not tried: {why}")),
    }
}

/// One candidate effect scored on every joint: the scores, the model with it added where
/// it is significant, and the joints where a link-scale error imitates it (with the
/// largest scale).
pub(super) type Scored = (Vec<JointScore>, Model, Vec<(usize, String)>);
