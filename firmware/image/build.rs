//! Links the image with the project's memory map (`linker/g3beige.ld`) plus defmt's linker
//! fragment, and stamps a build id: a hash of every source that goes into the image, so the host
//! can tell which firmware a target runs.
use std::path::{Path, PathBuf};
use std::{env, fs};

fn main() {
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").unwrap());
    let repo = manifest.join("../..").canonicalize().unwrap();
    let script = repo.join("linker/g3beige.ld");
    println!("cargo:rustc-link-arg=-T{}", script.display());
    println!("cargo:rustc-link-arg=-Tdefmt.x");
    println!("cargo:rerun-if-changed={}", script.display());

    let mut files = Vec::new();
    for dir in [
        "firmware/image/src",
        "firmware/autonomy/src",
        "fsw-bridge/src",
    ] {
        collect(&repo.join(dir), &mut files);
        println!("cargo:rerun-if-changed={}", repo.join(dir).display());
    }
    files.push(script);
    files.push(manifest.join("Cargo.toml"));
    files.sort();
    // FNV-1a, 64 bit, over paths and contents.
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for file in &files {
        let rel = file.strip_prefix(&repo).unwrap_or(file);
        for byte in rel.to_string_lossy().bytes().chain(fs::read(file).unwrap()) {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    let out = PathBuf::from(env::var("OUT_DIR").unwrap()).join("build_id.rs");
    fs::write(
        out,
        format!("pub const BUILD_ID: [u8; 8] = {:?};\n", hash.to_be_bytes()),
    )
    .unwrap();
}

fn collect(dir: &Path, files: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect(&path, files);
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
}
