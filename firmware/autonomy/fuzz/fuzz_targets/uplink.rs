//! Fuzzes the uplink validator and decoder: any bytes must either be refused with a validation
//! error, leaving the loaded network untouched, or decode into a network that re-validates,
//! re-encodes to the same bytes, and can be planned without panicking.
#![no_main]
use autonomy::{Autonomy, StepBudget, TaskNetwork};
use libfuzzer_sys::fuzz_target;

struct Sink;
impl autonomy::Outputs for Sink {
    fn dispatch(&mut self, _: u32, _: autonomy::Opcode, _: &autonomy::CommandArgs) {}
    fn telemetry(&mut self, _: autonomy::TelemetryEvent) {}
}

fuzz_target!(|data: &[u8]| {
    let mut network = TaskNetwork::EMPTY;
    match autonomy::uplink::decode_into(&mut network, data) {
        Err(_) => assert_eq!(network, TaskNetwork::EMPTY, "a refused uplink changed the network"),
        Ok(()) => {
            assert!(TaskNetwork::from_spec(network.spec().clone()).is_ok());
            let mut buf = vec![0u8; data.len() + 64];
            let len = network.encode(&mut buf).expect("fits");
            let mut again = TaskNetwork::EMPTY;
            autonomy::uplink::decode_into(&mut again, &buf[..len]).expect("re-encoded network decodes");
            assert_eq!(again, network, "encode/decode does not round-trip");
            let mut core = Box::new(Autonomy::new());
            core.load_network(network).expect("idle core loads");
            core.step(autonomy::MissionTimeUs(0), StepBudget { planner_checks: 2_000 }, &mut Sink);
        }
    }
});
