//! Enforced hill-climbing (FF's EHC, Hoffmann and Nebel 2001), the first search of the
//! portfolio: from the state reached so far, a breadth-first search over the successors the
//! relaxed plan prefers (helpful actions) until a state with a lower h turns up; that state is
//! committed to and the next breadth-first search starts from it. Seed 001's section 4 and FF
//! both fall back to best-first search where the climb fails: here, when a breadth-first search
//! runs out of successors or memory, the best-first searches of the portfolio run from the root
//! ([`super::ORDERED_RESTART_AFTER`]).
//!
//! Why: on driverlog the best-first searches spend tens of thousands of evaluations on
//! plateaus (h stays at 4 to 10 while drivers walk and trucks drive back), weighing every open
//! state of the plateau against all the others, and fill the arena with nodes on the larger
//! instances. A breadth-first search from the last better state explores the plateau nearest
//! to it, in order of distance, and stops at its first exit.
//!
//! Memory: on a commit the node store keeps only the path to the committed state (moved to the
//! store's start, in order; [`Planner::keep_only_path`]), the duplicate table holds only those
//! nodes and the open list is emptied, so the store holds one plan and one breadth-first search
//! at a time, however long the climb.
//!
//! Within a breadth-first search every repeated state is pruned (as FF does): the climb may
//! lose plans that need concurrency, like the third search, and the searches after it decide.
use super::*;

impl<'t, 'm> Planner<'t, 'm> {
    /// Make the path from the root to `node` the whole node store: its nodes moved to the
    /// store's start in order (each still after its parent, so the open lists' ties by node
    /// keep their order), the duplicate table emptied and given those nodes again. Returns
    /// `node`'s new id; None if the path is longer than the path scratch (the caller treats it
    /// as a plan too long).
    pub(super) fn keep_only_path(&mut self, node: u32) -> Option<u32> {
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
            let old = self.path_nodes[d] as usize;
            let state_len = self.nodes[old + 3] as usize;
            let bytes = (self.nodes[old + 2] & 0xffff) as usize;
            let words = NODE_HEADER + state_len + bytes.div_ceil(4);
            self.nodes.copy_within(old..old + words, write);
            self.nodes[write] = prev;
            let hash = self.state_hash(&self.nodes[write + NODE_HEADER..]);
            let bucket = hash as usize & (self.buckets.len() - 1);
            self.nodes[write + 4] = self.buckets[bucket];
            self.buckets[bucket] = write as u32;
            prev = write as u32;
            write += words;
        }
        self.nodes_used = write;
        Some(prev)
    }

    /// The climb found a state better than the one it last committed to (`node`, whose state
    /// is in `child_state` and was evaluated last): commit to it and start the next
    /// breadth-first search from it.
    pub(super) fn commit_climb(&mut self, node: u32, h: u32) -> Result<(), Region> {
        let node = self.keep_only_path(node).ok_or(Region::PlanLength)?;
        self.climb_node = node;
        self.best_node = node;
        self.climb_since = self.stats.expanded;
        self.climb_helpful = self.config.preferred_operators;
        self.regular.len = 0;
        self.preferred.len = 0;
        self.push_successors(node, h)
    }

    /// The breadth-first search over helpful successors found no better state: search again
    /// from the state last committed to, over every successor (the helpful ones alone miss the
    /// exit where the relaxed plan's actions are not the way out, as at driverlog's last
    /// deliveries). False if the search was over every successor already.
    pub(super) fn widen_climb(&mut self) -> Result<bool, Region> {
        if !self.climb_helpful {
            return Ok(false);
        }
        self.climb_from(self.climb_node, false)?;
        Ok(true)
    }

    /// Start a breadth-first search of the climb from `node` (over helpful successors only if
    /// `helpful`), keeping only the path to it.
    pub(super) fn climb_from(&mut self, node: u32, helpful: bool) -> Result<(), Region> {
        self.climb_helpful = helpful;
        self.climb_since = self.stats.expanded;
        let node = self.keep_only_path(node).ok_or(Region::PlanLength)?;
        self.climb_node = node;
        self.best_node = node;
        self.regular.len = 0;
        self.preferred.len = 0;
        // The heuristic marks the ready actions the successors are generated from: evaluate
        // the state again.
        let task = self.task;
        let len = self.used_state_words(self.node_state(node));
        let at = node as usize + NODE_HEADER;
        self.child_state[..len].copy_from_slice(&self.nodes[at..at + len]);
        let h = {
            let cs = &*self.child_state;
            let ra = self.running_at();
            let rn = cs[ra] as usize;
            self.stats.evaluated += 1;
            self.relax
                .evaluate(&task, &cs[..self.fact_words], &cs[ra + 1..ra + 1 + rn])
        };
        self.push_successors(node, h)
    }

    /// The ordered search stalled: climb from the best state it found (its h is the h to
    /// beat), and if the climb fails, search `then` of the portfolio runs from the root.
    pub(super) fn climb_from_best(&mut self, then: u8) {
        self.climbing = true;
        self.phase = then;
        self.duplicates = Duplicates::PruneAll;
        self.boost = 0;
        self.turn = false;
        if self
            .climb_from(self.best_node, self.config.preferred_operators)
            .is_err()
        {
            self.end_climb();
        }
    }

    /// The climb failed (no better state within its breadth-first search, or no memory for
    /// it): the best-first searches take over from the root.
    pub(super) fn end_climb(&mut self) {
        self.climbing = false;
        if self.phase == 4 {
            // Best-first from the best state the climb reached.
            self.duplicates = self.config.duplicates;
            self.boost_amount = BOOST_SECOND;
            self.boost = 0;
            self.turn = false;
            self.shed_base = self.stats.shed;
            self.stats.restarts += 1;
            if let Err(r) = self.climb_from(self.best_node, false) {
                self.status = Status::OutOfMemory(r);
            }
            return;
        }
        self.restart(self.phase);
    }

    /// Start the climb from the root; when it fails, search `then` of the portfolio follows.
    pub(super) fn start_climb(&mut self, then: u8) {
        self.climbing = true;
        self.climb_node = 0;
        self.climb_helpful = self.config.preferred_operators;
        self.restart(then);
        self.duplicates = Duplicates::PruneAll;
        self.climb_since = self.stats.expanded;
    }

    /// The climb's breadth-first search from its last committed state has run
    /// `climb_limit` expansions without a better state.
    pub(super) fn climb_stalled(&self) -> bool {
        self.stats.expanded - self.climb_since > self.climb_limit
    }
}
