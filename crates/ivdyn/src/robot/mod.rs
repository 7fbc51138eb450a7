//! Runtime-sized robots: a [`Robot`] holds joint and link names and a [`DynModel`], an
//! enum over `ivdyn_core::Model<1>` .. `Model<MAX_DOF>` (rust-numpy's `SupportedArray`
//! pattern), so a URDF read at run time still runs the fixed-size, allocation-free core.

pub mod load;
pub mod mjcf;
pub mod physical;
pub mod urdf;
pub mod urdf_lenient;
pub mod write;

use crate::error::{Error, Result};
use ivdyn_core::params::{DRIVE_PARAM_NAMES, LINK_PARAM_NAMES, LINK_PARAMS, link_col, param_count};
use ivdyn_core::{
    self as core_, CoulombShape, DriveParams, Joint, JointLimits, LinkInertia, Model, Transform, Vec3, VecN,
};

/// Largest supported number of movable joints.
pub const MAX_DOF: usize = 12;

/// A model whose joint count is known at run time.
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)]
pub enum DynModel {
    N1(Box<Model<1>>),
    N2(Box<Model<2>>),
    N3(Box<Model<3>>),
    N4(Box<Model<4>>),
    N5(Box<Model<5>>),
    N6(Box<Model<6>>),
    N7(Box<Model<7>>),
    N8(Box<Model<8>>),
    N9(Box<Model<9>>),
    N10(Box<Model<10>>),
    N11(Box<Model<11>>),
    N12(Box<Model<12>>),
}

/// Runs `$body` with `$m` bound to the `&Model<N>` (or `&mut`) inside a [`DynModel`];
/// the body is compiled once per `N`.
#[macro_export]
macro_rules! with_model {
    ($model:expr, $m:ident => $body:expr) => {
        match $model {
            $crate::robot::DynModel::N1($m) => $body,
            $crate::robot::DynModel::N2($m) => $body,
            $crate::robot::DynModel::N3($m) => $body,
            $crate::robot::DynModel::N4($m) => $body,
            $crate::robot::DynModel::N5($m) => $body,
            $crate::robot::DynModel::N6($m) => $body,
            $crate::robot::DynModel::N7($m) => $body,
            $crate::robot::DynModel::N8($m) => $body,
            $crate::robot::DynModel::N9($m) => $body,
            $crate::robot::DynModel::N10($m) => $body,
            $crate::robot::DynModel::N11($m) => $body,
            $crate::robot::DynModel::N12($m) => $body,
        }
    };
}

/// A chain described with vectors (any length), before it becomes a fixed-size model.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    /// Joint kinds and axes.
    pub joints: Vec<Joint>,
    /// Joint placements at q = 0 in the previous link's frame.
    pub x_tree: Vec<Transform>,
    /// Link inertial parameters in the link frames.
    pub inertia: Vec<LinkInertia>,
    /// Drive parameters.
    pub drive: Vec<DriveParams>,
    /// Joint limits.
    pub limits: Vec<JointLimits>,
    /// Gravity in the base frame.
    pub gravity: Vec3,
    /// Tool frame in the last link's frame.
    pub tool: Transform,
}

impl Chain {
    fn to_model<const N: usize>(&self) -> Result<Model<N>> {
        let joints: [Joint; N] = self.joints.clone().try_into().map_err(|_| dim("joints", N, self.joints.len()))?;
        let x_tree: [Transform; N] = self.x_tree.clone().try_into().map_err(|_| dim("x_tree", N, self.x_tree.len()))?;
        let mut m = Model::new(joints, x_tree)?;
        m.inertia = self.inertia.clone().try_into().map_err(|_| dim("inertia", N, self.inertia.len()))?;
        m.drive = self.drive.clone().try_into().map_err(|_| dim("drive", N, self.drive.len()))?;
        m.limits = self.limits.clone().try_into().map_err(|_| dim("limits", N, self.limits.len()))?;
        m.gravity = self.gravity;
        m.tool = self.tool;
        Ok(m)
    }

