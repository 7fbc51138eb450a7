//! Model-gap diagnosis (`ivdyn diagnose`, DESIGN.md "The model-gap diagnosis"): predict
//! the torques of a log with the nominal model, find where measurement and model
//! disagree, name the missing effect from a fixed vocabulary, add it, refit, and repeat
//! until nothing significant is left.
//!
//! The algorithm, one job per file, each importing only from the ones above it:
//! * `signals`: the log conditioned for the diagnosis (trimmed edges, torque alignment).
//! * `residual`: what a residual looks like: noise level, autocorrelation, regimes.
//! * `dictionary`: the candidate effects' regressor columns and their Gram matrices.
//! * `model`: a model of effects, its parameters and its fit from the Gram matrices.
//! * `prepare`: the differentiation cutoff and torque alignment chosen on the log.
//! * `refit`: the nominal model's own error re-fitted when the log calls for it.
//! * `rotor`: an armature the re-fit holds, named by its size (its column is a link's).
//! * `effort_check`: a joint whose logged effort is not its torque in N m (an error).
//! * `rules`: scoring a candidate (F test, held-out share, size, physics, look-alikes).
//! * [`search`]: the add / drop / refit loop ([`diagnose`]).
//! * `stick`: smooth friction or Coulomb friction through a stick phase, once found.
//! * `uncertainty`: standard errors of the final fit's parameters (`parameters_std`).
//! * `assemble`: the [`Diagnosis`] of the model found (parameters, evidence, verdict).
//!
//! And [`report`]: `report.html` (self-contained, PNG plots) and `residuals.mcap`.
//!
//! The types below are shared by all of them: [`DiagnoseOptions`] is the input;
//! [`DiagnosisJson`] is `diagnosis.json` exactly; [`Diagnosis`] adds what a person needs
//! to trust it (evidence, candidate scores, regimes, traces for the plots).

use serde::{Deserialize, Serialize};

mod assemble;
mod constant_view;
mod detectable;
mod dictionary;
mod drive_rules;
mod effort_check;
mod levels;
mod model;
mod offset_swap;
mod pairs;
mod payload_cad;
mod prepare;
mod realise;
mod refit;
mod regrid;
pub mod report;
mod reshape;
mod residual;
mod ripple_period;
mod rotor;
mod rules;
mod score;
pub mod search;
mod shape_scale;
mod signals;
mod stick;
mod swap;
mod uncertainty;
mod urdf_friction;

pub use search::diagnose;

