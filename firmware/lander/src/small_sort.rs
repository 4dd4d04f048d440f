//! An insertion sort for the short index lists the downlink manager orders (at most
//! [`crate::capacity::MAX_DATA_PRODUCTS`] entries), in place of `sort_unstable_by`: with crate
//! `lander` at opt-level 2, core's quicksort monomorphised for one comparison closure was
//! 44 KB of code (15 KB for another), most of the image growth of that change. The orders it
//! is used for are total (their last key is the entry's index), so every correct sort gives
//! the same result: the decisions do not change (`tests` below check it against the library's
//! sort).
use core::cmp::Ordering;

/// Sorts `v` by `cmp` (insertion sort: quadratic, for short lists).
pub fn sort_small<T: Copy>(v: &mut [T], mut cmp: impl FnMut(&T, &T) -> Ordering) {
    for i in 1..v.len() {
        let Some(&x) = v.get(i) else {
            break;
        };
        let mut j = i;
        while j > 0 {
            let Some(prev) = v.get(j - 1).copied() else {
                break;
            };
            if cmp(&prev, &x) != Ordering::Greater {
                break;
            }
            if let Some(slot) = v.get_mut(j) {
                *slot = prev;
            }
            j -= 1;
        }
        if let Some(slot) = v.get_mut(j) {
            *slot = x;
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    /// The same order as the library's unstable sort under a total order, on seeded random
    /// lists with many equal primary keys (the index breaks the ties), empty and one long.
    #[test]
    fn sorts_as_the_library_under_a_total_order() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for len in 0..=64usize {
            for _ in 0..20 {
                let keys: [u64; 64] = core::array::from_fn(|_| next() % 5);
                let mut mine: [u8; 64] = core::array::from_fn(|i| (63 - i) as u8);
                let mut theirs = mine;
                let order = |a: &u8, b: &u8| {
                    keys[usize::from(*a)]
                        .cmp(&keys[usize::from(*b)])
                        .then(a.cmp(b))
                };
                sort_small(&mut mine[..len], order);
                theirs[..len].sort_unstable_by(order);
                assert_eq!(mine, theirs, "{len}");
                assert!(mine[..len].windows(2).all(|w| order(&w[0], &w[1]).is_lt()));
            }
        }
    }
}
