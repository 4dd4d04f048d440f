//! Grackle PCI host bridge: configuration cycles on bus 0, and the set-up nobody else does
//! without OpenBIOS (mapping mac-io's BAR so the ESCC appears, and the ivshmem devices).
//!
//! The configuration address and data registers are little-endian: every word is byte-swapped.
use crate::Bus;

pub const CONFIG_ADDRESS: usize = 0xfec0_0000;
pub const CONFIG_DATA: usize = 0xfee0_0000;

/// Vendor/device word of the Heathrow mac-io (Apple 0x106b, device 0x0010).
pub const HEATHROW_MAC_IO: u32 = 0x0010_106b;
/// Where the firmware maps mac-io's BAR0.
pub const MAC_IO_BASE: usize = 0xf300_0000;

pub const REG_ID: u8 = 0x00;
pub const REG_COMMAND: u8 = 0x04;
pub const REG_BAR0: u8 = 0x10;
pub const REG_BAR2: u8 = 0x18;
pub const REG_BAR3: u8 = 0x1c;
/// BAR low bits: memory space, 64-bit type.
const BAR_TYPE_MASK: u32 = 0x6;
const BAR_TYPE_64: u32 = 0x4;
const BAR_FLAGS_MASK: u32 = 0xf;

/// Vendor/device word of QEMU's `ivshmem-plain` (Red Hat 0x1af4, device 0x1110): shared memory
/// backed by a host file: the board's non-volatile memory, and on the emulated target the
/// shared-memory link.
pub const IVSHMEM: u32 = 0x1110_1af4;
/// Command register: memory space + bus master.
pub const COMMAND_MEMORY_AND_MASTER: u32 = 0x6;

/// A device/function number on bus 0 (device << 3 | function).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DevFn(pub u8);

/// The configuration address word for `reg` of `devfn` (type 0 cycle, enable bit set), as the
/// bus sees it.
pub const fn address(devfn: DevFn, reg: u8) -> u32 {
    (0x8000_0000 | ((devfn.0 as u32) << 8) | (reg & 0xfc) as u32).swap_bytes()
}

/// What the board's shared-memory devices turned out to be.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SharedMemories {
    /// Bytes of non-volatile memory mapped at the NV base, if the board has it.
    pub nv_bytes: Option<u32>,
    /// The shared-memory link device is mapped at the link base.
    pub link: bool,
}

/// The host bridge over register access `B`.
pub struct Grackle<B: Bus> {
    bus: B,
}

impl<B: Bus> Grackle<B> {
    #[inline]
    pub const fn new(bus: B) -> Self {
        Self { bus }
    }

    pub fn config_read(&self, devfn: DevFn, reg: u8) -> u32 {
        self.bus.write32(CONFIG_ADDRESS, address(devfn, reg));
        self.bus.read32(CONFIG_DATA).swap_bytes()
    }

    pub fn config_write(&self, devfn: DevFn, reg: u8, value: u32) {
        self.bus.write32(CONFIG_ADDRESS, address(devfn, reg));
        self.bus.write32(CONFIG_DATA, value.swap_bytes());
    }

    /// First function on bus 0 whose vendor/device word is `id`.
    pub fn find(&self, id: u32) -> Option<DevFn> {
        (0..32u8)
            .map(|dev| DevFn(dev << 3))
            .find(|&devfn| self.config_read(devfn, REG_ID) == id)
    }

    /// Map a device's 32-bit BAR at `base` and enable memory decoding and bus mastering.
    pub fn map_bar(&self, devfn: DevFn, bar_reg: u8, base: u32) {
        self.config_write(devfn, bar_reg, base);
        self.config_write(devfn, REG_COMMAND, COMMAND_MEMORY_AND_MASTER);
    }