/// Options of [`diagnose`].
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Significance level of the per-joint F test on the effective sample count (default
    /// 1e-3; the held-out share, the size and the physics rules guard against what an
    /// F test on correlated residuals lets through).
    pub alpha: f64,
    /// An effect must add at least this many noise standard deviations of RMS torque on
    /// a joint to be named there (default 0.5).
    pub min_effect: f64,
    /// Share of the held-out residual above the noise a candidate must remove on a joint
    /// to be named there (default 0.75; a refinement of Coulomb friction already on the
    /// joint needs 0.8 of it).
    pub min_share: f64,
    /// Zero-phase low-pass cutoff (Hz) for q / qd before differentiation (default: the
    /// one on a grid of 10-160 Hz, at most fs/4, that leaves the least residual).
    pub cutoff_hz: Option<f64>,
    /// Where the velocity comes from (default: the log's where it agrees with the
    /// positions, [`crate::prep::velocity`]).
    pub velocity: crate::prep::VelocitySource,
    /// Only the samples in `[start, end]` seconds from the log's first sample.
    pub window: Option<(f64, f64)>,
    /// Spans left out (seconds from the log's first sample).
    pub exclude: Vec<(f64, f64)>,
    /// Cross-validation blocks per fold (default 8).
    pub blocks_per_fold: usize,
    /// Most effects to add (default 20: friction and rotor inertia on every joint of a
    /// 7-joint arm took 10 steps on the everywhere set).
    pub max_steps: usize,
    /// Also search the effects of real drives (smooth and load-dependent friction, torque
    /// gain, torque ripple, time delay; direction-dependent friction is searched either
    /// way, `EffectKind::needs_drives`): `Some` as given; `None` (default) when the samples
    /// used span at least [`DRIVES_MIN_DURATION_S`] and the torque noise is white at the
    /// sample rate ([`DiagnoseOptions::drives_for`]).
    pub drives: Option<bool>,
    /// Most threads the diagnosis uses (`Some(1)`: the calling thread alone); `None`
    /// (default): the machine's cores on a log of at least [`PARALLEL_MIN_SAMPLES`]
    /// samples, else one ([`DiagnoseOptions::threads_for`]). The results are the same with
    /// any count, bit for bit.
    pub threads: Option<usize>,
    /// Most bytes the diagnosis' dictionary of candidate columns may take (default
    /// [`DICTIONARY_MAX_BYTES`]): it holds every column on every sample of every joint,
    /// ~10 MB per second of a 1 kHz, 7-joint log, so a log too long for it is diagnosed on
    /// every k-th block of its samples, spread over all of it, with a note saying so.
    pub max_dictionary_bytes: usize,
    /// Log file name for the report (informational).
    pub log_name: String,
    /// URDF file name for the report (informational).
    pub urdf_name: String,
    /// How this run read the robot and the log, as `ivdyn identify` arguments beyond
    /// `--urdf` and `--log` (`--base`, `--tip`, `--topic`, ...): the next command the
    /// report suggests (`next_command`) reads them the same way.
    pub next_args: Vec<String>,
}

/// Shortest log (seconds of samples used) on which the effects of real drives are searched
/// by default (with white torque noise, [`DiagnoseOptions::drives_for`]). On 2 s logs (1.6-1.9
/// s used) their many candidates take up rigid-body error of CAD inertials and noise: false
/// alarms on effect-free logs rise (new random arms 4 -> 6 of 18, CAD 1 -> 3 of 12). From 5 s
/// on (4.6 s used) they name far more true (effect, joint) pairs and fewer extra ones, with no
/// false alarm (5-12 s tuning parts: 86 -> 125 true pairs, 87 -> 47 extra). 4 s lies in the
/// untested gap, toward the tested side (docs/diagnose.md, "Effects of real drives from 4 s").
pub const DRIVES_MIN_DURATION_S: f64 = 4.0;

/// The `reason` of the final candidate that was added and then removed again by the backward
/// step (which then stopped the search): its rows say why.
pub(crate) const UNDONE: &str = "added, then removed again by the backward step";

/// Fewest log samples on which the diagnosis uses the machine's cores (`par`: the cutoffs,
/// the dictionary and Gram sums, the candidate scores, the pairs; the report beside the
/// residual file). Below it one thread: a diagnosis of a few thousand samples takes well
/// under a second, and there the threads cost more than they save (the 40 fixture logs of
/// 2-12 s on both cores: wall -17 %, user CPU +12 %, system CPU +70 %), which a test suite or
/// a fleet running many diagnoses side by side pays. The 60 s, 1 kHz bench log (60 000
/// samples) goes from 5.6-6.0 s to 3.7-3.9 s (benches/README.md).
pub const PARALLEL_MIN_SAMPLES: usize = 20_000;

/// Default [`DiagnoseOptions::max_dictionary_bytes`]: 4 GiB, about 7.5 minutes of a 1 kHz,
/// 7-joint log (a 600 s log of one took 6.0 GB at its peak without the cap, a 60 s one
/// 0.64 GB). A longer log is diagnosed on a subsample of blocks spread over it, not refused
/// and not left to exhaust the machine's memory.
pub const DICTIONARY_MAX_BYTES: usize = 4 << 30;

