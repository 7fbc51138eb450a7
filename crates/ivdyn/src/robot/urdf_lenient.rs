//! What urdfdom, ROS's URDF parser, reads and urdf-rs refuses: the text fixed up so that
//! urdf-rs reads it as urdfdom would (`urdf::load_str_with` tries these only after a plain
//! parse fails).
//!
//! - A joint with several `<origin>` elements (hand-edited xacro output): urdfdom reads the
//!   first one.
//! - Appearance urdf-rs is stricter about than urdfdom, e.g. `<texture />` without a file
//!   name (exported by CAD plug-ins; urdfdom takes it as "no texture"): `<visual>`,
//!   `<collision>` and `<material>` carry no dynamics, so they are dropped.

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
}
