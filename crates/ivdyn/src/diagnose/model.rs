//! A model of effects (which effect on which joint, a payload), its parameters as
//! dictionary columns, and its weighted least-squares fit from the Gram matrices.

use nalgebra::{DMatrix, DVector};

use super::EffectKind;
use super::dictionary::{
    C_BASE, C_DELAY, C_GAIN, C_LINK, C_LOAD, C_ONE, C_PAYLOAD, C_Q, C_QD, C_QDD, C_RIPPLE, C_SIGN, C_SIGN_POS,
    C_STRIBECK, C_STUCK, C_TANH, C_TARGET, Dictionary, Grams, LINK_GROUPS, RIPPLE_N, SMOOTH_VS,
};
use super::residual::noise_and_tau;

/// One parameter of a model: which joints' rows it touches and through which column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Param {
    /// `None`: a link-scale parameter of the look-alike check (not an effect).
    pub(super) kind: Option<EffectKind>,
    /// `Some(j)`: a per-joint parameter; `None`: payload (all joints).
    pub(super) joint: Option<usize>,
    /// Dictionary column (for payload: `C_PAYLOAD + k`).
    pub(super) col: usize,
}

/// The model: per joint, the effects on it (and the Stribeck shape), plus payload.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct Model {
    pub(super) per_joint: Vec<Vec<EffectKind>>,
    pub(super) stribeck_vs: Vec<usize>,
    /// The stick column (`C_STUCK`) on joints without Stribeck friction: the model Stribeck
    /// friction is compared with (Stribeck friction has it always). Coulomb friction's
    /// `sign(qd)` takes a stuck joint's samples at their noisy sign; beside the Stribeck
    /// shape, which weighs the lowest speeds most, those samples (friction anywhere within
    /// the static level) pull `fs` to zero. The stick column holds them apart, and the
    /// comparison model has it too, so it gains Stribeck friction nothing on a joint that
    /// only sticks.
    pub(super) stick: Vec<bool>,
    /// Smooth Coulomb `vs` (index into `SMOOTH_VS`) per joint.
    pub(super) smooth_vs: Vec<usize>,
    /// Ripple harmonic (index into `RIPPLE_N`) per joint.
    pub(super) ripple_n: Vec<usize>,
    pub(super) payload: bool,
    /// Every shape of the grid effects (smooth friction, ripple) on every joint: the
    /// all-candidates model only (its residual must hold no structure any candidate explains,
    /// or the noise and autocorrelation estimated from it are those of a missing effect).
    pub(super) all_shapes: bool,
    /// Per-link scale factors of the nominal inertials, every link (look-alike check).
    pub(super) link_scale: bool,
    /// The nominal re-fit (`refit`): this many base-parameter columns (`C_BASE..`; 0: off),
    /// the rigid-body base parameters of the links before the terminal one, ridge-regularised
    /// toward the nominal (`Grams::ridge`). The terminal link is left out: a change there is
    /// what a payload is, and the payload candidate and its rules decide it.
    pub(super) refit: usize,
    /// Base columns (indices into `Dictionary::base`) left out of the re-fit: each is an
    /// armature's column on this log, and the armature holds it (`rotor`).
    pub(super) refit_skip: Vec<usize>,
    /// The terminal link's 10 inertial parameters free on this joint's row alone (the
    /// look-alike check of the terminal joint, whose torque is that link's alone).
    pub(super) terminal_row: Option<usize>,
    /// The terminal link's 10 inertial parameters free on every row, as a correction of the
    /// nominal pulled toward it by the re-fit's ridge, not a payload (`terminal_cad`).
    pub(super) terminal_cad: bool,
    /// Per joint, the speed below which its Coulomb friction was read as a stick phase
    /// (`stick`; 0: none): its level is read above it (`levels`).
    pub(super) stick_band: Vec<f64>,
}

impl Model {
    pub(super) fn new(n: usize) -> Self {
        Model {
            per_joint: vec![vec![]; n],
            stribeck_vs: vec![0; n],
            stick: vec![false; n],
            smooth_vs: vec![0; n],
            ripple_n: vec![0; n],
            payload: false,
            all_shapes: false,
            link_scale: false,
            refit: 0,
            refit_skip: vec![],
            terminal_row: None,
            terminal_cad: false,
            stick_band: vec![0.0; n],
        }
    }

