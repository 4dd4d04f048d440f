//! A fixed-capacity text buffer that `const fn` code can write, so the configuration checker
//! can name the offending entry in a compile-time panic ("window 3 (planner) overlaps ...").

/// Bytes a message holds; longer text is cut.
pub const MESSAGE_CAPACITY: usize = 240;

#[derive(Clone, Copy)]
pub struct Message {
    bytes: [u8; MESSAGE_CAPACITY],
    len: usize,
}

impl Message {
    pub const fn new() -> Self {
        Self {
            bytes: [0; MESSAGE_CAPACITY],
            len: 0,
        }
    }

    const fn byte(mut self, b: u8) -> Self {
        if self.len < MESSAGE_CAPACITY {
            self.bytes[self.len] = b;
            self.len += 1;
        }
        self
    }

    /// Append text (ASCII is kept whole; a cut never splits a UTF-8 sequence because only
    /// whole `str`s of ASCII names and literals are appended here).
    pub const fn str(mut self, s: &str) -> Self {
        let b = s.as_bytes();
        let mut i = 0;
        while i < b.len() {
            self = self.byte(b[i]);
            i += 1;
        }
        self
    }

    /// Append a decimal number.
    pub const fn num(mut self, mut n: u64) -> Self {
        let mut digits = [0u8; 20];
        let mut count = 0;
        loop {
            digits[count] = b'0' + (n % 10) as u8;
            count += 1;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        while count > 0 {
            count -= 1;
            self = self.byte(digits[count]);
        }
        self
    }

    /// Append `0x` and eight hex digits.
    pub const fn hex(mut self, n: u32) -> Self {
        self = self.str("0x");
        let mut shift = 32;
        while shift > 0 {
            shift -= 4;
            let d = ((n >> shift) & 0xf) as u8;
            self = self.byte(if d < 10 { b'0' + d } else { b'a' + d - 10 });
        }
        self
    }

    pub const fn as_str(&self) -> &str {
        let (used, _) = self.bytes.split_at(self.len);
        match core::str::from_utf8(used) {
            Ok(s) => s,
            Err(_) => "kernel configuration: (unprintable message)",
        }
    }
}

impl Default for Message {
    fn default() -> Self {
        Self::new()
    }
}

impl core::fmt::Debug for Message {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl core::fmt::Display for Message {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}
