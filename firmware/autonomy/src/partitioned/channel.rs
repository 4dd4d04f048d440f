//! The channel ends: the numbered, acknowledged messages of one direction ([`Outbox`] on the
//! sending side, [`Inbox`] on the receiving side) and what crosses a port ([`Wire`]).
use super::*;

/// What crosses a port between the two partitions.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wire<T> {
    /// Message number `seq` (from 1, in order).
    Message { seq: u32, message: T },
    /// The sender of this has checkpointed every message up to `upto` it received.
    Ack { upto: u32 },
    /// The sender of this (re)started, restored or cold, and has applied every message up to
    /// `received`: send again what came after.
    Resume { received: u32 },
    /// The messages before `next` are void: the receiver lost what they built on (its
    /// checkpoint, or the sender's, is gone). The receiver takes `next` as the next message.
    Rebase { next: u32 },
}

/// The sending end of one direction: every message numbered and kept until acknowledged.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Outbox<T, const N: usize> {
    /// The number the next message gets.
    next_seq: u32,
    /// Messages up to this number have gone to the port (or were acknowledged). Not saved:
    /// after a restore every message kept goes again.
    #[serde(skip)]
    sent: u32,
    /// Messages up to this number were in this side's last checkpoint: only they may go. Not
    /// saved: a restored state is a checkpointed one.
    #[serde(skip)]
    sendable: u32,
    /// Messages not acknowledged yet, oldest first.
    log: Vec<(u32, T), N>,
    /// Messages refused because the log was full (the sender's count of what it lost).
    pub refused: u32,
    /// Messages sent again after the receiver was restored.
    pub resent: u32,
    /// The receiver cannot be caught up by sending again (see [`Wire::Rebase`]): the next
    /// transmission starts with a `Rebase` to this number (the first message kept after it).
    /// Not saved: the receiver's next `Resume` asks again.
    #[serde(skip)]
    rebase: Option<u32>,
    /// Times the channel was rebased.
    pub rebases: u32,
}

impl<T: Clone, const N: usize> Default for Outbox<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Clone, const N: usize> Outbox<T, N> {
    pub const fn new() -> Self {
        Self {
            next_seq: 1,
            sent: 0,
            sendable: 0,
            log: Vec::new(),
            refused: 0,
            resent: 0,
            rebase: None,
            rebases: 0,
        }
    }

    /// Makes this outbox what [`Outbox::new`] is, in place: assigning `new()` writes the
    /// whole log's capacity (the planner's outbox is about 9 KiB), clearing writes its length.
    pub fn reset(&mut self) {
        self.next_seq = 1;
        self.sent = 0;
        self.sendable = 0;
        self.log.clear();
        self.refused = 0;
        self.resent = 0;
        self.rebase = None;
        self.rebases = 0;
    }

    /// Keeps `message` for sending; false (and counted) when the log is full.
    pub fn push(&mut self, message: T) -> bool {
        if self.log.push((self.next_seq, message)).is_err() {
            self.refused = self.refused.saturating_add(1);
            return false;
        }
        self.next_seq = self.next_seq.wrapping_add(1);
        true
    }

    /// Keeps `message` if that leaves at least `free` places for what must still go (a
    /// frame's own message, a window's status); else refuses it, counted in `refused` as a
    /// full log's refusal is.
    pub fn push_leaving(&mut self, free: usize, message: T) -> bool {
        if self.room() > free {
            self.push(message)
        } else {
            self.refused = self.refused.saturating_add(1);
            false
        }
    }

    /// Room for this many more messages.
    pub fn room(&self) -> usize {
        N - self.log.len()
    }

    /// Messages not acknowledged yet.
    pub fn unacknowledged(&self) -> usize {
        self.log.len()
    }

    /// Messages kept but not sent yet.
    pub fn unsent(&self) -> usize {
        self.log.iter().filter(|(seq, _)| *seq > self.sent).count()
    }

    /// The receiver has checkpointed every message up to `upto` (an acknowledgement of
    /// messages this side never sent, from before a rebase, is void).
    pub fn on_ack(&mut self, upto: u32) {
        if upto >= self.next_seq {
            return;
        }
        self.log.retain(|(seq, _)| *seq > upto);
        self.sent = self.sent.max(upto);
    }