    pub(super) fn has(&self, j: usize, e: EffectKind) -> bool {
        self.per_joint[j].contains(&e)
    }

    pub(super) fn with(&self, j: Option<usize>, e: EffectKind) -> Model {
        let mut m = self.clone();
        match j {
            None => m.payload = true,
            Some(j) => {
                if !m.has(j, e) {
                    m.per_joint[j].push(e);
                }
            }
        }
        m
    }

    pub(super) fn without(&self, j: Option<usize>, e: EffectKind) -> Model {
        let mut m = self.clone();
        match j {
            None => m.payload = false,
            Some(j) => m.per_joint[j].retain(|&x| x != e),
        }
        m
    }

    /// The parameters, in a fixed order.
    pub(super) fn params(&self) -> Vec<Param> {
        let mut p = vec![];
        for (j, effects) in self.per_joint.iter().enumerate() {
            let mut kinds = effects.clone();
            kinds.sort();
            for e in kinds {
                let (tanh, rip) = (C_TANH + self.smooth_vs[j], C_RIPPLE + 2 * self.ripple_n[j]);
                let cols: Vec<usize> = match e {
                    // smooth Coulomb friction replaces the sign column by its tanh
                    EffectKind::Coulomb if effects.contains(&EffectKind::SmoothCoulomb) => vec![],
                    EffectKind::Coulomb => vec![C_SIGN],
                    EffectKind::AsymmetricCoulomb => vec![C_SIGN_POS],
                    EffectKind::SmoothCoulomb => vec![tanh],
                    EffectKind::LoadDependent => vec![C_LOAD],
                    EffectKind::TorqueGain => vec![C_GAIN],
                    EffectKind::TimeDelay => vec![C_DELAY],
                    EffectKind::TorqueRipple => vec![rip, rip + 1],
                    EffectKind::Viscous => vec![C_QD],
                    EffectKind::Armature => vec![C_QDD],
                    EffectKind::TorqueOffset => vec![C_ONE],
                    // k (q - q0) = k q + c: the constant is the offset's column, so a
                    // spring and an offset on one joint share it (never both: see rules)
                    EffectKind::JointSpring => vec![C_Q, C_ONE],
                    EffectKind::Stribeck => vec![C_STRIBECK, C_STUCK],
                    EffectKind::Payload => vec![],
                };
                for c in cols {
                    let c = if c == C_STRIBECK { C_STRIBECK + self.stribeck_vs[j] } else { c };
                    if !p.iter().any(|x: &Param| x.joint == Some(j) && x.col == c) {
                        p.push(Param { kind: Some(e), joint: Some(j), col: c });
                    }
                }
            }
            if self.stick[j] && !effects.contains(&EffectKind::Stribeck) {
                p.push(Param { kind: Some(EffectKind::Coulomb), joint: Some(j), col: C_STUCK });
            }
        }
        if self.all_shapes {
            for j in 0..self.per_joint.len() {
                for c in C_TANH..C_TANH + SMOOTH_VS.len() {
                    p.push(Param { kind: Some(EffectKind::SmoothCoulomb), joint: Some(j), col: c });
                }
                for c in C_RIPPLE..C_RIPPLE + 2 * RIPPLE_N.len() {
                    p.push(Param { kind: Some(EffectKind::TorqueRipple), joint: Some(j), col: c });
                }
            }
        }
        if self.payload {
            for k in 0..10 {
                p.push(Param { kind: Some(EffectKind::Payload), joint: None, col: C_PAYLOAD + k });
            }
        } else if let Some(j) = self.terminal_row {
            for k in 0..10 {
                p.push(Param { kind: Some(EffectKind::Payload), joint: Some(j), col: C_PAYLOAD + k });
            }
        } else if self.terminal_cad {
            for k in 0..10 {
                p.push(Param { kind: None, joint: None, col: C_PAYLOAD + k });
            }
        }
        let links = if self.link_scale { self.per_joint.len() } else { 0 };
        let link_cols = C_LINK..C_LINK + LINK_GROUPS.len() * links;
        let refit = (C_BASE..C_BASE + self.refit).filter(|c| !self.refit_skip.contains(&(c - C_BASE)));
        for c in link_cols.chain(refit) {
            p.push(Param { kind: None, joint: None, col: c });
        }
        p
    }
}

