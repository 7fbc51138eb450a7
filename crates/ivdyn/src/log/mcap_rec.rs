//! The four MCAP records ivdyn reads (Schema, Channel, Message, Chunk), parsed with every
//! length prefix checked against the bytes left in the record before anything is
//! allocated, and the records inside a chunk walked the same way.
//!
//! Why not `mcap::parse_record`: its string fields reserve the length the file claims
//! before reading (binrw's `count`), so a 45 KB file with a corrupt schema-name length
//! asked for a 1.8 GB allocation (found by the `mcap` fuzz target). Why not the mcap
//! crate's chunk walk: mcap 0.26's linear reader subtracts a record's claimed length from
//! what is left of an uncompressed chunk unchecked (an overflow panic, or a wrapped count
//! in release; found by the same target). Records of other kinds are not parsed at all:
//! ivdyn does not use them.
//!
//! Layouts (MCAP specification, little-endian): Schema `id u16, name string, encoding
//! string, data bytes`; Channel `id u16, schema_id u16, topic string, message_encoding
//! string, metadata map`; Message `channel_id u16, sequence u32, log_time u64,
//! publish_time u64, data` (the rest). A string or bytes field is a `u32` length and
//! that many bytes. Chunk `message_start_time u64, message_end_time u64,
//! uncompressed_size u64, uncompressed_crc u32, compression string, records` (a `u64`
//! length and that many bytes: records one after the other, each `opcode u8, length u64`
//! and its body).

use std::io::Read;

/// A record as ivdyn uses it.
#[derive(Debug, PartialEq)]
pub(super) enum Rec<'a> {
    /// A schema: its id, name and encoding.
    Schema { id: u16, name: String, encoding: String },
    /// A channel: its id, schema, topic and message encoding.
    Channel { id: u16, schema_id: u16, topic: String, message_encoding: String },
    /// A message: its channel, log time and data.
    Message { channel_id: u16, log_time: u64, data: &'a [u8] },
    /// A chunk: its records, as stored (see [`chunk_records`]).
    Chunk { size: u64, crc: u32, compression: &'a str, records: &'a [u8] },
    /// Any other record (skipped).
    Other,
}

/// Opcodes (MCAP specification).
const SCHEMA: u8 = 0x03;
const CHANNEL: u8 = 0x04;
const MESSAGE: u8 = 0x05;
const CHUNK: u8 = 0x06;
const FOOTER: u8 = 0x02;
const STATISTICS: u8 = 0x0B;

/// The file's last bytes: the footer record (`opcode, length 20, summary_start u64,
/// summary_offset_start u64, summary_crc u32`) and the 8 magic bytes.
pub(super) const FOOTER_LEN: usize = 1 + 8 + 20 + 8;

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

    fn str(&mut self) -> Result<&'a str, String> {
        let b = self.bytes()?;
        std::str::from_utf8(b).map_err(|_| "a string field is not UTF-8".to_string())
    }

    fn string(&mut self) -> Result<String, String> {
        self.str().map(str::to_string)
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
        CHUNK => {
            let (_start, _end, size, crc) = (c.u64()?, c.u64()?, c.u64()?, c.u32()?);
            let compression = c.str()?;
            let n = c.u64()?;
            let records = c.take(usize::try_from(n).unwrap_or(usize::MAX))?;
            Rec::Chunk { size, crc, compression, records }
        }
        _ => Rec::Other,
    })
}

/// The records of a chunk (`size` bytes uncompressed, CRC-32 `crc`, 0 for none), from
/// `records` as stored: decompressed into `buf` when `compression` is zstd or lz4, and
/// never more than `limit` bytes, whatever the chunk claims.
pub(super) fn chunk_records<'b>(
    size: u64,
    crc: u32,
    compression: &str,
    records: &'b [u8],
    buf: &'b mut Vec<u8>,
    limit: usize,
) -> Result<&'b [u8], String> {
    if size > limit as u64 {
        return Err(format!(
            "a chunk of {size} bytes uncompressed: at most {limit} bytes are read (a corrupt length?)"
        ));
    }
    let out: &[u8] = match compression {
        "" => records,
        "zstd" => {
            let dec = zstd::Decoder::new(records).map_err(|e| format!("zstd chunk: {e}"))?;
            bounded(dec, buf, limit).map_err(|e| format!("zstd chunk: {e}"))?
        }
        "lz4" => {
            let dec = lz4::Decoder::new(records).map_err(|e| format!("lz4 chunk: {e}"))?;
            bounded(dec, buf, limit).map_err(|e| format!("lz4 chunk: {e}"))?
        }
        other => return Err(format!("chunk compression '{other}' (zstd, lz4 or none are read)")),
    };
    if out.len() as u64 != size {
        return Err(format!("a chunk that claims {size} bytes uncompressed holds {}", out.len()));
    }
    let got = crc32fast::hash(out);
    if crc != 0 && got != crc {
        return Err(format!("chunk CRC mismatch: saved {crc:#010x}, calculated {got:#010x}"));
    }
    Ok(out)
}

