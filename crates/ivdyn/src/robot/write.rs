//! URDF write-back: a copy of the input URDF *text* with identified `<inertial>` blocks
//! and `<dynamics>` of the chain, an optional payload, and a JSON side file for what URDF
//! cannot hold. Everything else (visuals, collisions, transmissions, gazebo tags, comments,
//! formatting) is kept byte for byte: the XML is scanned with quick-xml for the byte ranges
//! of the elements to replace, and only those ranges are rewritten.
//!
//! * Chain link `k` (the child link of movable joint `k`) gets an `<inertial>` with the
//!   mass, the centre of mass as `<origin xyz>` (`rpy="0 0 0"`) and the inertia about the
//!   centre of mass (URDF attribute order `ixx ixy ixz iyy iyz izz`). The model's link `k`
//!   also contains the links fused into it (fixed children, locked side branches); those
//!   keep their nominal `<inertial>`, and link `k` gets the identified segment total minus
//!   their nominal sum, so that loading the file gives back the identified parameters.
//! * Movable chain joints get `<dynamics damping="fv" friction="fc"/>`.
//! * Armature `ia` and torque offset `tau0` have no URDF element: they go in the side file
//!   `OUT.urdf.json` ([`SideFile`]), which [`Robot::apply_side_file`] (and the command line,
//!   when the file sits next to the URDF) applies after loading.
//! * A payload is either a new link `ivdyn_payload` on a fixed joint to the last chain link
//!   (identity origin, as the payload's COM and inertia are in that link's frame), or merged
//!   into the last chain link's `<inertial>`.
//!
//! Numbers are written in Rust's shortest round-trip form, so reloading reproduces the
//! parameters to rounding of the COM conversion (~1e-16 relative).

use std::path::Path;

use nalgebra::{Matrix3, Vector3};
use quick_xml::Reader;
use quick_xml::events::Event;
use serde::Serialize;

use super::Robot;
use crate::error::{Error, Result};
use crate::report::CoulombShapeFile;
use crate::report::PayloadSpec;
use crate::robot::load::{SIDE_FORMAT, SideFile, side_path};
use crate::robot::physical::check_link;
use ivdyn_core::LinkInertia;
use ivdyn_core::params::{FC, FV, IA, LINK_PARAMS, TAU0, drive_col, link_col};

/// How a payload is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PayloadMode {
    /// A new link `ivdyn_payload` on a fixed joint to the last chain link.
    Link,
    /// Added to the last chain link's `<inertial>`.
    Merge,
}

/// The written URDF text and its side file.
#[derive(Debug, Clone)]
pub struct WriteBack {
    /// URDF text.
    pub urdf: String,
    /// Side file.
    pub side: SideFile,
}

fn num(x: f64) -> String {
    // shortest round-trip representation; integers keep a ".0" (valid in URDF)
    format!("{x:?}")
}

/// `<inertial>` element text for 10 parameters about the link origin.
fn inertial_xml(p: &[f64], indent: &str, link: &str) -> Result<String> {
    let (m, c, ic) = if p.iter().all(|v| *v == 0.0) {
        (0.0, Vector3::zeros(), Matrix3::zeros())
    } else {
        LinkInertia([p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9]])
            .to_mass_com_inertia(0)
            .map_err(|_| Error::PhysicallyInconsistent {
                what: "URDF write-back".into(),
                problems: format!("link '{link}' would get mass {} kg, which URDF cannot express (use consistent parameters: identify --consistent)", p[0]),
            })?
    };
    let i2 = format!("{indent}  ");
    Ok(format!(
        "<inertial>\n{i2}<origin xyz=\"{} {} {}\" rpy=\"0 0 0\" />\n{i2}<mass value=\"{}\" />\n{i2}<inertia ixx=\"{}\" ixy=\"{}\" ixz=\"{}\" iyy=\"{}\" iyz=\"{}\" izz=\"{}\" />\n{indent}</inertial>",
        num(c.x),
        num(c.y),
        num(c.z),
        num(m),
        num(ic[(0, 0)]),
        num(ic[(0, 1)]),
        num(ic[(0, 2)]),
        num(ic[(1, 1)]),
        num(ic[(1, 2)]),
        num(ic[(2, 2)])
    ))
}

