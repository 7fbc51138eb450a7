//! MJCF export: the robot as ivdyn models it (the chain base..tip, fixed links fused),
//! with its full parameters, as a MuJoCo model, and a JSON side file for what MJCF cannot
//! hold.
//!
//! * One `<body>` per model link, nested base to tip, placed by the joint's `x_tree`
//!   (`pos`, `quat` w x y z), so the body frame is ivdyn's link frame.
//! * `<inertial pos="COM" mass fullinertia="Ixx Iyy Izz Ixy Ixz Iyz">` (MuJoCo's order),
//!   inertia about the centre of mass in the link axes; `inertiafromgeom="false"`, so the
//!   visual capsules carry no mass.
//! * `<joint>` (`hinge` or `slide`, axis in the link frame) with `armature` (= `ia`),
//!   `damping` (= viscous `fv`: MuJoCo's passive force `-damping qd`) and `frictionloss`
//!   (= Coulomb `fc`: MuJoCo's friction constraint, bounded by it); `range` when the
//!   URDF has limits; a `<motor>` per joint (`ctrlrange` = effort limit).
//! * Gravity as the model's (base frame = MuJoCo's world).
//! * Torque offsets `tau0` have no MJCF field: they are in a comment and in the side file
//!   ([`SideFile`], the `--write-urdf` format). So is a Coulomb shape other than `sign`
//!   (MuJoCo's frictionloss is symmetric and saturates at once).
//! * A payload ([`PayloadSpec`], in the last link's frame) is a body `ivdyn_payload` without
//!   joint inside the last link's body (welded), COM and inertia as given.
//!
//! Nothing physically impossible is written: every link (and the payload) must have a
//! positive definite pseudo-inertia ([`check_link`]: mass > 0, inertia about the COM
//! positive definite, strict triangle inequalities) and every joint `fc, fv, ia >= 0`;
//! otherwise the error names the link or joint. Numbers are in shortest round-trip form.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use quick_xml::escape::escape;

use super::Robot;
use super::load::{SideFile, side_path};
use super::physical::{check_link, refuse_inconsistent, refused};
use super::write::{side_file, stage_side};
use crate::error::{Error, Result};
use crate::output::OutputSet;
use crate::report::PayloadSpec;
use ivdyn_core::params::{FC, FV, IA, LINK_PARAMS, TAU0, drive_col, link_col};
use ivdyn_core::{JointKind, LinkInertia, Transform};

/// The written MJCF text and its side file.
#[derive(Debug, Clone)]
pub struct Mjcf {
    /// MJCF (XML) text.
    pub xml: String,
    /// Side file (torque offsets, Coulomb shapes, payload, notes).
    pub side: SideFile,
}

/// Radius of the visual capsules between joint origins (m).
const CAPSULE_RADIUS: f64 = 0.02;

fn num(x: f64) -> String {
    // shortest round-trip representation (parsed exactly by MuJoCo's strtod)
    format!("{x:?}")
}

fn nums(v: &[f64]) -> String {
    v.iter().map(|x| num(*x)).collect::<Vec<_>>().join(" ")
}

/// Text safe inside an XML comment (no `--`, no trailing `-`).
fn comment_safe(s: &str) -> String {
    let mut t = s.replace("--", "- -");
    while t.contains("--") {
        t = t.replace("--", "- -");
    }
    if t.ends_with('-') {
        t.push(' ');
    }
    t
}

/// Mass, COM and inertia about the COM of 10 parameters, after the physical check;
/// `what` names the body in the error.
fn mass_com_inertia(p: &[f64], what: &str) -> Result<(f64, Vector3<f64>, Matrix3<f64>)> {
    let problems = check_link(p);
    if !problems.is_empty() {
        return Err(refusal(&[format!("{what}: {}", problems.join("; "))]));
    }
    let li = LinkInertia(p[..LINK_PARAMS].try_into().expect("10 parameters"));
    li.to_mass_com_inertia(0).map_err(|_| refusal(&[format!("{what}: mass {} kg is not positive", p[0])]))
}

fn refusal(lines: &[String]) -> Error {
    refused("MJCF", lines)
}

