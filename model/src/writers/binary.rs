//! The binary records (`inputs.bin`, `expected.bin`): what the
//! testbenches read with `$fread` and the Verilator harness in bulk.

use super::VectorWriter;
use crate::vectors::{pack, Field};

/// Bytes of one binary record of `fields`: `ceil((32 + W) / 8)`.
pub fn record_bytes(fields: &[Field]) -> usize {
    super::record_bits(fields).div_ceil(8)
}

/// Append the binary record `{zero pad, index[31:0], fields…}`, big endian,
/// [`record_bytes`] long: what the testbench reads with `$fread`.
pub fn push_record(out: &mut Vec<u8>, index: u32, fields: &[Field], row: &[i128]) {
    let (w, total) = pack(index, fields, row);
    for b in (0..total.div_ceil(8)).rev() {
        out.push(w[b / 8].to_le_bytes()[b % 8]);
    }
}

/// The binary format.
pub struct Binary;

impl VectorWriter for Binary {
    fn name(&self) -> &'static str {
        "binary"
    }
    fn files(&self) -> [&'static str; 2] {
        ["inputs.bin", "expected.bin"]
    }
    fn manifest_keys(&self) -> [&'static str; 2] {
        ["inputs_bin", "expected_bin"]
    }
    fn record_bytes(&self, fields: &[Field]) -> usize {
        record_bytes(fields)
    }
    fn push(&self, out: &mut Vec<u8>, index: u32, fields: &[Field], row: &[i128]) {
        push_record(out, index, fields, row);
    }
}
