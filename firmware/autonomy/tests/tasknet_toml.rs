//! The ground's TOML compiler (`host-harness/src/tasknet.rs`, compiled here against this crate
//! with its own unit tests) and the check that `scenarios/tasknets/flyby.toml` is exactly the
//! network `autonomy::scenarios::flyby_spec()` builds: one truth for the flyby.
#[path = "../../../host-harness/src/tasknet.rs"]
#[allow(dead_code)]
mod tasknet;

#[test]
fn flyby_toml_is_the_rust_flyby_network() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/tasknets/flyby.toml");
    let (network, bytes) = tasknet::compile_file(&path).unwrap_or_else(|e| panic!("{e}"));
    let built =
        autonomy::TaskNetwork::from_spec(autonomy::scenarios::flyby_spec().unwrap()).unwrap();
    assert_eq!(network, built);
    let mut buf = vec![0u8; 1 << 16];
    let len = built.encode(&mut buf).unwrap();
    assert_eq!(bytes, &buf[..len], "same uplink bytes");
}
