//! What urdfdom, ROS's URDF parser, reads and urdf-rs refuses: the text fixed up so that
//! urdf-rs reads it as urdfdom would (`urdf::load_str_with` tries these only after a plain
//! parse fails).
//!
//! - A joint with several `<origin>` elements (hand-edited xacro output): urdfdom reads the
//!   first one.
//! - Appearance urdf-rs is stricter about than urdfdom, e.g. `<texture />` without a file
//!   name (exported by CAD plug-ins; urdfdom takes it as "no texture"): `<visual>`,
//!   `<collision>` and `<material>` carry no dynamics, so they are dropped.
//!
//! When the file is refused all the same, urdf-rs says which attribute is missing but not
//! where: [`locate_missing`] finds the element, its link or joint and its line.

use quick_xml::Reader;
use quick_xml::events::Event;

/// Drops every `<origin .../>` after the first inside each `<joint>...</joint>`
/// (urdfdom's reading of duplicated joint origins).
pub fn first_joint_origin_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(js) = rest.find("<joint") {
        out.push_str(&rest[..js]);
        let Some(je) = rest[js..].find("</joint>").map(|e| js + e + "</joint>".len()) else {
            rest = &rest[js..];
            break;
        };
        let joint = &rest[js..je];
        let mut seen = false;
        let mut jr = joint;
        while let Some(os) = jr.find("<origin") {
            let oe = jr[os..].find("/>").map(|e| os + e + 2).unwrap_or(jr.len());
            out.push_str(&jr[..os]);
            if !seen {
                out.push_str(&jr[os..oe]);
                seen = true;
            }
            jr = &jr[oe..];
        }
        out.push_str(jr);
        rest = &rest[je..];
    }
    out.push_str(rest);
    out
}

/// Elements that carry no dynamics: the shapes drawn and collided, and their colours.
const APPEARANCE: [&[u8]; 3] = [b"visual", b"collision", b"material"];