/// The model with friction (Coulomb and viscous) on every joint: the effects a wrong
/// nominal link inertial cannot imitate (the base of the nominal re-fit's decision).
pub(super) fn friction_model(n: usize) -> Model {
    let mut m = Model::new(n);
    for j in 0..n {
        m.per_joint[j] = vec![EffectKind::Coulomb, EffectKind::Viscous];
    }
    m
}

/// The model with every candidate on every joint (and a payload): what is left after it
/// is the noise plus what no effect of the vocabulary explains.
pub(super) fn all_model(n: usize, drives: bool) -> Model {
    let mut all = basic_all_model(n);
    if !drives {
        return all;
    }
    for effects in all.per_joint.iter_mut() {
        effects.extend([EffectKind::LoadDependent, EffectKind::TorqueGain, EffectKind::TimeDelay]);
    }
    all.all_shapes = true;
    all
}

/// The all-candidates model of the basic vocabulary (friction, armature, spring, payload):
/// the differentiation cutoff is chosen with it (the smooth-friction shapes would absorb the
/// smearing of the velocity's sign a too low cutoff makes).
pub(super) fn basic_all_model(n: usize) -> Model {
    let mut all = Model::new(n);
    for j in 0..n {
        all.per_joint[j] =
            vec![EffectKind::Coulomb, EffectKind::Viscous, EffectKind::Armature, EffectKind::JointSpring];
    }
    all.payload = true;
    all
}

/// A fitted model.
#[derive(Debug, Clone)]
pub(super) struct Fit {
    pub(super) params: Vec<Param>,
    pub(super) theta: Vec<f64>,
}

pub(super) fn joint_index(params: &[Param], j: usize) -> Vec<(usize, usize)> {
    params.iter().enumerate().filter(|(_, p)| p.joint.is_none_or(|x| x == j)).map(|(i, p)| (i, p.col)).collect()
}

pub(super) fn sum_folds(g: &[DMatrix<f64>; 2], folds: &[usize]) -> DMatrix<f64> {
    let mut m = g[folds[0]].clone();
    for &f in &folds[1..] {
        m += &g[f];
    }
    m
}

/// The weighted normal equations of [`fit`] over `folds`: `A = sum_j w_j X_j^T X_j` and
/// `b = sum_j w_j X_j^T r_j` on the model's parameters, from the Gram matrices.
pub(super) fn normal_equations(
    model_params: &[Param],
    gr: &Grams,
    w: &[f64],
    folds: &[usize],
) -> (DMatrix<f64>, DVector<f64>) {
    let p = model_params.len();
    let mut a = DMatrix::<f64>::zeros(p, p);
    let mut b = DVector::<f64>::zeros(p);
    for j in 0..gr.g.len() {
        let g = sum_folds(&gr.g[j], folds);
        let idx = joint_index(model_params, j);
        for &(ia, ca) in &idx {
            b[ia] += w[j] * g[(ca, C_TARGET)];
            for &(ib, cb) in &idx {
                a[(ia, ib)] += w[j] * g[(ca, cb)];
            }
        }
    }
    (a, b)
}

/// Prior standard deviation of a re-fit correction, as a fraction of its combination's
/// nominal scale (`Grams::prior`): CAD inertials are typically 20-50 % off. (0.1 was tried:
/// more extra pairs and a false alarm, docs/diagnose.md.)
const PRIOR_C: f64 = 0.3;

/// The solution operator of [`fit`] for the normal matrix `a`: the column scaling `s`
/// (unit diagonal) and the pseudo-inverse of the scaled matrix with the ridge (and the
/// re-fit corrections' physical prior) on the link-scale parameters, so that `theta = S pinv (S b)`; `None` if the eigen-decomposition fails.
pub(super) fn scaled_pinv(model_params: &[Param], gr: &Grams, a: &DMatrix<f64>) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let (s, an) = scaled_normal(model_params, gr, a);
    Some((s, pinv(an)?))
}

