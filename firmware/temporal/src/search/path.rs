//! Search nodes in the arena, and the plan to a node loaded back: its steps, their ordering
//! annotations and the temporal constraints to check in the STN.

use super::*;
impl<'t, 'm> Planner<'t, 'm> {
    // ----- nodes --------------------------------------------------------------------------------

    pub(super) fn node_parent(&self, node: u32) -> u32 {
        self.nodes[node as usize]
    }
    pub(super) fn node_snap(&self, node: u32) -> u32 {
        self.nodes[node as usize + 1]
    }
    /// The hash of the node's state ([`Self::state_hash`]; the state itself is rebuilt,
    /// [`super::replay`]).
    pub(super) fn node_hash(&self, node: u32) -> u32 {
        self.nodes[node as usize + 3]
    }
    /// Snaps from the nearest node on the path that keeps its state (0: this one does).
    pub(super) fn node_since(&self, node: u32) -> u32 {
        self.nodes[node as usize + 2] >> 12 & 0xf
    }
    pub(super) fn node_constraint_bytes(&self, node: u32) -> (usize, usize) {
        let n = node as usize;
        let bytes = (self.nodes[n + 2] & 0xfff) as usize;
        (n + NODE_HEADER, bytes)
    }
    pub(super) fn state_hash(&self, state: &[u32]) -> u32 {
        let n = self.used_state_words(state);
        let mut h: u32 = 0x811c_9dc5;
        for &w in &state[..n] {
            h = (h ^ w).wrapping_mul(0x0100_0193);
            h ^= h >> 15;
        }
        h
    }
    /// Whether the state in `child_state` (hash `hash`) was stored before.
    pub(super) fn find_duplicate(&mut self, hash: u32) -> bool {
        let mut node = self.buckets[hash as usize & (self.buckets.len() - 1)];
        while node != NONE {
            if self.node_has_child_state(node, hash) {
                return true;
            }
            node = self.nodes[node as usize + 4];
        }
        false
    }

    /// Store the child state with the constraint bytes in `self.child_bytes[..bytes]`.
    pub(super) fn store_node(
        &mut self,
        parent: u32,
        snap: u32,
        h: u32,
        bytes: usize,
        hash: u32,
    ) -> Option<u32> {
        // Snaps since the last node that keeps its state (see [`STATE_EVERY`]).
        let since = if parent == NONE {
            0
        } else {
            (self.node_since(parent) + 1) % STATE_EVERY
        };
        let state_len = if since == 0 {
            self.used_state_words(self.child_state)
        } else {
            0
        };
        let words = NODE_HEADER + bytes.div_ceil(4) + state_len;
        if self.nodes_used + words + self.novelty_words > self.nodes.len() {
            return None;
        }
        let id = self.nodes_used as u32;
        let at = self.nodes_used;
        let bucket = hash as usize & (self.buckets.len() - 1);
        self.nodes[at] = parent;
        self.nodes[at + 1] = snap;
        self.nodes[at + 2] = h.min(0xffff) << 16 | since << 12 | bytes as u32;
        self.nodes[at + 3] = hash;
        self.nodes[at + 4] = self.buckets[bucket];
        self.buckets[bucket] = id;
        let cat = at + NODE_HEADER;
        for (i, chunk) in self.child_bytes[..bytes].chunks(4).enumerate() {
            let mut w = [0u8; 4];
            w[..chunk.len()].copy_from_slice(chunk);
            self.nodes[cat + i] = u32::from_le_bytes(w);
        }
        let sat = cat + bytes.div_ceil(4);
        self.nodes[sat..sat + state_len].copy_from_slice(&self.child_state[..state_len]);
        self.nodes_used += words;
        self.stats.nodes += 1;
        Some(id)
    }

    pub(super) fn constraint_byte(&self, node: u32, i: usize) -> u8 {
        let (at, _) = self.node_constraint_bytes(node);
        self.nodes[at + i / 4].to_le_bytes()[i % 4]
    }

    // ----- the loaded path ----------------------------------------------------------------------