/// Largest median (over joints) lag-1 autocorrelation of the residual's sample-to-sample
/// differences at which the torque noise counts as white at the sample rate: -0.5 for
/// white noise, about -0.25 once interpolated onto a resampled grid, about 0 for a torque
/// low-passed before it was logged (the LWR4+ runs: -0.01 to 0.01). On such a log the
/// residual is smooth model error the drive candidates fit (a spring, ripples and gains
/// on the LWR4+), so they are left out by default.
pub const WHITE_NOISE_MAX_LAG1: f64 = -0.125;

impl DiagnoseOptions {
    /// Whether the effects of real drives are searched on a log whose samples used span
    /// `duration_s` seconds and whose residual's differences have median lag-1
    /// autocorrelation `noise_lag1`: as given, else on logs of at least
    /// [`DRIVES_MIN_DURATION_S`] with white torque noise ([`WHITE_NOISE_MAX_LAG1`]).
    pub fn drives_for(&self, duration_s: f64, noise_lag1: f64) -> bool {
        self.drives.unwrap_or(duration_s >= DRIVES_MIN_DURATION_S && noise_lag1 <= WHITE_NOISE_MAX_LAG1)
    }

    /// The threads the diagnosis of a log of `samples` uses: as given, else the machine's
    /// cores from [`PARALLEL_MIN_SAMPLES`] on and one below.
    pub fn threads_for(&self, samples: usize) -> usize {
        let auto = if samples >= PARALLEL_MIN_SAMPLES { crate::par::available() } else { 1 };
        self.threads.unwrap_or(auto)
    }

    /// [`DiagnoseOptions::max_dictionary_bytes`] from GiB, as the command line
    /// (`--max-dictionary-gib`) and Python (`max_dictionary_gib=`) give it: from 1 MiB
    /// (1/1024) to 1 TiB (1024), else an error naming the option.
    pub fn dictionary_bytes_of_gib(gib: f64) -> crate::error::Result<usize> {
        crate::limits::in_range("max_dictionary_gib", gib, 1.0 / 1024.0, 1024.0)?;
        Ok((gib * (1u64 << 30) as f64) as usize)
    }

    /// Rejects option values the search cannot use (docs/reliability.md): `alpha` outside
    /// `(0, 0.5]`, `min_effect` outside `[0, 1e3]` noise standard deviations, `min_share`
    /// outside `[0, 1]`, block, step and thread counts outside their bounds.
    pub fn check(&self) -> crate::error::Result<()> {
        crate::limits::positive_up_to("alpha", self.alpha, 0.5)?;
        crate::limits::in_range("min_effect", self.min_effect, 0.0, 1e3)?;
        crate::limits::in_range("min_share", self.min_share, 0.0, 1.0)?;
        crate::limits::count_in("blocks_per_fold", self.blocks_per_fold, 1, 1000)?;
        crate::limits::count_in("max_steps", self.max_steps, 0, 100)?;
        crate::limits::count_in("max_dictionary_bytes", self.max_dictionary_bytes, 1 << 20, usize::MAX)?;
        self.threads.map_or(Ok(()), |t| crate::limits::count_in("threads", t, 1, 1024))
    }
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            alpha: 1e-3,
            min_effect: 0.5,
            min_share: 0.75,
            cutoff_hz: None,
            velocity: crate::prep::VelocitySource::Auto,
            window: None,
            exclude: vec![],
            blocks_per_fold: 8,
            max_steps: 20,
            drives: None,
            threads: None,
            max_dictionary_bytes: DICTIONARY_MAX_BYTES,
            log_name: String::new(),
            urdf_name: String::new(),
            next_args: vec![],
        }
    }
}

