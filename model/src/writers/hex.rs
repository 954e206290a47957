//! The hex lines (`inputs.hex`, `expected.hex`): one line per vector, for
//! people and for `$readmemh` into a `[32+W-1:0]` memory word.

use super::VectorWriter;
use crate::vectors::{pack, Field};

/// `{index[31:0], fields…}` as one hex number, most significant first.
///
/// # Panics
///
/// Never: every digit is a nibble.
pub fn hex_line(index: u32, fields: &[Field], row: &[i128]) -> String {
    let (w, total) = pack(index, fields, row);
    let digits = total.div_ceil(4);
    let mut s = String::with_capacity(digits);
    for d in (0..digits).rev() {
        let v = (w[d * 4 / 64] >> ((d * 4) % 64)) & 0xf;
        s.push(char::from_digit(v as u32, 16).expect("nibble"));
    }
    s
}

/// The hex format.
pub struct Hex;

impl VectorWriter for Hex {
    fn name(&self) -> &'static str {
        "hex"
    }
    fn files(&self) -> [&'static str; 2] {
        ["inputs.hex", "expected.hex"]
    }
    fn manifest_keys(&self) -> [&'static str; 2] {
        ["inputs", "expected"]
    }
    fn record_bytes(&self, fields: &[Field]) -> usize {
        // The digits and a newline.
        super::record_bits(fields).div_ceil(4) + 1
    }
    fn push(&self, out: &mut Vec<u8>, index: u32, fields: &[Field], row: &[i128]) {
        out.extend_from_slice(hex_line(index, fields, row).as_bytes());
        out.push(b'\n');
    }
}