/// `text` without its `<visual>`, `<collision>` and `<material>` elements (at any depth);
/// `None` when the text is not well-formed XML (the parse error then stands).
pub fn without_appearance(text: &str) -> Option<String> {
    let mut r = Reader::from_str(text);
    let mut out = String::with_capacity(text.len());
    let (mut kept_to, mut depth, mut skip_from) = (0usize, 0usize, None::<(usize, usize)>);
    loop {
        let before = r.buffer_position() as usize;
        let ev = r.read_event().ok()?;
        let after = r.buffer_position() as usize;
        match ev {
            Event::Start(e) => {
                depth += 1;
                if skip_from.is_none() && APPEARANCE.contains(&e.local_name().as_ref()) {
                    skip_from = Some((before, depth));
                }
            }
            Event::End(_) => {
                if let Some((from, _)) = skip_from.filter(|s| s.1 == depth) {
                    out.push_str(&text[kept_to..from]);
                    kept_to = after;
                    skip_from = None;
                }
                depth = depth.checked_sub(1)?;
            }
            Event::Empty(e) if skip_from.is_none() && APPEARANCE.contains(&e.local_name().as_ref()) => {
                out.push_str(&text[kept_to..before]);
                kept_to = after;
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if skip_from.is_some() {
        return None;
    }
    out.push_str(&text[kept_to..]);
    Some(out)
}

/// The URDF elements that must carry attribute `attr` (the URDF specification's required
/// attributes urdf-rs names in its "missing field" message).
fn elements_requiring(attr: &str) -> &'static [&'static [u8]] {
    match attr {
        "ixx" | "ixy" | "ixz" | "iyy" | "iyz" | "izz" => &[b"inertia"],
        "value" => &[b"mass"],
        "effort" | "velocity" => &[b"limit"],
        "link" => &[b"parent", b"child"],
        "filename" => &[b"mesh", b"texture"],
        "size" => &[b"box"],
        "radius" => &[b"cylinder", b"sphere"],
        "length" => &[b"cylinder"],
        "name" => &[b"link", b"joint"],
        "type" => &[b"joint"],
        _ => &[],
    }
}

/// Where the first element lacking the required attribute `attr` is: "`<inertia>` of link
/// 'link3' (line 24)"; `None` when none lacks it or the text is not well-formed.
pub fn locate_missing(text: &str, attr: &str) -> Option<String> {
    let tags = elements_requiring(attr);
    let mut r = Reader::from_str(text);
    let mut depth = 0usize;
    let mut owner: Option<(String, String)> = None; // (link|joint, name) at depth 2
    loop {
        let at = r.buffer_position() as usize;
        let (e, empty) = match r.read_event().ok()? {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                depth = depth.checked_sub(1)?;
                continue;
            }
            Event::Eof => return None,
            _ => continue,
        };
        let tag = e.local_name().as_ref().to_vec();
        let level = depth + 1;
        let name = e.try_get_attribute("name").ok()?.map(|a| String::from_utf8_lossy(&a.value).into_owned());
        if level == 2 {
            owner = Some((String::from_utf8_lossy(&tag).into_owned(), name.clone().unwrap_or_default()));
        }
        if tags.contains(&tag.as_slice()) && e.try_get_attribute(attr).ok()?.is_none() {
            let line = text[..at].matches('\n').count() + 1;
            let within = match &owner {
                Some((kind, n)) if level > 2 => format!(" of {kind} '{n}'"),
                _ => String::new(),
            };
            return Some(format!("`<{}>`{within} (line {line})", String::from_utf8_lossy(&tag)));
        }
        if !empty {
            depth += 1;
        }
    }
}

/// The urdf-rs message `msg`, with where the missing attribute it names is in `text`.
pub fn with_location(msg: String, text: &str) -> String {
    let attr = msg.split("missing field `").nth(1).and_then(|r| r.split('`').next());
    match attr.and_then(|a| locate_missing(text, a).map(|w| (a, w))) {
        Some((a, w)) => format!("{msg}: {w} has no `{a}` attribute"),
        None => msg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_first_origin_of_joints_only() {
        let s = r#"<link name="a"><visual><origin xyz="1 0 0"/><origin xyz="2 0 0"/></visual></link><joint name="j" type="fixed"><origin xyz="0 0 1"/><origin xyz="0 0 0"/><parent link="a"/></joint>"#;
        let want = r#"<link name="a"><visual><origin xyz="1 0 0"/><origin xyz="2 0 0"/></visual></link><joint name="j" type="fixed"><origin xyz="0 0 1"/><parent link="a"/></joint>"#;
        assert_eq!(first_joint_origin_only(s), want);
    }

    #[test]
    fn drops_visual_collision_and_material_only() {
        let s = r#"<robot name="r"><material name="m"><texture /></material><link name="a"><inertial><mass value="1"/></inertial><visual><geometry><box size="1 1 1"/></geometry><material name="x"><texture/></material></visual><collision/></link><joint name="j" type="fixed"><parent link="a"/></joint></robot>"#;
        let want = r#"<robot name="r"><link name="a"><inertial><mass value="1"/></inertial></link><joint name="j" type="fixed"><parent link="a"/></joint></robot>"#;
        assert_eq!(without_appearance(s).as_deref(), Some(want));
        assert_eq!(without_appearance("<robot><visual></robot>"), None);
    }

    #[test]
    fn a_missing_attribute_is_located() {
        let s = "<robot name=\"r\">\n<link name=\"a\"><inertial><mass value=\"1\"/>\n<inertia ixx=\"1\" iyy=\"1\"/></inertial></link>\n<joint name=\"j\" type=\"revolute\"><limit lower=\"0\"/></joint></robot>";
        assert_eq!(locate_missing(s, "ixy").as_deref(), Some("`<inertia>` of link 'a' (line 3)"));
        assert_eq!(locate_missing(s, "velocity").as_deref(), Some("`<limit>` of joint 'j' (line 4)"));
        assert_eq!(locate_missing(s, "value"), None);
        let m = with_location("custom: missing field `ixy`".into(), s);
        assert_eq!(m, "custom: missing field `ixy`: `<inertia>` of link 'a' (line 3) has no `ixy` attribute");
    }
}