/// The effect vocabulary of DESIGN.md, in its order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum EffectKind {
    /// `fc sign(qd)` per joint.
    #[serde(rename = "coulomb_friction")]
    Coulomb,
    /// `fv qd` per joint.
    #[serde(rename = "viscous_friction")]
    Viscous,
    /// `(fc + fs exp(-(qd/vs)^2)) sign(qd)` per joint.
    #[serde(rename = "stribeck_friction")]
    Stribeck,
    /// Rotor inertia `ia qdd` per joint.
    #[serde(rename = "armature")]
    Armature,
    /// A rigid body fixed to the terminal link (all joints).
    #[serde(rename = "payload")]
    Payload,
    /// A constant `tau0` per joint (sensor or drive offset).
    #[serde(rename = "torque_offset")]
    TorqueOffset,
    /// `k (q - q0)` per joint.
    #[serde(rename = "joint_spring")]
    JointSpring,
    /// Direction-dependent Coulomb friction: `fc_pos` when `qd > 0`, `-fc_neg` when `qd < 0`
    /// (a refinement of Coulomb friction found on the joint).
    #[serde(rename = "asymmetric_coulomb_friction")]
    AsymmetricCoulomb,
    /// Smooth (sigmoid) Coulomb friction `fc tanh(qd / vs)`, `vs` fitted (replaces Coulomb
    /// friction found on the joint when held-out data prefer it).
    #[serde(rename = "smooth_coulomb_friction")]
    SmoothCoulomb,
    /// `mu |tau_load| sign(qd)`, the load torque being the joint's rigid-body torque
    /// (harmonic drives).
    #[serde(rename = "load_dependent_friction")]
    LoadDependent,
    /// A torque-constant (gain) error: measured = `k` x true torque.
    #[serde(rename = "torque_gain")]
    TorqueGain,
    /// Position-periodic ripple (cogging) `a sin(2 pi q / period) + b cos(2 pi q / period)`.
    #[serde(rename = "torque_ripple")]
    TorqueRipple,
    /// The measured torque lags the motion by `delay_s` (beyond the sub-sample alignment).
    #[serde(rename = "time_delay")]
    TimeDelay,
}

impl EffectKind {
    /// Every effect, in the vocabulary's order.
    pub const ALL: [EffectKind; 13] = [
        EffectKind::Coulomb,
        EffectKind::Viscous,
        EffectKind::Stribeck,
        EffectKind::Armature,
        EffectKind::Payload,
        EffectKind::TorqueOffset,
        EffectKind::JointSpring,
        EffectKind::AsymmetricCoulomb,
        EffectKind::SmoothCoulomb,
        EffectKind::LoadDependent,
        EffectKind::TorqueGain,
        EffectKind::TorqueRipple,
        EffectKind::TimeDelay,
    ];

    /// Searched only with `DiagnoseOptions::drives`: the real-drive effects but
    /// direction-dependent Coulomb friction. That one only refines Coulomb friction found on
    /// a joint, so it never names a joint the basic search leaves alone, and a small offset
    /// beside Coulomb friction is already read as it (`drive_rules::offset_or_asymmetric`).
    pub fn needs_drives(&self) -> bool {
        self.is_drive() && *self != EffectKind::AsymmetricCoulomb
    }

    /// An effect of the real-drive vocabulary (DESIGN.md).
    pub fn is_drive(&self) -> bool {
        matches!(
            self,
            EffectKind::AsymmetricCoulomb
                | EffectKind::SmoothCoulomb
                | EffectKind::LoadDependent
                | EffectKind::TorqueGain
                | EffectKind::TorqueRipple
                | EffectKind::TimeDelay
        )
    }