    fn from_model<const N: usize>(m: &Model<N>) -> Self {
        Chain {
            joints: m.joints.to_vec(),
            x_tree: m.x_tree.to_vec(),
            inertia: m.inertia.to_vec(),
            drive: m.drive.to_vec(),
            limits: m.limits.to_vec(),
            gravity: m.gravity,
            tool: m.tool,
        }
    }
}

fn dim(what: &str, expected: usize, got: usize) -> Error {
    Error::Dimension { what: what.to_string(), expected, got }
}

impl DynModel {
    /// Builds the fixed-size model for the chain's joint count.
    pub fn from_chain(c: &Chain) -> Result<Self> {
        Ok(match c.joints.len() {
            1 => DynModel::N1(Box::new(c.to_model::<1>()?)),
            2 => DynModel::N2(Box::new(c.to_model::<2>()?)),
            3 => DynModel::N3(Box::new(c.to_model::<3>()?)),
            4 => DynModel::N4(Box::new(c.to_model::<4>()?)),
            5 => DynModel::N5(Box::new(c.to_model::<5>()?)),
            6 => DynModel::N6(Box::new(c.to_model::<6>()?)),
            7 => DynModel::N7(Box::new(c.to_model::<7>()?)),
            8 => DynModel::N8(Box::new(c.to_model::<8>()?)),
            9 => DynModel::N9(Box::new(c.to_model::<9>()?)),
            10 => DynModel::N10(Box::new(c.to_model::<10>()?)),
            11 => DynModel::N11(Box::new(c.to_model::<11>()?)),
            12 => DynModel::N12(Box::new(c.to_model::<12>()?)),
            dof => return Err(Error::TooManyJoints { dof, max: MAX_DOF }),
        })
    }

    /// The chain description (vectors).
    pub fn to_chain(&self) -> Chain {
        with_model!(self, m => Chain::from_model(&**m))
    }

    /// Number of joints.
    pub fn dof(&self) -> usize {
        with_model!(self, m => m.nq())
    }
}

/// A robot arm: names plus a runtime-sized model. Methods take and return flat slices
/// (row-major matrices) and check lengths and finiteness.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Robot name (URDF `<robot name>`).
    pub name: String,
    /// Movable joint names, base to tip (the order of every joint-space vector).
    pub joint_names: Vec<String>,
    /// Link (frame) name of each joint: the URDF child link of the joint.
    pub link_names: Vec<String>,
    /// Base link.
    pub base_link: String,
    /// Tip link (its placement in the last link is the model's tool frame).
    pub tip_link: String,
    /// Movable joints off the chain that were locked at q = 0 and fused.
    pub locked_joints: Vec<String>,
    /// Links off the chain (side branches, and the bodies below the tip when they are
    /// fused) whose inertia was added to a model link: `(link, model link)`.
    pub fused_links: Vec<(String, String)>,
    /// Links below a chosen tip that were left out of the model
    /// ([`urdf::UrdfOptions::fuse_beyond_tip`] fuses them instead).
    pub dropped_links: Vec<String>,
    /// The model.
    pub model: DynModel,
}

fn vec_n<const N: usize>(what: &str, x: &[f64]) -> Result<VecN<N>> {
    if x.len() != N {
        return Err(dim(what, N, x.len()));
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(Error::Core(core_::Error::NonFinite { what: static_name(what), index: i }));
    }
    Ok(VecN::<N>::from_column_slice(x))
}

fn static_name(what: &str) -> &'static str {
    match what {
        "q" => "q",
        "qd" => "qd",
        "qdd" => "qdd",
        "tau" => "tau",
        _ => "input",
    }
}

impl Robot {
    /// The paper's six-joint robot (Tables 1 and 2); links `link1..6`, joints `joint1..6`.
    pub fn paper() -> Self {
        Self::from_model_named("paper", core_::paper::robot())
    }

