//! Building and identifying the target image.
//!
//! `hil` builds `firmware/image` with cargo for `powerpc-unknown-linux-gnu` (cargo does nothing
//! when it is up to date: it tracks the image's workspace, the partition crates
//! `firmware/userlib` and `firmware/task-*` included, and every path dependency) into
//! `target/firmware`, and reads the build id the image carries (symbol `FIRMWARE_BUILD_ID`) to
//! check the target runs what was built.
use std::path::{Path, PathBuf};
use std::process::Command;

use object::{Object, ObjectSection, ObjectSymbol};

use crate::repo_root;

#[derive(Debug, thiserror::Error)]
pub enum FirmwareError {
    #[error("could not run cargo to build the firmware: {0}")]
    Cargo(std::io::Error),
    #[error("building the firmware failed (cargo exit {status}):\n{stderr}")]
    Build { status: String, stderr: String },
    #[error("cannot read firmware image {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("the Rust target {TARGET} is not installed for the pinned toolchain and `rustup target add {TARGET}` failed ({why}); install it by hand with that command")]
    TargetMissing { why: String },
    #[error("{path} is not a RAD750-proxy firmware image: {why}")]
    NotFirmware { path: PathBuf, why: String },
}

/// A firmware ELF and the build id stamped into it.
#[derive(Clone, Debug)]
pub struct FirmwareImage {
    pub elf: PathBuf,
    pub build_id: [u8; 8],
}

impl FirmwareImage {
    /// The function `addr` lies in, as `symbol+0xoffset` with the symbol as the linker has it
    /// (None when the image cannot be read or no text symbol covers it).
    pub fn symbolize(&self, addr: u32) -> Option<String> {
        let bytes = std::fs::read(&self.elf).ok()?;
        let file = object::File::parse(&*bytes).ok()?;
        let addr = u64::from(addr);
        let symbol = file
            .symbols()
            .filter(|s| s.kind() == object::SymbolKind::Text && s.address() <= addr)
            .filter(|s| addr < s.address() + s.size().max(1))
            .max_by_key(|s| s.address())?;
        let name = symbol.name().ok()?;
        Some(format!("{name}+{:#x}", addr - symbol.address()))
    }

    /// Identify an existing image.
    pub fn open(elf: &Path) -> Result<Self, FirmwareError> {
        let bytes = std::fs::read(elf).map_err(|source| FirmwareError::Read {
            path: elf.to_path_buf(),
            source,
        })?;
        let build_id = read_build_id(&bytes).map_err(|why| FirmwareError::NotFirmware {
            path: elf.to_path_buf(),
            why,
        })?;
        Ok(Self {
            elf: elf.to_path_buf(),
            build_id,
        })
    }
}

/// Where `build` puts its output.
pub fn target_dir() -> PathBuf {
    repo_root().join("target/firmware")
}

/// Build the firmware image (release profile) if needed and identify it.
pub fn build() -> Result<FirmwareImage, FirmwareError> {
    build_into(&[], target_dir())
}

/// Build the image with cargo features of `firmware/image` (e.g. `test-partitions`, the test
/// image with the rogue partition) into `target/firmware-<features>`, so it never replaces
/// the default image.
pub fn build_with_features(features: &[&str]) -> Result<FirmwareImage, FirmwareError> {
    if features.is_empty() {
        return build();
    }
    let dir = repo_root().join(format!("target/firmware-{}", features.join("-")));
    build_into(features, dir)
}

/// The Rust target the image is built for.
pub const TARGET: &str = "powerpc-unknown-linux-gnu";

/// Make sure the toolchain that builds `image_dir` (the one `rust-toolchain.toml` pins) has the
/// PowerPC target's standard library. rustup adds the targets `rust-toolchain.toml` lists only
/// when it installs the toolchain, so a machine that had the pinned toolchain already (without
/// the target) would fail with "can't find crate for `core`"; this adds it instead, once.
fn ensure_target(image_dir: &Path) -> Result<(), FirmwareError> {
    ensure_target_with(image_dir, Path::new("rustc"), Path::new("rustup"))
}

/// [`ensure_target`] with the `rustc` and `rustup` to run (tests give stand-ins).
fn ensure_target_with(image_dir: &Path, rustc: &Path, rustup: &Path) -> Result<(), FirmwareError> {
    let libdir = Command::new(rustc)
        .current_dir(image_dir)
        .args(["--print", "target-libdir", "--target", TARGET])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    let installed = libdir
        .and_then(|dir| std::fs::read_dir(dir).ok())
        .is_some_and(|mut entries| {
            entries
                .any(|e| e.is_ok_and(|e| e.file_name().to_string_lossy().starts_with("libcore-")))
        });
    if installed {
        return Ok(());
    }
    eprintln!("  the {TARGET} target is missing from the pinned toolchain: running `rustup target add {TARGET}` (once)");
    let status = Command::new(rustup)
        .current_dir(image_dir)
        .args(["target", "add", TARGET])
        .status()
        .map_err(|e| FirmwareError::TargetMissing {
            why: format!("cannot run rustup: {e}"),
        })?;
    if status.success() {
        Ok(())
    } else {
        Err(FirmwareError::TargetMissing {
            why: format!("rustup exited with {status}"),
        })
    }
}

