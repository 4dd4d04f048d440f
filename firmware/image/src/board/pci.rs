//! Grackle PCI host bridge: configuration cycles on bus 0, and the set-up nobody else does
//! without OpenBIOS (mapping mac-io's BAR so the ESCC appears).
//!
//! The configuration address and data registers are little-endian: every word is byte-swapped.
use super::{mmio_read32, mmio_write32};

const CONFIG_ADDRESS: usize = 0xfec0_0000;
const CONFIG_DATA: usize = 0xfee0_0000;

/// Vendor/device word of the Heathrow mac-io (Apple 0x106b, device 0x0010).
pub const HEATHROW_MAC_IO: u32 = 0x0010_106b;
/// Where the firmware maps mac-io's BAR0.
pub const MAC_IO_BASE: usize = 0xf300_0000;

const REG_ID: u8 = 0x00;
const REG_COMMAND: u8 = 0x04;
const REG_BAR0: u8 = 0x10;
const REG_BAR2: u8 = 0x18;
const REG_BAR3: u8 = 0x1c;
/// BAR low bits: memory space, 64-bit type.
const BAR_TYPE_MASK: u32 = 0x6;
const BAR_TYPE_64: u32 = 0x4;
const BAR_FLAGS_MASK: u32 = 0xf;

/// Vendor/device word of QEMU's `ivshmem-plain` (Red Hat 0x1af4, device 0x1110): shared memory
/// backed by a host file: the board's non-volatile memory, and on the emulated target the
/// shared-memory link.
pub const IVSHMEM: u32 = 0x1110_1af4;
/// Command register: memory space + bus master.
const COMMAND_MEMORY_AND_MASTER: u32 = 0x6;

/// A device/function number on bus 0 (device << 3 | function).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct DevFn(pub u8);

fn address(devfn: DevFn, reg: u8) -> u32 {
    (0x8000_0000 | (u32::from(devfn.0) << 8) | u32::from(reg & 0xfc)).swap_bytes()
}

pub fn config_read(devfn: DevFn, reg: u8) -> u32 {
    // SAFETY: the Grackle configuration registers exist on g3beige at these addresses and the
    // MMU is off (or maps them 1:1 for the kernel).
    unsafe {
        mmio_write32(CONFIG_ADDRESS, address(devfn, reg));
        mmio_read32(CONFIG_DATA).swap_bytes()
    }
}

pub fn config_write(devfn: DevFn, reg: u8, value: u32) {
    // SAFETY: as in `config_read`.
    unsafe {
        mmio_write32(CONFIG_ADDRESS, address(devfn, reg));
        mmio_write32(CONFIG_DATA, value.swap_bytes());
    }
}

/// First function on bus 0 whose vendor/device word is `id`.
pub fn find(id: u32) -> Option<DevFn> {
    (0..32u8)
        .map(|dev| DevFn(dev << 3))
        .find(|&devfn| config_read(devfn, REG_ID) == id)
}

/// Map a device's 32-bit BAR at `base` and enable memory decoding and bus mastering.
pub fn map_bar(devfn: DevFn, bar_reg: u8, base: u32) {
    config_write(devfn, bar_reg, base);
    config_write(devfn, REG_COMMAND, COMMAND_MEMORY_AND_MASTER);
}

/// The size of an ivshmem device's BAR2 (64-bit memory of the backing file's size), found by
/// writing all ones and reading back which address bits stick; None if it is not what QEMU's
/// ivshmem-plain offers. Leaves the BAR unmapped until [`map_ivshmem`].
fn ivshmem_size(devfn: DevFn) -> Option<u32> {
    config_write(devfn, REG_BAR2, u32::MAX);
    config_write(devfn, REG_BAR3, u32::MAX);
    let low = config_read(devfn, REG_BAR2);
    let high = config_read(devfn, REG_BAR3);
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
fn map_ivshmem(devfn: DevFn, base: u32) {
    config_write(devfn, REG_BAR3, 0);
    map_bar(devfn, REG_BAR2, base);
}

/// What the board's shared-memory devices turned out to be.
#[derive(Clone, Copy, Default)]
pub struct SharedMemories {
    /// Bytes of non-volatile memory mapped at the NV base, if the board has it.
    pub nv_bytes: Option<u32>,
    /// The shared-memory link device is mapped at the link base.
    pub link: bool,
}

/// Find the board's ivshmem devices (QEMU `ivshmem-plain`: shared memory backed by a host
/// file): the link device, `link_bytes` long and recognised by `is_link` once mapped at
/// `link_base`, and the non-volatile memory (the first other one), mapped at `nv_base`.
pub fn init_shared_memories(
    nv_base: u32,
    link_base: u32,
    link_bytes: u32,
    is_link: impl Fn() -> bool,
) -> SharedMemories {
    let mut found = SharedMemories::default();
    for devfn in (0..32u8).map(|dev| DevFn(dev << 3)) {
        if config_read(devfn, REG_ID) != IVSHMEM {
            continue;
        }
        let Some(size) = ivshmem_size(devfn) else {
            continue;
        };
        if !found.link && size == link_bytes {
            map_ivshmem(devfn, link_base);
            if is_link() {
                found.link = true;
                continue;
            }
        }
        if found.nv_bytes.is_none() && nv_base.is_multiple_of(size) {
            map_ivshmem(devfn, nv_base);
            found.nv_bytes = Some(size);
        }
    }
    found
}

/// Find mac-io and map it at [`MAC_IO_BASE`]. Returns where it was found.
pub fn init_mac_io() -> Option<DevFn> {
    let devfn = find(HEATHROW_MAC_IO)?;
    map_bar(devfn, REG_BAR0, MAC_IO_BASE as u32);
    Some(devfn)
}