    /// Wraps a fixed-size model, naming joints `joint1..` and links `link1..`.
    pub fn from_model_named<const N: usize>(name: &str, model: Model<N>) -> Self {
        let chain = Chain::from_model(&model);
        Robot {
            name: name.to_string(),
            joint_names: (1..=N).map(|i| format!("joint{i}")).collect(),
            link_names: (1..=N).map(|i| format!("link{i}")).collect(),
            base_link: "base".into(),
            tip_link: format!("link{N}"),
            locked_joints: vec![],
            fused_links: vec![],
            dropped_links: vec![],
            // N >= 1 and <= MAX_DOF is the caller's promise; fall back to a panic-free error path.
            model: DynModel::from_chain(&chain).expect("model size within 1..=MAX_DOF"),
        }
    }

    /// Number of movable joints.
    pub fn dof(&self) -> usize {
        self.model.dof()
    }

    /// Number of parameters (`14 dof`).
    pub fn num_params(&self) -> usize {
        param_count(self.dof())
    }

    /// Parameter vector `theta` (layout in `ivdyn_core::params`).
    pub fn params(&self) -> Vec<f64> {
        let mut t = vec![0.0; self.num_params()];
        with_model!(&self.model, m => m.params_to_slice(&mut t).expect("length is num_params"));
        t
    }

    /// Sets all parameters from `theta`.
    pub fn set_params(&mut self, theta: &[f64]) -> Result<()> {
        with_model!(&mut self.model, m => m.set_params_from_slice(theta)?);
        Ok(())
    }

    /// The shape of each joint's Coulomb friction (model constants, not in `theta`).
    pub fn coulomb_shapes(&self) -> Vec<CoulombShape> {
        with_model!(&self.model, m => m.drive.iter().map(|d| d.coulomb).collect())
    }

    /// Sets the shape of each joint's Coulomb friction (one per joint; finite, `v_scale >= 0`,
    /// `|asym| < 1` so that both directions keep the sign of `fc`).
    pub fn set_coulomb_shapes(&mut self, shapes: &[CoulombShape]) -> Result<()> {
        if shapes.len() != self.dof() {
            return Err(dim("Coulomb shapes", self.dof(), shapes.len()));
        }
        if let Some(j) = shapes.iter().position(|c| !(c.v_scale >= 0.0 && c.v_scale.is_finite() && c.asym.abs() < 1.0))
        {
            return Err(Error::option(
                "coulomb",
                format!(
                    "joint {}: velocity scale {} must be finite and >= 0 and asymmetry {} inside (-1, 1)",
                    self.joint_names[j], shapes[j].v_scale, shapes[j].asym
                ),
            ));
        }
        with_model!(&mut self.model, m => m.drive.iter_mut().zip(shapes).for_each(|(d, c)| d.coulomb = *c));
        Ok(())
    }