/// `<inertial>` of a body: COM, mass, inertia about the COM in MuJoCo's order.
fn inertial_xml(m: f64, c: &Vector3<f64>, ic: &Matrix3<f64>) -> String {
    format!(
        "<inertial pos=\"{}\" mass=\"{}\" fullinertia=\"{}\"/>",
        nums(c.as_slice()),
        num(m),
        nums(&[ic[(0, 0)], ic[(1, 1)], ic[(2, 2)], ic[(0, 1)], ic[(0, 2)], ic[(1, 2)]])
    )
}

/// `pos` and `quat` (w x y z) attributes of a placement.
fn placement(x: &Transform) -> String {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(x.rot));
    format!("pos=\"{}\" quat=\"{}\"", nums(x.trans.as_slice()), nums(&[q.w, q.i, q.j, q.k]))
}

/// `body` name of the payload: `ivdyn_payload`, or `ivdyn_payload_<k>` when a link has it.
fn payload_name(robot: &Robot) -> String {
    let mut name = "ivdyn_payload".to_string();
    let mut k = 2;
    while robot.link_names.contains(&name) {
        name = format!("ivdyn_payload_{k}");
        k += 1;
    }
    name
}

/// The MJCF of `robot` with its current parameters and an optional payload welded to the
/// last link; `notes` go into the side file (and the header comment). See the module docs.
pub fn to_mjcf(robot: &Robot, payload: Option<&PayloadSpec>, notes: Vec<String>) -> Result<Mjcf> {
    let theta = robot.params();
    refuse_inconsistent(robot, &theta, "MJCF")?;
    let payload_body = payload.map(|p| payload_xml(robot, p)).transpose()?;
    let mut notes = notes;
    notes.extend(drive_notes(robot, &theta));
    let chain = robot.model.to_chain();
    let n = robot.dof();
    let mut x = String::new();
    let e = |s: &str| escape(s).into_owned();
    let _ = writeln!(x, "<mujoco model=\"{}\">", e(&robot.name));
    let _ = writeln!(
        x,
        "  <!-- written by ivdyn: chain '{}' .. '{}' of robot '{}' (fixed links fused into their moving link)",
        comment_safe(&robot.base_link),
        comment_safe(&robot.tip_link),
        comment_safe(&robot.name)
    );
    for note in &notes {
        let _ = writeln!(x, "       {}", comment_safe(note));
    }
    let _ = writeln!(x, "  -->");
    let _ = writeln!(x, "  <compiler angle=\"radian\" autolimits=\"true\" inertiafromgeom=\"false\"/>");
    let _ = writeln!(x, "  <option gravity=\"{}\"/>", nums(chain.gravity.as_slice()));
    let _ = writeln!(
        x,
        "  <default>\n    <geom type=\"capsule\" contype=\"0\" conaffinity=\"0\" group=\"1\" size=\"{CAPSULE_RADIUS}\"/>\n  </default>"
    );
    let _ = writeln!(x, "  <worldbody>");
    for k in 0..n {
        body_open(&mut x, robot, &chain, &theta, k)?;
    }
    let ind = "  ".repeat(n + 2);
    let _ = writeln!(x, "{ind}<site name=\"{}\" {}/>", e(&robot.tip_link), placement(&chain.tool));
    if let Some(pb) = payload_body {
        let _ = writeln!(x, "{ind}{pb}");
    }
    for k in (0..n).rev() {
        let _ = writeln!(x, "{}</body>", "  ".repeat(k + 2));
    }
    let _ = writeln!(x, "  </worldbody>\n  <actuator>");
    for (j, name) in robot.joint_names.iter().enumerate() {
        let eff = chain.limits[j].effort;
        let range = if eff.is_finite() { format!(" ctrlrange=\"{} {}\"", num(-eff), num(eff)) } else { String::new() };
        let _ = writeln!(x, "    <motor name=\"{}\" joint=\"{}\"{range}/>", e(name), e(name));
    }
    let _ = writeln!(x, "  </actuator>\n</mujoco>");
    Ok(Mjcf { xml: x, side: side_file(robot, &theta, payload.copied(), notes) })
}

