//! Serialisable results shared by every layer: base-parameter values, per-joint fit
//! quality, the LS-vs-IV test, the full parameter file and a payload description. The
//! JSON the command line writes is these types, field for field.
//!
//! Below them, what every HTML report (diagnose, identify, payload) is made of:
//! [`page`] (the page skeleton, style sheet, escaping, number formats) and `plots` (PNG
//! figures drawn with plotters and an embedded font, decimated for long logs).

mod backend;
pub mod page;
pub(crate) mod plots;

use serde::{Deserialize, Serialize};

/// One base parameter of the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BaseValue {
    /// Readable combination, e.g. `"wrist_1_link.Izz + ..."`.
    pub name: String,
    /// Estimate (`null` when not excited).
    pub value: f64,
    /// Standard deviation.
    pub std: f64,
    /// Relative standard deviation in percent.
    pub rel_std_pct: f64,
    /// Value of the nominal (URDF) model for the same combination.
    pub nominal: f64,
}

/// Per-joint quality of a torque prediction.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Quality {
    /// Which data: `"fit"`, `"tail 25% of the log"`, or the validation log's name.
    pub data: String,
    /// Samples used.
    pub samples: usize,
    /// RMS of `measured - predicted` per joint (N m).
    pub rms: Vec<f64>,
    /// Coefficient of determination per joint.
    pub r2: Vec<f64>,
    /// RMS of the measured torque per joint (N m), for scale.
    pub tau_rms: Vec<f64>,
}

/// The Durbin-Wu-Hausman LS-vs-IV test.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Dwh {
    /// Statistic (chi-square under "LS unbiased").
    pub statistic: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// p-value.
    pub p_value: f64,
    /// `p < 0.01`: LS and IV differ beyond their uncertainty (LS biased, or a model gap
    /// that biases both differently).
    pub ls_biased: bool,
    /// The largest `|θ_IV - θ_LS|` over the base parameters, in standard deviations of
    /// that difference (`null` when nothing was tested).
    #[serde(default)]
    pub largest_difference: Option<f64>,
    /// The base parameter where that difference is largest.
    #[serde(default)]
    pub largest_difference_param: Option<String>,
    /// The verdict in words.
    pub verdict: String,
}

/// Full parameter vector, reloadable with [`load_params`].
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ParamsFile {
    /// Robot name.
    pub robot: String,
    /// Joint names, base to tip.
    pub joints: Vec<String>,
    /// Parameter names (`<link>.m`, ..., `<joint>.fc`, ...).
    pub names: Vec<String>,
    /// Values (SI).
    pub theta: Vec<f64>,
    /// Each joint's Coulomb-friction shape (`fc c(qd)`, `c = tanh(qd / v_scale)` or
    /// `sign`, plus `asym |c|`); absent: `sign` on every joint.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coulomb: Option<Vec<CoulombShapeFile>>,
}

/// A joint's Coulomb-friction shape in a parameter file ([`ivdyn_core::CoulombShape`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CoulombShapeFile {
    /// Velocity scale of the smooth sign (0: exact sign).
    pub v_scale: f64,
    /// Direction asymmetry (`fc+ = fc (1 + asym)`, `fc- = fc (1 - asym)`).
    pub asym: f64,
}

impl ParamsFile {
    /// The parameter file of `theta` for a robot whose joint `j` has Coulomb shape
    /// `shapes[j]` (written only when some joint is not the exact sign).
    pub fn new(
        robot: &str,
        joints: Vec<String>,
        names: Vec<String>,
        theta: Vec<f64>,
        shapes: &[ivdyn_core::CoulombShape],
    ) -> Self {
        let coulomb = shapes
            .iter()
            .any(|c| !c.is_sign())
            .then(|| shapes.iter().map(|c| CoulombShapeFile { v_scale: c.v_scale, asym: c.asym }).collect());
        ParamsFile { robot: robot.into(), joints, names, theta, coulomb }
    }

