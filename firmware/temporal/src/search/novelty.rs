//! Width-based ordering (Lipovetzky and Geffner's best-first width search, BFWS): the
//! novelty of a state within a partition of the states by (h, goal facts achieved).
//!
//! A state has novelty 1 in its partition if one of its facts holds in no state of that
//! partition evaluated before, 2 otherwise (BFWS(f5)'s w over single atoms, with 2 standing for
//! "more than 1"). A novelty search of the portfolio ([`super::NOVELTY_PHASES`]) orders its
//! regular open list by the novelty of the state a successor is generated from (the search is
//! lazy: a successor is evaluated when taken), then by its h; the second search's preferred
//! list keeps h, the last resort's ([`super::NOVELTY_LAST`]) is ordered the same way. On a
//! plateau (h stays the same while drivers walk and trucks drive back) states that reach a fact
//! not seen at that h come first, so the search spreads over the plateau instead of taking
//! every interleaving of the same moves.
//!
//! The table is bounded and heap-free, in a slice of the arena: a bitset over the facts per
//! partition, at most [`NOVELTY_PARTITIONS`] partitions (fewer if the slice is smaller), found
//! through an open-addressing index of twice as many slots. A state of a partition that does
//! not fit (the table full) has novelty 2.

use super::*;

impl<'t, 'm> Planner<'t, 'm> {
    /// Give the search under way its novelty table at the end of the node store (emptied) if
    /// it is a novelty search ([`NOVELTY_PHASES`]), or the node store all of it back. The
    /// table takes at most an eighth of the node store's free part (all of it at a restart,
    /// whose nodes are emptied first).
    pub(super) fn set_novelty_table(&mut self) {
        self.novelty_words = 0;
        if self.novelty_phases & 1 << self.phase == 0 {
            return;
        }
        let room = self.nodes.len().saturating_sub(self.nodes_used) / 8;
        let want = NoveltyTable::words_for(self.fact_words, NOVELTY_PARTITIONS);
        let words = want.min(room);
        let at = self.nodes.len() - words;
        NoveltyTable::new(&mut self.nodes[at..], self.fact_words);
        self.novelty_words = words;
    }

    /// The novelty (1 or 2) of the state in `child_state`, of heuristic value `h`, in its
    /// partition by h and goal facts achieved, counted as seen; 0 outside a novelty search.
    pub(super) fn novelty(&mut self, h: u32) -> u32 {
        if self.novelty_words == 0 {
            return 0;
        }
        let state = &*self.child_state;
        let goals = self
            .task
            .goal_facts()
            .iter()
            .enumerate()
            .filter(|&(i, g)| {
                !heuristic::goal_dropped(self.config.dropped_goals, i) && Self::fact(state, g)
            })
            .count() as u32;
        let key = h.min(0x00ff_ffff) << 8 | goals.min(0xff);
        let at = self.nodes.len() - self.novelty_words;
        let mut table = NoveltyTable::open(&mut self.nodes[at..], self.fact_words);
        table.novelty(key, &state[..self.fact_words])
    }
}

/// Most partitions the table holds (each a bitset over the task's facts).
pub const NOVELTY_PARTITIONS: usize = 1024;

/// The novelty table in `words`: one word of partitions in use, `2 * cap` index slots
/// (partition key + 1, 0 for empty), `2 * cap` slot numbers beside them, then `cap` bitsets of
/// `fact_words` words. It keeps nothing outside `words` ([`Self::open`] takes it up again).
pub struct NoveltyTable<'a> {
    words: &'a mut [u32],
    fact_words: usize,
    cap: usize,
}

impl<'a> NoveltyTable<'a> {
    /// Words a table of `cap` partitions over `fact_words` words of facts takes.
    pub const fn words_for(fact_words: usize, cap: usize) -> usize {
        1 + 4 * cap + cap * fact_words
    }

    /// The most partitions `words` words hold (at most [`NOVELTY_PARTITIONS`]).
    pub const fn capacity_in(words: usize, fact_words: usize) -> usize {
        let cap = words.saturating_sub(1) / (4 + fact_words);
        if cap < NOVELTY_PARTITIONS {
            cap
        } else {
            NOVELTY_PARTITIONS
        }
    }

    /// A table over `words` (as many partitions as fit, at most [`NOVELTY_PARTITIONS`]),
    /// emptied.
    pub fn new(words: &'a mut [u32], fact_words: usize) -> Self {
        let mut t = Self::open(words, fact_words);
        t.clear();
        t
    }