/// The pseudo-inverse of the symmetric `an`: its eigen-decomposition is its SVD (singular
/// values |lambda|) at about half the cost; it keeps the directions above the relative
/// threshold. `None` if the decomposition fails.
fn pinv(an: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let eig = crate::linalg::sym_eigen(an, "diagnosis: candidate fit").ok()?;
    let tol = 1e-10 * eig.eigenvalues.amax();
    let v = eig.eigenvectors;
    let mut v_inv = v.clone();
    for (mut col, &l) in v_inv.column_iter_mut().zip(eig.eigenvalues.iter()) {
        col *= if l.abs() > tol { 1.0 / l } else { 0.0 };
    }
    Some(v_inv * v.transpose())
}

/// The column scaling `s` (unit diagonal) of the normal matrix `a` and the scaled matrix with
/// the ridge and the re-fit corrections' prior ([`scaled_pinv`]).
fn scaled_normal(model_params: &[Param], gr: &Grams, a: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    let ridge = gr.ridge;
    let p = model_params.len();
    // scale to unit diagonal, then a pseudo-inverse with a relative threshold
    let s: Vec<f64> = (0..p).map(|i| if a[(i, i)] > 0.0 { 1.0 / a[(i, i)].sqrt() } else { 0.0 }).collect();
    let mut an = DMatrix::from_fn(p, p, |i, k| a[(i, k)] * s[i] * s[k]);
    // the link-scale parameters are pulled toward the nominal model (scale 0) with the
    // ridge chosen for the nominal re-fit (0: plain least squares)
    for (i, q) in model_params.iter().enumerate() {
        if q.kind.is_none() && s[i] > 0.0 {
            an[(i, i)] += ridge;
            // and a re-fit correction also by its physical size: a Gaussian prior of standard
            // deviation `PRIOR_C` times its scale against the noise-weighted normal equations
            // (precision `1 / (c scale)^2`, here scaled by `s^2`), so that a well-excited
            // column cannot take a correction many times its combination's size
            if ridge > 0.0
                && q.col >= C_BASE
                && let Some(sc) = gr.prior.get(q.col - C_BASE)
            {
                an[(i, i)] += (s[i] / (PRIOR_C * sc)).powi(2);
            }
            // the terminal link's CAD error alike (`Model::terminal_cad`): a CAD error, not
            // any change of that link
            if ridge > 0.0
                && (C_PAYLOAD..C_PAYLOAD + 10).contains(&q.col)
                && let Some(sc) = gr.terminal_prior.get(q.col - C_PAYLOAD)
            {
                an[(i, i)] += (s[i] / (PRIOR_C * sc)).powi(2);
            }
        }
    }
    (s, an)
}

/// Smallest squared Cholesky pivot, relative to the largest diagonal entry, for which [`fit`]
/// solves by Cholesky; below it, or where Cholesky fails, the pseudo-inverse (which drops
/// eigenvalues under 1e-10 of the largest; the smallest eigenvalue is at most the smallest
/// squared pivot, so a rank-deficient fit, e.g. a payload this motion cannot see, falls back).
/// Measured on the tuning parts of nine sets (656 cases): the same names, every parameter's
/// error against truth the same within 3e-4 (within 3e-8 on all but one).
const CHOLESKY_MIN_PIVOT: f64 = 1e-6;

/// Weighted LS over `folds` (weights `w[j]` per joint). Rank-deficient directions (e.g.
/// payload parameters this motion cannot see) get the minimum-norm solution.
pub(super) fn fit(model_params: &[Param], gr: &Grams, w: &[f64], folds: &[usize]) -> Fit {
    let p = model_params.len();
    if p == 0 {
        return Fit { params: vec![], theta: vec![] };
    }
    let (a, b) = normal_equations(model_params, gr, w, folds);
    // a well-conditioned system by Cholesky (the search's fits: 8-10 % of the diagnosis' time
    // on the bench log went to eigen-decompositions), the rest by the pseudo-inverse
    let (s, an) = scaled_normal(model_params, gr, &a);
    let bn = DVector::from_fn(p, |i, _| b[i] * s[i]);
    let top = an.diagonal().max();
    let xn = match an.clone().cholesky() {
        Some(ch) if ch.l_dirty().diagonal().iter().all(|l| l * l >= CHOLESKY_MIN_PIVOT * top) => ch.solve(&bn),
        // The Gram matrices are checked finite before the search (`prepare`), so this
        // converges; were it not to, the candidate explains nothing (zero effects) rather
        // than hanging.
        _ => match pinv(an) {
            Some(pi) => &pi * &bn,
            None => return Fit { params: model_params.to_vec(), theta: vec![0.0; p] },
        },
    };
    let theta: Vec<f64> = (0..p).map(|i| xn[i] * s[i]).collect();
    Fit { params: model_params.to_vec(), theta }
}