    /// The size of an ivshmem device's BAR2 (64-bit memory of the backing file's size), found
    /// by writing all ones and reading back which address bits stick; None if it is not what
    /// QEMU's ivshmem-plain offers. Leaves the BAR unmapped until [`Self::map_ivshmem`].
    fn ivshmem_size(&self, devfn: DevFn) -> Option<u32> {
        self.config_write(devfn, REG_BAR2, u32::MAX);
        self.config_write(devfn, REG_BAR3, u32::MAX);
        let low = self.config_read(devfn, REG_BAR2);
        let high = self.config_read(devfn, REG_BAR3);
        if low & BAR_TYPE_MASK != BAR_TYPE_64 || high != u32::MAX {
            return None;
        }
        let mask = low & !BAR_FLAGS_MASK;
        if mask == 0 {
            return None;
        }
        let size = (!mask).wrapping_add(1);
        (size != 0).then_some(size)
    }

    /// Map an ivshmem device's BAR2 at `base` (aligned to its size).
    #[inline]
    fn map_ivshmem(&self, devfn: DevFn, base: u32) {
        self.config_write(devfn, REG_BAR3, 0);
        self.map_bar(devfn, REG_BAR2, base);
    }

    /// Find the board's ivshmem devices (QEMU `ivshmem-plain`: shared memory backed by a host
    /// file): the link device, `link_bytes` long and recognised by `is_link` once mapped at
    /// `link_base`, and the non-volatile memory (the first other one), mapped at `nv_base`.
    pub fn init_shared_memories(
        &self,
        nv_base: u32,
        link_base: u32,
        link_bytes: u32,
        is_link: impl Fn() -> bool,
    ) -> SharedMemories {
        let mut found = SharedMemories::default();
        for dev in 0..32u32 {
            let devfn = DevFn((dev << 3) as u8);
            if self.config_read(devfn, REG_ID) != IVSHMEM {
                continue;
            }
            let Some(size) = self.ivshmem_size(devfn) else {
                continue;
            };
            if !found.link && size == link_bytes {
                self.map_ivshmem(devfn, link_base);
                if is_link() {
                    found.link = true;
                    continue;
                }
            }
            if found.nv_bytes.is_none() && nv_base.is_multiple_of(size) {
                self.map_ivshmem(devfn, nv_base);
                found.nv_bytes = Some(size);
            }
        }
        found
    }