    /// The Coulomb shapes (the exact sign when absent), `n` joints.
    pub fn coulomb_shapes(&self, n: usize) -> Vec<ivdyn_core::CoulombShape> {
        match &self.coulomb {
            Some(c) => c.iter().map(|c| ivdyn_core::CoulombShape { v_scale: c.v_scale, asym: c.asym }).collect(),
            None => vec![ivdyn_core::CoulombShape::SIGN; n],
        }
    }
}

/// A payload to add to the last link.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PayloadSpec {
    /// Mass (kg).
    pub mass: f64,
    /// COM in the last link's frame (m).
    pub com: [f64; 3],
    /// Inertia about the COM `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (ivdyn's order; the side file
    /// keeps URDF attribute order).
    #[serde(with = "urdf_inertia")]
    pub inertia: [f64; 6],
}

impl PayloadSpec {
    /// The payload's 10 standard parameters about the last link's origin.
    pub fn link_inertia(&self) -> ivdyn_core::LinkInertia {
        let i_c = ivdyn_core::inertia_matrix(&self.inertia);
        ivdyn_core::LinkInertia::from_mass_com_inertia(
            self.mass,
            &self.com.into(),
            &nalgebra::Matrix3::identity(),
            &i_c,
        )
    }
}

/// Inertia 6-vectors held in ivdyn's order `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` and written to (read
/// from) JSON files in URDF attribute order `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`, the files' convention
/// (`#[serde(with = "urdf_inertia")]`).
pub mod urdf_inertia {
    use ivdyn_core::{inertia_from_urdf, inertia_to_urdf};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes `i` in URDF order.
    pub fn serialize<S: Serializer>(i: &[f64; 6], s: S) -> Result<S::Ok, S::Error> {
        inertia_to_urdf(*i).serialize(s)
    }

    /// Reads a URDF-order 6-vector into ivdyn's order.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 6], D::Error> {
        <[f64; 6]>::deserialize(d).map(inertia_from_urdf)
    }

    /// [`serialize`] for an optional vector (`null` when absent).
    pub fn serialize_opt<S: Serializer>(i: &Option<[f64; 6]>, s: S) -> Result<S::Ok, S::Error> {
        i.map(inertia_to_urdf).serialize(s)
    }
}

/// Per-joint quality of `predicted` against `measured` (`T x n` each, row-major): RMS of
/// the difference, R^2 = 1 - SSE / SST (NaN for a constant joint), RMS of the measurement.
pub fn quality_of(data: &str, measured: &[f64], predicted: &[f64], n: usize) -> Quality {
    let t = measured.len() / n;
    let (mut sse, mut sum, mut sum2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..t {
        for i in 0..n {
            let (y, e) = (measured[k * n + i], measured[k * n + i] - predicted[k * n + i]);
            sse[i] += e * e;
            sum[i] += y;
            sum2[i] += y * y;
        }
    }
    let tf = t.max(1) as f64;
    let rms = sse.iter().map(|s| (s / tf).sqrt()).collect();
    let r2 = (0..n)
        .map(|i| {
            let sst = sum2[i] - sum[i] * sum[i] / tf;
            if sst > 0.0 { 1.0 - sse[i] / sst } else { f64::NAN }
        })
        .collect();
    let tau_rms = sum2.iter().map(|s| (s / tf).sqrt()).collect();
    Quality { data: data.into(), samples: t, rms, r2, tau_rms }
}

/// Per-joint quality of the prediction `phi theta` of `tau` (`T x n` rows, `phi`
/// row-major `T n x b`).
pub fn quality(data: String, phi: &[f64], tau: &[f64], theta: &[f64], n: usize) -> Quality {
    let b = theta.len();
    let predicted: Vec<f64> =
        (0..tau.len()).map(|r| phi[r * b..(r + 1) * b].iter().zip(theta).map(|(a, b)| a * b).sum()).collect();
    quality_of(&data, tau, &predicted, n)
}
