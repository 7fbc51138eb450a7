//! URDF loading (urdf-rs) into a fixed-base serial chain.
//!
//! - The chain is the path from the base link to the tip link. Without a base, the URDF
//!   root is used; without a tip, the only branch that contains movable joints is
//!   followed (an error names the joints where two such branches split).
//! - Revolute and continuous joints become revolute, prismatic stays prismatic; fixed
//!   joints are fused (child inertia moved into the parent link's frame, origins composed
//!   into the next joint's placement). Floating, planar and spherical joints on the chain,
//!   and mimic joints on the chain, are errors naming the joint.
//! - Links hanging off the chain (side branches) are fused into their chain ancestor with
//!   their movable joints locked at q = 0, as Pinocchio's `buildReducedModel` does; the
//!   locked joints and the fused links are listed in the result.
//! - The bodies below the tip: with a tip chosen by the caller they are dropped (the chain
//!   ends at the tip; a hand or gripper beyond a chosen flange is not part of the arm),
//!   unless [`UrdfOptions::fuse_beyond_tip`] asks to fuse them as a tool the arm carries.
//!   Without a tip, the default tip is the last link reached through movable joints, so
//!   what hangs below it is rigid (a flange, a tool frame, a fixed tool): it is fused,
//!   because the arm carries it. The dropped links are listed in the result.
//! - Links above the base and links fused into the base carry no dynamics. Gravity is
//!   `(0, 0, -9.81)` in the root frame, rotated into the base frame when the base sits
//!   below the root on fixed joints.
//! - `<dynamics damping friction>` become the viscous and Coulomb drive parameters.

use super::urdf_lenient::{first_joint_origin_only, with_location, without_appearance};
use super::{Chain, DynModel, MAX_DOF, Robot};
use crate::error::{Error, Result};
use ivdyn_core::model::GRAVITY_Z;
use ivdyn_core::{DriveParams, Joint, JointLimits, LinkInertia, Mat3, Transform, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use urdf_rs::JointType;

/// Which chain of a URDF becomes the robot.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct UrdfOptions {
    /// Base link (default: the URDF's root).
    pub base: Option<String>,
    /// Tip link (default: the end of the only branch with movable joints). A tip given
    /// here ends the chain: the bodies below it are dropped unless `fuse_beyond_tip`.
    pub tip: Option<String>,
    /// Fuse the bodies below a given tip into the last link (movable joints locked at
    /// q = 0), as the tool the arm carries, instead of dropping them. Without a tip they
    /// are always fused.
    pub fuse_beyond_tip: bool,
}

impl UrdfOptions {
    /// The chain from `base` to `tip`; the bodies below a given tip are dropped.
    pub fn new(base: Option<&str>, tip: Option<&str>) -> Self {
        UrdfOptions { base: base.map(Into::into), tip: tip.map(Into::into), fuse_beyond_tip: false }
    }
}

/// Loads `path`; see the module documentation for the rules.
pub fn load(path: &Path, base: Option<&str>, tip: Option<&str>) -> Result<Robot> {
    load_with(path, &UrdfOptions::new(base, tip))
}

/// Loads `path` with `opts`; see the module documentation for the rules.
pub fn load_with(path: &Path, opts: &UrdfOptions) -> Result<Robot> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
    load_str_with(&text, path, opts)
}

/// Loads URDF text; `file` is only used in error messages.
pub fn load_str(text: &str, file: &Path, base: Option<&str>, tip: Option<&str>) -> Result<Robot> {
    load_str_with(text, file, &UrdfOptions::new(base, tip))
}

/// Loads URDF text with `opts`; `file` is only used in error messages.
pub fn load_str_with(text: &str, file: &Path, opts: &UrdfOptions) -> Result<Robot> {
    check_xml_depth(text, file)?;
    let urdf = parse_as_urdfdom(text, file)?;
    Builder::new(&urdf, file)?.build(opts)
}