    /// Readable names of the parameters: `"<link>.m"`, `"<link>.m*cx"`, ..., `"<joint>.fc"`.
    pub fn param_names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(self.num_params());
        for l in &self.link_names {
            names.extend(LINK_PARAM_NAMES.iter().map(|p| format!("{l}.{p}")));
        }
        for j in &self.joint_names {
            names.extend(DRIVE_PARAM_NAMES.iter().map(|p| format!("{j}.{p}")));
        }
        names
    }

    /// Inverse dynamics with drive terms.
    pub fn rnea(&self, q: &[f64], qd: &[f64], qdd: &[f64]) -> Result<Vec<f64>> {
        with_model!(&self.model, m => {
            let (q, qd, qdd) = (vec_n("q", q)?, vec_n("qd", qd)?, vec_n("qdd", qdd)?);
            let mut data = core_::Data::new();
            Ok(core_::rnea(&**m, &mut data, &q, &qd, &qdd).as_slice().to_vec())
        })
    }

    /// Gravity torques (no drive terms).
    pub fn gravity(&self, q: &[f64]) -> Result<Vec<f64>> {
        with_model!(&self.model, m => {
            let q = vec_n("q", q)?;
            let mut data = core_::Data::new();
            Ok(core_::gravity(&**m, &mut data, &q).as_slice().to_vec())
        })
    }

    /// Regressor, row-major `dof x 14 dof`.
    pub fn regressor(&self, q: &[f64], qd: &[f64], qdd: &[f64]) -> Result<Vec<f64>> {
        with_model!(&self.model, m => {
            let (q, qd, qdd) = (vec_n("q", q)?, vec_n("qd", qd)?, vec_n("qdd", qdd)?);
            let mut data = core_::Data::new();
            let y = core_::regressor(&**m, &mut data, &q, &qd, &qdd);
            let mut out = vec![0.0; y.cols() * m.nq()];
            y.write_row_major(&mut out);
            Ok(out)
        })
    }

    /// Static (gravity) regressor, row-major `dof x 14 dof`.
    pub fn gravity_regressor(&self, q: &[f64]) -> Result<Vec<f64>> {
        with_model!(&self.model, m => {
            let q = vec_n("q", q)?;
            let mut data = core_::Data::new();
            let y = core_::gravity_regressor(&**m, &mut data, &q);
            let mut out = vec![0.0; y.cols() * m.nq()];
            y.write_row_major(&mut out);
            Ok(out)
        })
    }

    /// Mass matrix (with armature), row-major `dof x dof`.
    pub fn mass_matrix(&self, q: &[f64]) -> Result<Vec<f64>> {
        with_model!(&self.model, m => {
            let q = vec_n("q", q)?;
            let mut data = core_::Data::new();
            // symmetric: column-major storage equals row-major
            Ok(core_::mass_matrix(&**m, &mut data, &q).as_slice().to_vec())
        })
    }

    /// Forward dynamics `qdd` for torques `tau`.
    pub fn forward_dynamics(&self, q: &[f64], qd: &[f64], tau: &[f64]) -> Result<Vec<f64>> {
        with_model!(&self.model, m => {
            let (q, qd, tau) = (vec_n("q", q)?, vec_n("qd", qd)?, vec_n("tau", tau)?);
            let mut data = core_::Data::new();
            Ok(core_::forward_dynamics(&**m, &mut data, &q, &qd, &tau)?.as_slice().to_vec())
        })
    }

    /// Index of a joint by name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joint_names.iter().position(|n| n == name)
    }

    /// What loading the URDF left out of the chain and where it went, one line each (for
    /// the command line and reports): off-chain links fused into each model link, the
    /// links dropped below the tip, and links whose inertials are no rigid body's (CAD
    /// exports have them; a massless link, all zero, is allowed). Empty for a plain chain
    /// of physical links.
    pub fn chain_notes(&self) -> Vec<String> {
        let mut notes = vec![];
        for into in &self.link_names {
            let links: Vec<&str> =
                self.fused_links.iter().filter(|(_, k)| k == into).map(|(l, _)| l.as_str()).collect();
            if !links.is_empty() {
                notes.push(format!("links off the chain fused into link '{into}' (at q = 0): {}", links.join(", ")));
            }
        }
        if !self.dropped_links.is_empty() {
            notes.push(format!(
                "bodies below the tip '{}' are not in the model: {} (the fuse-beyond-tip option adds them to link '{}')",
                self.tip_link,
                self.dropped_links.join(", "),
                self.link_names.last().map(String::as_str).unwrap_or("")
            ));
        }
        notes.extend(self.inertial_notes());
        notes
    }

    /// The links whose inertials no body has (`physical::check_link_limits`), one line each:
    /// a CAD export's broken inertia is a nominal error no re-fit of its own makes physical.
    pub fn inertial_notes(&self) -> Vec<String> {
        let theta = self.params();
        let mut notes = vec![];
        for (k, link) in self.link_names.iter().enumerate().take(self.dof()) {
            let problems = physical::check_link_limits(&theta[link_col(k, 0)..link_col(k, LINK_PARAMS)]);
            if !problems.is_empty() {
                notes.push(format!(
                    "link '{link}' is no rigid body: {} (the nominal model is not physical; `identify --consistent` fits one that is)",
                    problems.join("; ")
                ));
            }
        }
        notes
    }
}