    /// The vocabulary name (`"coulomb_friction"`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            EffectKind::Coulomb => "coulomb_friction",
            EffectKind::Viscous => "viscous_friction",
            EffectKind::Stribeck => "stribeck_friction",
            EffectKind::Armature => "armature",
            EffectKind::Payload => "payload",
            EffectKind::TorqueOffset => "torque_offset",
            EffectKind::JointSpring => "joint_spring",
            EffectKind::AsymmetricCoulomb => "asymmetric_coulomb_friction",
            EffectKind::SmoothCoulomb => "smooth_coulomb_friction",
            EffectKind::LoadDependent => "load_dependent_friction",
            EffectKind::TorqueGain => "torque_gain",
            EffectKind::TorqueRipple => "torque_ripple",
            EffectKind::TimeDelay => "time_delay",
        }
    }

    /// A short human label ("Coulomb friction", ...).
    pub fn label(&self) -> &'static str {
        match self {
            EffectKind::Coulomb => "Coulomb friction",
            EffectKind::Viscous => "viscous friction",
            EffectKind::Stribeck => "Stribeck friction",
            EffectKind::Armature => "armature (rotor inertia)",
            EffectKind::Payload => "payload on the last link",
            EffectKind::TorqueOffset => "torque offset",
            EffectKind::JointSpring => "joint spring",
            EffectKind::AsymmetricCoulomb => "direction-dependent Coulomb friction",
            EffectKind::SmoothCoulomb => "smooth (sigmoid) Coulomb friction",
            EffectKind::LoadDependent => "load-dependent friction",
            EffectKind::TorqueGain => "torque gain (torque-constant) error",
            EffectKind::TorqueRipple => "position-periodic torque ripple",
            EffectKind::TimeDelay => "torque-to-motion time delay",
        }
    }
}

/// One effect entry of `diagnosis.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EffectJson {
    /// Vocabulary name.
    pub name: String,
    /// Joint names the effect was found on (empty for `payload`, which acts on the
    /// terminal link).
    pub joints: Vec<String>,
    /// Per DESIGN.md: coulomb `{"fc": [..]}`, viscous `{"fv": [..]}`, stribeck
    /// `{"fc","fs","vs"}`, armature `{"ia"}`, torque_offset `{"tau0"}`, joint_spring
    /// `{"k","q0"}` (lists over `joints`), payload `{"mass","com","inertia"}`;
    /// asymmetric_coulomb_friction `{"fc_pos","fc_neg"}`, smooth_coulomb_friction
    /// `{"fc","vs"}`, load_dependent_friction `{"mu"}`, torque_gain `{"k"}`, torque_ripple
    /// `{"period","a","b"}`, time_delay `{"delay_s"}` (lists over `joints`).
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// Standard error of each parameter, same keys and shape as `parameters` (`null` where
    /// there is none: a shape chosen on a grid, a value that is not identifiable); from
    /// the final fit's covariance, its spread over the log's blocks and the re-fit's ridge (docs/diagnose.md,
    /// "Uncertainty"). Not written when empty.
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub parameters_std: serde_json::Map<String, serde_json::Value>,
    /// RMS residual per joint (N m, whole log) before this effect was added.
    pub rms_before: Vec<f64>,
    /// RMS residual per joint (N m, whole log) with it (and every earlier effect) added.
    pub rms_after: Vec<f64>,
}

/// `diagnosis.json`, exactly (DESIGN.md): nothing more, nothing less.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiagnosisJson {
    /// Effects in the order found; empty when nothing is missing.
    pub effects: Vec<EffectJson>,
    /// RMS residual per joint of the nominal model (N m).
    pub baseline_rms: Vec<f64>,
    /// RMS residual per joint with every effect added (N m).
    pub final_rms: Vec<f64>,
    /// Joint names, the order of every per-joint list.
    pub joints: Vec<String>,
    /// The nominal rigid-body model re-identified inside the diagnosis (DESIGN.md); absent
    /// when the log did not call for it (then the key is not written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nominal_refit: Option<NominalRefitJson>,
    /// The `ivdyn identify` command to run next (the named effects switched on, the
    /// identified model written as a URDF), as it can be pasted into a shell; absent when
    /// nothing was named and the nominal model was not re-fitted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_command: Option<String>,
    /// The smallest look-alike per joint the log can tell from the links' inertials
    /// (`detectable`); absent in files written before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detectable: Option<DetectableJson>,
}

