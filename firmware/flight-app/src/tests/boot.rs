//! Boot from the memories: what a boot reads from the warm area and non-volatile memory, torn
//! records, and sequence numbers across the wrap.

use super::*;

/// The real memories behind a target's copies (as the firmware's are behind the kernel):
/// serves the application's reads and logs them.
struct Backing {
    warm: Vec<u8>,
    nv: Vec<u8>,
    reads: Reads,
}

impl MemoryFetch for Backing {
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError> {
        self.reads.push((memory, offset, bytes.len()));
        let source = match memory {
            MemoryKind::Warm => &self.warm,
            MemoryKind::Nv => &self.nv,
        };
        bytes.copy_from_slice(source.get(offset..offset + bytes.len()).ok_or(StoreError)?);
        Ok(())
    }
}

const AREA: usize = 60 * 1024;

/// Reads logged by [`Backing`]: (memory, offset, length).
type Reads = Vec<(MemoryKind, usize, usize)>;

/// The executive's shares of warm and non-volatile memory (`AREA` bytes each) after the
/// flyby uplink and `frames` granted frames, and the security area.
fn flown(frames: u32) -> (Vec<u8>, Vec<u8>, TestNv) {
    let mut app = std::boxed::Box::new(FlightApp::new());
    let (mut warm, mut nv) = (std::vec![0u8; 2 * AREA], std::vec![0u8; 2 * AREA]);
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: Some(&mut security),
    };
    boot_and_uplink_flyby(&mut app, &mut mem);
    for frame in 0..frames {
        let at = 9 * 3600 + 600 * u64::from(frame);
        app.handle(&grant(frame, at), &mut mem, &mut NoClock, &mut |_| {});
    }
    assert_eq!(executive_share(2 * AREA), AREA);
    warm.truncate(AREA);
    nv.truncate(AREA);
    (warm, nv, security)
}

/// Byte `at` of slot `slot`'s payload flipped (the record no longer whole).
fn torn(mut area: Vec<u8>, slot: usize, at: usize) -> Vec<u8> {
    area[slot * (AREA / 2) + autonomy::checkpoint::RECORD_HEADER_LEN + at] ^= 0x40;
    area
}

/// The slot of the newest whole record of an area.
fn newest_slot(area: &mut [u8]) -> usize {
    usize::from(WarmRestartArea::new(area).latest().unwrap().0)
}

/// Boot the executive's application and run the first window of a frame twice: with
/// complete copies of the memories (`boot`, `handle`), and with empty copies filled on
/// demand from `Backing` (`boot_fetching`, `handle_fetching`, each checkpoint's bytes
/// copied out as the firmware does). Both must decide the same, say the same, and leave
/// the memories byte for byte the same. Returns the outcome and the reads of the fetching
/// boot (before the frame) and of the frame.
fn boot_both_ways(warm: &[u8], nv: &[u8], security: &TestNv) -> (BootOutcome, Reads, Reads) {
    let frame = grant(40, 10 * 3600);
    // Complete copies.
    let (mut full_warm, mut full_nv) = (warm.to_vec(), nv.to_vec());
    let mut full_security = security.clone();
    let mut full_app = std::boxed::Box::new(ExecutiveApp::new());
    let mut full_out: Vec<TargetToHost> = Vec::new();
    let mut mem = Memories {
        warm: &mut full_warm,
        nv: Some(&mut full_nv),
        security: Some(&mut full_security),
    };
    let full_outcome = full_app.boot(&mut mem, &mut NoClock, &mut |m| full_out.push(m));
    full_app.handle(&frame, &mut mem, &mut NoClock, &mut |m| full_out.push(m));
    // Copies filled on demand.
    let mut backing = Backing {
        warm: warm.to_vec(),
        nv: nv.to_vec(),
        reads: Vec::new(),
    };
    let (mut copy_warm, mut copy_nv) = (std::vec![0u8; AREA], std::vec![0u8; AREA]);
    let mut copy_security = security.clone();
    let mut app = std::boxed::Box::new(ExecutiveApp::new());
    let mut out: Vec<TargetToHost> = Vec::new();
    let mut mem = Memories {
        warm: &mut copy_warm,
        nv: Some(&mut copy_nv),
        security: Some(&mut copy_security),
    };
    let outcome = app.boot_fetching(&mut mem, Some(&mut backing), &mut NoClock, &mut |m| {
        out.push(m)
    });
    let boot_reads = core::mem::take(&mut backing.reads);
    app.handle_fetching(
        &frame,
        &mut mem,
        Some(&mut backing),
        &mut NoClock,
        &mut |m| out.push(m),
    );
    for (start, end) in app.take_warm_writes() {
        backing.warm[start..end].copy_from_slice(&mem.warm[start..end]);
    }
    for (start, end) in app.take_nv_writes() {
        let nv = mem.nv.as_deref().unwrap();
        backing.nv[start..end].copy_from_slice(&nv[start..end]);
    }
    assert_eq!(outcome, full_outcome);
    assert_eq!(out, full_out);
    if backing.warm != full_warm {
        let diff: Vec<usize> = (0..full_warm.len())
            .filter(|&i| backing.warm[i] != full_warm[i])
            .collect();
        panic!(
            "warm memories differ at {} bytes, first {:?} last {:?}",
            diff.len(),
            diff.first(),
            diff.last()
        );
    }
    assert!(backing.nv == full_nv, "non-volatile memories differ");
    (outcome, boot_reads, backing.reads)
}