/// urdf-rs's reading of `text`; when it fails, retried on the text fixed up as urdfdom reads
/// it (`urdf_lenient`: duplicated joint origins, then the appearance dropped). When no fix-up
/// helps, the error is that of the most fixed-up text (what is wrong beyond what urdfdom
/// forgives), located in the file as given.
fn parse_as_urdfdom(text: &str, file: &Path) -> Result<urdf_rs::Robot> {
    let parse = |t: &str| {
        urdf_rs::read_from_string(t).map_err(|e| Error::UrdfParse { file: file.to_path_buf(), msg: e.to_string() })
    };
    let first = match parse(text) {
        Ok(u) => return Ok(u),
        Err(e) => e,
    };
    let origins = first_joint_origin_only(text);
    if let Ok(u) = parse(&origins) {
        return Ok(u);
    }
    // not well-formed XML (no appearance to drop): the first error says where
    let last = match without_appearance(&origins).map(|t| parse(&t)) {
        Some(Ok(u)) => return Ok(u),
        Some(Err(e)) => e,
        None => first,
    };
    Err(with_xacro_hint(located(last, text), text))
}

/// urdf-rs names a missing attribute but not where: the element, its link or joint and line.
fn located(e: Error, text: &str) -> Error {
    match e {
        Error::UrdfParse { file, msg } => Error::UrdfParse { file, msg: with_location(msg, text) },
        e => e,
    }
}

/// A xacro file (macros, `${...}` expressions) is no URDF until expanded: the parse error
/// says so, since urdf-rs's own ("invalid float literal") does not.
fn with_xacro_hint(e: Error, text: &str) -> Error {
    match e {
        Error::UrdfParse { file, msg } if text.contains("${") || text.contains("<xacro:") => Error::UrdfParse {
            file,
            msg: format!(
                "{msg}; the file holds xacro (`${{...}}` expressions or `<xacro:...>` elements): expand it first, e.g. `xacro robot.urdf.xacro > robot.urdf`"
            ),
        },
        e => e,
    }
}

/// Deepest element nesting accepted in a URDF. Real URDFs nest about 6 deep
/// (`robot/link/visual/geometry/mesh`); urdf-rs parses recursively and overflows the stack
/// at some tens of thousands, so anything beyond this is refused before parsing.
pub const MAX_XML_DEPTH: usize = 256;

/// Refuses XML nested deeper than [`MAX_XML_DEPTH`], naming `file` and the line. A cheap
/// linear scan of the raw text (comments, CDATA, `<?...?>`, `<!...>` and quoted attribute
/// values skipped), run before urdf-rs because its recursion cannot be bounded from outside.
pub fn check_xml_depth(text: &str, file: &Path) -> Result<()> {
    let b = text.as_bytes();
    let skip_to = |from: usize, end: &str| text[from..].find(end).map_or(b.len(), |e| from + e + end.len());
    let (mut i, mut depth) = (0, 0usize);
    while let Some(lt) = text[i..].find('<').map(|o| i + o) {
        let rest = &text[lt..];
        i = if rest.starts_with("<!--") {
            skip_to(lt, "-->")
        } else if rest.starts_with("<![CDATA[") {
            skip_to(lt, "]]>")
        } else if rest.starts_with("<?") {
            skip_to(lt, "?>")
        } else if rest.starts_with("<!") || rest.starts_with("</") {
            depth = depth.saturating_sub(usize::from(rest.starts_with("</")));
            skip_to(lt, ">")
        } else {
            let end = tag_end(b, lt + 1);
            if b.get(end.wrapping_sub(1)) != Some(&b'/') {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    let line = text[..lt].matches('\n').count() + 1;
                    return Err(Error::UrdfParse {
                        file: file.to_path_buf(),
                        msg: format!("XML elements nested more than {MAX_XML_DEPTH} deep (line {line}); refused"),
                    });
                }
            }
            (end + 1).min(b.len())
        };
    }
    Ok(())
}

/// Index of the `>` closing the tag that starts at `from` (quoted `>` skipped), or the end.
fn tag_end(b: &[u8], from: usize) -> usize {
    let mut quote = None;
    for (k, &c) in b.iter().enumerate().skip(from) {
        match (quote, c) {
            (None, b'"' | b'\'') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, b'>') => return k,
            _ => {}
        }
    }
    b.len()
}

