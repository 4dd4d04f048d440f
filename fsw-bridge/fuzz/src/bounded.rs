//! The bounded run of a fuzz target on stable Rust: every seed of its corpus, then a fixed
//! number of deterministic mutations of them, through the same function the libFuzzer wrapper
//! calls. `cargo test` runs it for every target (a few thousand inputs in all), so CI exercises
//! the targets without nightly; the long campaigns run under cargo-fuzz.
//!
//! One file shared by every fuzz crate (each includes it by path): the crates are separate
//! workspaces, and the tests that use it belong to the crates being fuzzed.
#![allow(dead_code)]

use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::path::Path;

/// A fuzz target: its name (and seed folder) and the function libFuzzer and the bounded run
/// call with each input.
pub type Target = (&'static str, fn(&[u8]));

/// Every file of a seed corpus directory, in file name order. Panics when the directory is
/// missing or empty: a target without seeds would be fuzzed from nothing.
pub fn seeds(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("seed corpus {}: {e}", dir.display()))
        .map(|entry| entry.expect("readable directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "seed corpus {} is empty", dir.display());
    files
        .into_iter()
        .map(|p| {
            let name = p
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned();
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (name, bytes)
        })
        .collect()
}

/// A deterministic source of mutations (xorshift64*), the same on every machine.
pub struct Mutator {
    state: u64,
}

/// Byte values that tend to sit on boundaries: zero, one, sign bits, all ones, varint
/// continuation bits.
const INTERESTING: [u8; 8] = [0, 1, 2, 0x7f, 0x80, 0x81, 0xfe, 0xff];

impl Mutator {
    pub fn new(seed: u64) -> Self {
        Self { state: seed | 1 }
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next_u64() % n as u64) as usize
        }
    }

    /// `input` with one to four stacked mutations: bit flips, random or boundary bytes,
    /// inserted, deleted or repeated runs, a run spliced in from another seed, a truncation.
    /// At most `max_len` bytes.
    pub fn mutate(&mut self, input: &[u8], corpus: &[&[u8]], max_len: usize) -> Vec<u8> {
        let mut out = input.to_vec();
        for _ in 0..1 + self.below(4) {
            let len = out.len();
            match self.below(9) {
                0 if len > 0 => {
                    let at = self.below(len);
                    out[at] ^= 1 << self.below(8);
                }
                1 if len > 0 => {
                    let at = self.below(len);
                    out[at] = self.next_u64() as u8;
                }
                2 if len > 0 => {
                    let at = self.below(len);
                    out[at] = INTERESTING[self.below(INTERESTING.len())];
                }
                3 => {
                    let at = self.below(len + 1);
                    let n = 1 + self.below(8);
                    let bytes: Vec<u8> = (0..n).map(|_| self.next_u64() as u8).collect();
                    out.splice(at..at, bytes);
                }
                4 if len > 0 => {
                    let at = self.below(len);
                    let n = 1 + self.below((len - at).min(16));
                    out.drain(at..at + n);
                }
                5 if len > 0 => {
                    let at = self.below(len);
                    let n = 1 + self.below((len - at).min(16));
                    let run: Vec<u8> = out[at..at + n].to_vec();
                    let to = self.below(len + 1);
                    out.splice(to..to, run);
                }
                6 if !corpus.is_empty() => {
                    let other = corpus[self.below(corpus.len())];
                    if !other.is_empty() {
                        let from = self.below(other.len());
                        let n = 1 + self.below((other.len() - from).min(64));
                        let at = self.below(len + 1);
                        let end = (at + n).min(len);
                        out.splice(at..end, other[from..from + n].iter().copied());
                    }
                }
                7 if len > 0 => {
                    let keep = self.below(len);
                    out.truncate(keep);
                }
                _ if len > 0 => {
                    // A small number where a length, count or enum tag may be.
                    let at = self.below(len);
                    out[at] = self.below(40) as u8;
                }
                _ => out.push(self.next_u64() as u8),
            }
        }
        out.truncate(max_len);
        out
    }
}

/// Runs `target` on every seed, then on `mutations` mutated seeds (mutator seeded with
/// `rng_seed`, inputs at most `max_len` bytes). Returns the number of inputs run. When the
/// target panics, the input is printed (hex) before the panic goes on, so it can be added to
/// the corpus as a regression seed.
pub fn run(
    seeds: &[(String, Vec<u8>)],
    mutations: usize,
    rng_seed: u64,
    max_len: usize,
    mut target: impl FnMut(&[u8]),
) -> usize {
    let mut check = |what: &str, input: &[u8]| {
        if let Err(panic) = catch_unwind(AssertUnwindSafe(|| target(input))) {
            let hex: String = input.iter().map(|b| format!("{b:02x}")).collect();
            eprintln!(
                "fuzz target failed on {what} ({} bytes): {hex}",
                input.len()
            );
            resume_unwind(panic);
        }
    };
    for (name, bytes) in seeds {
        check(&format!("seed {name}"), bytes);
    }
    let corpus: Vec<&[u8]> = seeds.iter().map(|(_, b)| b.as_slice()).collect();
    let mut mutator = Mutator::new(rng_seed);
    for i in 0..mutations {
        let base = corpus[mutator.below(corpus.len())];
        let input = mutator.mutate(base, &corpus, max_len);
        check(&format!("mutation {i}"), &input);
    }
    seeds.len() + mutations
}