/// Residual sum of squares of joint `j` over `folds` (unweighted, N m^2).
pub(super) fn rss_joint(f: &Fit, gr: &Grams, j: usize, folds: &[usize]) -> f64 {
    let g = sum_folds(&gr.g[j], folds);
    let idx = joint_index(&f.params, j);
    let mut v = g[(C_TARGET, C_TARGET)];
    for &(ia, ca) in &idx {
        v -= 2.0 * f.theta[ia] * g[(ca, C_TARGET)];
        for &(ib, cb) in &idx {
            v += f.theta[ia] * f.theta[ib] * g[(ca, cb)];
        }
    }
    v.max(0.0)
}

/// RMS over the log of the torque the parameters of `which` add on joint `j`.
pub(super) fn effect_rms(f: &Fit, gr: &Grams, j: usize, which: &dyn Fn(&Param) -> bool) -> f64 {
    let g = sum_folds(&gr.g[j], &[0, 1]);
    let idx: Vec<(usize, usize)> =
        joint_index(&f.params, j).into_iter().filter(|&(i, _)| which(&f.params[i])).collect();
    let mut v = 0.0;
    for &(ia, ca) in &idx {
        for &(ib, cb) in &idx {
            v += f.theta[ia] * f.theta[ib] * g[(ca, cb)];
        }
    }
    (v.max(0.0) / (gr.rows[j][0] + gr.rows[j][1]) as f64).sqrt()
}

/// Predicted extra torque of a fit over the whole log (`T x N`).
pub(super) fn effect_torque(f: &Fit, d: &Dictionary, n: usize, t_len: usize) -> Vec<f64> {
    let mut out = vec![0.0; t_len * n];
    for (i, p) in f.params.iter().enumerate() {
        let js: Vec<usize> = match p.joint {
            Some(j) => vec![j],
            None => (0..n).collect(),
        };
        for j in js {
            let c = &d.cols[j][p.col];
            for k in 0..t_len {
                out[k * n + j] += f.theta[i] * c[k];
            }
        }
    }
    out
}

/// The least noise std the tests compare with, as fractions of the joint's measured torque
/// RMS (`NOISE_FLOOR`) and of the residual of its nominal model (`GAP_FLOOR`): the floor of
/// the double-precision pipeline itself. On an exact log (a simulation without noise) what
/// [`all_model`] leaves is the conditioning's own error, 1e-7 to 2e-5 of the torque (500 and
/// 100 Hz) and smooth: read as noise, its autocorrelation time (~300 samples on a 10 s,
/// 500 Hz log) left the F tests 17 effective samples, and Coulomb and viscous friction of
/// half a N m on every joint of the test arm went unnamed, the final residual above the
/// nominal one. No sensor resolves 1e-5 of its range (a 16-bit converter's step is 1.5e-5 of
/// full scale), and a residual 1e-4 of what the effects explain is their numerical floor, not
/// noise: at the floor the noise is the floor, and white.
const NOISE_FLOOR: f64 = 1e-5;
const GAP_FLOOR: f64 = 1e-4;

/// Joint `j`'s noise floor (`NOISE_FLOOR`, `GAP_FLOOR`).
pub(super) fn noise_floor(d: &Dictionary, j: usize) -> f64 {
    let (tau_nom, r0) = (&d.cols[j][C_GAIN], &d.r0[j]);
    let rms = |x: &mut dyn Iterator<Item = f64>| (x.map(|v| v * v).sum::<f64>() / r0.len().max(1) as f64).sqrt();
    let measured = rms(&mut tau_nom.iter().zip(r0).map(|(a, b)| a + b));
    (NOISE_FLOOR * measured).max(GAP_FLOOR * rms(&mut r0.iter().copied()))
}