struct Builder<'a> {
    urdf: &'a urdf_rs::Robot,
    file: PathBuf,
    link_index: HashMap<&'a str, usize>,
    /// joint index whose child is this link
    parent_joint: Vec<Option<usize>>,
    /// joints whose parent is this link
    child_joints: Vec<Vec<usize>>,
    /// does the subtree below this link contain a movable joint?
    movable_below: Vec<bool>,
}

/// The model chain being built, with names and each link's segment.
struct ChainWalk {
    chain: Chain,
    joint_names: Vec<String>,
    link_names: Vec<String>,
    /// Segment of each link: `Some(k)` = fused into model link `k`, `None` = base (ignored);
    /// with the link's placement in that segment's frame (at locked q = 0). `None`: not
    /// reached yet.
    segment: Vec<Option<(Option<usize>, Transform)>>,
}

/// What [`Builder::fuse_off_chain`] did beyond the chain links themselves.
#[derive(Default)]
struct Fused {
    /// Movable joints off the chain, locked at q = 0.
    locked: Vec<String>,
    /// Off-chain links fused into a model link: (link, model link).
    links: Vec<(String, String)>,
    /// Links below a chosen tip, left out.
    dropped: Vec<String>,
}

fn is_movable(t: &JointType) -> bool {
    !matches!(t, JointType::Fixed)
}

fn type_name(t: &JointType) -> &'static str {
    match t {
        JointType::Revolute => "revolute",
        JointType::Continuous => "continuous",
        JointType::Prismatic => "prismatic",
        JointType::Fixed => "fixed",
        JointType::Floating => "floating",
        JointType::Planar => "planar",
        JointType::Spherical => "spherical",
    }
}

/// Largest joint or COM offset accepted in a URDF (m): no arm's link is a kilometre long,
/// and offsets far beyond make torques beyond every log's range.
pub const MAX_URDF_OFFSET: f64 = 1e3;

fn pose(p: &urdf_rs::Pose) -> Transform {
    Transform::from_xyz_rpy(*p.xyz, *p.rpy)
}

impl<'a> Builder<'a> {
    fn new(urdf: &'a urdf_rs::Robot, file: &Path) -> Result<Self> {
        let file = file.to_path_buf();
        let link_index: HashMap<&str, usize> =
            urdf.links.iter().enumerate().map(|(i, l)| (l.name.as_str(), i)).collect();
        let mut parent_joint = vec![None; urdf.links.len()];
        let mut child_joints = vec![Vec::new(); urdf.links.len()];
        for (ji, j) in urdf.joints.iter().enumerate() {
            let unknown = |l: &str| Error::UrdfStructure {
                file: file.clone(),
                msg: format!("joint '{}' refers to unknown link '{l}'", j.name),
            };
            let p = *link_index.get(j.parent.link.as_str()).ok_or_else(|| unknown(&j.parent.link))?;
            let c = *link_index.get(j.child.link.as_str()).ok_or_else(|| unknown(&j.child.link))?;
            if parent_joint[c].is_some() {
                return Err(Error::UrdfStructure {
                    file: file.clone(),
                    msg: format!("link '{}' is the child of more than one joint", j.child.link),
                });
            }
            parent_joint[c] = Some(ji);
            child_joints[p].push(ji);
        }
        let mut b = Self { urdf, file, link_index, parent_joint, child_joints, movable_below: vec![] };
        // every walk below (up to the root, down the subtrees) ends only on a tree
        b.check_loops()?;
        b.check_numbers()?;
        b.movable_below = b.movable_below_all();
        Ok(b)
    }