    /// The receiver (re)started with every message up to `received` applied: what came after
    /// goes again. When that cannot be (it has applied messages this side never sent, or lacks
    /// ones this side no longer keeps), the messages kept are dropped, the next transmission
    /// starts with a [`Wire::Rebase`], and this returns true: the sender must bring the
    /// receiver up to date another way.
    pub fn on_resume(&mut self, received: u32) -> bool {
        let last = self.next_seq.wrapping_sub(1);
        let oldest_kept = self.log.first().map_or(self.next_seq, |(seq, _)| *seq);
        if received > last || received.wrapping_add(1) < oldest_kept {
            self.log.clear();
            self.sent = last;
            self.rebase = Some(self.next_seq);
            self.rebases = self.rebases.saturating_add(1);
            return true;
        }
        self.log.retain(|(seq, _)| *seq > received);
        let again = self.log.iter().filter(|(seq, _)| *seq <= self.sent).count();
        self.resent = self
            .resent
            .saturating_add(u32::try_from(again).unwrap_or(u32::MAX));
        self.sent = received;
        false
    }

    /// Whether messages were kept since this side's last checkpoint (they cannot go before
    /// the next one).
    pub fn awaits_checkpoint(&self) -> bool {
        self.log.iter().any(|(seq, _)| *seq > self.sendable)
    }

    /// This side was restored: whatever was in the ports is gone, so every message kept goes
    /// again (the receiver drops those it has).
    pub fn after_restore(&mut self) {
        let again = self.log.iter().filter(|(seq, _)| *seq <= self.sent).count();
        self.resent = self
            .resent
            .saturating_add(u32::try_from(again).unwrap_or(u32::MAX));
        self.sent = self
            .log
            .first()
            .map_or(self.sent, |(seq, _)| seq.wrapping_sub(1));
        self.checkpointed();
    }

    /// This side's checkpoint now holds every message kept: they may go.
    pub fn checkpointed(&mut self) {
        self.sendable = self.next_seq.wrapping_sub(1);
    }

    /// Hands the messages not sent yet that a checkpoint holds to `send`, in order, until it
    /// refuses one (a full port: the rest go at the next call).
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<T>) -> bool) {
        if let Some(next) = self.rebase {
            if !send(Wire::Rebase { next }) {
                return;
            }
            self.rebase = None;
        }
        for (seq, message) in &self.log {
            let seq = *seq;
            if seq <= self.sent {
                continue;
            }
            if seq > self.sendable {
                return;
            }
            if !send(Wire::Message {
                seq,
                message: message.clone(),
            }) {
                return;
            }
            self.sent = seq;
        }
    }
}

/// Decodes an outbox as a checkpoint holds it (its `Serialize`) into the outbox itself, its
/// log straight into place ([`crate::in_place`]): `take_from_bytes` built it in a temporary
/// that was moved whole (capacity, not length) twice or more on the way to its place. What
/// the encoding skips is as in a decoded one: nothing sent, nothing sendable, no rebase.
pub(super) struct OutboxInPlace<'a, T, const N: usize>(pub &'a mut Outbox<T, N>);

impl<'de, T: Deserialize<'de>, const N: usize> serde::de::DeserializeSeed<'de>
    for OutboxInPlace<'_, T, N>
{
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        // Five fields saved: next_seq, log, refused, resent, rebases.
        deserializer.deserialize_tuple(5, self)
    }
}

impl<'de, T: Deserialize<'de>, const N: usize> serde::de::Visitor<'de> for OutboxInPlace<'_, T, N> {
    type Value = ();

    fn expecting(&self, formatter: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        formatter.write_str("a saved outbox")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        use crate::in_place::{field, field_into, VecInto};
        let o = self.0;
        o.sent = 0;
        o.sendable = 0;
        o.rebase = None;
        o.next_seq = field(&mut seq, 0)?;
        field_into(&mut seq, VecInto(&mut o.log), 1)?;
        o.refused = field(&mut seq, 2)?;
        o.resent = field(&mut seq, 3)?;
        o.rebases = field(&mut seq, 4)?;
        Ok(())
    }
}

/// The receiving end of one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Inbox {
    /// Every message up to this number has been applied.
    pub received: u32,
    /// The last number acknowledged. Not saved: a restored side acknowledges again.
    #[serde(skip)]
    acknowledged: u32,
    /// Every message up to this number was applied when this side's last checkpoint was
    /// taken: the most that may be acknowledged. Not saved: a restored state is a
    /// checkpointed one.
    #[serde(skip)]
    checkpointed: u32,
    /// Messages dropped as already applied (sent again after a restore).
    pub duplicates: u32,
    /// Messages dropped because one before them is missing (they come again in order).
    pub out_of_order: u32,
}