fn build_into(features: &[&str], target_dir: PathBuf) -> Result<FirmwareImage, FirmwareError> {
    let root = repo_root();
    let image_dir = root.join("firmware/image");
    ensure_target(&image_dir)?;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut args = vec!["build", "--release", "--quiet"];
    let joined = features.join(",");
    if !features.is_empty() {
        args.extend(["--features", joined.as_str()]);
    }
    let remap = remap_flags(&root, &cargo_home());
    args.extend(["--config", remap.as_str()]);
    let output = Command::new(cargo)
        .current_dir(&image_dir)
        .args(&args)
        .env("CARGO_TARGET_DIR", &target_dir)
        // Settings of an outer cargo invocation (a test run) must not leak into this build.
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .output()
        .map_err(FirmwareError::Cargo)?;
    if !output.status.success() {
        return Err(FirmwareError::Build {
            status: output.status.to_string(),
            stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
        });
    }
    FirmwareImage::open(&target_dir.join("powerpc-unknown-linux-gnu/release/rad750-firmware"))
}

/// A `--config` value that adds `--remap-path-prefix` for the checkout and for cargo's home to
/// the image's rustflags (cargo merges it with `.cargo/config.toml`'s list). Source paths end up
/// in the image (panic locations of crates outside the image's directory and of dependencies):
/// without the remapping the image, and with it the guest instruction counts and the run's
/// transcript, would depend on where the repository was cloned and where cargo keeps its
/// registry. With it, the same commit gives the same image on every machine.
fn remap_flags(root: &Path, cargo_home: &Path) -> String {
    let flag = |from: &Path, to: &str| {
        toml::Value::String(format!("--remap-path-prefix={}={to}", from.display())).to_string()
    };
    format!(
        "target.{TARGET}.rustflags=[{}, {}]",
        flag(root, "/rad750"),
        flag(cargo_home, "/cargo")
    )
}

/// Where cargo keeps registry sources: `CARGO_HOME`, or `~/.cargo`.
fn cargo_home() -> PathBuf {
    std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
        .unwrap_or_else(|| PathBuf::from(".cargo"))
}

/// Read the 8-byte `FIRMWARE_BUILD_ID` symbol's contents from the ELF.
pub fn read_build_id(elf: &[u8]) -> Result<[u8; 8], String> {
    let file = object::File::parse(elf).map_err(|e| format!("not an ELF file: {e}"))?;
    let symbol = file
        .symbols()
        .find(|s| s.name() == Ok("FIRMWARE_BUILD_ID"))
        .ok_or("no FIRMWARE_BUILD_ID symbol")?;
    let section = symbol
        .section_index()
        .and_then(|i| file.section_by_index(i).ok())
        .ok_or("FIRMWARE_BUILD_ID is not in a section")?;
    let data = section.data().map_err(|e| e.to_string())?;
    let offset = symbol
        .address()
        .checked_sub(section.address())
        .ok_or("bad FIRMWARE_BUILD_ID address")? as usize;
    let bytes = data
        .get(offset..offset + 8)
        .ok_or("FIRMWARE_BUILD_ID outside its section")?;
    let mut id = [0u8; 8];
    id.copy_from_slice(bytes);
    Ok(id)
}

/// Hex form of a build id, as printed everywhere.
pub fn build_id_hex(id: &[u8; 8]) -> String {
    id.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    //! The missing-target path of the README's set-up, without a network: stand-in `rustc` and
    //! `rustup` scripts play a pinned toolchain installed without the PowerPC target.
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    /// A toolchain whose target libdir is `libdir`, and a `rustup` that logs its arguments to
    /// `rustup.log` and exits with `rustup_status`.
    fn toolchain(dir: &Path, libdir: &Path, rustup_status: i32) -> (PathBuf, PathBuf) {
        let script = |name: &str, body: String| {
            let path = dir.join(name);
            std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
            path
        };
        let rustc = script("rustc", format!("echo {}", libdir.display()));
        let log = dir.join("rustup.log");
        let rustup = script(
            "rustup",
            format!("echo \"$@\" >> {}\nexit {rustup_status}", log.display()),
        );
        (rustc, rustup)
    }

    fn rustup_calls(dir: &Path) -> String {
        std::fs::read_to_string(dir.join("rustup.log")).unwrap_or_default()
    }

    #[test]
    fn a_toolchain_without_the_powerpc_target_gets_it_added() {
        let dir = tempfile::tempdir().unwrap();
        let empty = dir.path().join("lib");
        std::fs::create_dir(&empty).unwrap();
        let (rustc, rustup) = toolchain(dir.path(), &empty, 0);
        ensure_target_with(dir.path(), &rustc, &rustup).unwrap();
        assert_eq!(rustup_calls(dir.path()), format!("target add {TARGET}\n"));
    }

    #[test]
    fn a_toolchain_with_the_target_is_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let lib = dir.path().join("lib");
        std::fs::create_dir(&lib).unwrap();
        std::fs::write(lib.join("libcore-0123.rlib"), b"").unwrap();
        let (rustc, rustup) = toolchain(dir.path(), &lib, 0);
        ensure_target_with(dir.path(), &rustc, &rustup).unwrap();
        assert_eq!(rustup_calls(dir.path()), "");
    }

    #[test]
    fn a_failing_rustup_says_which_command_to_run() {
        let dir = tempfile::tempdir().unwrap();
        let empty = dir.path().join("lib");
        std::fs::create_dir(&empty).unwrap();
        let (rustc, rustup) = toolchain(dir.path(), &empty, 1);
        let e = ensure_target_with(dir.path(), &rustc, &rustup).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(&format!("rustup target add {TARGET}")),
            "{text}"
        );
        assert!(text.contains("exit status: 1"), "{text}");
    }
}