    /// Make `node` the loaded path: its steps, decoded constraints, earliest times, last
    /// writers and its running actions' start steps. False if the plan is too long.
    ///
    /// The loaded path is cut back to where `node`'s path leaves it (undoing the last writers
    /// and earliest times its later nodes changed, from their undo logs) and `node`'s
    /// nodes after that are applied to it one by one ([`Self::extend_path`]); a node whose
    /// path meets the loaded one more than a few nodes up, or a loaded path that cannot be
    /// cut back (deeper than its marks, [`MARKED_DEPTH`], or its logs full), is loaded from the root the
    /// same way. Either way the path, its constraints and its times are those of a load from
    /// the root: the earliest times are the least schedule, which does not depend on the
    /// order it is worked out in.
    pub(super) fn load_path(&mut self, node: u32) -> Result<(), Region> {
        if self.loaded_node == node {
            return Ok(());
        }
        let previous = self.loaded_node;
        self.loaded_node = NONE;
        // The nodes of `node`'s path below the loaded path, deepest first, and how many nodes
        // of the loaded path it keeps.
        let mut above = [NONE; 32];
        let mut k = 0usize;
        let mut keep = None;
        if previous != NONE {
            let mut m = node;
            while m != NONE && k < above.len() {
                if let Ok(i) = self.path_nodes[..self.loaded_depth].binary_search(&m) {
                    keep = Some(i + 1);
                    break;
                }
                above[k] = m;
                k += 1;
                m = self.node_parent(m);
            }
        }
        let cut = match keep {
            Some(d) if d == self.loaded_depth => Some(d),
            Some(d) if self.truncatable && d <= self.path_marks.len() / 4 => Some(d),
            _ => None,
        };
        let from = if let Some(d) = cut {
            if d + k > self.path_nodes.len() {
                return Err(Region::PlanLength);
            }
            self.cut_path(d);
            for j in 0..k {
                self.path_nodes[d + j] = above[k - 1 - j];
            }
            d
        } else {
            let mut depth = 0usize;
            let mut n = node;
            while n != NONE {
                if depth >= self.path_nodes.len() {
                    return Err(Region::PlanLength);
                }
                self.path_nodes[depth] = n;
                depth += 1;
                n = self.node_parent(n);
            }
            self.path_nodes[..depth].reverse();
            k = depth;
            let ids = self.last_writer.len();
            self.last_writer[..ids].iter_mut().for_each(|x| *x = 0);
            self.loaded_depth = 0;
            self.loaded_steps = 0;
            self.loaded_constraints = 0;
            self.writer_undo_len = 0;
            self.est_undo_len = 0;
            self.truncatable = true;
            self.est_parent[0] = 0;
            0
        };
        for d in from..from + k {
            self.extend_path(d)?;
        }
        // The node's state.
        let ps = core::mem::take(&mut self.parent_state);
        self.rebuild_state(node, ps);
        self.parent_state = ps;
        // Start steps of the running actions: the last start of each.
        let steps = self.loaded_steps;
        let at = self.running_at();
        let running_n = self.parent_state[at] as usize;
        for i in 0..running_n {
            let a = self.parent_state[at + 1 + i];
            let mut s = steps;
            while s > 0 && self.path_snap[s] != a << 1 {
                s -= 1;
            }
            self.running_start[i] = s as u32;
        }
        self.loaded_node = node;
        Ok(())
    }

    /// Cut the loaded path back to its first `depth` nodes (`depth` at least 1, and at most
    /// the loaded depth; below it only if the path is truncatable and `depth` is marked): the
    /// last writers and earliest times the later nodes changed are undone.
    fn cut_path(&mut self, depth: usize) {
        if depth == self.loaded_depth {
            return;
        }
        let m = 4 * (depth - 1);
        let (steps, constraints, writers, ests) = (
            self.path_marks[m] as usize,
            self.path_marks[m + 1] as usize,
            self.path_marks[m + 2] as usize,
            self.path_marks[m + 3] as usize,
        );
        for e in (writers..self.writer_undo_len).rev() {
            self.last_writer[self.writer_undo[2 * e] as usize] = self.writer_undo[2 * e + 1];
        }
        for e in (ests..self.est_undo_len).rev() {
            self.est_parent[self.est_undo[2 * e] as usize] = self.est_undo[2 * e + 1];
        }
        self.writer_undo_len = writers;
        self.est_undo_len = ests;
        self.loaded_steps = steps;
        self.loaded_constraints = constraints;
        self.loaded_depth = depth;
    }

