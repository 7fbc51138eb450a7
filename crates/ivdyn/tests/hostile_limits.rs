//! Issue 16, hangs and memory: hostile inputs that used to overflow the stack, loop
//! forever or allocate gigabytes now end in an error naming what is wrong. Every input is
//! built here, small, so each test runs in well under a second when the limit holds.

use std::fmt::Write as _;
use std::path::Path;

use ivdyn::robot::urdf;

const FILE: &str = "hostile.urdf";

fn link(name: &str) -> String {
    format!(
        "<link name=\"{name}\"><inertial><mass value=\"1\"/><origin xyz=\"0 0 0.1\"/>\
         <inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
    )
}

fn joint(name: &str, kind: &str, parent: &str, child: &str) -> String {
    format!(
        "<joint name=\"{name}\" type=\"{kind}\"><parent link=\"{parent}\"/><child link=\"{child}\"/>\
         <origin xyz=\"0 0 0.2\"/><axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"2\"/></joint>\n"
    )
}

fn robot(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<robot name=\"hostile\">\n{body}</robot>\n")
}

fn load(text: &str, base: Option<&str>, tip: Option<&str>) -> String {
    match urdf::load_str(text, Path::new(FILE), base, tip) {
        Ok(r) => panic!("loaded a robot with {} joints from a hostile URDF", r.dof()),
        Err(e) => e.to_string(),
    }
}

/// world -> a -> b -> c, plus `c -> a`... `a` cannot have two parents, so the loop is
/// closed without a second parent: root `w`, a -> b -> c -> a with `a` not under `w`.
#[test]
fn urdf_loop_with_tip_inside_is_an_error_naming_the_links() {
    let mut body = String::new();
    for l in ["w", "a", "b", "c"] {
        body += &link(l);
    }
    body += &joint("j_wx", "revolute", "w", "x");
    body += &link("x");
    body += &joint("j_ab", "revolute", "a", "b");
    body += &joint("j_bc", "revolute", "b", "c");
    body += &joint("j_ca", "revolute", "c", "a");
    let text = robot(&body);
    for (base, tip) in [(None, Some("b")), (Some("a"), Some("c")), (Some("b"), None), (None, None)] {
        let msg = load(&text, base, tip);
        assert!(msg.contains(FILE), "{msg}");
        assert!(msg.contains("loop") && msg.contains("'a'") && msg.contains("'b'") && msg.contains("'c'"), "{msg}");
    }
}

#[test]
fn urdf_self_loop_is_an_error_naming_the_link() {
    // a side link looping on itself, then the root itself looping (no root left)
    let side = link("base") + &link("arm") + &link("tool") + &joint("j1", "revolute", "base", "arm");
    let side = side + &joint("j_self", "fixed", "tool", "tool");
    for (base, tip) in [(None, None), (None, Some("arm")), (Some("tool"), None), (None, Some("tool"))] {
        let msg = load(&robot(&side), base, tip);
        assert!(msg.contains("loop: 'tool' -> 'tool'"), "{msg}");
    }
    let root = link("base") + &link("arm") + &joint("j1", "revolute", "base", "arm");
    let root = root + &joint("j_self", "revolute", "base", "base");
    let msg = load(&robot(&root), None, None);
    assert!(msg.contains("loop: 'base' -> 'base'"), "{msg}");
}

/// A chain of 100,000 movable joints: more than the model's MAX_DOF, refused before any
/// deep walk (it used to overflow the stack in the default-tip search).
#[test]
fn urdf_long_chain_is_refused_without_overflow() {
    let n = 100_000;
    let mut body = String::with_capacity(n * 400);
    body += &link("l0");
    for k in 1..=n {
        let _ = write!(body, "<link name=\"l{k}\"/>\n");
        body += &joint(&format!("j{k}"), "revolute", &format!("l{}", k - 1), &format!("l{k}"));
    }
    let msg = load(&robot(&body), None, None);
    assert!(msg.contains("100000") && msg.contains("12"), "{msg}");
}

/// 30,000 nested elements used to overflow inside urdf-rs's XML parser; refused by the
/// depth pre-scan, naming the file.
#[test]
fn urdf_deep_xml_nesting_is_refused() {
    let depth = 30_000;
    let body = link("base") + &"<extra>".repeat(depth) + &"</extra>".repeat(depth);
    let msg = load(&robot(&body), None, None);
    assert!(msg.contains(FILE) && msg.contains("nest"), "{msg}");
}

/// Normal nesting (comments, CDATA, quoted `>` and `/>` in attributes) stays accepted.
#[test]
fn urdf_depth_scan_accepts_ordinary_files() {
    let body = link("base")
        + "<!-- a <comment> with <tags -->\n<![CDATA[ <not> <xml ]]>\n"
        + &link("arm").replace("<link name=\"arm\">", "<link name=\"arm\" note=\"a > b /> c\">")
        + &joint("j1", "revolute", "base", "arm");
    let r = urdf::load_str(&robot(&body), Path::new(FILE), None, None).unwrap();
    assert_eq!(r.dof(), 1);
}
