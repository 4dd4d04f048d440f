//! The memories the application checkpoints into (the warm-restart area, non-volatile memory,
//! the security area), and copies of them filled on demand.
use super::*;

/// The memories the application checkpoints into, and where it keeps its key and counters.
pub struct Memories<'a> {
    /// Warm-restart area: survives a warm reset.
    pub warm: &'a mut [u8],
    /// Non-volatile memory's checkpoint areas: survive a power cycle (None where there is none).
    pub nv: Option<&'a mut [u8]>,
    /// Non-volatile memory's security area (`sdls::nv`: the key slot and the anti-replay
    /// counter records). None where there is none: then every authenticated uplink and
    /// ground command is refused with `NoKey`.
    pub security: Option<&'a mut dyn SecurityStore>,
}

/// Which of the two checkpoint memories. The warm one sorts first: of two records with the
/// same sequence number (the same checkpoint), the warm one is tried first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum MemoryKind {
    /// The warm-restart area ([`Memories::warm`]).
    Warm,
    /// Non-volatile memory's checkpoint areas ([`Memories::nv`]).
    Nv,
}

/// A target whose memories sit behind an interface (the firmware: system calls into the
/// kernel) gives the application copies that start out empty, and this to fill them: the
/// application asks for the bytes it needs, at the offset they have in the copy, instead of the
/// target copying both 64 KiB areas in at every boot. At boot it reads the two record headers
/// of each memory, then the records they claim, newest claim of either memory first, until one
/// is whole and its payload validates (usually the first: the warm area's newest). The records
/// of a memory that the choice did not need are read before its first checkpoint write (which
/// must know the slot holding its newest whole record). A target that passes none hands over
/// complete copies.
pub trait MemoryFetch {
    /// Fill `bytes` from `memory` at `offset`.
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError>;
}

/// What the application's copy of one memory holds, when a [`MemoryFetch`] fills it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct CopyState {
    /// The slots whose payloads have been read in (bit `i` for slot `i`).
    pub(crate) payloads_read: u8,
    /// The copy holds the memory's newest whole record, or the memory has none: a checkpoint
    /// write into the copy picks the slot it would pick in the memory.
    pub(crate) newest_known: bool,
}

impl CopyState {
    /// A complete copy.
    pub(crate) const COMPLETE: Self = Self {
        payloads_read: 0b11,
        newest_known: true,
    };
}

/// Reads the payload that slot `index`'s header claims into `copy`, unless it is there already.
/// False if the header claims none or the read failed. Without `fetch` the copy is complete.
pub(crate) fn fetch_payload(
    copy: &mut [u8],
    memory: MemoryKind,
    index: u8,
    fetch: Option<&mut (dyn MemoryFetch + '_)>,
    state: &mut CopyState,
) -> bool {
    let Some(fetch) = fetch else {
        return true;
    };
    let bit = 1u8 << index;
    if state.payloads_read & bit != 0 {
        return true;
    }
    let area = WarmRestartArea::new(copy);
    let Some((_, len)) = area.claimed(index) else {
        return false;
    };
    let start = area.slot_offset(index) + RECORD_HEADER_LEN;
    let Some(payload) = copy.get_mut(start..start + len) else {
        return false;
    };
    if fetch.fetch(memory, start, payload).is_err() {
        return false;
    }
    state.payloads_read |= bit;
    true
}

/// Makes `copy` hold its memory's newest whole record, before a checkpoint write into it:
/// reads the payloads of the slots whose headers claim a record, newest claim first, until one
/// is whole (what [`WarmRestartArea::latest`] would look at). The headers must be in `copy`
/// already. Returns that record's (slot, sequence), None when no slot holds a whole record:
/// what the write needs to know where it goes, so that it checks no CRC again.
pub(crate) fn fetch_latest(
    copy: &mut [u8],
    memory: MemoryKind,
    mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
    state: &mut CopyState,
) -> Option<(u8, u32)> {
    if state.newest_known {
        // Read before (a restore tried this memory's records): the copy holds them.
        return WarmRestartArea::new(copy)
            .latest()
            .map(|(slot, sequence, _)| (slot, sequence));
    }
    state.newest_known = true;
    let candidates = WarmRestartArea::new(copy).candidates();
    for index in candidates.into_iter().flatten() {
        if fetch_payload(copy, memory, index, fetch.as_deref_mut(), state) {
            if let Some((sequence, _)) = WarmRestartArea::new(copy).record(index) {
                return Some((index, sequence));
            }
        }
    }
    None
}

/// Read the two record headers of an A/B area into its copy (a failed read leaves that
/// header's bytes as they were: zero in a fresh copy, which claims nothing).
pub(crate) fn fetch_headers(
    copy: &mut [u8],
    memory: MemoryKind,
    fetch: &mut (dyn MemoryFetch + '_),
) {
    for index in 0..2 {
        let start = WarmRestartArea::new(copy).slot_offset(index);
        if let Some(header) = copy.get_mut(start..start + RECORD_HEADER_LEN) {
            let _ = fetch.fetch(memory, start, header);
        }
    }
}

/// A record a header claims: its memory, slot and sequence number.
type Claim = (MemoryKind, u8, u32);

/// The records the headers of both memories claim, newest first by sequence number with
/// wrap-around ([`checkpoint::is_newer`]); of two with the same number the warm one, then
/// slot A. Reads the headers only (no CRC).
pub(crate) fn claims(memories: &mut Memories<'_>) -> heapless::Vec<Claim, 4> {
    let mut claims: heapless::Vec<Claim, 4> = heapless::Vec::new();
    let warm = Some(&mut *memories.warm);
    let nv = memories.nv.as_deref_mut();
    for (memory, copy) in [(MemoryKind::Warm, warm), (MemoryKind::Nv, nv)] {
        let Some(copy) = copy else { continue };
        let area = WarmRestartArea::new(copy);
        for index in 0..2 {
            if let Some((sequence, _)) = area.claimed(index) {
                let _ = claims.push((memory, index, sequence));
            }
        }
    }
    // Sequence numbers relative to one of them are a linear order as long as they span less
    // than half the number space (they are a few frames apart).
    let reference = claims.first().map_or(0, |&(_, _, sequence)| sequence);
    let key =
        |&(memory, slot, sequence): &Claim| (reference.wrapping_sub(sequence) as i32, memory, slot);
    // At most four claims, with distinct keys (memory and slot): an insertion sort, which
    // orders them as any sort does, without the library's general sort in the image (its
    // code is read by the reset stub's image check at every warm boot).
    for i in 1..claims.len() {
        let mut j = i;
        while j > 0 {
            let (Some(a), Some(b)) = (claims.get(j - 1).copied(), claims.get(j).copied()) else {
                break;
            };
            if key(&a) <= key(&b) {
                break;
            }
            claims.swap(j - 1, j);
            j -= 1;
        }
    }
    claims
}

/// The newer of two sequence numbers (wrap-around).
pub(crate) fn newer(a: Option<u32>, b: u32) -> u32 {
    match a {
        Some(a) if checkpoint::is_newer(a, b) => a,
        _ => b,
    }
}