    /// Every joint's origin and limits and every link's inertial origin are finite, and
    /// offsets at most [`MAX_URDF_OFFSET`]: a NaN origin used to simulate NaN torques, and
    /// identify then blamed the log.
    fn check_numbers(&self) -> Result<()> {
        let bad_pose = |p: &urdf_rs::Pose| {
            p.xyz.iter().chain(p.rpy.iter()).any(|v| !v.is_finite()) || p.xyz.iter().any(|v| v.abs() > MAX_URDF_OFFSET)
        };
        for j in &self.urdf.joints {
            let err = |msg: String| Error::BadJoint { file: self.file.clone(), joint: j.name.clone(), msg };
            if bad_pose(&j.origin) {
                return Err(err(format!(
                    "origin xyz {:?} rpy {:?}: values must be finite, offsets at most {MAX_URDF_OFFSET} m",
                    *j.origin.xyz, *j.origin.rpy
                )));
            }
            let l = &j.limit;
            if [l.lower, l.upper, l.velocity, l.effort].iter().any(|v| v.is_nan()) {
                return Err(err(format!(
                    "limit lower {} upper {} velocity {} effort {}: NaN is not a limit",
                    l.lower, l.upper, l.velocity, l.effort
                )));
            }
        }
        for link in &self.urdf.links {
            if bad_pose(&link.inertial.origin) {
                return Err(self.structure(format!(
                    "link '{}': inertial origin xyz {:?} rpy {:?}: values must be finite, offsets at most {MAX_URDF_OFFSET} m",
                    link.name, *link.inertial.origin.xyz, *link.inertial.origin.rpy
                )));
            }
        }
        Ok(())
    }

    fn parent_link(&self, l: usize) -> Option<usize> {
        self.parent_joint[l].map(|j| self.link_index[self.urdf.joints[j].parent.link.as_str()])
    }

    /// An error naming the links of the first kinematic loop (a link its own ancestor,
    /// a self-loop included). Each link has at most one parent, so following parents from
    /// every link, marking the links seen, finds each loop in linear time.
    fn check_loops(&self) -> Result<()> {
        const NEW: u8 = 0;
        const ON_PATH: u8 = 1;
        const DONE: u8 = 2;
        let mut state = vec![NEW; self.urdf.links.len()];
        for start in 0..state.len() {
            let mut path: Vec<usize> = vec![];
            let mut l = Some(start);
            while let Some(k) = l.filter(|&k| state[k] != DONE) {
                if state[k] == ON_PATH {
                    let at = path.iter().position(|&p| p == k).unwrap_or(0);
                    let mut cycle: Vec<String> =
                        path[at..].iter().rev().map(|&p| format!("'{}'", self.urdf.links[p].name)).collect();
                    cycle.push(cycle[0].clone());
                    return Err(self.structure(format!("kinematic loop: {}", cycle.join(" -> "))));
                }
                state[k] = ON_PATH;
                path.push(k);
                l = self.parent_link(k);
            }
            path.iter().for_each(|&p| state[p] = DONE);
        }
        Ok(())
    }

    /// [`Self::movable_below`] for every link, children before parents (no recursion: a
    /// long chain would overflow the stack). Needs a loop-free graph.
    fn movable_below_all(&self) -> Vec<bool> {
        let n = self.urdf.links.len();
        let mut order: Vec<usize> = (0..n).filter(|&l| self.parent_joint[l].is_none()).collect();
        let mut k = 0;
        while k < order.len() {
            let l = order[k];
            order
                .extend(self.child_joints[l].iter().map(|&j| self.link_index[self.urdf.joints[j].child.link.as_str()]));
            k += 1;
        }
        let mut below = vec![false; n];
        for &l in order.iter().rev() {
            below[l] = self.child_joints[l].iter().any(|&j| {
                let joint = &self.urdf.joints[j];
                is_movable(&joint.joint_type) || below[self.link_index[joint.child.link.as_str()]]
            });
        }
        below
    }

    fn link(&self, name: &str) -> Result<usize> {
        self.link_index.get(name).copied().ok_or_else(|| Error::UnknownLink {
            file: self.file.clone(),
            link: name.to_string(),
            available: self.urdf.links.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join(", "),
        })
    }

    fn root(&self) -> Result<usize> {
        let roots: Vec<usize> = (0..self.urdf.links.len()).filter(|&l| self.parent_joint[l].is_none()).collect();
        match roots.as_slice() {
            [r] => Ok(*r),
            [] => Err(self.structure("the kinematic graph has no root link (a loop?)".into())),
            rs => Err(self.structure(format!(
                "several root links: {}",
                rs.iter().map(|&l| self.urdf.links[l].name.as_str()).collect::<Vec<_>>().join(", ")
            ))),
        }
    }

    fn structure(&self, msg: String) -> Error {
        Error::UrdfStructure { file: self.file.clone(), msg }
    }

