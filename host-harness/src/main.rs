//! `hil`: the host harness of the RAD750 proxy. See README.md; the commands are in
//! [`hil::cli`].
fn main() -> std::process::ExitCode {
    hil::cli::main()
}
