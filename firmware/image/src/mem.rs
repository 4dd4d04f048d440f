//! `memcpy`, `memmove`, `memset`, `memcmp` and `bcmp`: libcore calls them, and nothing provides
//! them for this target. Written with volatile accesses so the compiler cannot turn the loops
//! back into calls to themselves; word-sized where both pointers allow it.

use core::ptr::{read_volatile, write_volatile};

/// # Safety
/// 1. `dest` and `src` are valid for `n` bytes and do not overlap.
#[no_mangle]
pub unsafe extern "C" fn memcpy(dest: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    let mut i = 0;
    if (dest as usize | src as usize) & 3 == 0 {
        while i + 4 <= n {
            write_volatile(
                dest.add(i) as *mut u32,
                read_volatile(src.add(i) as *const u32),
            );
            i += 4;
        }
    }
    while i < n {
        write_volatile(dest.add(i), read_volatile(src.add(i)));
        i += 1;
    }
    dest
}

/// # Safety
/// 1. `dest` and `src` are valid for `n` bytes; they may overlap.
#[no_mangle]
pub unsafe extern "C" fn memmove(dest: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    if (dest as usize) <= (src as usize) || (dest as usize) >= (src as usize) + n {
        // Forward copy is safe when dest is before src or the ranges do not overlap.
        let mut i = 0;
        while i < n {
            write_volatile(dest.add(i), read_volatile(src.add(i)));
            i += 1;
        }
    } else {
        let mut i = n;
        while i > 0 {
            i -= 1;
            write_volatile(dest.add(i), read_volatile(src.add(i)));
        }
    }
    dest
}

/// # Safety
/// 1. `dest` is valid for `n` bytes.
#[no_mangle]
pub unsafe extern "C" fn memset(dest: *mut u8, c: i32, n: usize) -> *mut u8 {
    let byte = c as u8;
    let mut i = 0;
    if dest as usize & 3 == 0 {
        let word = u32::from_ne_bytes([byte; 4]);
        while i + 4 <= n {
            write_volatile(dest.add(i) as *mut u32, word);
            i += 4;
        }
    }
    while i < n {
        write_volatile(dest.add(i), byte);
        i += 1;
    }
    dest
}

/// # Safety
/// 1. `a` and `b` are valid for `n` bytes.
#[no_mangle]
pub unsafe extern "C" fn memcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    let mut i = 0;
    while i < n {
        let (x, y) = (read_volatile(a.add(i)), read_volatile(b.add(i)));
        if x != y {
            return i32::from(x) - i32::from(y);
        }
        i += 1;
    }
    0
}

/// # Safety
/// 1. `a` and `b` are valid for `n` bytes.
#[no_mangle]
pub unsafe extern "C" fn bcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    memcmp(a, b, n)
}
