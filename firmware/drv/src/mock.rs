//! A register mock for the drivers' host tests: it logs every access in order, and answers
//! reads from a per-register script (consumed one value per read), else from a fixed value;
//! a read of a register with neither fails the test.
extern crate std;

use std::cell::RefCell;
use std::collections::{BTreeMap, VecDeque};
use std::vec::Vec;

use crate::Bus;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    R8(usize, u8),
    W8(usize, u8),
    R32(usize, u32),
    W32(usize, u32),
}

#[derive(Default)]
pub struct MockBus {
    log: RefCell<Vec<Access>>,
    script: RefCell<BTreeMap<usize, VecDeque<u32>>>,
    fixed: RefCell<BTreeMap<usize, u32>>,
}

impl MockBus {
    pub fn new() -> Self {
        Self::default()
    }

    /// The next reads of `addr` return `values`, one each, before its fixed value.
    pub fn script(&self, addr: usize, values: &[u32]) {
        self.script
            .borrow_mut()
            .entry(addr)
            .or_default()
            .extend(values.iter().copied());
    }

    /// Reads of `addr` return `value` once its script is used up.
    pub fn fix(&self, addr: usize, value: u32) {
        self.fixed.borrow_mut().insert(addr, value);
    }

    /// Every access so far, in order; the log is emptied.
    pub fn take_log(&self) -> Vec<Access> {
        core::mem::take(&mut *self.log.borrow_mut())
    }

    /// The writes so far, in order (the log is kept).
    pub fn writes(&self) -> Vec<Access> {
        self.log
            .borrow()
            .iter()
            .copied()
            .filter(|a| matches!(a, Access::W8(..) | Access::W32(..)))
            .collect()
    }

    /// True when every scripted read was consumed.
    pub fn script_done(&self) -> bool {
        self.script.borrow().values().all(VecDeque::is_empty)
    }

    fn value(&self, addr: usize) -> u32 {
        if let Some(v) = self
            .script
            .borrow_mut()
            .get_mut(&addr)
            .and_then(VecDeque::pop_front)
        {
            return v;
        }
        match self.fixed.borrow().get(&addr) {
            Some(&v) => v,
            None => panic!("unexpected read of {addr:#x}"),
        }
    }
}

impl Bus for MockBus {
    fn read8(&self, addr: usize) -> u8 {
        let v = self.value(addr) as u8;
        self.log.borrow_mut().push(Access::R8(addr, v));
        v
    }
    fn write8(&self, addr: usize, value: u8) {
        self.log.borrow_mut().push(Access::W8(addr, value));
    }
    fn read32(&self, addr: usize) -> u32 {
        let v = self.value(addr);
        self.log.borrow_mut().push(Access::R32(addr, v));
        v
    }
    fn write32(&self, addr: usize, value: u32) {
        self.log.borrow_mut().push(Access::W32(addr, value));
    }
}