/// Opens link `k`'s body: placement, inertial, joint, visual capsule to the next joint.
fn body_open(x: &mut String, robot: &Robot, chain: &super::Chain, theta: &[f64], k: usize) -> Result<()> {
    let n = robot.dof();
    let ind = "  ".repeat(k + 2);
    let (link, joint) = (escape(&robot.link_names[k]), escape(&robot.joint_names[k]));
    let p = &theta[link_col(k, 0)..link_col(k, LINK_PARAMS)];
    let (m, c, ic) = mass_com_inertia(p, &format!("link '{}'", robot.link_names[k]))?;
    let _ = writeln!(x, "{ind}<body name=\"{link}\" {}>", placement(&chain.x_tree[k]));
    let _ = writeln!(x, "{ind}  {}", inertial_xml(m, &c, &ic));
    let j = &chain.joints[k];
    let kind = match j.kind {
        JointKind::Revolute => "hinge",
        JointKind::Prismatic => "slide",
    };
    let lim = &chain.limits[k];
    let range = if lim.lower.is_finite() && lim.upper.is_finite() {
        format!(" range=\"{} {}\"", num(lim.lower), num(lim.upper))
    } else {
        String::new()
    };
    let _ = writeln!(
        x,
        "{ind}  <joint name=\"{joint}\" type=\"{kind}\" axis=\"{}\"{range} armature=\"{}\" damping=\"{}\" frictionloss=\"{}\"/>",
        nums(j.axis.as_slice()),
        num(theta[drive_col(n, k, IA)]),
        num(theta[drive_col(n, k, FV)]),
        num(theta[drive_col(n, k, FC)])
    );
    // a capsule from this link's origin to the next joint's (or the tool frame), for viewing
    let to = if k + 1 < n { chain.x_tree[k + 1].trans } else { chain.tool.trans };
    if to.norm() > 1e-6 {
        let _ = writeln!(x, "{ind}  <geom name=\"{link}_visual\" fromto=\"0 0 0 {}\"/>", nums(to.as_slice()));
    }
    Ok(())
}

/// The payload's welded `<body>`, after the physical check.
fn payload_xml(robot: &Robot, p: &PayloadSpec) -> Result<String> {
    let li = p.link_inertia();
    let name = payload_name(robot);
    let (m, c, ic) = mass_com_inertia(&li.0, &format!("payload '{name}'"))?;
    Ok(format!("<body name=\"{}\">{}</body>", escape(&name), inertial_xml(m, &c, &ic)))
}

/// What the MJCF leaves out of the drive model, one note each: torque offsets, Coulomb
/// shapes other than `sign`.
fn drive_notes(robot: &Robot, theta: &[f64]) -> Vec<String> {
    let n = robot.dof();
    let tau0: Vec<f64> = (0..n).map(|j| theta[drive_col(n, j, TAU0)]).collect();
    let mut notes = vec![format!(
        "torque offsets tau0 (N m, joints base to tip; MJCF has no field for them, not in the model): {}",
        nums(&tau0)
    )];
    for (j, c) in robot.coulomb_shapes().iter().enumerate() {
        if !c.is_sign() {
            notes.push(format!(
                "joint '{}': ivdyn's Coulomb friction is shaped (velocity scale {} rad/s, asymmetry {}); MuJoCo's frictionloss is fc, symmetric and saturating at once",
                robot.joint_names[j], c.v_scale, c.asym
            ));
        }
    }
    notes
}

/// Stages `mj` for `path` (MJCF) and [`side_path`]`(path)` (JSON) in `set`.
pub fn stage_files(set: &mut OutputSet, path: &Path, mj: &Mjcf) -> Result<()> {
    set.write_bytes(path, mj.xml.as_bytes())?;
    stage_side(set, &side_path(path), &mj.side)
}

/// Writes `mj` to `path` and its side file, both or neither.
pub fn write_files(path: &Path, mj: &Mjcf) -> Result<()> {
    let mut set = OutputSet::new();
    stage_files(&mut set, path, mj)?;
    set.commit()
}
