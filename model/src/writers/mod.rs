//! Vector formats: how a set's records are written to files. Each format
//! is one file of this directory implementing [`VectorWriter`] and one line
//! of [`WRITERS`]; `write_set` (`crate::vectors`), `fxshade vectors` and
//! the counterexample replay write every format the caller selects from
//! that list, and the manifest names each format's files.
//!
//! Adding a format: a file here with a `VectorWriter`, its line in
//! [`WRITERS`], its two manifest keys in `schema/manifest.schema.json`, and
//! a decoder arm in this module's read-back test.

pub mod binary;
pub mod hex;

use crate::vectors::Field;

/// One format of vector records.
pub trait VectorWriter: Sync {
    /// The format's name (`binary`, `hex`).
    fn name(&self) -> &'static str;
    /// Its two files: the inputs, then the expected outputs.
    fn files(&self) -> [&'static str; 2];
    /// Their keys in the manifest's `files` object.
    fn manifest_keys(&self) -> [&'static str; 2];
    /// The most bytes one record of `fields` takes in this format (exact
    /// for fixed-length records such as the binary ones the testbench
    /// seeks in; an upper bound for a text format of variable length): the
    /// disk-space check sums them.
    fn record_bytes(&self, fields: &[Field]) -> usize;
    /// Append the record of vector `index` (the codes `row` of `fields`).
    fn push(&self, out: &mut Vec<u8>, index: u32, fields: &[Field], row: &[i128]);
}

/// Bits of one record of `fields`: the 32-bit index and every field.
pub fn record_bits(fields: &[Field]) -> usize {
    32 + fields
        .iter()
        .map(|f| f.format.width() as usize)
        .sum::<usize>()
}

/// The binary records the testbenches read.
pub const BINARY: &dyn VectorWriter = &binary::Binary;

/// Every format, the binary records first (what the testbench reads).
pub static WRITERS: &[&dyn VectorWriter] = &[BINARY, &hex::Hex];

#[cfg(test)]
mod tests {
    use super::*;
    use num_bigint::BigUint;

    /// Every format's record of a row reads back, by an independent
    /// decoder (arbitrary-precision integers), as `{index[31:0], fields…}`
    /// most significant first: the binary record as big-endian bytes of
    /// `record_bytes` length, the hex line as one hex number and a newline.
    #[test]
    fn every_format_reads_back_as_index_then_fields() {
        let fields = vec![
            Field::new("a", "I2F14".parse().unwrap()),
            Field::new("b", "U0F37".parse().unwrap()),
            Field::new("c", "I1F0".parse().unwrap()),
            Field::new("d", "U3F5".parse().unwrap()),
        ];
        let rows: [[i128; 4]; 3] = [
            [-1, (1 << 37) - 1, -1, 255],
            [0x1234, 0x15_5555_5555, 0, 1],
            [-0x8000, 0, -1, 0],
        ];
        for w in WRITERS {
            for (k, row) in rows.iter().enumerate() {
                let index = 0xdead_0000 + k as u32;
                let mut out = Vec::new();
                w.push(&mut out, index, &fields, row);
                assert!(out.len() <= w.record_bytes(&fields), "{}", w.name());
                let n = match w.name() {
                    "binary" => {
                        // Fixed length: the testbench seeks record k at
                        // k times this.
                        assert_eq!(out.len(), w.record_bytes(&fields));
                        BigUint::from_bytes_be(&out)
                    }
                    "hex" => {
                        assert_eq!(out.len(), w.record_bytes(&fields));
                        assert_eq!(out.last(), Some(&b'\n'));
                        BigUint::parse_bytes(&out[..out.len() - 1], 16).unwrap()
                    }
                    other => panic!("no decoder for the format {other}: add one here"),
                };
                // Fields from the least significant end: the last first.
                let mut rest = n;
                for (f, &code) in fields.iter().zip(row).rev() {
                    let width = f.format.width();
                    let mask = (BigUint::from(1u8) << width) - 1u8;
                    let bits = &rest & &mask;
                    let want = (code as u128) & ((1u128 << width) - 1);
                    assert_eq!(bits, BigUint::from(want), "{}: {}", w.name(), f.name);
                    rest >>= width;
                }
                assert_eq!(rest, BigUint::from(index), "{}", w.name());
            }
        }
    }
}
