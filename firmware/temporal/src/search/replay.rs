//! States rebuilt from the plan instead of stored in every node (issue 13: driverlog 16 to 20
//! filled the 8 MiB arena with nodes). A node keeps its parent, its snap, its h, its state's
//! hash, its duplicate-chain link and its constraint bytes; one node in [`STATE_EVERY`] along
//! a path (the root, and every node that many snaps below one that does) also keeps its
//! state. Any other node's state is the nearest such ancestor's with the snaps after it
//! applied, rebuilt when the search needs it: the loaded path's end
//! state on each expansion ([`Planner::load_path`]), and a stored state only where its hash
//! equals a new state's (the duplicate table, [`Planner::find_duplicate`], and the ancestors
//! [`Planner::repeats_ancestor`] compares). Every node on a path was checked applicable when
//! it was stored, so applying the snaps' effects again, without the checks, gives the state
//! it had; the search, node for node, is the one that stored states.
use super::*;

impl<'t, 'm> Planner<'t, 'm> {
    /// Apply the effects of snap id `snap` (start, end or compressed) of a node already
    /// checked applicable to `state`, as [`Self::apply`] did: deletes, then adds, numeric
    /// effects on the values before the snap, the running list kept sorted.
    pub(super) fn replay(&self, state: &mut [u32], snap: u32) {
        let a = (snap >> 2) as usize;
        match snap & 3 {
            START => self.replay_snap(state, a, false),
            END => self.replay_snap(state, a, true),
            _ => {
                self.replay_snap(state, a, false);
                self.replay_snap(state, a, true);
            }
        }
    }

    fn replay_snap(&self, state: &mut [u32], a: usize, end: bool) {
        let act = self.task.action(a);
        let (add, del, effs) = if end {
            (FactList::AddEnd, FactList::DelEnd, NumericList::EffEnd)
        } else {
            (
                FactList::AddStart,
                FactList::DelStart,
                NumericList::EffStart,
            )
        };
        let mut new_values = [(0usize, 0i64); 16];
        let mut n_values = 0;
        for e in act.numeric(effs) {
            if let (Some(x), true) = (
                e.apply(&|v| self.value(state, v)),
                n_values < new_values.len(),
            ) {
                new_values[n_values] = (e.target, x);
                n_values += 1;
            }
        }
        for f in act.facts(del).iter() {
            Self::set_fact(state, f, false);
        }
        for f in act.facts(add).iter() {
            Self::set_fact(state, f, true);
        }
        for &(v, x) in &new_values[..n_values] {
            self.set_value(state, v, x);
        }
        let at = self.running_at();
        let n = state[at] as usize;
        let list = &mut state[at + 1..at + 1 + MAX_RUNNING];
        if end {
            if let Ok(i) = list[..n].binary_search(&(a as u32)) {
                list.copy_within(i + 1..n, i);
                state[at] -= 1;
            }
        } else if n < MAX_RUNNING {
            let i = list[..n].partition_point(|&x| x < a as u32);
            list.copy_within(i..n, i + 1);
            list[i] = a as u32;
            state[at] += 1;
        }
    }

    /// Rebuild the state of `node` into `out`: the state kept by the nearest node of its path
    /// that keeps one (at most [`STATE_EVERY`] - 1 snaps up), with the snaps after it applied.
    pub(super) fn rebuild_state(&self, node: u32, out: &mut [u32]) {
        let mut after = [NONE; STATE_EVERY as usize];
        let mut m = 0;
        let mut n = node;
        while self.node_since(n) != 0 && m < after.len() {
            after[m] = n;
            m += 1;
            n = self.node_parent(n);
        }
        let (at, bytes) = self.node_constraint_bytes(n);
        let at = at + bytes.div_ceil(4);
        let len = self.used_state_words(&self.nodes[at..]);
        out[..len].copy_from_slice(&self.nodes[at..at + len]);
        for &n in after[..m].iter().rev() {
            self.replay(out, self.node_snap(n));
        }
    }

    /// The state a node keeps (one with [`Self::node_since`] 0).
    fn node_stored_state(&self, node: u32) -> &[u32] {
        let (at, bytes) = self.node_constraint_bytes(node);
        &self.nodes[at + bytes.div_ceil(4)..]
    }

    /// Whether the state of `node` equals `child_state` (compared over the words the child
    /// uses), rebuilt in `probe_state` only if the stored hash is `hash`.
    pub(super) fn node_has_child_state(&mut self, node: u32, hash: u32) -> bool {
        if self.node_hash(node) != hash {
            return false;
        }
        let probe = core::mem::take(&mut self.probe_state);
        self.rebuild_state(node, probe);
        let n = self.used_state_words(self.child_state);
        let same = probe[..n] == self.child_state[..n];
        self.probe_state = probe;
        same
    }
}

impl<'t, 'm> Planner<'t, 'm> {
    /// For tests, between calls of [`Self::step`]: every stored node's state rebuilt by
    /// [`Self::rebuild_state`] against the straightforward computation, the search's own
    /// checked [`Self::apply`] of each snap of the node's path from the initial state, with the
    /// running actions' invariants protected as the search does (every snap must still apply),
    /// and against the hash stored when the node was made from the state the search had then.
    /// The number of nodes checked, or the first node that differs.
    #[doc(hidden)]
    pub fn verify_node_states(&mut self) -> Result<usize, u32> {
        let mut node = 0usize;
        let mut count = 0;
        let mut path = [0u32; MAX_STEPS];
        while node < self.nodes_used {
            let id = node as u32;
            let probe = core::mem::take(&mut self.probe_state);
            self.rebuild_state(id, probe);
            self.probe_state = probe;
            let state_len = if self.node_since(id) == 0 {
                self.used_state_words(self.node_stored_state(id))
            } else {
                0
            };
            // The path, root first.
            let mut depth = 0;
            let mut n = id;
            while n != NONE && depth < path.len() {
                path[depth] = n;
                depth += 1;
                n = self.node_parent(n);
            }
            let state = core::mem::take(&mut self.child_state);
            self.initial_state(state);
            let mut applied = n == NONE;
            for &p in path[..depth].iter().rev() {
                let snap = self.node_snap(p);
                if snap == NONE {
                    continue;
                }
                let mut running = [0u32; MAX_RUNNING];
                let rn = state[self.running_at()] as usize;
                running[..rn].copy_from_slice(self.running(state));
                self.load_protection(&running[..rn], true);
                applied &= self.apply(state, snap);
                self.load_protection(&running[..rn], false);
            }
            let used = self.used_state_words(state);
            let same = applied
                && self.probe_state[..used] == state[..used]
                && self.state_hash(state) == self.node_hash(id);
            self.child_state = state;
            if !same {
                return Err(id);
            }
            count += 1;
            let (_, bytes) = self.node_constraint_bytes(id);
            node += NODE_HEADER + bytes.div_ceil(4) + state_len;
        }
        self.loaded_node = NONE;
        // An elimination under way keeps a state in `probe_state`: worked out again.
        self.elimination_scratch_lost();
        Ok(count)
    }
}
