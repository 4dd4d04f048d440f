//! A queuing port's ring of message slots, and the rule for stale messages.
//!
//! Every message carries the generation its sender had when it sent it (the kernel counts a
//! partition's restarts). A message whose sender has restarted since it was sent is **stale**:
//! it was meant for a conversation that no longer exists (the restarted sender has forgotten it,
//! and may send again from its beginning). On receive the kernel drops the stale messages at
//! the head of the queue, counts them, and hands over the first fresh one, if any.
//!
//! Sampling ports are not affected: they keep the latest message, and the receiver sees its
//! generation and age.

/// Where a queuing port's messages are: the oldest one's slot and how many there are, in a
/// ring of `depth` slots.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QueueState {
    pub head: u16,
    pub count: u16,
}

/// True if a message sent at `message_generation` is older than its sender's
/// `sender_generation`. Generations only ever advance (wrapping), so a message is never newer
/// than its sender; the wrapping difference keeps the rule right across the wrap.
pub const fn is_stale(message_generation: u32, sender_generation: u32) -> bool {
    let behind = sender_generation.wrapping_sub(message_generation);
    behind != 0 && behind < 1 << 31
}

impl QueueState {
    pub const EMPTY: QueueState = QueueState { head: 0, count: 0 };

    /// The slot the next message goes into, or None when all `depth` are taken.
    pub const fn push_slot(&self, depth: u32) -> Option<usize> {
        if self.count as u32 >= depth {
            None
        } else {
            Some((self.head as usize + self.count as usize) % depth as usize)
        }
    }

    /// A message went into [`Self::push_slot`].
    pub fn pushed(&mut self) {
        self.count = self.count.saturating_add(1);
    }

    /// Take the oldest message: its slot, or None when empty.
    pub fn pop(&mut self, depth: u32) -> Option<usize> {
        if self.count == 0 || depth == 0 {
            return None;
        }
        let slot = self.head as usize;
        self.head = ((self.head as usize + 1) % depth as usize) as u16;
        self.count -= 1;
        Some(slot)
    }

    /// The oldest message's slot, or None when empty.
    pub const fn front(&self) -> Option<usize> {
        if self.count == 0 {
            None
        } else {
            Some(self.head as usize)
        }
    }

    /// Drop the stale messages at the head (those whose generation, `generation_at(slot)`, is
    /// older than `sender_generation`), up to the first fresh one; returns how many were
    /// dropped. Afterwards the queue is empty or its oldest message is fresh.
    pub fn drop_stale(
        &mut self,
        depth: u32,
        sender_generation: u32,
        generation_at: impl Fn(usize) -> u32,
    ) -> u16 {
        let mut dropped = 0;
        while let Some(slot) = self.front() {
            if !is_stale(generation_at(slot), sender_generation) {
                break;
            }
            let _ = self.pop(depth);
            dropped += 1;
        }
        dropped
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec::Vec;

    use super::*;

    /// A queue of `depth` slots holding the generations of its messages.
    struct Queue {
        state: QueueState,
        depth: u32,
        slots: Vec<u32>,
    }

    impl Queue {
        fn new(depth: u32) -> Self {
            Self {
                state: QueueState::EMPTY,
                depth,
                slots: std::vec![u32::MAX; depth as usize],
            }
        }
        fn send(&mut self, generation: u32) -> bool {
            match self.state.push_slot(self.depth) {
                Some(slot) => {
                    self.slots[slot] = generation;
                    self.state.pushed();
                    true
                }
                None => false,
            }
        }
        /// The kernel's receive: drop stale, then take one. (dropped, taken generation)
        fn receive(&mut self, sender_generation: u32) -> (u16, Option<u32>) {
            let slots = &self.slots;
            let dropped = self
                .state
                .drop_stale(self.depth, sender_generation, |s| slots[s]);
            let taken = self.state.pop(self.depth).map(|s| self.slots[s]);
            (dropped, taken)
        }
    }

    #[test]
    fn a_message_from_the_senders_current_generation_is_fresh() {
        assert!(!is_stale(3, 3));
        assert!(is_stale(2, 3));
        assert!(is_stale(0, 100));
    }

    #[test]
    fn staleness_survives_the_generation_wrap() {
        assert!(is_stale(u32::MAX, 0));
        assert!(is_stale(u32::MAX - 1, 1));
        assert!(!is_stale(0, 0));
        // Never newer than the sender: a "future" generation is not called stale.
        assert!(!is_stale(5, 4));
    }

    #[test]
    fn messages_sent_before_the_sender_restarted_are_dropped_and_counted() {
        let mut q = Queue::new(4);
        assert!(q.send(1));
        assert!(q.send(1));
        // The sender restarts (generation 2) and sends again.
        assert!(q.send(2));
        assert_eq!(q.receive(2), (2, Some(2)));
        assert_eq!(q.state.count, 0);
        assert_eq!(q.receive(2), (0, None));
    }

    #[test]
    fn only_stale_messages_leave_the_queue_empty() {
        let mut q = Queue::new(2);
        q.send(7);
        q.send(7);
        assert!(!q.send(7), "full");
        assert_eq!(q.receive(8), (2, None));
        assert_eq!(q.state.count, 0);
        // Room again, in ring order.
        assert!(q.send(8));
        assert!(q.send(8));
        assert_eq!(q.receive(8), (0, Some(8)));
    }

    #[test]
    fn fresh_messages_are_taken_in_order_across_the_ring_wrap_and_none_dropped() {
        let mut q = Queue::new(3);
        for round in 0..5u32 {
            assert!(q.send(round));
            assert!(q.send(round));
            assert_eq!(q.receive(round), (0, Some(round)));
            assert_eq!(q.receive(round), (0, Some(round)));
        }
        assert_eq!(q.state.count, 0);
    }

    #[test]
    fn the_drop_stops_at_the_first_fresh_message() {
        let mut q = Queue::new(4);
        q.send(1);
        q.send(2);
        // Receiver sees sender generation 2: the first is stale, the second is taken; a later
        // message of generation 1 cannot follow one of 2 (generations only advance).
        assert_eq!(q.receive(2), (1, Some(2)));
    }
}