    /// Default tip: follow the only branch with movable joints until none is left.
    fn default_tip(&self, base: usize) -> Result<usize> {
        let mut link = base;
        loop {
            let branches: Vec<usize> = self.child_joints[link]
                .iter()
                .copied()
                .filter(|&j| {
                    let joint = &self.urdf.joints[j];
                    is_movable(&joint.joint_type) || self.movable_below[self.link_index[joint.child.link.as_str()]]
                })
                .collect();
            match branches.as_slice() {
                [] => return Ok(link),
                [j] => link = self.link_index[self.urdf.joints[*j].child.link.as_str()],
                js => {
                    return Err(Error::Branching {
                        file: self.file.clone(),
                        link: self.urdf.links[link].name.clone(),
                        branches: js
                            .iter()
                            .map(|&j| format!("'{}'", self.urdf.joints[j].name))
                            .collect::<Vec<_>>()
                            .join(", "),
                    });
                }
            }
        }
    }

    /// Builds the robot from `base` (default: the root) to `tip` (default: [`Self::default_tip`]).
    fn build(&self, opts: &UrdfOptions) -> Result<Robot> {
        let root = self.root()?;
        let base = match &opts.base {
            Some(b) => self.link(b)?,
            None => root,
        };
        let tip = match &opts.tip {
            Some(t) => self.link(t)?,
            None => self.default_tip(base)?,
        };
        let path = self.chain_path(base, tip)?;
        // refused before the chain is built: the model has at most MAX_DOF joints
        let dof = path.iter().filter(|&&j| is_movable(&self.urdf.joints[j].joint_type)).count();
        if dof > MAX_DOF {
            return Err(self.structure(format!(
                "{dof} movable joints between base '{}' and tip '{}'; at most {MAX_DOF} are supported",
                self.urdf.links[base].name, self.urdf.links[tip].name
            )));
        }
        let gravity = self.base_gravity(base)?;
        let mut walk = self.walk_chain(&path, base, tip, gravity)?;
        // a tip the caller chose ends the chain; the default tip only has rigid bodies below
        let drop_below = (opts.tip.is_some() && !opts.fuse_beyond_tip).then_some(tip);
        let fused = self.fuse_off_chain(base, drop_below, &mut walk)?;
        Ok(Robot {
            name: self.urdf.name.clone(),
            joint_names: walk.joint_names,
            link_names: walk.link_names,
            base_link: self.urdf.links[base].name.clone(),
            tip_link: self.urdf.links[tip].name.clone(),
            locked_joints: fused.locked,
            fused_links: fused.links,
            dropped_links: fused.dropped,
            model: DynModel::from_chain(&walk.chain)?,
        })
    }

    /// The joints from `base` down to `tip`, in that order (an error when the tip is not below the base).
    fn chain_path(&self, base: usize, tip: usize) -> Result<Vec<usize>> {
        // path tip -> base through parent joints
        let mut path = Vec::new();
        let mut l = tip;
        while l != base {
            let j = self.parent_joint[l].ok_or_else(|| {
                self.structure(format!(
                    "tip link '{}' is not below base link '{}'",
                    self.urdf.links[tip].name, self.urdf.links[base].name
                ))
            })?;
            path.push(j);
            l = self.link_index[self.urdf.joints[j].parent.link.as_str()];
        }
        path.reverse();
        Ok(path)
    }

    /// Gravity in the base frame: the root's `-z` gravity rotated through the fixed joints
    /// above the base (a movable one there is an error).
    fn base_gravity(&self, base: usize) -> Result<Vec3> {
        let mut base_rot = Mat3::identity();
        let mut l = base;
        while let Some(j) = self.parent_joint[l] {
            let joint = &self.urdf.joints[j];
            if is_movable(&joint.joint_type) {
                return Err(self.structure(format!(
                    "joint '{}' between the root and base link '{}' is movable; choose a base above it",
                    joint.name, self.urdf.links[base].name
                )));
            }
            base_rot = pose(&joint.origin).rot * base_rot;
            l = self.link_index[joint.parent.link.as_str()];
        }
        Ok(base_rot.transpose() * GRAVITY_Z)
    }