    /// Find mac-io and map it at [`MAC_IO_BASE`]. Returns where it was found.
    pub fn init_mac_io(&self) -> Option<DevFn> {
        let devfn = self.find(HEATHROW_MAC_IO)?;
        self.map_bar(devfn, REG_BAR0, MAC_IO_BASE as u32);
        Some(devfn)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::cell::{Cell, RefCell};
    use std::collections::BTreeMap;
    use std::vec::Vec;

    use super::*;

    /// Bus 0 behind a Grackle: configuration space per device, BAR sizing like QEMU's (a BAR
    /// reads back the written value masked by its size), and a log of configuration writes.
    #[derive(Default)]
    struct Board {
        address: Cell<u32>,
        ids: BTreeMap<u8, u32>,
        /// devfn -> BAR2 size (64-bit memory BAR) for the ivshmem devices.
        bar2_sizes: BTreeMap<u8, u32>,
        space: RefCell<BTreeMap<(u8, u8), u32>>,
        writes: RefCell<Vec<(u8, u8, u32)>>,
    }

    impl Board {
        fn decode(&self) -> (u8, u8) {
            let a = self.address.get().swap_bytes();
            assert_eq!(a & 0x8000_0000, 0x8000_0000, "enable bit");
            ((a >> 8) as u8, (a & 0xfc) as u8)
        }
    }

    impl Bus for Board {
        fn read8(&self, _: usize) -> u8 {
            unreachable!()
        }
        fn write8(&self, _: usize, _: u8) {
            unreachable!()
        }
        fn read32(&self, addr: usize) -> u32 {
            assert_eq!(addr, CONFIG_DATA);
            let (devfn, reg) = self.decode();
            let value = match reg {
                REG_ID => self.ids.get(&devfn).copied().unwrap_or(u32::MAX),
                REG_BAR2 => match self.bar2_sizes.get(&devfn) {
                    Some(size) => {
                        let w = self.space.borrow().get(&(devfn, reg)).copied().unwrap_or(0);
                        (w & !(size - 1)) | BAR_TYPE_64
                    }
                    None => 0,
                },
                _ => self.space.borrow().get(&(devfn, reg)).copied().unwrap_or(0),
            };
            value.swap_bytes()
        }
        fn write32(&self, addr: usize, value: u32) {
            if addr == CONFIG_ADDRESS {
                self.address.set(value);
                return;
            }
            assert_eq!(addr, CONFIG_DATA);
            let (devfn, reg) = self.decode();
            let value = value.swap_bytes();
            self.space.borrow_mut().insert((devfn, reg), value);
            self.writes.borrow_mut().push((devfn, reg, value));
        }
    }

    #[test]
    fn the_address_word_is_little_endian_with_the_enable_bit() {
        assert_eq!(address(DevFn(0x68), 0x13), 0x1068_0080);
    }

    #[test]
    fn init_mac_io_maps_bar0_and_enables_memory_and_mastering() {
        let board = Board {
            ids: [(0x68, HEATHROW_MAC_IO)].into(),
            ..Board::default()
        };
        assert_eq!(Grackle::new(&board).init_mac_io(), Some(DevFn(0x68)));
        assert_eq!(
            *board.writes.borrow(),
            std::vec![
                (0x68, REG_BAR0, MAC_IO_BASE as u32),
                (0x68, REG_COMMAND, COMMAND_MEMORY_AND_MASTER),
            ]
        );
    }

    #[test]
    fn no_mac_io_is_none_and_writes_nothing() {
        let board = Board::default();
        assert_eq!(Grackle::new(&board).init_mac_io(), None);
        assert!(board.writes.borrow().is_empty());
    }

    #[test]
    fn shared_memories_the_link_by_size_and_check_then_nv_at_its_base() {
        const LINK_BYTES: u32 = 0x10_0000;
        const NV_BYTES: u32 = 0x4_0000;
        let board = Board {
            ids: [(0x08, IVSHMEM), (0x10, IVSHMEM), (0x18, HEATHROW_MAC_IO)].into(),
            bar2_sizes: [(0x08, NV_BYTES), (0x10, LINK_BYTES)].into(),
            ..Board::default()
        };
        let checked = Cell::new(0);
        let found =
            Grackle::new(&board).init_shared_memories(0x8000_0000, 0x9000_0000, LINK_BYTES, || {
                checked.set(checked.get() + 1);
                true
            });
        assert_eq!(
            found,
            SharedMemories {
                nv_bytes: Some(NV_BYTES),
                link: true
            }
        );
        assert_eq!(
            checked.get(),
            1,
            "only the device of the link's size is checked"
        );
        let space = board.space.borrow();
        assert_eq!(space.get(&(0x08, REG_BAR2)), Some(&0x8000_0000));
        assert_eq!(space.get(&(0x10, REG_BAR2)), Some(&0x9000_0000));
        assert_eq!(space.get(&(0x10, REG_BAR3)), Some(&0));
        assert_eq!(
            space.get(&(0x10, REG_COMMAND)),
            Some(&COMMAND_MEMORY_AND_MASTER)
        );
    }

    #[test]
    fn a_link_sized_device_that_fails_the_check_becomes_the_nv() {
        const BYTES: u32 = 0x10_0000;
        let board = Board {
            ids: [(0x08, IVSHMEM)].into(),
            bar2_sizes: [(0x08, BYTES)].into(),
            ..Board::default()
        };
        let found =
            Grackle::new(&board).init_shared_memories(0x8000_0000, 0x9000_0000, BYTES, || false);
        assert_eq!(
            found,
            SharedMemories {
                nv_bytes: Some(BYTES),
                link: false
            }
        );
        assert_eq!(
            board.space.borrow().get(&(0x08, REG_BAR2)),
            Some(&0x8000_0000)
        );
    }
}
