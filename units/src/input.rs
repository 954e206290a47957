//! Text inputs read whole (a configuration, a sweep file, a JSON result to
//! merge), with a size limit so no input can exhaust memory.

use std::path::Path;

/// The most bytes fxshade reads from a text input it parses whole (a
/// configuration, a sweep file, a JSON result to merge): 64 MiB.
pub const MAX_TEXT_INPUT: u64 = 64 << 20;

/// Read a text file of at most [`MAX_TEXT_INPUT`] bytes: a larger file, or
/// an endless one (`/dev/zero`), is refused after reading one byte more
/// than the limit, a directory or a device with a clear reason.
///
/// # Errors
///
/// The reason, as text, when the metadata, opening or reading of `path` fails, or it is a
/// directory, holds more than [`MAX_TEXT_INPUT`] bytes, or is not UTF-8.
pub fn read_text_limited(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if meta.is_dir() {
        return Err("is a directory".into());
    }
    let f = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut buf = Vec::new();
    f.take(MAX_TEXT_INPUT + 1)
        .read_to_end(&mut buf)
        .map_err(|e| e.to_string())?;
    if buf.len() as u64 > MAX_TEXT_INPUT {
        return Err(format!(
            "larger than {} MiB: not a file fxshade reads",
            MAX_TEXT_INPUT >> 20
        ));
    }
    String::from_utf8(buf).map_err(|e| {
        format!(
            "not UTF-8 text (byte {} is not valid)",
            e.utf8_error().valid_up_to()
        )
    })
}