    /// Walks the chain `path`: movable joints become model joints (placement = the fixed
    /// origins accumulated since the last one), fixed ones accumulate; records each chain
    /// link's segment and sets the tool frame (what is left after the last movable joint).
    fn walk_chain(&self, path: &[usize], base: usize, tip: usize, gravity: Vec3) -> Result<ChainWalk> {
        let mut w = ChainWalk {
            chain: Chain {
                joints: vec![],
                x_tree: vec![],
                inertia: vec![],
                drive: vec![],
                limits: vec![],
                gravity,
                tool: Transform::IDENTITY,
            },
            joint_names: vec![],
            link_names: vec![],
            segment: vec![None; self.urdf.links.len()],
        };
        w.segment[base] = Some((None, Transform::IDENTITY));
        let mut acc = Transform::IDENTITY; // placement of the current link in the last segment frame
        let mut seg: Option<usize> = None;
        for &j in path {
            let joint = &self.urdf.joints[j];
            let child = self.link_index[joint.child.link.as_str()];
            let origin = pose(&joint.origin);
            match joint.joint_type {
                JointType::Fixed => {
                    acc = acc.compose(&origin);
                }
                JointType::Revolute | JointType::Continuous | JointType::Prismatic => {
                    self.push_joint(&mut w, joint, acc.compose(&origin))?;
                    seg = Some(w.chain.joints.len() - 1);
                    acc = Transform::IDENTITY;
                }
                _ => return Err(self.unsupported(joint)),
            }
            w.segment[child] = Some((seg, acc));
        }
        if w.chain.joints.is_empty() {
            return Err(self.structure(format!(
                "no movable joint between base '{}' and tip '{}'",
                self.urdf.links[base].name, self.urdf.links[tip].name
            )));
        }
        w.chain.tool = acc;
        Ok(w)
    }

    /// Appends movable `joint` at placement `x_tree` to the chain (axis, limits, URDF
    /// `<dynamics>` as drive friction, zero inertia until the links are fused).
    fn push_joint(&self, w: &mut ChainWalk, joint: &urdf_rs::Joint, x_tree: Transform) -> Result<()> {
        if joint.mimic.is_some() {
            return Err(Error::MimicJoint { file: self.file.clone(), joint: joint.name.clone() });
        }
        w.chain.x_tree.push(x_tree);
        w.chain.joints.push(self.joint(joint)?);
        w.chain.limits.push(limits(joint));
        w.chain.drive.push(match &joint.dynamics {
            Some(d) => DriveParams { fc: d.friction, fv: d.damping, ia: 0.0, tau0: 0.0, ..DriveParams::ZERO },
            None => DriveParams::ZERO,
        });
        w.chain.inertia.push(LinkInertia::ZERO);
        w.joint_names.push(joint.name.clone());
        w.link_names.push(joint.child.link.clone());
        Ok(())
    }

    /// Fuses every link below the base into its segment's inertia, off-chain links rigidly
    /// attached at q = 0 (as Pinocchio's `buildReducedModel`), except the subtree below
    /// `drop_below` (the links beyond a chosen tip), which is left out of the model.
    fn fuse_off_chain(&self, base: usize, drop_below: Option<usize>, w: &mut ChainWalk) -> Result<Fused> {
        let mut fused = Fused::default();
        let mut stack = vec![base];
        while let Some(l) = stack.pop() {
            let (seg_l, x_l) = w.segment[l].expect("visited links have a segment");
            if Some(l) == drop_below {
                fused.dropped = self.links_below(l);
            } else {
                self.attach_children(l, w, &mut fused)?;
                stack.extend(
                    self.child_joints[l].iter().map(|&j| self.link_index[self.urdf.joints[j].child.link.as_str()]),
                );
            }
            if let Some(k) = seg_l {
                let body = self.inertial(l)?;
                w.chain.inertia[k] = w.chain.inertia[k].add(&body.transformed(&x_l));
            }
        }
        Ok(fused)
    }

