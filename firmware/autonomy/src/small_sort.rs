//! A sort for the executive's per-step ordering of its tasks, small in code.
//!
//! The library's `sort_unstable` instantiates its quicksort, pivot selection and sorting
//! networks (about 4 KiB a type) in the RAM image that the reset stub checks at every warm boot.
//! The library's sorts are otherwise called only by the temporal planner's and the lander's
//! code, so with the executive's call gone the linker script places all of them in the
//! deferred code (checked only before it first runs: see "What a warm boot checks, and when"
//! in the README). This sorts as the library does for keys that are all different (the
//! executive sorts by planned start, then instance id, which is unique): insertion for up to
//! [`INSERTION_MAX`] elements (the library's own choice; a task list already in order costs
//! one comparison per element), heapsort above (no quadratic worst case at capacity).

/// Up to this many elements, insertion sort (as the library's `sort_unstable`).
pub const INSERTION_MAX: usize = 20;

/// Sorts `v` in increasing order.
pub fn sort<T: Ord>(v: &mut [T]) {
    if v.len() <= INSERTION_MAX {
        insertion(v);
    } else {
        heapsort(v);
    }
}

fn insertion<T: Ord>(v: &mut [T]) {
    for i in 1..v.len() {
        let mut j = i;
        while j > 0 && v.get(j - 1) > v.get(j) {
            v.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// Sorts `v` in increasing order by heapsort (no quadratic worst case; a few hundred bytes of
/// code a type). Also the MEXEC planner's sort of its candidate starts.
pub fn heapsort<T: Ord>(v: &mut [T]) {
    fn sift_down<T: Ord>(v: &mut [T], mut root: usize, end: usize) {
        loop {
            let mut child = 2 * root + 1;
            if child >= end {
                return;
            }
            if child + 1 < end && v.get(child) < v.get(child + 1) {
                child += 1;
            }
            if v.get(root) >= v.get(child) {
                return;
            }
            v.swap(root, child);
            root = child;
        }
    }
    let n = v.len();
    for start in (0..n / 2).rev() {
        sift_down(v, start, n);
    }
    for end in (1..n).rev() {
        v.swap(0, end);
        sift_down(v, 0, end);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    proptest! {
        #[test]
        fn sorts_as_the_library_does(
            values in proptest::collection::vec((any::<u16>(), any::<u8>()), 0..300),
        ) {
            let mut ours = values.clone();
            sort(&mut ours);
            let mut sorted = values;
            sorted.sort_unstable();
            prop_assert_eq!(ours, sorted);
        }
    }

    #[test]
    fn both_branches_are_taken() {
        // Short (insertion) and long (heapsort), each reversed: every element moves.
        for n in [INSERTION_MAX, INSERTION_MAX + 1, 256] {
            let mut v: Vec<u32> = (0..n as u32).rev().collect();
            sort(&mut v);
            assert_eq!(v, (0..n as u32).collect::<Vec<_>>(), "{n} elements");
        }
    }
}
