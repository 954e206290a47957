//! What the generated files share with the vector sets: the fields of a
//! record (a port list, most significant first), the generator's name that
//! heads both, and the fingerprint that names configurations and sources.

use crate::format::Format;

/// Generator name and version, recorded in manifests and headers.
pub const GENERATOR: &str = concat!("fxshade ", env!("CARGO_PKG_VERSION"));

/// One field of a vector line.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Field {
    /// Name (`nx`, `ovf`, …).
    pub name: String,
    /// Format of the codes (flags are `U<n>F0`).
    pub format: Format,
}

impl Field {
    /// A field.
    pub fn new(name: &str, format: Format) -> Self {
        Field {
            name: name.to_string(),
            format,
        }
    }
}

/// FNV-1a, 64 bits: a stable fingerprint of a configuration or of sources
/// (for names and build caches, not for security).
pub fn fingerprint(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for &b in *p {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        h ^= 0xff;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}