/// A link found in the text: name, end of the start tag (start of `<link/>`), start of
/// `</link>` (end of `<link/>`), range of its `<inertial>`, whether it is `<link/>`.
type LinkSpan = (String, usize, usize, Option<(usize, usize)>, bool);
/// A joint: name, end of the start tag, start of `</joint>`, range of its `<dynamics>`.
type JointSpan = (String, usize, usize, Option<(usize, usize)>);

/// Byte ranges found in the URDF text.
#[derive(Default)]
struct Scan {
    links: Vec<LinkSpan>,
    joints: Vec<JointSpan>,
    robot_end: Option<usize>,
    link_names: Vec<String>,
    joint_names: Vec<String>,
}

fn xml_err(file: &Path, e: impl std::fmt::Display) -> Error {
    Error::UrdfParse { file: file.to_path_buf(), msg: e.to_string() }
}

fn name_attr(e: &quick_xml::events::BytesStart, file: &Path) -> Result<String> {
    match e.try_get_attribute("name").map_err(|x| xml_err(file, x))? {
        Some(a) => Ok(a.unescape_value().map_err(|x| xml_err(file, x))?.into_owned()),
        None => Ok(String::new()),
    }
}

fn scan(text: &str, file: &Path) -> Result<Scan> {
    let mut r = Reader::from_str(text);
    let mut sc = Scan::default();
    let mut depth = 0usize;
    // current top-level element: ("link"|"joint", name, start, header end)
    let mut cur: Option<(String, String, usize, usize)> = None;
    let mut child: Option<(usize, usize)> = None; // inertial or dynamics range in the current element
    let mut child_start = 0usize;
    loop {
        let before = r.buffer_position() as usize;
        let ev = r.read_event().map_err(|e| xml_err(file, format!("XML error at byte {}: {e}", r.error_position())))?;
        let after = r.buffer_position() as usize;
        match ev {
            Event::Start(e) => {
                depth += 1;
                let tag = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                if depth == 2 && (tag == "link" || tag == "joint") {
                    cur = Some((tag, name_attr(&e, file)?, before, after));
                    child = None;
                } else if depth == 3 && cur.is_some() {
                    let want = if cur.as_ref().map(|c| c.0.as_str()) == Some("link") { "inertial" } else { "dynamics" };
                    if tag == want {
                        child_start = before;
                    }
                }
            }
            Event::Empty(e) => {
                let tag = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                if depth == 1 && tag == "link" {
                    let name = name_attr(&e, file)?;
                    sc.link_names.push(name.clone());
                    sc.links.push((name, before, after, None, true));
                } else if depth == 2
                    && let Some(c) = &cur
                    && tag == if c.0 == "link" { "inertial" } else { "dynamics" }
                {
                    child = Some((before, after));
                }
            }
            Event::End(e) => {
                let tag = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                if depth == 3 && cur.is_some() {
                    let want = if cur.as_ref().map(|c| c.0.as_str()) == Some("link") { "inertial" } else { "dynamics" };
                    if tag == want {
                        child = Some((child_start, after));
                    }
                }
                if depth == 2
                    && let Some((kind, name, _start, head)) = cur.take()
                {
                    if kind == "link" {
                        sc.link_names.push(name.clone());
                        sc.links.push((name, head, before, child, false));
                    } else {
                        sc.joint_names.push(name.clone());
                        sc.joints.push((name, head, before, child));
                    }
                }
                if depth == 1 && tag == "robot" {
                    sc.robot_end = Some(before);
                }
                depth = depth.saturating_sub(1);
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if sc.robot_end.is_none() {
        return Err(xml_err(file, "no </robot> closing tag"));
    }
    Ok(sc)
}

/// Indentation (spaces/tabs) of the line containing byte `pos`.
fn indent_at(text: &str, pos: usize) -> String {
    let line_start = text[..pos].rfind('\n').map(|i| i + 1).unwrap_or(0);
    text[line_start..].chars().take_while(|c| *c == ' ' || *c == '\t').collect()
}

/// A text edit: replace bytes `start..end` of the input with the string.
type Edit = (usize, usize, String);

/// Writes back `theta` (full parameters of `robot`, `None`: leave the arm as it is) and an
/// optional payload into the URDF text `input` (the file `robot` was loaded from; `file`
/// names it in errors). See the module docs.
pub fn write_back(
    input: &str,
    file: &Path,
    robot: &Robot,
    theta: Option<&[f64]>,
    payload: Option<(&PayloadSpec, PayloadMode)>,
    notes: Vec<String>,
) -> Result<WriteBack> {
    let n = robot.dof();
    // the same chain as `robot`: its bodies below the tip fused unless it dropped some
    let opts = crate::robot::urdf::UrdfOptions {
        base: Some(robot.base_link.clone()),
        tip: Some(robot.tip_link.clone()),
        fuse_beyond_tip: robot.dropped_links.is_empty(),
    };
    let nominal = crate::robot::urdf::load_str_with(input, file, &opts)?;
    if nominal.joint_names != robot.joint_names {
        return Err(xml_err(
            file,
            format!("the URDF's chain {:?} is not the robot's {:?}", nominal.joint_names, robot.joint_names),
        ));
    }
    let urdf = urdf_rs::read_from_string(input).map_err(|e| xml_err(file, e))?;
    let nom_theta = nominal.params();
    let theta = theta_or_nominal(robot, theta, &nom_theta)?;
    let mut notes = notes;
    let mut own = own_shares(&urdf, file, robot, &theta, &nom_theta)?;
    let mut extra = String::new();
    if let Some((p, mode)) = payload {
        extra = add_payload(p, mode, &urdf, robot, &mut own[n - 1], &mut notes)?;
    }
    note_inconsistent_own(robot, &theta, &own, &mut notes);

    let sc = scan(input, file)?;
    let arm_changed = theta != nom_theta;
    let write_arm = arm_changed || payload.is_some_and(|(_, m)| m == PayloadMode::Merge);
    let mut edits = inertial_edits(input, file, &sc, robot, &own, write_arm, arm_changed)?;
    if arm_changed {
        edits.extend(dynamics_edits(input, file, &sc, robot, &theta)?);
    }
    if !extra.is_empty() {
        let pos = sc.robot_end.expect("checked in scan");
        let line_start = input[..pos].rfind('\n').map(|i| i + 1).unwrap_or(pos);
        edits.push((line_start, line_start, extra));
    }
    Ok(WriteBack { urdf: apply_edits(input, edits), side: side_file(robot, &theta, payload.map(|(p, _)| *p), notes) })
}

/// `theta` checked against the robot's parameter count, or the nominal parameters when
/// none is given (leave the arm as it is).
fn theta_or_nominal(robot: &Robot, theta: Option<&[f64]>, nom_theta: &[f64]) -> Result<Vec<f64>> {
    match theta {
        Some(t) if t.len() == robot.num_params() => Ok(t.to_vec()),
        Some(t) => {
            Err(Error::Dimension { what: "theta (full parameters)".into(), expected: robot.num_params(), got: t.len() })
        }
        None => Ok(nom_theta.to_vec()),
    }
}

/// Own share of each chain link: identified total minus the nominal of the links fused into
/// it (those keep their nominal `<inertial>`, so reloading gives back `theta`).
fn own_shares(
    urdf: &urdf_rs::Robot,
    file: &Path,
    robot: &Robot,
    theta: &[f64],
    nom_theta: &[f64],
) -> Result<Vec<[f64; LINK_PARAMS]>> {
    let mut own: Vec<[f64; LINK_PARAMS]> = vec![[0.0; LINK_PARAMS]; robot.dof()];
    for k in 0..robot.dof() {
        let l = urdf
            .links
            .iter()
            .find(|l| l.name == robot.link_names[k])
            .ok_or_else(|| xml_err(file, format!("no link '{}'", robot.link_names[k])))?;
        let own_nom = crate::robot::urdf::link_inertia(&l.inertial).0;
        for c in 0..LINK_PARAMS {
            let others = nom_theta[link_col(k, c)] - own_nom[c];
            own[k][c] = theta[link_col(k, c)] - others;
        }
    }
    Ok(own)
}

/// Adds the payload `p`: merged into the last link's own share `own_last`, or as the text
/// of a new link on a fixed joint (returned, to insert before `</robot>`; empty when
/// merged). Says which in `notes`.
fn add_payload(
    p: &PayloadSpec,
    mode: PayloadMode,
    urdf: &urdf_rs::Robot,
    robot: &Robot,
    own_last: &mut [f64; LINK_PARAMS],
    notes: &mut Vec<String>,
) -> Result<String> {
    let last = &robot.link_names[robot.dof() - 1];
    let li = p.link_inertia();
    match mode {
        PayloadMode::Merge => {
            for (o, v) in own_last.iter_mut().zip(li.0) {
                *o += v;
            }
            notes.push(format!("payload {} kg merged into link '{last}'", p.mass));
            Ok(String::new())
        }
        PayloadMode::Link => {
            let name = payload_link_name(urdf);
            let inertial = inertial_xml(&li.0, "    ", &name)?;
            let extra = format!(
                "  <!-- payload identified by ivdyn: COM and inertia in the frame of '{parent}' -->\n  <link name=\"{name}\">\n    {inertial}\n  </link>\n  <joint name=\"{name}_joint\" type=\"fixed\">\n    <parent link=\"{parent}\" />\n    <child link=\"{name}\" />\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0\" />\n  </joint>\n",
                parent = last
            );
            notes.push(format!("payload {} kg written as link '{name}' on a fixed joint to '{last}'", p.mass));
            Ok(extra)
        }
    }
}

/// `ivdyn_payload`, or `ivdyn_payload_<k>` for the first `k >= 2` whose link and
/// `_joint` names are both free in the URDF.
fn payload_link_name(urdf: &urdf_rs::Robot) -> String {
    let taken = |s: &str| urdf.links.iter().any(|l| l.name == s) || urdf.joints.iter().any(|j| j.name == s);
    let mut name = "ivdyn_payload".to_string();
    let mut k = 2;
    while taken(&name) || taken(&format!("{name}_joint")) {
        name = format!("ivdyn_payload_{k}");
        k += 1;
    }
    name
}

/// Notes each link whose own share is less consistent than the segment total: only the sum
/// with the fused links' nominal inertials is what the data identify.
fn note_inconsistent_own(robot: &Robot, theta: &[f64], own: &[[f64; LINK_PARAMS]], notes: &mut Vec<String>) {
    for (k, own_k) in own.iter().enumerate() {
        let total = &theta[link_col(k, 0)..link_col(k, LINK_PARAMS)];
        if check_link(own_k).len() > check_link(total).len() && !own_k.iter().all(|v| *v == 0.0) {
            notes.push(format!(
                "link '{}': its own <inertial> is not physically consistent on its own (the links fused into it keep their nominal inertials); their sum is what the data identify",
                robot.link_names[k]
            ));
        }
    }
}

/// The `<inertial>` edits of the chain links: every link when the arm changed (`arm_changed`),
/// else only the last one (a merged payload), nothing unless `write_arm`. An empty `<link/>`
/// is expanded, an existing `<inertial>` replaced, a missing one inserted after the start tag.
fn inertial_edits(
    input: &str,
    file: &Path,
    sc: &Scan,
    robot: &Robot,
    own: &[[f64; LINK_PARAMS]],
    write_arm: bool,
    arm_changed: bool,
) -> Result<Vec<Edit>> {
    let n = robot.dof();
    let mut edits = vec![];
    for (k, own_k) in own.iter().enumerate() {
        let touch = write_arm && (arm_changed || k == n - 1);
        if !touch {
            continue;
        }
        let name = &robot.link_names[k];
        let (_, head, end, inertial, empty) = sc
            .links
            .iter()
            .find(|l| &l.0 == name)
            .ok_or_else(|| xml_err(file, format!("no <link name=\"{name}\"> element")))?;
        if *empty {
            let ind = indent_at(input, *head);
            let body = inertial_xml(own_k, &format!("{ind}  "), name)?;
            edits.push((*head, *end, format!("<link name=\"{name}\">\n{ind}  {body}\n{ind}</link>")));
        } else if let Some((s, e)) = inertial {
            let ind = indent_at(input, *s);
            edits.push((*s, *e, inertial_xml(own_k, &ind, name)?));
        } else {
            let ind = format!("{}  ", indent_at(input, *end));
            edits.push((*head, *head, format!("\n{ind}{}", inertial_xml(own_k, &ind, name)?)));
        }
    }
    Ok(edits)
}

/// The `<dynamics damping="fv" friction="fc"/>` edits of the movable chain joints: an
/// existing element replaced, a missing one inserted on its own line before `</joint>`.
fn dynamics_edits(input: &str, file: &Path, sc: &Scan, robot: &Robot, theta: &[f64]) -> Result<Vec<Edit>> {
    let n = robot.dof();
    let mut edits = vec![];
    for j in 0..n {
        let name = &robot.joint_names[j];
        let (_, _head, end, dynamics) = sc
            .joints
            .iter()
            .find(|x| &x.0 == name)
            .ok_or_else(|| xml_err(file, format!("no <joint name=\"{name}\"> element")))?;
        let dyn_xml = format!(
            "<dynamics damping=\"{}\" friction=\"{}\" />",
            num(theta[drive_col(n, j, FV)]),
            num(theta[drive_col(n, j, FC)])
        );
        match dynamics {
            Some((s, e)) => edits.push((*s, *e, dyn_xml)),
            None => {
                let ind = format!("{}  ", indent_at(input, *end));
                // insert before the line of </joint>
                let line_start = input[..*end].rfind('\n').map(|i| i + 1).unwrap_or(*end);
                edits.push((line_start, line_start, format!("{ind}{dyn_xml}\n")));
            }
        }
    }
    Ok(edits)
}

/// `input` with the edits applied back to front (so earlier byte offsets stay valid).
fn apply_edits(input: &str, mut edits: Vec<Edit>) -> String {
    edits.sort_by_key(|e| std::cmp::Reverse(e.0));
    let mut out = input.to_string();
    for (s, e, t) in edits {
        out.replace_range(s..e, &t);
    }
    out
}

/// The side file: what URDF cannot hold (armature, torque offset), the drive friction
/// again, the payload and the notes (also written next to an MJCF, [`super::mjcf`]).
pub(crate) fn side_file(robot: &Robot, theta: &[f64], payload: Option<PayloadSpec>, notes: Vec<String>) -> SideFile {
    let n = robot.dof();
    let col = |k: usize| (0..n).map(|j| theta[drive_col(n, j, k)]).collect::<Vec<f64>>();
    SideFile {
        format: SIDE_FORMAT.into(),
        robot: robot.name.clone(),
        base_link: robot.base_link.clone(),
        tip_link: robot.tip_link.clone(),
        joints: robot.joint_names.clone(),
        armature: col(IA),
        tau0: col(TAU0),
        friction: col(FC),
        damping: col(FV),
        payload,
        coulomb: robot.coulomb_shapes().iter().any(|c| !c.is_sign()).then(|| {
            robot.coulomb_shapes().iter().map(|c| CoulombShapeFile { v_scale: c.v_scale, asym: c.asym }).collect()
        }),
        notes,
    }
}

/// Writes `wb` to `path` (URDF) and [`side_path`]`(path)` (JSON), both or neither.
pub fn write_files(path: &Path, wb: &WriteBack) -> Result<()> {
    let mut set = crate::output::OutputSet::new();
    stage_files(&mut set, path, wb)?;
    set.commit()
}

/// [`write_files`] into `set` (put in place when `set` is committed).
pub fn stage_files(set: &mut crate::output::OutputSet, path: &Path, wb: &WriteBack) -> Result<()> {
    set.write_bytes(path, wb.urdf.as_bytes())?;
    stage_side(set, &side_path(path), &wb.side)
}

/// Stages the side file `side` as JSON at `path` in `set`.
pub(crate) fn stage_side(set: &mut crate::output::OutputSet, path: &Path, side: &SideFile) -> Result<()> {
    let text =
        serde_json::to_string_pretty(side).map_err(|e| Error::internal(format!("side file as JSON: {e}")))? + "\n";
    set.write_bytes(path, text.as_bytes())
}