    /// Apply node `path_nodes[d]` (a child of the loaded path's last node, `d` its depth) to
    /// the loaded path: its steps and their last writes, its decoded constraints, and the
    /// earliest times of the path it ends ([`stn::earliest_extend`]: the steps before keep
    /// theirs unless its constraints move them), logging what a cut back would undo.
    pub(super) fn extend_path(&mut self, d: usize) -> Result<(), Region> {
        let n = self.path_nodes[d];
        let old_steps = self.loaded_steps;
        let first = self.loaded_constraints;
        let eps = self.task.epsilon();
        let mut steps = old_steps;
        let snap = self.node_snap(n);
        if snap != NONE {
            let a = snap >> 2;
            let kinds: &[u32] = match snap & 3 {
                START => &[0],
                END => &[1],
                _ => &[0, 1],
            };
            for &k in kinds {
                steps += 1;
                if steps + 2 >= self.path_snap.len() {
                    return Err(Region::PlanLength);
                }
                self.set_step(steps, a << 1 | k);
                self.record_writes(steps, a as usize, k == 1);
            }
        }
        let mut constraints = first;
        let (_, len) = self.node_constraint_bytes(n);
        let mut bytes = [0u8; MAX_NODE_CONSTRAINT_BYTES];
        for (i, b) in bytes[..len].iter_mut().enumerate() {
            *b = self.constraint_byte(n, i);
        }
        let mut at = 0;
        while at < len {
            let Ok(c) = constraints::decode(&bytes[..len], eps, &mut at) else {
                break;
            };
            if 3 * (constraints + 1) > self.path_constraints.len() {
                return Err(Region::PlanLength);
            }
            self.path_constraints[3 * constraints] = u32::from(c.before) | u32::from(c.after) << 16;
            self.path_constraints[3 * constraints + 1] = c.lb;
            self.path_constraints[3 * constraints + 2] = c.ub;
            constraints += 1;
        }
        // Earliest times of the path (consistent: it was checked when the node was stored).
        if steps > old_steps || constraints > first {
            let wins = &self.path_window;
            let window = |k: usize| (wins[2 * k], wins[2 * k + 1]);
            let words = &self.path_constraints[..3 * constraints];
            let settled = stn::earliest_extend(
                old_steps,
                steps,
                first,
                constraints,
                &|i| unpack(words, i),
                &window,
                self.est_parent,
            );
            if !settled {
                // Old steps may move: keep their times to log the ones that do.
                self.est_child[..=old_steps].copy_from_slice(&self.est_parent[..=old_steps]);
                earliest_words(steps, words, &window, self.est_parent)
                    .map_err(|_| Region::PlanLength)?;
                for s in 1..=old_steps {
                    let before = self.est_child[s];
                    if before != self.est_parent[s] {
                        if 2 * self.est_undo_len < self.est_undo.len() {
                            let e = self.est_undo_len;
                            self.est_undo[2 * e] = s as u32;
                            self.est_undo[2 * e + 1] = before;
                            self.est_undo_len += 1;
                        } else {
                            self.truncatable = false;
                        }
                    }
                }
            }
        }
        self.loaded_steps = steps;
        self.loaded_constraints = constraints;
        self.loaded_depth = d + 1;
        if d < self.path_marks.len() / 4 {
            self.path_marks[4 * d..4 * d + 4].copy_from_slice(&[
                steps as u32,
                constraints as u32,
                self.writer_undo_len as u32,
                self.est_undo_len as u32,
            ]);
        }
        Ok(())
    }

