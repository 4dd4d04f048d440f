//! `hil`: the host harness of the RAD750 proxy. See README.md; the commands are in
//! [`hil::cli`].
fn main() -> std::process::ExitCode {
    // `hil ... | head`: once the reader has gone, `println!` panics on the broken pipe. The
    // panic unwinds through the command, so every QEMU it started is still ended by its PID;
    // what is left is to say nothing of it and exit as a piped Unix tool does (128 + SIGPIPE).
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !is_broken_stdout(panic_text(info.payload())) {
            default_hook(info);
        }
    }));
    // The flight application and the networks `hil` builds are large at the lander capacities
    // (issue 14: an `Autonomy` is about 550 KiB), and an unoptimised build copies them on the
    // stack several times over the main thread's 8 MiB. The commands run on a thread with room;
    // QEMU's parent-death signal still follows `hil` (the thread lives until the command ends).
    match std::thread::Builder::new()
        .name("hil".into())
        .stack_size(256 << 20)
        .spawn(hil::cli::main)
    {
        Ok(command) => command.join().unwrap_or_else(|panic| {
            if is_broken_stdout(panic_text(panic.as_ref())) {
                std::process::ExitCode::from(141)
            } else {
                std::panic::resume_unwind(panic)
            }
        }),
        Err(e) => {
            eprintln!("error: cannot start hil's command thread: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> &str {
    payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
        .unwrap_or("")
}

/// The standard library's panic when writing to a closed standard output.
fn is_broken_stdout(text: &str) -> bool {
    text.starts_with("failed printing to stdout") && text.contains("Broken pipe")
}
