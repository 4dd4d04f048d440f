//! Prints the operations a fuzz input decodes to, one a line, and applies them to a fresh
//! harness, naming the first one whose check fails: `cargo run --example show_ops FILE`.
fn main() {
    let path = std::env::args().nth(1).expect("usage: show_ops FILE");
    let data = std::fs::read(&path).expect("readable input");
    let mut harness = flight_app_fuzz::Harness::new();
    for (i, op) in flight_app_fuzz::decode_ops(&data).iter().enumerate() {
        let text = format!("{op:?}");
        println!("{i:4} {}", &text[..text.len().min(160)]);
        let applied = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| harness.apply(op)));
        if applied.is_err() {
            println!("op {i} failed its check");
            return;
        }
    }
}