    /// Make step `k` of the loaded path the snap `snap` (`action << 1 | is_end`), with its
    /// window.
    pub(super) fn set_step(&mut self, k: usize, snap: u32) {
        self.path_snap[k] = snap;
        let (lo, hi) = step_window(&self.task, snap);
        self.path_window[2 * k] = lo;
        self.path_window[2 * k + 1] = hi;
    }

    pub(super) fn record_writes(&mut self, step: usize, a: usize, end: bool) {
        let act = self.task.action(a);
        let facts = self.task.fact_count();
        let (add, del, effs) = if end {
            (FactList::AddEnd, FactList::DelEnd, NumericList::EffEnd)
        } else {
            (
                FactList::AddStart,
                FactList::DelStart,
                NumericList::EffStart,
            )
        };
        for f in act.facts(add).iter().chain(act.facts(del).iter()) {
            self.write_id(f, step);
        }
        for e in act.numeric(effs) {
            self.write_id(facts + e.target, step);
        }
    }

    /// `last_writer[id] = step`, logging the value before for a cut back (see
    /// [`Self::load_path`]; a full log makes the path load from the root next time).
    fn write_id(&mut self, id: usize, step: usize) {
        if 2 * self.writer_undo_len < self.writer_undo.len() {
            let e = self.writer_undo_len;
            self.writer_undo[2 * e] = id as u32;
            self.writer_undo[2 * e + 1] = self.last_writer[id];
            self.writer_undo_len += 1;
        } else {
            self.truncatable = false;
        }
        self.last_writer[id] = step as u32;
    }

    /// Whether step `s` of the loaded path reads id `id` (a fact, or `facts + variable`).
    /// An end's invariants count as reads only against deletes (`for_delete`).
    pub(super) fn step_reads(&self, s: usize, id: usize, for_delete: bool) -> bool {
        let snap = self.path_snap[s];
        snap_reads(&self.task, snap >> 1, snap & 1 == 1, id, for_delete)
    }

    /// The constraints of a new step `j` (snap of `a`) on the loaded path plus `extra` steps
    /// already appended, appended to `out` (deduplicated by earlier step).
    pub(super) fn step_constraints(
        &self,
        j: usize,
        a: usize,
        end: bool,
        start_step: usize,
        out: &mut [Constraint; 64],
        n: &mut usize,
    ) -> Result<(), Region> {
        let task = self.task;
        let eps = task.epsilon();
        let facts = task.fact_count();
        let mut add = |before: usize, lb: u32, ub: u32, n: &mut usize| -> Result<(), Region> {
            if before == 0 && lb == 0 {
                return Ok(());
            }
            for c in out[..*n].iter_mut() {
                if c.before as usize == before && c.after as usize == j {
                    c.lb = c.lb.max(lb);
                    c.ub = c.ub.min(ub);
                    return Ok(());
                }
            }
            if *n == out.len() {
                return Err(Region::PlanLength);
            }
            out[*n] = Constraint {
                before: before as u16,
                after: j as u16,
                lb,
                ub,
            };
            *n += 1;
            Ok(())
        };
        // Reads: after the last writer.
        let mut reads_err = Ok(());
        for_each_read(&task, a, end, &mut |id| {
            let w = self.last_writer[id] as usize;
            if w > 0 && reads_err.is_ok() {
                reads_err = add(w, eps, UNBOUNDED, n);
            }
        });
        reads_err?;
        // Writes: after the last writer and every reader since.
        let mut writes_err = Ok(());
        for_each_write(&task, a, end, &mut |id, is_delete| {
            if writes_err.is_err() {
                return;
            }
            let w = self.last_writer[id] as usize;
            if w > 0 {
                writes_err = add(w, eps, UNBOUNDED, n);
            }
            for s in w + 1..j {
                if self.step_reads(s, id, is_delete || id >= facts) {
                    writes_err = add(s, eps, UNBOUNDED, n);
                    if writes_err.is_err() {
                        return;
                    }
                }
            }
        });
        writes_err?;
        if end {
            let ((lb, ub), _, _) = task.action_times(a);
            add(start_step, lb, ub, n)?;
        }
        Ok(())
    }
}