/// Calls `f` on the record `(opcode, data)` of the file's top level or, when it is a
/// chunk, on each record inside it (decompressed into `buf`, at most `limit` bytes);
/// `bad` makes the error of a corrupt chunk.
pub(super) fn each_record<E>(
    opcode: u8,
    data: &[u8],
    buf: &mut Vec<u8>,
    limit: usize,
    mut f: impl FnMut(u8, &[u8]) -> Result<(), E>,
    bad: impl Fn(String) -> E,
) -> Result<(), E> {
    if opcode != CHUNK {
        return f(opcode, data);
    }
    let Rec::Chunk { size, crc, compression, records } = parse(opcode, data).map_err(&bad)? else {
        unreachable!("a chunk opcode parses as a chunk or fails")
    };
    let inner = chunk_records(size, crc, compression, records, buf, limit).map_err(&bad)?;
    for rec in (Records { rest: inner }) {
        let (opcode, data) = rec.map_err(&bad)?;
        if opcode == CHUNK {
            return Err(bad("a chunk inside a chunk".into()));
        }
        f(opcode, data)?;
    }
    Ok(())
}

/// Where the summary section starts (`None`: the file has none), from the file's last
/// [`FOOTER_LEN`] bytes `tail`.
pub(super) fn summary_start(tail: &[u8]) -> Result<Option<u64>, String> {
    let mut c = Cursor { rest: tail };
    let (opcode, len) = (c.array::<1>()?[0], c.u64()?);
    if opcode != FOOTER || len != 20 {
        return Err(format!("no footer record before the end magic (opcode {opcode:#04x}, length {len})"));
    }
    let start = c.u64()?;
    Ok((start != 0).then_some(start))
}

/// Messages per channel of `topic` according to the summary section `summary` (its
/// Channel and Statistics records): `None` when it has no statistics or no such channel.
pub(super) fn summary_topic_count(summary: &[u8], topic: &str) -> Result<Option<u64>, String> {
    let (mut ids, mut counts) = (vec![], None);
    for rec in (Records { rest: summary }) {
        let (opcode, data) = rec?;
        match opcode {
            CHANNEL => {
                if let Rec::Channel { id, topic: t, .. } = parse(opcode, data)?
                    && t == topic
                {
                    ids.push(id);
                }
            }
            STATISTICS => {
                // message, schema, channel, attachment, metadata, chunk counts; start, end
                let mut c = Cursor { rest: data };
                c.take(8 + 2 + 4 * 4 + 8 + 8)?;
                let mut map = Cursor { rest: c.bytes()? };
                let mut per_channel = vec![];
                while !map.rest.is_empty() {
                    per_channel.push((map.u16()?, map.u64()?));
                }
                counts = Some(per_channel);
            }
            _ => {}
        }
    }
    let Some(counts) = counts.filter(|_| !ids.is_empty()) else { return Ok(None) };
    Ok(Some(counts.iter().filter(|(id, _)| ids.contains(id)).map(|(_, n)| n).sum()))
}

/// Reads `src` to its end into `out`, at most `limit` bytes.
pub(super) fn bounded<R: Read>(src: R, out: &mut Vec<u8>, limit: usize) -> std::io::Result<&[u8]> {
    out.clear();
    src.take(limit as u64 + 1).read_to_end(out)?;
    if out.len() > limit {
        return Err(std::io::Error::other(format!("decompresses to more than {limit} bytes")));
    }
    Ok(out)
}

/// The records laid one after the other in `rest` (a chunk's content): `(opcode, body)`,
/// each length checked against what is left.
pub(super) struct Records<'b> {
    pub(super) rest: &'b [u8],
}

