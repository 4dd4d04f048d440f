//! Where one partition's checkpoints stand in its two memories: writing them (A/B records under
//! one sequence number in both memories) and restoring the newest that validates.
use super::*;

/// Where one partition's checkpoints stand in its two memories: what its copies hold, the
/// newest sequence number, and the byte ranges the last checkpoint wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Persistence {
    /// What the copies of the warm-restart area and of non-volatile memory hold, when a
    /// [`MemoryFetch`] fills them.
    pub(crate) copies: [CopyState; 2],
    /// The slot of each memory (warm, non-volatile) that holds the newest whole record, once
    /// this side has written one there since its boot: the next write goes to the other
    /// without reading or checking the old records.
    pub(crate) newest_slot: [Option<u8>; 2],
    /// The newest sequence number of a whole record in either memory (found at boot, then the
    /// last one written): both memories' next checkpoints are numbered after it.
    pub(crate) newest_sequence: Option<u32>,
    /// Byte ranges of the warm memory the checkpoints since the last take wrote, in order (a
    /// target whose warm-restart area sits behind a system call copies just these bytes).
    pub(crate) last_warm_write: Writes,
    /// The same for non-volatile memory.
    pub(crate) last_nv_write: Writes,
}

/// Byte ranges (start, end) written into a memory's copy, in order.
pub type Writes = heapless::Vec<(usize, usize), 4>;

/// Adds `range` to `writes`; with no room left, the last range grows to cover it (more
/// bytes copied out, none missed).
pub(crate) fn record_write(writes: &mut Writes, range: (usize, usize)) {
    if let Err(range) = writes.push(range) {
        if let Some(last) = writes.last_mut() {
            *last = (last.0.min(range.0), last.1.max(range.1));
        }
    }
}

impl Persistence {
    pub(crate) const NEW: Self = Self {
        copies: [CopyState::COMPLETE; 2],
        newest_slot: [None; 2],
        newest_sequence: None,
        last_warm_write: heapless::Vec::new(),
        last_nv_write: heapless::Vec::new(),
    };

    /// Checkpoint `side` into the warm memory and, if there is one, non-volatile memory, both
    /// under the sequence number after the newest of either; returns how many of the writes
    /// failed. When one write succeeded the side is told it is checkpointed.
    pub(crate) fn checkpoint_all(
        &mut self,
        side: &mut impl PartitionSide,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
    ) -> u64 {
        let newest = self.newest_sequence;
        let sequence = newest.map_or(1, |n| n.wrapping_add(1));
        let mut failures = 0;
        // A write goes to the slot that does not hold the newest whole record. Once this side
        // has written a memory it knows that slot; before (after a boot), the copy must hold
        // the records to find it (see `MemoryFetch`).
        let [warm_copy, nv_copy] = &mut self.copies;
        let warm = match self.newest_slot[0] {
            Some(slot) => {
                WarmRestartArea::new(memories.warm)
                    .write_slot(1 - slot, sequence, |buf| side.encode_state(buf))
            }
            None => {
                let newest_here = fetch_latest(
                    memories.warm,
                    MemoryKind::Warm,
                    fetch.as_deref_mut(),
                    warm_copy,
                );
                WarmRestartArea::new(memories.warm)
                    .write_following(newest_here, newest, |buf| side.encode_state(buf))
            }
        };
        let warm = match warm {
            Ok(written) => {
                record_write(&mut self.last_warm_write, written.bytes);
                self.newest_sequence = Some(newer(self.newest_sequence, written.sequence));
                self.newest_slot[0] = Some(written.slot);
                Some(written)
            }
            Err(_) => {
                failures += 1;
                None
            }
        };
        if let Some(nv) = memories.nv.as_deref_mut() {
            // The same record: copied from the warm memory's when both are numbered alike
            // (no second encoding, no second CRC), else written afresh.
            let record = warm
                .filter(|w| w.sequence == sequence)
                .and_then(|w| memories.warm.get(w.bytes.0..w.bytes.1));
            let written = match (self.newest_slot[1], record) {
                (Some(slot), Some(record)) => {
                    WarmRestartArea::new(nv).copy_record(1 - slot, record)
                }
                (Some(slot), None) => {
                    WarmRestartArea::new(nv)
                        .write_slot(1 - slot, sequence, |buf| side.encode_state(buf))
                }
                (None, record) => {
                    // The first write since the boot: find this memory's newest whole record
                    // (one CRC) and write into the other slot, by copying the warm record
                    // when it carries the number this write would (as a later write does).
                    let newest_here = fetch_latest(nv, MemoryKind::Nv, fetch, nv_copy);
                    let (slot, after) = checkpoint::following(newest_here, newest);
                    match record.filter(|_| after == sequence) {
                        Some(record) => WarmRestartArea::new(nv).copy_record(slot, record),
                        None => {
                            WarmRestartArea::new(nv)
                                .write_following(newest_here, newest, |buf| side.encode_state(buf))
                        }
                    }
                }
            };
            match written {
                Ok(written) => {
                    record_write(&mut self.last_nv_write, written.bytes);
                    self.newest_sequence = Some(newer(self.newest_sequence, written.sequence));
                    self.newest_slot[1] = Some(written.slot);
                }
                Err(_) => failures += 1,
            }
        }
        // A state that fits no slot (a network over what a checkpoint holds) is flown on
        // unprotected, as a single core was: the side goes on as if checkpointed, so the ports
        // keep moving, and every failed write is counted (CHECKPOINT_WRITE_FAILURES). A reset
        // then restores the side's older checkpoint, or none, and the ports' resume brings the
        // other side up to date.
        side.checkpointed();
        failures
    }