/// The window of plan step `snap` (`action << 1 | is_end`).
pub(super) fn step_window(task: &Task<'_>, snap: u32) -> (u32, u32) {
    let (_, start, end) = task.action_times((snap >> 1) as usize);
    if snap & 1 == 1 {
        end
    } else {
        start
    }
}

pub(super) fn unpack(words: &[u32], i: usize) -> Constraint {
    let w = words[3 * i];
    Constraint {
        before: (w & 0xffff) as u16,
        after: (w >> 16) as u16,
        lb: words[3 * i + 1],
        ub: words[3 * i + 2],
    }
}

/// [`stn::earliest`] over constraints packed three words each.
pub(super) fn earliest_words(
    steps: usize,
    words: &[u32],
    window: &dyn Fn(usize) -> (u32, u32),
    est: &mut [u32],
) -> Result<(), stn::Inconsistent> {
    stn::earliest_with(steps, words.len() / 3, &|i| unpack(words, i), window, est)
}

pub(super) fn latest_words(
    steps: usize,
    words: &[u32],
    window: &dyn Fn(usize) -> (u32, u32),
    horizon: u32,
    lst: &mut [u32],
) -> Result<(), stn::Inconsistent> {
    stn::latest_with(
        steps,
        words.len() / 3,
        &|i| unpack(words, i),
        window,
        horizon,
        lst,
    )
}

/// Every fact or variable (`facts + v`) the start or end of `a` reads, for ordering.
pub(crate) fn for_each_read(task: &Task<'_>, a: usize, end: bool, f: &mut dyn FnMut(usize)) {
    let act = task.action(a);
    let facts = task.fact_count();
    let lists: &[FactList] = if end {
        &[FactList::PreEnd]
    } else {
        &[FactList::PreStart, FactList::Invariant]
    };
    for &l in lists {
        for p in act.facts(l).iter() {
            f(p);
        }
    }
    let numeric: &[NumericList] = if end {
        &[
            NumericList::CondEnd,
            NumericList::CondInvariant,
            NumericList::EffEnd,
        ]
    } else {
        &[
            NumericList::CondStart,
            NumericList::CondInvariant,
            NumericList::EffStart,
        ]
    };
    for &l in numeric {
        for c in act.numeric(l) {
            for v in c.term_vars() {
                f(facts + v);
            }
        }
    }
}

/// Every fact or variable the start or end of `a` writes, with whether it is a delete.
pub(crate) fn for_each_write(task: &Task<'_>, a: usize, end: bool, f: &mut dyn FnMut(usize, bool)) {
    let act = task.action(a);
    let facts = task.fact_count();
    let (add, del, effs) = if end {
        (FactList::AddEnd, FactList::DelEnd, NumericList::EffEnd)
    } else {
        (
            FactList::AddStart,
            FactList::DelStart,
            NumericList::EffStart,
        )
    };
    for p in act.facts(add).iter() {
        f(p, false);
    }
    for p in act.facts(del).iter() {
        f(p, true);
    }
    for e in act.numeric(effs) {
        f(facts + e.target, false);
    }
}

/// Whether the start or end of `a` reads `id`; an end's invariants count for deletes only
/// (and numeric invariants always).
pub(crate) fn snap_reads(task: &Task<'_>, a: u32, end: bool, id: usize, for_delete: bool) -> bool {
    let facts = task.fact_count();
    if id < facts {
        // The record's first three lists only (start conditions, invariants, end conditions).
        let [pre_start, inv, pre_end] = task.leading_facts::<3>(a as usize);
        if end {
            pre_end.contains(id) || (for_delete && inv.contains(id))
        } else {
            pre_start.contains(id) || inv.contains(id)
        }
    } else {
        let mut found = false;
        for_each_read(task, a as usize, end, &mut |x| found |= x == id);
        found
    }
}