/// `detectable` of `diagnosis.json`: per look-alike, per joint (the order of `joints`), the
/// smallest size whose torque beyond what the links before the terminal one can make (the
/// nominal re-fit's columns) is `noise_std` noise standard deviations RMS on its joint;
/// `null` where the log shows none of it. Sizes: `|tau0|` (N m), `|fc_pos - fc_neg|` (N m),
/// spring `|k|` (N m/rad), gain `|k - 1|`, armature `ia` (kg m^2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectableJson {
    /// The RMS, in noise standard deviations, an effect's part must reach.
    pub noise_std: f64,
    /// The noise standard deviation per joint it is measured in (N m): the size rule's.
    pub sigma: Vec<f64>,
    /// Smallest `|tau0|` (N m).
    pub torque_offset: Vec<Option<f64>>,
    /// Smallest `|fc_pos - fc_neg|` (N m).
    pub asymmetric_coulomb_friction: Vec<Option<f64>>,
    /// Smallest spring `|k|` (N m/rad).
    pub joint_spring: Vec<Option<f64>>,
    /// Smallest gain error `|k - 1|`.
    pub torque_gain: Vec<Option<f64>>,
    /// Smallest armature `ia` (kg m^2).
    pub armature: Vec<Option<f64>>,
}

/// `nominal_refit` of `diagnosis.json`: the rigid-body model the effects were searched on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NominalRefitJson {
    /// Base parameters (rigid body only) of the nominal and of the re-fitted model.
    pub base_params: BaseParamsJson,
    /// RMS residual per joint of the nominal model (N m).
    pub rms_before: Vec<f64>,
    /// RMS residual per joint with the re-fit alone (its part of the final fit; N m).
    pub rms_after: Vec<f64>,
    /// Why the nominal model was re-fitted, with the numbers.
    pub why: String,
}

/// Base parameters: names (combinations of link parameters), nominal and re-fitted values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaseParamsJson {
    /// Readable name of each base parameter (`ident::base::BaseParams::names`).
    pub names: Vec<String>,
    /// Values of the nominal (URDF) model.
    pub nominal: Vec<f64>,
    /// Values of the re-fitted model.
    pub values: Vec<f64>,
}

/// How one candidate fared on one joint at one step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointScore {
    /// F statistic of the candidate's columns on this joint's rows (training part).
    pub f: f64,
    /// Its p-value.
    pub p: f64,
    /// Fraction of the held-out residual (the part above the noise that the model with
    /// every candidate in can explain) the candidate removes on this joint (negative: it
    /// made the held-out part worse).
    pub heldout_gain: f64,
    /// RMS (N m) of the torque the fitted candidate adds on this joint.
    pub effect_rms: f64,
    /// RMS (N m) of the residual it removes on this joint beyond the model without it,
    /// `sqrt((RSS_before - RSS_after) / samples)`: `effect_rms` when its columns are
    /// orthogonal to the model's, less when the other effects (or the nominal re-fit) hold
    /// part of what it adds (for a torque gain, `effect_rms`: its column is the nominal
    /// model's torque, which a re-fit spans).
    pub explained_rms: f64,
    /// Whether the candidate is significant on this joint.
    pub significant: bool,
    /// The rule that rejected it on this joint, with its numbers (F test, held-out share,
    /// size, sign, CAD-uncertainty margin, look-alike; "not tried: ..." where it cannot
    /// go); `None` when significant.
    pub rejected_by: Option<String>,
}

/// One candidate effect scored at one step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CandidateScore {
    /// The effect.
    pub effect: EffectKind,
    /// Per joint (the log's joint order).
    pub per_joint: Vec<JointScore>,
    /// Joints it is significant on.
    pub joints: Vec<usize>,
    /// Overall score used to rank candidates (larger is better; 0 when nothing significant).
    pub score: f64,
    /// Whether it was the one added at this step.
    pub accepted: bool,
    /// Why it was or was not chosen, in words (e.g. "explains less than armature").
    pub reason: String,
}

/// One step of the search: the effect added, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Step {
    /// The effect added.
    pub effect: EffectKind,
    /// Joints (indices) it was added on (all joints for a payload).
    pub joints: Vec<usize>,
    /// The evidence, in sentences a user understands ("joint 2 residual jumps by
    /// 3.1 N m at every velocity reversal: Coulomb friction").
    pub evidence: Vec<String>,
    /// Every candidate scored at this step.
    pub candidates: Vec<CandidateScore>,
    /// RMS per joint before / after.
    pub rms_before: Vec<f64>,
    /// RMS per joint after.
    pub rms_after: Vec<f64>,
}

