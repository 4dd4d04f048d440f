//! Every class of mistake in a scenario or task network is refused before anything boots, with
//! the file, line, column and field path, and a message that says what is wrong (issue 15's
//! list, plus the messages it found misleading). No QEMU: these run in milliseconds.
use std::path::Path;

/// A scenario directory with a copy of the flyby network (and optionally another network).
struct Files {
    dir: tempfile::TempDir,
}

impl Files {
    fn new() -> Self {
        Self {
            dir: hil_tests::beside_the_flyby_tasknet(),
        }
    }

    fn write(&self, name: &str, text: &str) -> std::path::PathBuf {
        let path = self.dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    /// The error planning `scenario` gives, with the temporary directory cut from it.
    fn error(&self, scenario: &str) -> String {
        let path = self.write("bad.toml", scenario);
        let e = hil::mission::runner::prepare(&path)
            .err()
            .expect("the scenario must be refused")
            .to_string();
        e.replace(&format!("{}/", self.dir.path().display()), "")
    }
}

const HEAD: &str = "name = \"x\"\n[mission]\ntasknet = \"tasknets/flyby.toml\"\nstart = \"09:50\"\nend = \"11:30\"\n";

fn scenario_error(body: &str) -> String {
    Files::new().error(&format!("{HEAD}{body}"))
}

#[test]
fn a_coverage_expectation_whose_span_is_empty_is_refused() {
    let e = scenario_error(
        "[[expect]]\ncovered_by = [\"Instrument Flyby\"]\nfrom = \"11:00\"\nto = \"10:00\"\n",
    );
    assert_eq!(
        e,
        "bad.toml:9:6: expect[0].to: 10:00:00 is not after from (11:00:00): the span is empty and would check nothing"
    );
}

#[test]
fn instance_zero_is_refused() {
    let e = scenario_error(
        "[[expect]]\ntask = \"Instrument Flyby\"\ninstance = 0\noutcome = \"completed\"\n",
    );
    assert_eq!(
        e,
        "bad.toml:8:12: expect[0].instance: instances count from 1 (the first instance of the task)"
    );
}

#[test]
fn expectation_times_outside_the_mission_are_refused() {
    let e = scenario_error("[[expect]]\ntask = \"Instrument Flyby\"\nstarted_at = \"12:00\"\n");
    assert_eq!(
        e,
        "bad.toml:8:14: expect[0].started_at: 12:00:00 is outside the mission (09:50:00 to 11:30:00): the expectation could never be checked"
    );
    let e = scenario_error(
        "[[expect]]\ntimeline = \"GncAttitude\"\nat = \"2T10:00\"\nvalue = \"NADIR\"\n",
    );
    assert!(
        e.starts_with("bad.toml:8:6: expect[0].at: 2T10:00:00 is outside the mission"),
        "{e}"
    );
}

#[test]
fn unknown_metric_names_are_refused_before_the_run() {
    let e = scenario_error("[[expect]]\nmetric = \"max_reset_recovery_cycles\"\nmax = 5\n");
    assert!(
        e.starts_with("bad.toml:7:10: expect[0].metric: no metric named \"max_reset_recovery_cycles\" (metrics: max_step_ticks, "),
        "{e}"
    );
}

#[test]
fn a_max_frame_that_would_split_the_mission_into_millions_of_frames_is_refused() {
    let files = Files::new();
    let e = files.error("name = \"x\"\n[mission]\ntasknet = \"tasknets/flyby.toml\"\nstart = \"09:50\"\nend = \"11:30\"\nmax_frame = \"1ms\"\n");
    assert_eq!(
        e,
        "bad.toml:6:13: mission.max_frame: 1 ms would split the 100 min mission into 6000000 frames (at most 1000000): use a longer max_frame"
    );
}

#[test]
fn spacecraft_and_link_errors_point_at_their_field_not_at_1_1() {
    let e = scenario_error("[spacecraft.gnc]\nattitude = \"GncAttitude\"\nattain_opcode = 257\nslew = \"15 fortnights\"\ninitial = \"INERTIAL\"\nturning = \"TURNING\"\nafter_reset = \"UNKNOWN\"\n");
    assert!(
        e.starts_with(
            "bad.toml:9:8: spacecraft.gnc.slew: \"15 fortnights\": unknown unit \"fortnights\""
        ),
        "{e}"
    );
    let e = scenario_error("[spacecraft.gnc]\nattitude = \"Attitude\"\nattain_opcode = 257\nslew = \"15min\"\ninitial = \"INERTIAL\"\nturning = \"TURNING\"\nafter_reset = \"UNKNOWN\"\n");
    assert!(
        e.starts_with("bad.toml:7:12: spacecraft.gnc.attitude: no timeline named \"Attitude\""),
        "{e}"
    );
    let e = scenario_error("[link]\ncorrupt = 0.9\n");
    assert_eq!(
        e,
        "bad.toml:7:11: link.corrupt: 0.9 is not a probability in 0..=0.5"
    );
}

#[test]
fn a_state_value_type_that_does_not_match_its_timeline_is_refused() {
    // The battery model publishes integers; GncAttitude is a state timeline of names.
    let e = scenario_error(
        "[spacecraft.power]\nbattery = \"GncAttitude\"\ninitial = 100\nhotel_per_hour = 1\n",
    );
    assert!(
        e.starts_with("bad.toml:7:11: spacecraft.power.battery: \"GncAttitude\" is a state timeline, but this subsystem publishes integer values"),
        "{e}"
    );
    // A forced value of the wrong type.
    let e = scenario_error(
        "[[events]]\nat = \"10:00\"\nstate_override = { timeline = \"GncAttitude\", value = 3 }\n",
    );
    assert_eq!(
        e,
        "bad.toml:8:54: events[0].state_override.value: GncAttitude is a state timeline: give a value name, not an integer"
    );
}

#[test]
fn an_event_with_two_actions_names_the_second() {
    let e = scenario_error("[[events]]\nat = \"10:00\"\nwarm_reset = {}\npower_cycle = {}\n");
    assert!(
        e.starts_with("bad.toml:9:15: events[0].power_cycle: an event has exactly one action"),
        "{e}"
    );
}

#[test]
fn a_field_that_does_not_apply_to_the_expectation_is_refused() {
    let e =
        scenario_error("[[expect]]\nadded = \"GncAttain NADIR (template)\"\nexclusive = true\n");
    assert!(
        e.starts_with("bad.toml:8:13: expect[0].exclusive: `exclusive` does not apply to a `added` expectation"),
        "{e}"
    );
}

#[test]
fn a_missing_task_network_says_cannot_read_and_names_the_field() {
    let files = Files::new();
    let e = files.error("name = \"x\"\n[mission]\ntasknet = \"tasknets/missing.toml\"\nstart = \"09:50\"\nend = \"11:30\"\n");
    assert!(
        e.starts_with("bad.toml:3:11: mission.tasknet: cannot read the file: No such file"),
        "{e}"
    );
    assert!(e.contains("missing.toml"), "{e}");
    assert!(!e.contains(":0:0"), "{e}");
}

#[test]
fn a_too_large_duration_says_too_long() {
    let e = scenario_error(
        "[[events]]\nat = \"10:00\"\nwarm_reset = { recovery = \"9999999999999h\" }\n",
    );
    assert!(
        e.starts_with("bad.toml:8:27: events[0].warm_reset.recovery: \"9999999999999h\" is too long a duration"),
        "{e}"
    );
}

/// Task-network mistakes, each in the network file itself.
fn network_error(network: &str) -> String {
    let files = Files::new();
    files.write("tasknets/net.toml", network);
    files.error("name = \"x\"\n[mission]\ntasknet = \"tasknets/net.toml\"\nstart = \"09:50\"\nend = \"11:30\"\n")
}

const NET: &str = "[network]\nid = 1\n\n[[timeline]]\nname = \"Att\"\nkind = \"state\"\nvalues = [\"A\", \"B\"]\nstate_key = 1\n";

#[test]
fn duplicate_task_names_are_refused_in_the_network() {
    let e = network_error(&format!(
        "{NET}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1min\"\n\n[[task]]\nid = 2\nname = \"t\"\nduration = \"1min\"\n"
    ));
    assert!(
        e.starts_with("tasknets/net.toml:17:8: task[1].name: task[0] has the name `t` already"),
        "{e}"
    );
}

#[test]
fn temporal_constraints_that_form_an_impossible_cycle_are_refused() {
    let e = network_error(&format!(
        "{NET}\n[[task]]\nid = 1\nname = \"a\"\nduration = \"1min\"\n\n[[task]]\nid = 2\nname = \"b\"\nduration = \"1min\"\n\
         \n[[temporal]]\nfrom = \"a\"\nfrom_point = \"end\"\nto = \"b\"\nto_point = \"start\"\nmin = \"10min\"\nmax = \"1h\"\n\
         \n[[temporal]]\nfrom = \"b\"\nfrom_point = \"end\"\nto = \"a\"\nto_point = \"start\"\nmin = \"10min\"\nmax = \"1h\"\n"
    ));
    assert!(e.starts_with("tasknets/net.toml:"), "{e}");
    assert!(
        e.contains("temporal constraints form a cycle that no schedule can meet"),
        "{e}"
    );
}

#[test]
fn task_network_type_errors_have_a_field_path() {
    let e = network_error(&format!(
        "{NET}\n[[task]]\nid = \"one\"\nname = \"t\"\nduration = \"1min\"\n"
    ));
    assert!(
        e.starts_with("tasknets/net.toml:11:6: task[0]: invalid type"),
        "{e}"
    );
}

#[test]
fn link_check_steps_out_of_range_point_at_the_count() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(
        &path,
        "name = \"x\"\n[[steps]]\ncorrupt_frames = { count = 10001 }\n",
    )
    .unwrap();
    let e = hil::scenario::load(Path::new(&path))
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("s.toml:3:28: steps[0].corrupt_frames.count: 10001 is out of range 1..=10000"),
        "{e}"
    );
}