fn payload_reads(reads: &Reads, memory: MemoryKind) -> usize {
    reads
        .iter()
        .filter(|&&(m, _, len)| m == memory && len != autonomy::checkpoint::RECORD_HEADER_LEN)
        .count()
}

#[test]
fn a_boot_that_reads_what_it_needs_decides_and_writes_as_one_given_both_whole_memories() {
    let (warm, nv, security) = flown(3);
    let (mut later_warm, later_nv, _) = flown(4);

    // Both memories as written (the same sequence numbers): the warm area's newest record
    // and the headers; non-volatile memory's records only before its first write.
    let (outcome, boot, frame) = boot_both_ways(&warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(_)));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 1);
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);
    assert_eq!(boot.len(), 5, "four headers and one record: {boot:?}");
    assert_eq!(payload_reads(&frame, MemoryKind::Nv), 1);

    // The warm area's newest record torn: its other record, as new as non-volatile
    // memory's newest (sequence numbers equal): the warm one, from the other slot.
    let slot = newest_slot(&mut later_warm.clone());
    let (outcome, boot, _) = boot_both_ways(&torn(later_warm.clone(), slot, 7), &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if usize::from(info.slot) != slot));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);

    // Torn, and non-volatile memory a frame newer: non-volatile memory's.
    let (outcome, _, _) = boot_both_ways(&torn(later_warm.clone(), slot, 7), &later_nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(_)));

    // Non-volatile memory newer than the warm area (a reset after its write only).
    let (outcome, boot, _) = boot_both_ways(&warm, &later_nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(_)));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);

    // ... with its newest record torn: its other one (the checkpoint of the same frame's
    // first window) is still newer than the warm area's: non-volatile memory's other
    // slot, and the warm area's records are read only before its first write.
    let nv_slot = newest_slot(&mut later_nv.clone());
    let (outcome, boot, frame) =
        boot_both_ways(&warm, &torn(later_nv.clone(), nv_slot, 3), &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(info) if usize::from(info.slot) != nv_slot));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 2);
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 0);
    assert_eq!(payload_reads(&frame, MemoryKind::Warm), 1);

    // A power cycle: the warm area is gone.
    let (outcome, _, _) = boot_both_ways(&std::vec![0u8; AREA], &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(_)));

    // Nothing anywhere: cold, and the first frame writes the first records.
    let blank = std::vec![0u8; AREA];
    let (outcome, _, _) = boot_both_ways(&blank, &blank, &security);
    assert_eq!(outcome, BootOutcome::Cold);

    // The warm area's newest record whole but not a plan (a firmware whose layout changed
    // without a new format version): the next newest whole record of either memory, here
    // the warm area's other one (a frame newer than non-volatile memory's; the uplink's
    // checkpoint is number 1, and each frame writes two, one per executive window).
    let not_a_plan = |buf: &mut [u8]| {
        buf[..4].copy_from_slice(&[0xff; 4]);
        Some(4)
    };
    WarmRestartArea::new(&mut later_warm)
        .write(not_a_plan)
        .unwrap();
    let (outcome, boot, _) = boot_both_ways(&later_warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if info.sequence == 9));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);

    // Neither of the warm area's records a plan: non-volatile memory's newest, whose
    // records the choice had not needed until then.
    WarmRestartArea::new(&mut later_warm)
        .write(not_a_plan)
        .unwrap();
    let (outcome, boot, _) = boot_both_ways(&later_warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(info) if info.sequence == 7));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);
}