impl<'b> Iterator for Records<'b> {
    type Item = Result<(u8, &'b [u8]), String>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let mut c = Cursor { rest: self.rest };
        let item = (|| {
            let opcode = c.array::<1>()?[0];
            let n = c.u64()?;
            let left = c.rest.len();
            let body = c.take(usize::try_from(n).unwrap_or(usize::MAX)).map_err(|_| {
                format!("a record (opcode {opcode:#04x}) of {n} bytes with {left} bytes left in its chunk")
            })?;
            Ok((opcode, body))
        })();
        // after an error the walk stops
        self.rest = if item.is_ok() { c.rest } else { &[] };
        Some(item)
    }
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

    fn chunk(size: u64, compression: &str, records: &[u8]) -> Vec<u8> {
        let mut c = [1u64.to_le_bytes(), 2u64.to_le_bytes(), size.to_le_bytes()].concat();
        c.extend(crc32fast::hash(records).to_le_bytes());
        c.extend(string(compression));
        c.extend((records.len() as u64).to_le_bytes());
        c.extend(records);
        c
    }

    #[test]
    fn a_chunk_walked_record_by_record() {
        // two records: opcode 0x05 with 3 bytes, opcode 0x08 with none
        let recs = [&[0x05][..], &3u64.to_le_bytes(), &[7, 8, 9], &[0x08], &0u64.to_le_bytes()].concat();
        let raw = chunk(recs.len() as u64, "", &recs);
        let Ok(Rec::Chunk { size, crc, compression, records }) = parse(CHUNK, &raw) else { panic!("not a chunk") };
        let mut buf = vec![];
        let inner = chunk_records(size, crc, compression, records, &mut buf, 1 << 20).unwrap();
        let got: Vec<_> = Records { rest: inner }.collect();
        assert_eq!(got, vec![Ok((0x05, &[7u8, 8, 9][..])), Ok((0x08, &[][..]))]);
    }

    #[test]
    fn a_record_overrunning_its_chunk_is_an_error() {
        // the fuzz finding: a record claiming more bytes than its (uncompressed) chunk holds
        let recs = [&[0x05][..], &100u64.to_le_bytes(), &[1, 2]].concat();
        let mut it = Records { rest: &recs };
        let e = it.next().unwrap().unwrap_err();
        assert!(e.contains("opcode 0x05) of 100 bytes with 2 bytes left in its chunk"), "{e}");
        assert!(it.next().is_none());
        let e = chunk_records(1 << 40, 0, "", &recs, &mut vec![], 1 << 20).unwrap_err();
        assert!(e.contains("1099511627776 bytes uncompressed: at most 1048576"), "{e}");
        let e = chunk_records(recs.len() as u64, 1, "", &recs, &mut vec![], 1 << 20).unwrap_err();
        assert!(e.contains("CRC mismatch"), "{e}");
        let e = chunk_records(3, 0, "brotli", &recs, &mut vec![], 1 << 20).unwrap_err();
        assert!(e.contains("'brotli'"), "{e}");
    }

    #[test]
    fn the_summary_counts_of_a_file_the_mcap_crate_wrote() {
        let mut bytes = vec![];
        {
            let mut w = mcap::WriteOptions::new().create(std::io::Cursor::new(&mut bytes)).unwrap();
            let s = w.add_schema("raw", "none", b"").unwrap();
            let a = w.add_channel(s, "/joint_states", "raw", &Default::default()).unwrap();
            let b = w.add_channel(s, "/other", "raw", &Default::default()).unwrap();
            for (i, c) in [a, b, a, a, b, a].into_iter().enumerate() {
                let h =
                    mcap::records::MessageHeader { channel_id: c, sequence: 0, log_time: i as u64, publish_time: 0 };
                w.write_to_known_channel(&h, &[1, 2]).unwrap();
            }
            w.finish().unwrap();
        }
        let start = summary_start(&bytes[bytes.len() - FOOTER_LEN..]).unwrap().expect("a summary");
        let summary = &bytes[start as usize..bytes.len() - FOOTER_LEN];
        assert_eq!(summary_topic_count(summary, "/joint_states"), Ok(Some(4)));
        assert_eq!(summary_topic_count(summary, "/other"), Ok(Some(2)));
        assert_eq!(summary_topic_count(summary, "/none"), Ok(None));
        // a tail without a footer record
        let e = summary_start(&[0u8; FOOTER_LEN]).unwrap_err();
        assert!(e.contains("no footer record"), "{e}");
    }
}