/// Where the residual is, per joint (for one prediction).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Regimes {
    /// RMS over the whole log (N m).
    pub rms: f64,
    /// RMS within +-`window` samples of velocity reversals (N m; NaN if none).
    pub rms_reversal: f64,
    /// RMS where |qdd| is in its top 20 % (N m).
    pub rms_high_acc: f64,
    /// RMS elsewhere (away from reversals, moderate acceleration) (N m).
    pub rms_rest: f64,
    /// Mean jump of the residual across velocity reversals, signed as
    /// `r(after) - r(before)` times the sign of the new velocity (N m; 2 fc for Coulomb friction).
    pub reversal_jump: f64,
    /// Number of velocity reversals.
    pub reversals: usize,
    /// Correlation of the residual with q, qd, qdd of the same joint.
    pub corr_q: f64,
    /// Correlation with qd.
    pub corr_qd: f64,
    /// Correlation with qdd.
    pub corr_qdd: f64,
    /// Mean of the residual (N m).
    pub mean: f64,
}

/// The signals behind the plots (row-major `T x N`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Traces {
    /// Time (s) from the log's start.
    pub t: Vec<f64>,
    /// Positions (rad or m), conditioned.
    pub q: Vec<f64>,
    /// Velocities.
    pub qd: Vec<f64>,
    /// Accelerations.
    pub qdd: Vec<f64>,
    /// Measured torque (N m).
    pub tau: Vec<f64>,
    /// Predicted torque: `[0]` the nominal model, `[i]` after step `i`.
    pub predicted: Vec<Vec<f64>>,
}

/// Facts about the input.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogInfo {
    /// The log file (as given).
    pub file: String,
    /// The URDF (as given).
    pub urdf: String,
    /// Samples used.
    pub samples: usize,
    /// Duration (s).
    pub duration: f64,
    /// Sample rate (Hz).
    pub rate: f64,
    /// Whether velocities came from the log on some joint (else differentiated from
    /// positions); `velocity` says per joint and why.
    pub velocity_in_log: bool,
    /// The velocity's source per joint, and why ([`crate::prep::velocity`]).
    pub velocity: Vec<crate::prep::VelocityChoice>,
    /// Zero-phase low-pass cutoff (Hz) used before differentiating (chosen on a grid
    /// unless given).
    pub cutoff_hz: f64,
    /// Time alignment of the acceleration to the torque found in the log (samples; +0.5:
    /// the torque of sample k acts over [t_k, t_k+1), as in a simulator step).
    pub align_samples: f64,
}

/// The whole diagnosis: the JSON content plus what the report shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnosis {
    /// `diagnosis.json`.
    pub json: DiagnosisJson,
    /// The steps, one per effect in `json.effects`.
    pub steps: Vec<Step>,
    /// The candidates scored at the final step, when none was significant.
    pub final_candidates: Vec<CandidateScore>,
    /// Estimated sensor noise std per joint (N m), from differences of the residual two
    /// samples apart (robust to the slow structure a missing effect leaves).
    pub noise_std: Vec<f64>,
    /// Regimes of the nominal residual, per joint.
    pub regimes_before: Vec<Regimes>,
    /// Regimes of the final residual, per joint.
    pub regimes_after: Vec<Regimes>,
    /// The headline: one sentence of at most 200 characters naming what is missing (or
    /// "nothing significant missing").
    pub verdict: String,
    /// The details below the headline: each effect with its joints, the nominal re-fit
    /// and why, what is left above the noise per joint, what the next command leaves out,
    /// and whether the effects of real drives were searched and why
    /// ([`DiagnoseOptions::drives_for`]).
    pub details: Vec<String>,
    /// Signals for plots and `residuals.mcap`.
    pub traces: Traces,
    /// The input.
    pub info: LogInfo,
}
