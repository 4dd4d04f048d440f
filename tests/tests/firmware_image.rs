//! The image does not depend on where the repository was cloned: `hil` builds it with the
//! checkout's and cargo's home directories remapped, so no absolute source path of this
//! machine ends up in it (panic locations, debug information). Without that, the image's size,
//! the guest instruction counts and a run's transcript changed with the checkout's path.
use hil_tests::firmware;

fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    !needle.is_empty() && haystack.windows(needle.len()).any(|w| w == needle)
}

#[test]
fn the_image_carries_no_path_of_the_machine_that_built_it() {
    let elf = std::fs::read(&firmware().elf).expect("read the firmware ELF");
    let root = hil::repo_root();
    let root = root.to_string_lossy();
    assert!(
        !contains(&elf, root.as_bytes()),
        "the image contains the checkout's path {root}"
    );
    let cargo_home = std::env::var("CARGO_HOME")
        .ok()
        .or_else(|| std::env::var("HOME").ok().map(|h| format!("{h}/.cargo")))
        .expect("CARGO_HOME or HOME");
    assert!(
        !contains(&elf, cargo_home.as_bytes()),
        "the image contains cargo's home {cargo_home}"
    );
    // The remapped prefix is there instead (the partition crates' panic locations).
    assert!(contains(&elf, b"/rad750/firmware/"));
}
