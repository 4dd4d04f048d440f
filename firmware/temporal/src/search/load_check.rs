//! A check, for tests, that loading a node's path by cutting the loaded path back and
//! extending it ([`Planner::load_path`]) leaves what a load from the root leaves.
use super::*;

/// FNV-1a over words, folded into `h`.
fn fold(h: &mut u64, words: &[u32]) {
    for &w in words {
        *h = (*h ^ u64::from(w)).wrapping_mul(0x0000_0100_0000_01b3);
    }
}

impl<'t, 'm> Planner<'t, 'm> {
    /// A digest of the loaded path: its depth, steps and their windows, constraints,
    /// earliest times, last writers, running actions' start steps and state, and its undo
    /// logs and marks.
    fn loaded_digest(&self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let steps = self.loaded_steps;
        fold(
            &mut h,
            &[
                self.loaded_depth as u32,
                steps as u32,
                self.loaded_constraints as u32,
            ],
        );
        fold(&mut h, &self.path_nodes[..self.loaded_depth]);
        fold(&mut h, &self.path_snap[1..=steps]);
        fold(&mut h, &self.path_window[2..2 * (steps + 1)]);
        fold(
            &mut h,
            &self.path_constraints[..3 * self.loaded_constraints],
        );
        fold(&mut h, &self.est_parent[..=steps]);
        fold(&mut h, self.last_writer);
        let used = self.used_state_words(self.parent_state);
        fold(&mut h, &self.parent_state[..used]);
        let running = self.parent_state[self.running_at()] as usize;
        fold(&mut h, &self.running_start[..running]);
        // What a later cut back reads: equal logs make a load after a cut and one after a load
        // from the root the same (so comparing each node's two loads covers chains of cuts).
        fold(&mut h, &self.writer_undo[..2 * self.writer_undo_len]);
        fold(&mut h, &self.est_undo[..2 * self.est_undo_len]);
        let marked = self.loaded_depth.min(self.path_marks.len() / 4);
        fold(&mut h, &self.path_marks[..4 * marked]);
        fold(&mut h, &[u32::from(self.truncatable)]);
        h
    }

    /// For tests, between calls of [`Self::step`]: load the stored nodes' paths one after
    /// the other, in the store's order and in strides through it (so the loaded path is cut
    /// back and extended in every way the search's moves between nodes do, and more), each
    /// from the path loaded before and then from the root, and compare the two: the same path,
    /// constraints, earliest times, last writers, running actions' start steps and state.
    /// The number of loads compared, or the first node whose two loads differ.
    #[doc(hidden)]
    pub fn verify_path_loads(&mut self) -> Result<usize, u32> {
        let mut count = 0;
        for stride in [1usize, 7] {
            for phase in 0..stride {
                let mut node = 0usize;
                let mut index = 0usize;
                while node < self.nodes_used {
                    let id = node as u32;
                    if index % stride == phase {
                        let cut = self.load_path(id).map(|()| self.loaded_digest());
                        self.loaded_node = NONE;
                        let full = self.load_path(id).map(|()| self.loaded_digest());
                        if cut != full {
                            self.loaded_node = NONE;
                            return Err(id);
                        }
                        count += 1;
                    }
                    index += 1;
                    let (_, bytes) = self.node_constraint_bytes(id);
                    let state_len = if self.node_since(id) == 0 {
                        let at = node + NODE_HEADER + bytes.div_ceil(4);
                        self.used_state_words(&self.nodes[at..])
                    } else {
                        0
                    };
                    node += NODE_HEADER + bytes.div_ceil(4) + state_len;
                }
            }
        }
        Ok(count)
    }
}
