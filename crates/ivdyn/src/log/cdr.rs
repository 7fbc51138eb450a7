//! Hand-written CDR (XCDR1, as ROS 2 / Fast DDS write it) for `sensor_msgs/msg/JointState`.
//!
//! Layout: a 4-byte encapsulation header (`00 01 00 00` little endian, `00 00 00 00` big
//! endian; the last two bytes are options and ignored), then the fields, each aligned to its
//! own size counted from the byte *after* the header:
//! `header.stamp.sec: i32, header.stamp.nanosec: u32, header.frame_id: string,
//! name: string[], position/velocity/effort: f64[]`. A string is a `u32` length that
//! includes the NUL terminator, the bytes, then the NUL; a sequence is a `u32` count then
//! the elements. Every count is checked against the bytes left, so a corrupt message cannot
//! make us allocate more than the message size.

/// A decoded `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointState {
    /// `header.stamp.sec`.
    pub sec: i32,
    /// `header.stamp.nanosec`.
    pub nanosec: u32,
    /// `header.frame_id`.
    pub frame_id: String,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad or m).
    pub position: Vec<f64>,
    /// Velocities (may be empty).
    pub velocity: Vec<f64>,
    /// Efforts (may be empty).
    pub effort: Vec<f64>,
}

impl JointState {
    /// The header stamp in nanoseconds (i64 arithmetic: `sec` may be negative).
    pub fn stamp_ns(&self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
}

struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    le: bool,
}