/// An area holding one record, numbered `sequence`, of `payload`.
fn area_with(sequence: u32, payload: &[u8]) -> Vec<u8> {
    let mut area = std::vec![0u8; AREA];
    WarmRestartArea::new(&mut area)
        .write_after(Some(sequence.wrapping_sub(1)), |buf| {
            buf[..payload.len()].copy_from_slice(payload);
            Some(payload.len())
        })
        .unwrap();
    area
}

#[test]
fn a_boot_that_reads_what_it_needs_compares_sequence_numbers_across_the_wrap() {
    let (mut older, _, security) = flown(3);
    let (mut newer, _, _) = flown(4);
    let older = WarmRestartArea::new(&mut older)
        .latest()
        .unwrap()
        .2
        .to_vec();
    let newer = WarmRestartArea::new(&mut newer)
        .latest()
        .unwrap()
        .2
        .to_vec();
    let newest = |area: &mut [u8]| WarmRestartArea::new(area).latest().map(|r| r.1);

    // Non-volatile memory's checkpoint numbered 0, after the warm area's u32::MAX: newer,
    // tried first, and the only payload read at boot; the warm area's is read before its
    // first write, and both memories go on at 1.
    let (warm, nv) = (area_with(u32::MAX, &older), area_with(0, &newer));
    let (outcome, boot, frame) = boot_both_ways(&warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(info) if info.sequence == 0));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 0);
    assert_eq!(payload_reads(&frame, MemoryKind::Warm), 1);
    let mut full_warm = warm.clone();
    let mut full_nv = nv.clone();
    let mut app = std::boxed::Box::new(ExecutiveApp::new());
    let mut security_copy = security.clone();
    let mut mem = Memories {
        warm: &mut full_warm,
        nv: Some(&mut full_nv),
        security: Some(&mut security_copy),
    };
    app.boot(&mut mem, &mut NoClock, &mut |_| {});
    app.handle(&grant(40, 10 * 3600), &mut mem, &mut NoClock, &mut |_| {});
    assert_eq!(newest(&mut full_warm), Some(1));
    assert_eq!(newest(&mut full_nv), Some(1));

    // The other way round: the warm area's, without reading non-volatile memory's.
    let (warm, nv) = (area_with(0, &newer), area_with(u32::MAX, &older));
    let (outcome, boot, _) = boot_both_ways(&warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if info.sequence == 0));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);
}

/// The first checkpoint after a boot that restored the warm area's record: non-volatile
/// memory's record goes into the slot that does not hold its newest whole record (found with
/// one CRC), as a byte copy of the warm record just written; with non-volatile memory's
/// newest record torn (a reset during its write), into the torn slot, so its older whole
/// record survives until the new one is whole.
#[test]
fn the_first_checkpoint_after_a_boot_keeps_the_newest_whole_record_of_non_volatile_memory() {
    let (warm, nv, security) = flown(3);
    let nv_newest = newest_slot(&mut nv.clone());
    for (nv, kept) in [
        (nv.clone(), nv_newest),
        (torn(nv.clone(), nv_newest, 5), 1 - nv_newest),
    ] {
        let kept_record = autonomy::checkpoint::records(&nv)[0].unwrap();
        assert_eq!(usize::from(kept_record.slot), kept);
        let kept_sequence = kept_record.sequence;
        let (mut warm, mut nv, mut security) = (warm.clone(), nv.clone(), security.clone());
        let mut app = std::boxed::Box::new(ExecutiveApp::new());
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: Some(&mut security),
        };
        let outcome = app.boot(&mut mem, &mut NoClock, &mut |_| {});
        assert!(matches!(outcome, BootOutcome::RestoredWarm(_)));
        app.handle(&grant(40, 10 * 3600), &mut mem, &mut NoClock, &mut |_| {});
        let [warm_newest, _] = autonomy::checkpoint::records(&warm);
        let [nv_new, nv_old] = autonomy::checkpoint::records(&nv);
        let (warm_newest, nv_new, nv_old) =
            (warm_newest.unwrap(), nv_new.unwrap(), nv_old.unwrap());
        assert_eq!(
            usize::from(nv_new.slot),
            1 - kept,
            "written beside the kept record"
        );
        assert_eq!(usize::from(nv_old.slot), kept);
        assert_eq!(
            nv_old.sequence, kept_sequence,
            "the kept record is untouched"
        );
        assert_eq!(nv_new.sequence, warm_newest.sequence);
        assert_eq!(
            nv_new.payload, warm_newest.payload,
            "a copy of the warm record"
        );
    }
}