/// Noise std and integrated autocorrelation time per joint from the residual of
/// [`all_model`] (with the nominal re-fit's `refit` base columns, the drive effects when `drives`), and
/// that residual; the noise at least the floor (`NOISE_FLOOR`, `GAP_FLOOR`).
pub(super) fn noise_of_all_model(
    d: &Dictionary,
    gr: &Grams,
    n: usize,
    t_len: usize,
    refit: usize,
    drives: bool,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let unit = vec![1.0; n];
    let mut all = all_model(n, drives);
    all.refit = refit;
    let f_all = fit(&all.params(), gr, &unit, &[0, 1]);
    let e_all = effect_torque(&f_all, d, n, t_len);
    let r_all: Vec<f64> = (0..t_len * n).map(|i| d.r0[i % n][i / n] - e_all[i]).collect();
    let floored = |j: usize| {
        let (sigma, tau) = noise_and_tau(&r_all, n, j);
        let floor = noise_floor(d, j);
        if sigma < floor { (floor, 1.0) } else { (sigma, tau) }
    };
    let (sigma, rho): (Vec<f64>, Vec<f64>) = (0..n).map(floored).unzip();
    (sigma, rho, r_all)
}

/// RMS on joint `j` of the torque the parameters of `which` add beyond what the re-fit's
/// base columns `refit` can make ([`rms_beyond`]; the part the re-fitted links would not
/// take over; a payload's mass regroups into them).
pub(super) fn beyond_refit_rms(f: &Fit, gr: &Grams, refit: &[usize], j: usize, which: &dyn Fn(&Param) -> bool) -> f64 {
    let own: Vec<(f64, usize, Option<usize>)> = f
        .params
        .iter()
        .zip(&f.theta)
        .filter(|(p, _)| p.joint.is_none() && which(p))
        .map(|(p, &t)| (t, p.col, None))
        .collect();
    let absorb: Vec<(usize, Option<usize>)> = refit.iter().map(|&c| (c, None)).collect();
    rms_beyond(gr, &own, &absorb, j)
}

/// RMS on joint `j` of the torque `sum t x_c` of `own` (`(t, column, joint)`; joint `None`:
/// on every joint's rows) less its least-squares projection on the columns `absorb` over
/// every joint's rows: `x_p - X_a G_aa^-1 G_ap` with `G = sum_j X_j^T X_j` (unweighted).
pub(super) fn rms_beyond(
    gr: &Grams,
    own: &[(f64, usize, Option<usize>)],
    absorb: &[(usize, Option<usize>)],
    j: usize,
) -> f64 {
    let on = |jj: usize, at: Option<usize>| at.is_none_or(|x| x == jj);
    let g: Vec<DMatrix<f64>> = gr.g.iter().map(|gj| sum_folds(gj, &[0, 1])).collect();
    let na = absorb.len();
    let gaa = DMatrix::from_fn(na, na, |a, b| {
        let ((ca, ja), (cb, jb)) = (absorb[a], absorb[b]);
        (0..g.len()).filter(|&jj| on(jj, ja) && on(jj, jb)).map(|jj| g[jj][(ca, cb)]).sum::<f64>()
    });
    let gap = DVector::from_fn(na, |a, _| {
        let (ca, ja) = absorb[a];
        let on_both = |jj: usize, jp: Option<usize>| on(jj, ja) && on(jj, jp);
        own.iter()
            .map(|&(t, c, jp)| t * (0..g.len()).filter(|&jj| on_both(jj, jp)).map(|jj| g[jj][(ca, c)]).sum::<f64>())
            .sum()
    });
    // pseudo-inverse: base columns a short log barely excites are left at zero
    let eps = 1e-12 * gaa.norm();
    let beta = match na {
        0 => DVector::zeros(0),
        _ => gaa.svd(true, true).solve(&gap, eps).unwrap_or_else(|_| DVector::zeros(na)),
    };
    let cols: Vec<(f64, usize)> = own
        .iter()
        .filter(|&&(_, _, jp)| on(j, jp))
        .map(|&(t, c, _)| (t, c))
        .chain(absorb.iter().zip(beta.iter()).filter(|((_, ja), _)| on(j, *ja)).map(|(&(c, _), &b)| (-b, c)))
        .collect();
    let gj = &g[j];
    let v: f64 = cols.iter().flat_map(|&(ta, ca)| cols.iter().map(move |&(tb, cb)| ta * tb * gj[(ca, cb)])).sum();
    (v.max(0.0) / (gr.rows[j][0] + gr.rows[j][1]) as f64).sqrt()
}
