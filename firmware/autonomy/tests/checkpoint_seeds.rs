mod common;
use common::*;

/// Writes checkpoint seeds in this target's (the monolithic core's) payload format: the flyby
/// flown by the core, its checkpoint every 4 minutes. Run by hand after a format change:
/// `cargo test -p autonomy --test checkpoint_seeds -- --ignored`.
#[test]
#[ignore]
fn write_checkpoint_seeds() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/checkpoint");
    let mut sim = Sim::flyby();
    let mut written = 0;
    for k in 0..25u64 {
        let t = autonomy::MissionTimeUs((9 * 60 + 52 + 4 * k) * 60_000_000);
        sim.run(t, &[]);
        let mut buf = vec![0u8; 64 * 1024];
        let len = sim.autonomy.encode_state(&mut buf).unwrap();
        std::fs::write(dir.join(format!("core-flyby-{k:02}")), &buf[..len]).unwrap();
        written += 1;
    }
    assert_eq!(written, 25);
}
