//! The kernel never runs deferred code. The deferred block (`DEFERRED_CODE_BASE`, see "What a
//! warm boot checks, and when" in the README) is not checked at a warm boot: the partitions'
//! instruction BATs leave it out until the kernel has checked it at their first fetch from it.
//! The kernel runs with translation off, so nothing would stop it from running that code
//! unchecked: the linker script must place there only code the kernel never calls. This reads
//! the firmware ELF and follows every direct branch (`b`, `bl`, `bc`) from the kernel's code
//! (the vectors, the reset path, the image crate's functions and the trap entry) through every
//! function it reaches, and requires that none lies in the deferred block. Calls through
//! function pointers (`bctrl`) are not followed; the kernel makes none into the partitions'
//! crates.
//!
//! The same walk from the planner partition's entry must reach the deferred block (its lander
//! and temporal plug-ins are there), so a walk that follows nothing fails too.
use std::collections::{BTreeMap, BTreeSet};

use hil_tests::firmware;
use kernel_config::{DEFERRED_CODE_BASE, DEFERRED_CODE_SIZE};
use object::{Object, ObjectSection, ObjectSymbol, SymbolKind};

/// The shared code's functions: start address to (end, name).
struct Code {
    functions: BTreeMap<u32, (u32, String)>,
    /// The shared code's bytes (both parts), by address.
    bytes: BTreeMap<u32, Vec<u8>>,
}

impl Code {
    fn load() -> Code {
        let bytes = std::fs::read(&firmware().elf).expect("the firmware ELF");
        let file = object::File::parse(&*bytes).expect("an ELF");
        let mut functions = BTreeMap::new();
        for symbol in file.symbols() {
            if symbol.kind() == SymbolKind::Text && symbol.size() > 0 {
                let start = symbol.address() as u32;
                functions.insert(
                    start,
                    (
                        start + symbol.size() as u32,
                        symbol.name().unwrap_or("?").to_string(),
                    ),
                );
            }
        }
        let mut sections = BTreeMap::new();
        for name in [".ram_image", ".deferred_code"] {
            let section = file.section_by_name(name).expect(name);
            sections.insert(
                section.address() as u32,
                section.data().expect("section data").to_vec(),
            );
        }
        Code {
            functions,
            bytes: sections,
        }
    }

    fn word(&self, address: u32) -> Option<u32> {
        let (base, data) = self.bytes.range(..=address).next_back()?;
        let at = (address - base) as usize;
        let b = data.get(at..at + 4)?;
        Some(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The function containing `address`.
    fn function_at(&self, address: u32) -> Option<(u32, u32)> {
        let (&start, &(end, _)) = self.functions.range(..=address).next_back()?;
        (address < end).then_some((start, end))
    }

    /// Direct branch targets outside [start, end).
    fn branches(&self, start: u32, end: u32) -> Vec<u32> {
        let mut targets = Vec::new();
        for at in (start..end).step_by(4) {
            let Some(w) = self.word(at) else { continue };
            let absolute = w & 2 != 0;
            let offset = match w >> 26 {
                // I-form: b, bl (24-bit word offset)
                18 => ((w & 0x03ff_fffc) << 6) as i32 >> 6,
                // B-form: bc, bcl (14-bit word offset)
                16 => ((w & 0xfffc) << 16) as i32 >> 16,
                _ => continue,
            };
            let target = if absolute {
                offset as u32
            } else {
                at.wrapping_add(offset as u32)
            };
            if !(start..end).contains(&target) {
                targets.push(target);
            }
        }
        targets
    }

    /// Every function reached from `roots` (start addresses) by direct branches, with the
    /// function that first branched to it.
    fn reach(&self, roots: &[(u32, u32)]) -> BTreeMap<u32, Option<u32>> {
        let mut seen: BTreeMap<u32, Option<u32>> = roots.iter().map(|&(s, _)| (s, None)).collect();
        let mut todo: Vec<(u32, u32)> = roots.to_vec();
        while let Some((start, end)) = todo.pop() {
            for target in self.branches(start, end) {
                // A branch into a function's middle counts as reaching that function; a branch
                // to no function (into the deferred block's padding, say) counts by address.
                let callee = self.function_at(target).unwrap_or((target, target));
                if let std::collections::btree_map::Entry::Vacant(e) = seen.entry(callee.0) {
                    e.insert(Some(start));
                    if callee.1 > callee.0 {
                        todo.push(callee);
                    }
                }
            }
        }
        seen
    }

    fn name(&self, address: u32) -> String {
        self.functions
            .get(&address)
            .map(|(_, n)| n.clone())
            .unwrap_or_else(|| format!("{address:#x}"))
    }

    fn path(&self, seen: &BTreeMap<u32, Option<u32>>, mut at: u32) -> String {
        let mut names = vec![self.name(at)];
        while let Some(Some(from)) = seen.get(&at) {
            names.push(self.name(*from));
            at = *from;
        }
        names.join(" <- ")
    }
}

fn deferred(address: u32) -> bool {
    address.wrapping_sub(DEFERRED_CODE_BASE) < DEFERRED_CODE_SIZE
}

#[test]
fn the_kernel_reaches_no_deferred_code_by_a_direct_branch() {
    let code = Code::load();
    let mut roots: Vec<(u32, u32)> = code
        .functions
        .iter()
        .filter(|(_, (_, name))| {
            name.contains("rad750_firmware")
                || matches!(
                    name.as_str(),
                    "kernel_trap" | "__exception_common" | "__context_resume" | "rust_start"
                )
        })
        .map(|(&start, &(end, _))| (start, end))
        .collect();
    assert!(
        roots.len() > 20,
        "only {} kernel functions found",
        roots.len()
    );
    // The exception vectors.
    roots.push((0x100, 0x3000));
    let seen = code.reach(&roots);
    let into_deferred: BTreeSet<u32> = seen.keys().copied().filter(|&a| deferred(a)).collect();
    assert!(
        into_deferred.is_empty(),
        "the kernel reaches deferred code, which would run unchecked after a warm reset:\n{}",
        into_deferred
            .iter()
            .map(|&a| code.path(&seen, a))
            .collect::<Vec<_>>()
            .join("\n")
    );
    // The walk crosses crates: the kernel's telemetry goes through the message encoder.
    assert!(
        seen.keys()
            .any(|&a| code.name(a).contains("fsw_bridge5codec6encode")),
        "the walk did not reach the message encoder from the kernel"
    );
}

#[test]
fn the_planner_partition_reaches_deferred_code() {
    let code = Code::load();
    let entry = code
        .functions
        .iter()
        .find(|(_, (_, name))| name == "partition_planner_main")
        .map(|(&start, &(end, _))| (start, end))
        .expect("partition_planner_main");
    let seen = code.reach(&[entry]);
    assert!(
        seen.keys().any(|&a| deferred(a)),
        "the planner's plug-ins were not reached: the walk follows no branch"
    );
}
