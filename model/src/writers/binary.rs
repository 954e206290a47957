//! The binary records (`inputs.bin`, `expected.bin`): what the
//! testbenches read with `$fread` and the Verilator harness in bulk.

use super::VectorWriter;
use crate::vectors::Field;

/// Bytes of one binary record of `fields`: `ceil((32 + W) / 8)`.
pub fn record_bytes(fields: &[Field]) -> usize {
    super::record_bits(fields).div_ceil(8)
}

/// Append the binary record `{zero pad, index[31:0], fields…}`, big endian,
/// [`record_bytes`] long: what the testbench reads with `$fread`.
pub fn push_record(out: &mut Vec<u8>, index: u32, fields: &[Field], row: &[i128]) {
    let total = super::record_bits(fields);
    let n = total.div_ceil(8);
    out.reserve(n);
    // Most significant bits first: the pad, the index, the fields in order;
    // `acc` holds the `bits` (< 8 between fields) not yet written.
    let (mut acc, mut bits) = (0u128, 8 * n - total);
    let mut put = |v: u64, w: u32, out: &mut Vec<u8>| {
        acc = (acc << w) | u128::from(v);
        bits += w as usize;
        while bits >= 8 {
            bits -= 8;
            out.push((acc >> bits).to_le_bytes()[0]);
        }
        acc &= (1 << bits) - 1;
    };
    put(u64::from(index), 32, out);
    for (f, &code) in fields.iter().zip(row) {
        put(f.format.to_bits(code), f.format.width(), out);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::Format;

    /// A record is the big-endian integer `index·2^W + Σ code_i·2^{o_i}`
    /// (two's complement codes in their widths, the first field highest),
    /// computed here in `u128` arithmetic, on records from 5 to 15 bytes.
    #[test]
    fn records_are_the_big_endian_integer_of_their_fields() {
        let mut rng = crate::sampling::Rng::new(11);
        for case in 0..500 {
            let n = 1 + case % 5;
            let fields: Vec<Field> = (0..n)
                .map(|k| {
                    let w = 1 + u32::try_from(rng.below(18)).unwrap();
                    Field::new(&format!("f{k}"), Format::new(k % 2 == 0, w, 0).unwrap())
                })
                .collect();
            let row: Vec<i128> = fields
                .iter()
                .map(|f| {
                    let span = u64::try_from(f.format.max_code() - f.format.min_code()).unwrap();
                    f.format.min_code() + i128::from(rng.below(span + 1))
                })
                .collect();
            let index = u32::try_from(rng.below(1 << 32)).unwrap();
            let mut value = 0u128;
            for (f, &c) in fields.iter().zip(&row) {
                let w = f.format.width();
                value = (value << w) | (c.cast_unsigned() & ((1u128 << w) - 1));
            }
            let total: u32 = fields.iter().map(|f| f.format.width()).sum();
            value |= u128::from(index) << total;
            let bytes = (32 + total as usize).div_ceil(8);
            let want = &value.to_be_bytes()[16 - bytes..];
            let mut got = vec![0xa5];
            push_record(&mut got, index, &fields, &row);
            assert_eq!(got[0], 0xa5, "appended, not overwritten");
            assert_eq!(
                &got[1..],
                want,
                "fields {fields:?}, row {row:?}, index {index}"
            );
            assert_eq!(record_bytes(&fields), bytes);
        }
    }
}