    /// Gives the off-chain children of `l` the segment of `l` (rigidly attached at q = 0); notes
    /// them (when in a model link) and their movable joints (locked) in `fused`.
    fn attach_children(&self, l: usize, w: &mut ChainWalk, fused: &mut Fused) -> Result<()> {
        let (seg_l, x_l) = w.segment[l].expect("visited links have a segment");
        for &j in &self.child_joints[l] {
            let joint = &self.urdf.joints[j];
            let child = self.link_index[joint.child.link.as_str()];
            if w.segment[child].is_some() {
                continue; // on the chain
            }
            match joint.joint_type {
                JointType::Fixed => {}
                JointType::Revolute | JointType::Continuous | JointType::Prismatic => {
                    fused.locked.push(joint.name.clone())
                }
                _ => return Err(self.unsupported(joint)),
            }
            w.segment[child] = Some((seg_l, x_l.compose(&pose(&joint.origin))));
            if let Some(k) = seg_l {
                fused.links.push((joint.child.link.clone(), w.link_names[k].clone()));
            }
        }
        Ok(())
    }

    /// The links of the subtree below `l` (not `l` itself), depth first in URDF order.
    fn links_below(&self, l: usize) -> Vec<String> {
        let mut out = vec![];
        let mut stack: Vec<usize> = self.child_joints[l].iter().rev().copied().collect();
        while let Some(j) = stack.pop() {
            let child = self.link_index[self.urdf.joints[j].child.link.as_str()];
            out.push(self.urdf.links[child].name.clone());
            stack.extend(self.child_joints[child].iter().rev());
        }
        out
    }

    /// The error for a floating, planar or spherical joint.
    fn unsupported(&self, joint: &urdf_rs::Joint) -> Error {
        Error::UnsupportedJoint {
            file: self.file.clone(),
            joint: joint.name.clone(),
            kind: type_name(&joint.joint_type).to_string(),
        }
    }

    fn joint(&self, joint: &urdf_rs::Joint) -> Result<Joint> {
        let a = Vec3::from(*joint.axis.xyz);
        let n = a.norm();
        if !(n.is_finite() && n > 1e-12) {
            return Err(Error::BadJoint {
                file: self.file.clone(),
                joint: joint.name.clone(),
                msg: format!("axis {:?} has zero or non-finite length", *joint.axis.xyz),
            });
        }
        let axis = a / n;
        Ok(match joint.joint_type {
            JointType::Prismatic => Joint::prismatic(axis),
            _ => Joint::revolute(axis),
        })
    }

    fn inertial(&self, l: usize) -> Result<LinkInertia> {
        let link = &self.urdf.links[l];
        let i = &link.inertial;
        let vals =
            [i.mass.value, i.inertia.ixx, i.inertia.ixy, i.inertia.ixz, i.inertia.iyy, i.inertia.iyz, i.inertia.izz];
        if vals.iter().any(|v| !v.is_finite()) || i.mass.value < 0.0 {
            return Err(self.structure(format!("link '{}': non-finite or negative inertial values", link.name)));
        }
        Ok(link_inertia(i))
    }
}

/// A URDF `<inertial>` (mass, origin, inertia about the COM in the rotated frame) as the
/// 10 standard parameters in the link frame (no checks).
pub fn link_inertia(i: &urdf_rs::Inertial) -> LinkInertia {
    let o = pose(&i.origin);
    let ic = Mat3::new(
        i.inertia.ixx,
        i.inertia.ixy,
        i.inertia.ixz,
        i.inertia.ixy,
        i.inertia.iyy,
        i.inertia.iyz,
        i.inertia.ixz,
        i.inertia.iyz,
        i.inertia.izz,
    );
    LinkInertia::from_mass_com_inertia(i.mass.value, &o.trans, &o.rot, &ic)
}

fn limits(joint: &urdf_rs::Joint) -> JointLimits {
    let l = &joint.limit;
    let or_inf = |v: f64| if v > 0.0 { v } else { f64::INFINITY };
    let (lower, upper) = match joint.joint_type {
        JointType::Continuous => (f64::NEG_INFINITY, f64::INFINITY),
        _ if l.lower < l.upper => (l.lower, l.upper),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    };
    JointLimits { lower, upper, velocity: or_inf(l.velocity), effort: or_inf(l.effort) }
}
