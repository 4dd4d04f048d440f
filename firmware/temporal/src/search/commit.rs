//! A search that stalls or fills the node store goes on from its best node, the path to it
//! committed (issue 13: driverlog 19 and 20 filled the 8 MiB arena in every search of the
//! portfolio; 16 and 18 took 220,060 and 72,652 evaluations on plateaus).
//!
//! When a search of [`super::COMMIT_PHASES`] has made [`super::COMMIT_AFTER`] expansions
//! without a new best h, or has no room for another node, it keeps only the path from the root
//! to the latest node it made of its lowest h: those nodes are moved to the node store's start
//! in order, the duplicate table is given only them, the open lists and the novelty table are
//! emptied, and the same search goes on from that node as if it were the root, with the path
//! before it as its plan's prefix. The arena is free again for the search below it; the plan's
//! steps, constraints and STN are the path's as before (the prefix's nodes keep their
//! constraint bytes, and those that keep a state keep it), so a plan found later is checked
//! like any other, and nothing is kept outside the arena. Like the restarts of local-search
//! planners (LPG-td, which solves all of driverlog, is one), it trades completeness for
//! progress: on a plateau the latest node of the lowest h is where the search's walk over the
//! plateau has got to, and committing to it moves the next search there (committing to the
//! first node of the lowest h, and only when the store is full, repeats the search it
//! committed from; driverlog 19 was not solved that way).
//!
//! It gives up plans that need a step of the prefix undone, so only the last resort commits
//! (a search that prunes every repeated state, itself incomplete). A search that cannot
//! commit (no node of the lowest h made since its last commit) and fills its store ends out of
//! memory as before, and the portfolio goes on as without commits.
use super::*;

impl<'t, 'm> Planner<'t, 'm> {
    /// Whether the search under way commits ([`COMMIT_PHASES`]).
    pub(super) fn commits_here(&self) -> bool {
        self.commit_phases & 1 << self.phase != 0
    }

    /// Whether the search under way has committed to a prefix: its root is node 0 (the store
    /// starts with it at every restart and keeps it first at a commit) and it committed to
    /// another. Its open lists emptying then proves nothing (the prefix may be what is wrong).
    pub(super) fn has_committed(&self) -> bool {
        self.committed_node != 0 && self.committed_node != NONE
    }

    /// Times a search committed to its best node and went on from it ([`super::commit`]).
    pub fn commits(&self) -> u64 {
        self.commits
    }

    /// Choose the searches that commit (bit p: search p, as [`NOVELTY_PHASES`]), the
    /// expansions without a new best h after which they do and after which the third search
    /// gives way, instead of [`COMMIT_PHASES`], [`COMMIT_AFTER`] and
    /// [`THIRD_GIVES_WAY_AFTER`] (for measuring placements; before the first [`Self::step`]).
    pub fn set_commit(&mut self, mask: u8, after: u64, third_gives_way_after: u64) {
        self.commit_phases = mask;
        self.commit_after = after;
        self.third_gives_way_after = third_gives_way_after;
    }

    /// Keep only the path to the latest node of the lowest h made since the search (or its
    /// last commit) began and go on from it. False if there is none (the search's lowest h was
    /// last made by the node it committed to, or the root), or no room to go on: the search
    /// ends, or goes on, as it would without commits.
    pub(super) fn commit_to_best(&mut self) -> bool {
        let target = self.best_node;
        if target == self.committed_node {
            return false;
        }
        let Some(node) = self.keep_only_path(target) else {
            return false;
        };
        self.commits += 1;
        self.best_node = node;
        self.committed_node = node;
        self.regular.len = 0;
        self.preferred.len = 0;
        self.boost = 0;
        self.turn = false;
        self.last_progress = self.stats.expanded;
        self.set_novelty_table();
        // The successors come from the actions the heuristic found ready in the node's state:
        // evaluate it again.
        let cs = core::mem::take(&mut self.child_state);
        self.rebuild_state(node, cs);
        self.child_state = cs;
        let h = self.evaluate_child();
        self.push_successors(node, h).is_ok()
    }

    /// Make the path from the root to `node` the whole node store: its nodes moved to the
    /// store's start in order (each still after its parent, and the nodes that keep a state
    /// still keep it, so every state on it is rebuilt as before), the duplicate table emptied
    /// and given those nodes again. Returns `node`'s new id; None if the path is longer than
    /// the path scratch.
    pub(super) fn keep_only_path(&mut self, node: u32) -> Option<u32> {
        // The path scratch is overwritten here: no path is loaded after this, whatever the
        // outcome.
        self.loaded_node = NONE;
        let mut depth = 0usize;
        let mut n = node;
        while n != NONE {
            *self.path_nodes.get_mut(depth)? = n;
            depth += 1;
            n = self.node_parent(n);
        }
        self.path_nodes[..depth].reverse();
        // The high-water mark before the store shrinks.
        let s = self.stats();
        self.stats.peak_words = s.peak_words;
        self.loaded_node = NONE;
        self.buckets.iter_mut().for_each(|b| *b = NONE);
        let mut write = 0usize;
        let mut prev = NONE;
        for d in 0..depth {
            let old = self.path_nodes[d];
            let (_, bytes) = self.node_constraint_bytes(old);
            let state_len = if self.node_since(old) == 0 {
                let at = old as usize + NODE_HEADER + bytes.div_ceil(4);
                self.used_state_words(&self.nodes[at..])
            } else {
                0
            };
            let words = NODE_HEADER + bytes.div_ceil(4) + state_len;
            let old = old as usize;
            // Nodes are in the order made and the path's in order: `write` <= `old`.
            self.nodes.copy_within(old..old + words, write);
            self.nodes[write] = prev;
            let bucket = self.nodes[write + 3] as usize & (self.buckets.len() - 1);
            self.nodes[write + 4] = self.buckets[bucket];
            self.buckets[bucket] = write as u32;
            prev = write as u32;
            write += words;
        }
        self.nodes_used = write;
        Some(prev)
    }
}