    /// Read the record headers of both memories (a target whose memories sit behind `fetch`);
    /// the copies start out knowing nothing else.
    pub(crate) fn start(
        &mut self,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
    ) {
        self.copies = [CopyState::COMPLETE; 2];
        self.newest_slot = [None; 2];
        if let Some(fetch) = fetch {
            self.copies = [CopyState::default(); 2];
            fetch_headers(memories.warm, MemoryKind::Warm, fetch);
            if let Some(nv) = memories.nv.as_deref_mut() {
                fetch_headers(nv, MemoryKind::Nv, fetch);
            }
        }
    }

    /// The restore choice: the records of both memories (two slots each), newest first by
    /// sequence number with wrap-around ([`checkpoint::is_newer`]; of two with the same number,
    /// the warm one, which holds the same checkpoint); the first that is whole and whose payload
    /// decodes and validates is restored. Cold when there is none. Only the records tried are
    /// read in and CRC-checked: usually one. Also finds the newest sequence number of a whole
    /// record, after which the next checkpoints are numbered. Returns the outcome and the ticks
    /// spent decoding and validating payloads.
    pub(crate) fn restore_newest(
        &mut self,
        side: &mut impl PartitionSide,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
    ) -> (BootOutcome, u64) {
        let mut decode_ticks = 0u64;
        let mut newest = None;
        let mut outcome = BootOutcome::Cold;
        for (memory, slot, _) in claims(memories) {
            let (copy, state) = match memory {
                MemoryKind::Warm => (&mut *memories.warm, &mut self.copies[0]),
                MemoryKind::Nv => match memories.nv.as_deref_mut() {
                    Some(nv) => (nv, &mut self.copies[1]),
                    None => continue,
                },
            };
            if !fetch_payload(copy, memory, slot, fetch.as_deref_mut(), state) {
                continue;
            }
            let area = WarmRestartArea::new(copy);
            let Some((sequence, payload)) = area.record(slot) else {
                continue;
            };
            // The first whole record is the newest.
            newest.get_or_insert(sequence);
            // This memory's newest whole record is in its copy when the slots before this one
            // in its own order have been read (they were not whole, or were refused).
            let read_before = area
                .candidates()
                .into_iter()
                .flatten()
                .take_while(|&s| s != slot)
                .all(|s| state.payloads_read & (1 << s) != 0);
            state.newest_known |= read_before;
            let t = clock.ticks();
            let restored = side.restore_record(Record {
                slot,
                sequence,
                payload,
            });
            decode_ticks = decode_ticks.wrapping_add(clock.ticks().wrapping_sub(t));
            if let Ok(info) = restored {
                // The slot restored holds a whole, valid record: the next write in this memory
                // goes to the other without checking the old records again.
                let index = match memory {
                    MemoryKind::Warm => 0,
                    MemoryKind::Nv => 1,
                };
                self.newest_slot[index] = Some(slot);
                outcome = match memory {
                    MemoryKind::Warm => BootOutcome::RestoredWarm(info),
                    MemoryKind::Nv => BootOutcome::RestoredNv(info),
                };
                break;
            }
        }
        self.newest_sequence = newest;
        (outcome, decode_ticks)
    }
}