    /// The table left in `words` by [`Self::new`] (the same length and `fact_words`).
    pub fn open(words: &'a mut [u32], fact_words: usize) -> Self {
        let cap = Self::capacity_in(words.len(), fact_words);
        Self {
            words,
            fact_words,
            cap,
        }
    }

    /// Forget every partition.
    pub fn clear(&mut self) {
        let n = Self::words_for(self.fact_words, self.cap).min(self.words.len());
        self.words[..n].iter_mut().for_each(|w| *w = 0);
    }

    /// Partitions in use.
    pub fn partitions(&self) -> usize {
        self.words.first().copied().unwrap_or(0) as usize
    }

    /// The slot of partition `key`, made if new and there is room.
    fn slot(&mut self, key: u32) -> Option<usize> {
        let slots = 2 * self.cap;
        if slots == 0 {
            return None;
        }
        let tag = key.wrapping_add(1);
        let mut i = (key.wrapping_mul(0x9e37_79b9) >> 7) as usize % slots;
        loop {
            let at = self.words[1 + i];
            if at == tag && tag != 0 {
                return Some(self.words[1 + slots + i] as usize);
            }
            if at == 0 {
                // Not in the table: a new partition if one is left (key u32::MAX, whose tag
                // would be 0, never gets one).
                let used = self.partitions();
                if used == self.cap || tag == 0 {
                    return None;
                }
                self.words[1 + i] = tag;
                self.words[1 + slots + i] = used as u32;
                self.words[0] = used as u32 + 1;
                return Some(used);
            }
            i = (i + 1) % slots;
        }
    }

    /// The novelty (1 or 2) of the state whose facts are the bitset `facts` in partition
    /// `key`, its facts then counted as seen there. 2 if the partition does not fit.
    pub fn novelty(&mut self, key: u32, facts: &[u32]) -> u32 {
        let Some(s) = self.slot(key) else {
            return 2;
        };
        let at = 1 + 4 * self.cap + s * self.fact_words;
        let seen = &mut self.words[at..at + self.fact_words];
        let mut new = false;
        for (w, &f) in seen.iter_mut().zip(facts) {
            new |= f & !*w != 0;
            *w |= f;
        }
        if new {
            1
        } else {
            2
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::collections::{BTreeMap, BTreeSet};
    use std::vec::Vec;

    /// Against a straightforward computation: per partition the set of facts seen, a state
    /// novel if one of its facts is not in it; partitions past the capacity have novelty 2.
    #[test]
    fn novelty_matches_sets_of_seen_facts_per_partition() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % n
        };
        for round in 0..200 {
            let facts = 1 + next(90) as usize;
            let fw = facts.div_ceil(32);
            let cap = 1 + next(12) as usize;
            let mut words =
                std::vec![0xdead_beefu32; NoveltyTable::words_for(fw, cap) + next(3) as usize];
            let mut table = NoveltyTable::new(&mut words, fw);
            assert_eq!(table.cap, cap.min(NOVELTY_PARTITIONS));
            let mut seen: BTreeMap<u32, BTreeSet<usize>> = BTreeMap::new();
            let keys = 1 + next(20);
            for step in 0..300 {
                let key = next(keys) as u32 * 0x0101;
                // Sparse states, so that novelty 2 happens often.
                let state: Vec<usize> = (0..facts).filter(|_| next(6) == 0).collect();
                let mut bits = std::vec![0u32; fw];
                for &f in &state {
                    bits[f / 32] |= 1 << (f % 32);
                }
                let want = if let Some(set) = seen.get_mut(&key) {
                    let novel = state.iter().any(|f| !set.contains(f));
                    set.extend(state.iter().copied());
                    if novel {
                        1
                    } else {
                        2
                    }
                } else if seen.len() < cap {
                    let novel = !state.is_empty();
                    seen.insert(key, state.iter().copied().collect());
                    if novel {
                        1
                    } else {
                        2
                    }
                } else {
                    2
                };
                assert_eq!(table.novelty(key, &bits), want, "round {round} step {step}");
                assert_eq!(table.partitions(), seen.len());
            }
            table.clear();
            assert_eq!(table.partitions(), 0);
        }
    }

    /// A slice too small for a partition gives novelty 2 always.
    #[test]
    fn a_table_without_room_says_two() {
        let mut words = [0u32; 5];
        let mut table = NoveltyTable::new(&mut words, 1);
        assert_eq!(table.novelty(0, &[1]), 2);
    }
}
