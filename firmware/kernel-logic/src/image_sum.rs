//! The RAM image's checksum, as the reset stub computes it (`boot.rs`, routine 40) and the
//! kernel's check of the deferred code before it first runs (`kernel/deferred.rs`, the same
//! `lmw` loop): the definition, tested on the host.
//!
//! Two 32-bit words: a chain that takes the words in turn, adding one and XORing the next
//! (both steps are bijections of the chain and of the word, so any damage confined to one word
//! changes the chain's end; since they do not commute, so do two words swapped), and the sum
//! of the chain after each block (Fletcher's second sum at block granularity: blocks in the
//! wrong order change it). The blocks are those of the stub's `lmw`: 24 words while 24 are
//! left, then 8 at a time; a trailing part shorter than 8 words is not summed (the linker
//! aligns both parts of the image to 32 bytes).

/// Words per block while at least that many are left.
pub const BLOCK_WORDS: usize = 24;
/// Words per block for the rest.
pub const TAIL_BLOCK_WORDS: usize = 8;

/// The chain's end and the sum of the chain after each block, over `words`.
pub fn image_sums(words: &[u32]) -> (u32, u32) {
    let (head, tail) = words.as_chunks::<BLOCK_WORDS>();
    let mut sums = (0u32, 0u32);
    for block in head {
        sums = block_sums(sums, block);
    }
    for block in tail.as_chunks::<TAIL_BLOCK_WORDS>().0 {
        sums = block_sums(sums, block);
    }
    sums
}

/// One block: the chain through its words (a fixed number of them, so the loop unrolls to a
/// load and one add or XOR per word), then the chain added to the second sum.
#[inline(always)]
fn block_sums<const N: usize>((mut chain, blocks): (u32, u32), block: &[u32; N]) -> (u32, u32) {
    for [even, odd] in block.as_chunks::<2>().0 {
        chain = chain.wrapping_add(*even) ^ *odd;
    }
    (chain, blocks.wrapping_add(chain))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn image() -> Vec<u32> {
        // 24 * 3 + 8 * 2 words: both kinds of block.
        (0..88u32)
            .map(|i| i.wrapping_mul(0x9e37_79b9) ^ 0x5a5a_0f0f)
            .collect()
    }

    #[test]
    fn the_sums_follow_the_stubs_blocks() {
        // Worked by hand for 8 words (one tail block): chain = ((0+1)^2 + 3)^4 ... ; blocks = chain.
        let words = [1u32, 2, 3, 4, 5, 6, 7, 8];
        let mut chain = 0u32;
        for pair in words.chunks(2) {
            chain = chain.wrapping_add(pair[0]) ^ pair[1];
        }
        assert_eq!(image_sums(&words), (chain, chain));
        // 32 words: a 24-word block, then an 8-word one; the second sum adds the chain after each.
        let words: Vec<u32> = (1..=32).collect();
        let (first, _) = image_sums(&words[..24]);
        let (end, blocks) = image_sums(&words);
        assert_eq!(blocks, first.wrapping_add(end));
    }

    #[test]
    fn any_single_bit_flip_changes_the_sums() {
        let pristine = image();
        let sums = image_sums(&pristine);
        for word in 0..pristine.len() {
            for bit in [0, 7, 16, 31] {
                let mut damaged = pristine.clone();
                damaged[word] ^= 1 << bit;
                assert_ne!(image_sums(&damaged), sums, "word {word} bit {bit}");
            }
        }
    }

    #[test]
    fn swapped_words_and_blocks_change_the_sums() {
        let pristine = image();
        let sums = image_sums(&pristine);
        let mut swapped = pristine.clone();
        swapped.swap(3, 4);
        assert_ne!(image_sums(&swapped), sums);
        let mut blocks = pristine.clone();
        blocks[..48].rotate_left(24);
        assert_ne!(image_sums(&blocks), sums);
    }

    #[test]
    fn words_short_of_a_tail_block_are_not_summed() {
        let pristine = image();
        let mut longer = pristine.clone();
        longer.extend([1, 2, 3]);
        assert_eq!(image_sums(&longer), image_sums(&pristine));
    }
}
