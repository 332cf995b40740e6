//! The kernels' build identity: a hash of the crate's sources, the compiler's version, the
//! profile and the Rust flags, which the kernel plan cache is stamped with (`plan/cache.rs`),
//! so that plans measured on other kernels (a rebuild from changed sources, or with another
//! compiler or `target-cpu`, under the same version number) are measured again, not reused.

use std::path::{Path, PathBuf};

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

fn main() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let mut files = Vec::new();
    sources(&root.join("src"), &mut files);
    files.sort();
    // FNV-1a over each file's path (relative to the crate) and contents.
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    };
    for file in &files {
        let relative = file.strip_prefix(&root).unwrap_or(file);
        eat(relative.to_string_lossy().as_bytes());
        eat(&[0]);
        eat(&std::fs::read(file).unwrap_or_default());
        eat(&[0]);
    }
    // What else makes other machine code from the same sources.
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let version = std::process::Command::new(rustc)
        .arg("-vV")
        .output()
        .map(|o| o.stdout)
        .unwrap_or_default();
    eat(&version);
    for var in ["PROFILE", "OPT_LEVEL", "CARGO_ENCODED_RUSTFLAGS", "TARGET"] {
        eat(std::env::var(var).unwrap_or_default().as_bytes());
        eat(&[0]);
    }
    println!("cargo:rustc-env=TRIGINT_KERNEL_BUILD={hash:016x}");
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=build.rs");
}
