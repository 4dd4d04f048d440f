//! `hil`: the host harness of the RAD750 proxy. See README.md; the commands are in
//! [`hil::cli`].
fn main() -> std::process::ExitCode {
    // The flight application and the networks `hil` builds are large at the lander capacities
    // (issue 14: an `Autonomy` is about 550 KiB), and an unoptimised build copies them on the
    // stack several times over the main thread's 8 MiB. The commands run on a thread with room;
    // QEMU's parent-death signal still follows `hil` (the thread lives until the command ends).
    match std::thread::Builder::new()
        .name("hil".into())
        .stack_size(256 << 20)
        .spawn(hil::cli::main)
    {
        Ok(command) => command
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
        Err(e) => {
            eprintln!("error: cannot start hil's command thread: {e}");
            std::process::ExitCode::from(2)
        }
    }
}