impl Inbox {
    /// Whether message `seq` is the next one (apply it); counts the others.
    pub fn accept(&mut self, seq: u32) -> bool {
        if seq == self.received.wrapping_add(1) {
            self.received = seq;
            true
        } else {
            if seq <= self.received {
                self.duplicates = self.duplicates.saturating_add(1);
            } else {
                self.out_of_order = self.out_of_order.saturating_add(1);
            }
            false
        }
    }

    /// This side's checkpoint now holds every message applied.
    pub fn checkpointed(&mut self) {
        self.checkpointed = self.received;
    }

    /// The sender declared the messages before `next` void ([`Wire::Rebase`]).
    pub fn rebase(&mut self, next: u32) {
        self.received = next.wrapping_sub(1);
        // Nothing before `next` is to be acknowledged any more.
        self.checkpointed = self.received;
        self.acknowledged = self.received;
    }

    /// The acknowledgement to send, if there is a new one: up to what the last checkpoint
    /// holds.
    pub fn ack(&mut self) -> Option<u32> {
        (self.checkpointed != self.acknowledged).then(|| {
            self.acknowledged = self.checkpointed;
            self.checkpointed
        })
    }
}

/// An inbox that has received nothing.
pub(super) const EMPTY_INBOX: Inbox = Inbox {
    received: 0,
    acknowledged: 0,
    checkpointed: 0,
    duplicates: 0,
    out_of_order: 0,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// An outbox with messages kept, some sent, acknowledged and refused: every saved field
    /// away from its default.
    fn busy() -> Outbox<u32, 4> {
        let mut o = Outbox::new();
        for m in 10..16 {
            o.push(m);
        }
        o.checkpointed();
        o.transmit(&mut |_| true);
        o.on_ack(1);
        o.on_resume(1);
        o.rebases = 3;
        o
    }

    /// `outbox` encoded into `buf` with `extra` after it: the whole length used, or None.
    fn encoded<const N: usize>(
        outbox: &Outbox<u32, N>,
        buf: &mut [u8],
        extra: &[u8],
    ) -> Option<usize> {
        let n = postcard::to_slice(outbox, buf).ok()?.len();
        buf.get_mut(n..n + extra.len())?.copy_from_slice(extra);
        Some(n)
    }

    #[test]
    fn an_outbox_decoded_in_place_is_the_one_take_from_bytes_builds() {
        let saved = busy();
        let mut buf = [0u8; 128];
        let n = encoded(&saved, &mut buf, &[7, 8]).unwrap_or(0);
        assert!(n > 0);
        let (bytes, tail) = (buf.get(..n).unwrap_or(&[]), buf.get(..n + 2).unwrap_or(&[]));
        let built = postcard::take_from_bytes::<Outbox<u32, 4>>(bytes).ok();
        assert_eq!(built.as_ref().map(|(_, rest)| rest.len()), Some(0));
        // Into a busy outbox: nothing of what it held stays.
        let mut in_place = busy();
        in_place.sent = 9;
        in_place.rebase = Some(5);
        let rest = crate::in_place::take_in_place(tail, OutboxInPlace(&mut in_place));
        assert_eq!(rest, Some(&[7u8, 8][..]));
        assert_eq!(Some(&in_place), built.as_ref().map(|(o, _)| o));
        assert_eq!(in_place.unacknowledged(), 3);
        // A log longer than the capacity is refused, as `Deserialize` refuses it.
        let mut long: Outbox<u32, 8> = Outbox::new();
        for m in 0..6 {
            long.push(m);
        }
        let mut long_buf = [0u8; 128];
        let long_n = encoded(&long, &mut long_buf, &[]).unwrap_or(0);
        let long_bytes = long_buf.get(..long_n).unwrap_or(&[]);
        assert!(long_n > 0);
        assert!(postcard::from_bytes::<Outbox<u32, 4>>(long_bytes).is_err());
        assert!(crate::in_place::take_in_place(long_bytes, OutboxInPlace(&mut busy())).is_none());
        // Cut short: refused.
        let cut = buf.get(..n - 1).unwrap_or(&[]);
        assert!(crate::in_place::take_in_place(cut, OutboxInPlace(&mut busy())).is_none());
    }

    #[test]
    fn reset_makes_an_outbox_a_new_one() {
        let mut o = busy();
        o.reset();
        assert_eq!(o, Outbox::new());
        assert_eq!((o.sent, o.sendable, o.rebase), (0, 0, None));
    }
}
