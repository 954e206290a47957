//! What the C ABI's tests share.

use std::path::PathBuf;

/// `target/<profile>`: where cargo put the libraries and `fxshade`.
pub fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
    for lib in ["libfxshade_capi.so", "libfxshade_capi.a"] {
        assert!(
            dir.join(lib).exists(),
            "{} is missing: cargo test builds only the Rust library; run \
             `cargo build --release -p fxshade-capi` first (scripts/test builds it)",
            dir.join(lib).display()
        );
    }
    dir
}
