//! The records' CRC-32, slice-by-4 with tables built at compile time, and its check against
//! the `crc` crate's reference.

/// The records' CRC-32 (ISO-HDLC, the `crc` crate's `CRC_32_ISO_HDLC`: reflected polynomial
/// 0xEDB88320, initial value and final XOR all ones), four bytes per step with four 256-entry
/// tables (slice-by-4, 4 KiB of tables): about 4 instructions per byte on the 750 where the
/// byte-at-a-time table takes about 9. A warm boot checks the record it restores (about a
/// kilobyte) and every frame writes two; the values are the same (see the tests).
pub(super) struct Crc32 {
    value: u32,
}

/// `CRC32_TABLES[k][b]`: the CRC register after byte `b` followed by `k` zero bytes.
static CRC32_TABLES: [[u32; 256]; 4] = crc32_tables();

// Evaluated at compile time only (the static's initialiser): an index out of range would be a
// compile error, never a panic at run time.
#[allow(clippy::indexing_slicing)]
const fn crc32_tables() -> [[u32; 256]; 4] {
    let mut tables = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 256 {
        let mut crc = b as u32;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
            bit += 1;
        }
        tables[0][b] = crc;
        b += 1;
    }
    let mut k = 1;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            let previous = tables[k - 1][b];
            tables[k][b] = (previous >> 8) ^ tables[0][(previous & 0xFF) as usize];
            b += 1;
        }
        k += 1;
    }
    tables
}

impl Crc32 {
    pub(super) const fn new() -> Self {
        Self { value: u32::MAX }
    }

    pub(super) fn update(&mut self, bytes: &[u8]) {
        // `i & 0xFF` is always in range: the compiler drops the check and `get` never fails.
        let at = |table: &[u32; 256], i: u32| table.get((i & 0xFF) as usize).copied().unwrap_or(0);
        // One base register per table, opaque to the compiler: it then looks a byte up with one
        // indexed load (`lwzx`). Knowing the four tables' places, it added the table's offset
        // to the index first, a third instruction per byte (19 instructions per four bytes, 15
        // now). `black_box` costs nothing but the four registers, set once per call.
        let [t0, t1, t2, t3] = &CRC32_TABLES;
        let (t0, t1, t2, t3) = (
            core::hint::black_box(t0),
            core::hint::black_box(t1),
            core::hint::black_box(t2),
            core::hint::black_box(t3),
        );
        let mut crc = self.value;
        let mut words = bytes.chunks_exact(4);
        for w in &mut words {
            let (Some(&a), Some(&b), Some(&c), Some(&d)) =
                (w.first(), w.get(1), w.get(2), w.get(3))
            else {
                break;
            };
            crc ^= u32::from_le_bytes([a, b, c, d]);
            crc = at(t3, crc) ^ at(t2, crc >> 8) ^ at(t1, crc >> 16) ^ at(t0, crc >> 24);
        }
        for &byte in words.remainder() {
            crc = at(t0, crc ^ u32::from(byte)) ^ (crc >> 8);
        }
        self.value = crc;
    }

    pub(super) const fn finalize(self) -> u32 {
        !self.value
    }
}

#[cfg(test)]
mod tests {
    use super::Crc32;
    use crc::{Crc, CRC_32_ISO_HDLC};

    /// The `crc` crate's byte-at-a-time CRC-32 (ISO-HDLC) that the records used before.
    const REFERENCE: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

    #[test]
    fn the_slice_by_4_crc_is_the_iso_hdlc_crc_for_every_length_alignment_and_split() {
        // "123456789" is the catalogue's check value.
        let mut d = Crc32::new();
        d.update(b"123456789");
        assert_eq!(d.finalize(), 0xCBF4_3926);
        let mut x = 0x1234_5678u32;
        let bytes: [u8; 300] = core::array::from_fn(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        });
        for start in 0..4 {
            for len in 0..bytes.len() - start {
                let data = bytes.get(start..start + len).unwrap_or(&[]);
                for split in [0, 1, 3, 16, len / 2, len] {
                    let (a, b) = data.split_at(split.min(len));
                    let mut d = Crc32::new();
                    d.update(a);
                    d.update(b);
                    assert_eq!(
                        d.finalize(),
                        REFERENCE.checksum(data),
                        "{start} {len} {split}"
                    );
                }
            }
        }
    }
}