impl<'a> Cursor<'a> {
    fn align(&mut self, n: usize) -> Result<(), String> {
        // alignment is relative to the byte after the 4-byte header
        let rel = self.pos - 4;
        let pad = (n - rel % n) % n;
        self.take(pad).map(|_| ())
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if self.buf.len() - self.pos < n {
            return Err(format!(
                "CDR message ends early: need {n} bytes at offset {}, message has {}",
                self.pos,
                self.buf.len()
            ));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, String> {
        self.align(4)?;
        let b: [u8; 4] = self.take(4)?.try_into().unwrap();
        Ok(if self.le { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) })
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.align(8)?;
        let b: [u8; 8] = self.take(8)?.try_into().unwrap();
        Ok(if self.le { f64::from_le_bytes(b) } else { f64::from_be_bytes(b) })
    }
    fn count(&mut self, what: &str, min_elem: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        let left = self.buf.len() - self.pos;
        if n.saturating_mul(min_elem) > left {
            return Err(format!("CDR {what}: count {n} exceeds the {left} bytes left in the message"));
        }
        Ok(n)
    }
    fn string_into(&mut self, what: &str, out: &mut String) -> Result<(), String> {
        out.clear();
        let n = self.count(what, 1)?;
        if n == 0 {
            return Ok(()); // some writers emit 0 for an empty string
        }
        let b = self.take(n)?;
        let b = b.strip_suffix(&[0]).unwrap_or(b);
        out.push_str(std::str::from_utf8(b).map_err(|_| format!("CDR {what}: string is not UTF-8"))?);
        Ok(())
    }
    fn f64_seq_into(&mut self, what: &str, v: &mut Vec<f64>) -> Result<(), String> {
        v.clear();
        let n = self.count(what, 8)?;
        v.reserve(n);
        for _ in 0..n {
            v.push(self.f64()?);
        }
        Ok(())
    }
}

/// Decodes a CDR-serialised JointState (with its encapsulation header).
pub fn decode_joint_state(buf: &[u8]) -> Result<JointState, String> {
    let mut m = JointState::default();
    decode_joint_state_into(buf, &mut m)?;
    Ok(m)
}

/// [`decode_joint_state`] into `m`, reusing its allocations (strings and arrays are
/// overwritten in place: a stream of messages is decoded without allocating).
pub fn decode_joint_state_into(buf: &[u8], m: &mut JointState) -> Result<(), String> {
    if buf.len() < 4 {
        return Err(format!("CDR message of {} bytes has no encapsulation header", buf.len()));
    }
    let le = match (buf[0], buf[1]) {
        (0, 1) => true,
        (0, 0) => false,
        (a, b) => return Err(format!("unsupported CDR encapsulation {a:02x} {b:02x} (expected 00 01 or 00 00)")),
    };
    let mut c = Cursor { buf, pos: 4, le };
    m.sec = c.u32()? as i32;
    m.nanosec = c.u32()?;
    c.string_into("header.frame_id", &mut m.frame_id)?;
    let n = c.count("name", 4)?;
    m.name.resize_with(n, String::new);
    for s in m.name.iter_mut() {
        c.string_into("name", s)?;
    }
    c.f64_seq_into("position", &mut m.position)?;
    c.f64_seq_into("velocity", &mut m.velocity)?;
    c.f64_seq_into("effort", &mut m.effort)?;
    Ok(())
}

/// Encodes a JointState as little-endian CDR with its encapsulation header `00 01 00 00`.
pub fn encode_joint_state(m: &JointState) -> Vec<u8> {
    encode_parts(m.sec, m.nanosec, &m.frame_id, &m.name, &m.position, &m.velocity, &m.effort)
}

pub(crate) fn encode_parts<S: AsRef<str>>(
    sec: i32,
    nanosec: u32,
    frame_id: &str,
    names: &[S],
    position: &[f64],
    velocity: &[f64],
    effort: &[f64],
) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + names.len() * 24 + 8 * (position.len() + velocity.len() + effort.len()));
    out.extend_from_slice(&[0, 1, 0, 0]);
    fn align(out: &mut Vec<u8>, n: usize) {
        while !(out.len() - 4).is_multiple_of(n) {
            out.push(0);
        }
    }
    fn u32(out: &mut Vec<u8>, v: u32) {
        align(out, 4);
        out.extend_from_slice(&v.to_le_bytes());
    }
    fn string(out: &mut Vec<u8>, s: &str) {
        u32(out, s.len() as u32 + 1);
        out.extend_from_slice(s.as_bytes());
        out.push(0);
    }
    fn seq(out: &mut Vec<u8>, v: &[f64]) {
        u32(out, v.len() as u32);
        for x in v {
            align(out, 8);
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    u32(&mut out, sec as u32);
    u32(&mut out, nanosec);
    string(&mut out, frame_id);
    u32(&mut out, names.len() as u32);
    for s in names {
        string(&mut out, s.as_ref());
    }
    seq(&mut out, position);
    seq(&mut out, velocity);
    seq(&mut out, effort);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_big_endian() {
        let m = JointState {
            sec: -3,
            nanosec: 999_999_999,
            frame_id: "base".into(),
            name: vec!["a".into(), "bb".into(), "".into()],
            position: vec![1.0, -2.5, 3.25],
            velocity: vec![],
            effort: vec![0.5, 0.25, f64::MAX],
        };
        let b = encode_joint_state(&m);
        assert_eq!(decode_joint_state(&b).unwrap(), m);
        assert_eq!(m.stamp_ns(), -2_000_000_001);
        // big endian by hand: sec=1, nanosec=2, frame "", names [], pos [1.0], vel [], eff []
        let mut be = vec![0u8, 0, 0, 0];
        be.extend_from_slice(&1u32.to_be_bytes());
        be.extend_from_slice(&2u32.to_be_bytes());
        be.extend_from_slice(&1u32.to_be_bytes());
        be.push(0); // "" with NUL
        be.extend_from_slice(&[0, 0, 0]); // pad to 4
        be.extend_from_slice(&0u32.to_be_bytes()); // names count at rel offset 16
        be.extend_from_slice(&1u32.to_be_bytes()); // position count at rel 20
        be.extend_from_slice(&1.0f64.to_be_bytes()); // rel 24: already 8-aligned
        be.extend_from_slice(&0u32.to_be_bytes()); // velocity count at rel 32
        be.extend_from_slice(&0u32.to_be_bytes()); // effort count
        let d = decode_joint_state(&be).unwrap();
        assert_eq!((d.sec, d.nanosec, d.position.clone()), (1, 2, vec![1.0]));
        // with one name "j": the f64 now needs 4 bytes of padding
        let mut be = vec![0u8, 0, 0, 0];
        be.extend_from_slice(&1u32.to_be_bytes());
        be.extend_from_slice(&2u32.to_be_bytes());
        be.extend_from_slice(&1u32.to_be_bytes());
        be.extend_from_slice(&[0, 0, 0, 0]); // "" + pad
        be.extend_from_slice(&1u32.to_be_bytes()); // one name, rel 16
        be.extend_from_slice(&2u32.to_be_bytes()); // "j\0", rel 20
        be.extend_from_slice(&[b'j', 0, 0, 0]); // rel 24, pad to 28
        be.extend_from_slice(&1u32.to_be_bytes()); // position count, rel 28
        be.extend_from_slice(&1.0f64.to_be_bytes()); // rel 32: aligned
        be.extend_from_slice(&0u32.to_be_bytes());
        be.extend_from_slice(&0u32.to_be_bytes());
        let d = decode_joint_state(&be).unwrap();
        assert_eq!((d.sec, d.nanosec, d.position.clone()), (1, 2, vec![1.0]));
    }

    #[test]
    fn corrupt_counts_are_rejected() {
        let m = JointState { name: vec!["j".into()], position: vec![1.0], ..Default::default() };
        let mut b = encode_joint_state(&m);
        // the names count sits at rel offset 16 (after sec, nanosec, empty frame_id: len + "\0" + pad)
        b[4 + 16..4 + 20].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_joint_state(&b).unwrap_err().contains("exceeds"));
        assert!(decode_joint_state(&[1, 2, 3, 4]).unwrap_err().contains("encapsulation"));
        for n in 0..encode_joint_state(&m).len() {
            let _ = decode_joint_state(&encode_joint_state(&m)[..n]); // never panics
        }
    }
}
