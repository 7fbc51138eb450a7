//! The three MCAP records ivdyn reads (Schema, Channel, Message), parsed with every length
//! prefix checked against the bytes left in the record before anything is allocated.
//!
//! Why not `mcap::parse_record`: its string fields reserve the length the file claims
//! before reading (binrw's `count`), so a 45 KB file with a corrupt schema-name length
//! asked for a 1.8 GB allocation (found by the `mcap` fuzz target). Records of other
//! kinds are not parsed at all: ivdyn does not use them.
//!
//! Layouts (MCAP specification, little-endian): Schema `id u16, name string, encoding
//! string, data bytes`; Channel `id u16, schema_id u16, topic string, message_encoding
//! string, metadata map`; Message `channel_id u16, sequence u32, log_time u64,
//! publish_time u64, data` (the rest). A string or bytes field is a `u32` length and
//! that many bytes.

/// A record as ivdyn uses it.
#[derive(Debug, PartialEq)]
pub(super) enum Rec<'a> {
    /// A schema: its id, name and encoding.
    Schema { id: u16, name: String, encoding: String },
    /// A channel: its id, schema, topic and message encoding.
    Channel { id: u16, schema_id: u16, topic: String, message_encoding: String },
    /// A message: its channel, log time and data.
    Message { channel_id: u16, log_time: u64, data: &'a [u8] },
    /// Any other record (skipped).
    Other,
}

/// Opcodes (MCAP specification).
const SCHEMA: u8 = 0x03;
const CHANNEL: u8 = 0x04;
const MESSAGE: u8 = 0x05;

/// Reads fields off the front of a record, each bounded by what is left.
struct Cursor<'a> {
    rest: &'a [u8],
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.rest.len() {
            return Err(format!("a field of {n} bytes with {} bytes left in the record", self.rest.len()));
        }
        let (a, b) = self.rest.split_at(n);
        self.rest = b;
        Ok(a)
    }

    fn array<const K: usize>(&mut self) -> Result<[u8; K], String> {
        let mut a = [0u8; K];
        a.copy_from_slice(self.take(K)?);
        Ok(a)
    }

    fn u16(&mut self) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.array()?))
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    /// A length-prefixed field: the length is checked before the bytes are taken.
    fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.u32()? as usize;
        self.take(n)
    }

    fn string(&mut self) -> Result<String, String> {
        let b = self.bytes()?;
        std::str::from_utf8(b).map(str::to_string).map_err(|_| "a string field is not UTF-8".to_string())
    }
}

/// Parses record `opcode` with body `data`.
pub(super) fn parse(opcode: u8, data: &[u8]) -> Result<Rec<'_>, String> {
    let mut c = Cursor { rest: data };
    Ok(match opcode {
        SCHEMA => Rec::Schema { id: c.u16()?, name: c.string()?, encoding: c.string()? },
        CHANNEL => {
            let (id, schema_id) = (c.u16()?, c.u16()?);
            Rec::Channel { id, schema_id, topic: c.string()?, message_encoding: c.string()? }
        }
        MESSAGE => {
            let (channel_id, _sequence, log_time, _publish_time) = (c.u16()?, c.u32()?, c.u64()?, c.u64()?);
            Rec::Message { channel_id, log_time, data: c.rest }
        }
        _ => Rec::Other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn string(s: &str) -> Vec<u8> {
        let mut v = (s.len() as u32).to_le_bytes().to_vec();
        v.extend_from_slice(s.as_bytes());
        v
    }

    #[test]
    fn records_as_the_specification_lays_them_out() {
        let mut schema = 7u16.to_le_bytes().to_vec();
        schema.extend(string("sensor_msgs/msg/JointState"));
        schema.extend(string("ros2msg"));
        schema.extend(string("...definition..."));
        let want = Rec::Schema { id: 7, name: "sensor_msgs/msg/JointState".into(), encoding: "ros2msg".into() };
        assert_eq!(parse(SCHEMA, &schema), Ok(want));
        let mut chan = [3u16.to_le_bytes(), 7u16.to_le_bytes()].concat();
        chan.extend(string("/joint_states"));
        chan.extend(string("cdr"));
        chan.extend(0u32.to_le_bytes());
        let want = Rec::Channel { id: 3, schema_id: 7, topic: "/joint_states".into(), message_encoding: "cdr".into() };
        assert_eq!(parse(CHANNEL, &chan), Ok(want));
        let mut msg =
            [&3u16.to_le_bytes()[..], &9u32.to_le_bytes(), &42u64.to_le_bytes(), &43u64.to_le_bytes()].concat();
        msg.extend([1, 2, 3]);
        assert_eq!(parse(MESSAGE, &msg), Ok(Rec::Message { channel_id: 3, log_time: 42, data: &[1, 2, 3] }));
    }

    #[test]
    fn a_length_beyond_the_record_is_an_error_not_an_allocation() {
        // a schema name claiming 1.8 GB in a 20-byte record
        let mut schema = 1u16.to_le_bytes().to_vec();
        schema.extend(1_811_939_350u32.to_le_bytes());
        schema.extend([b'x'; 14]);
        let e = parse(SCHEMA, &schema).unwrap_err();
        assert!(e.contains("1811939350 bytes with 14 bytes left"), "{e}");
        assert!(parse(MESSAGE, &[0; 10]).unwrap_err().contains("left in the record"));
        assert_eq!(parse(0x08, &[0xff; 3]), Ok(Rec::Other));
    }
}
