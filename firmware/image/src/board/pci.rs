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

/// Find mac-io and map it at [`MAC_IO_BASE`]. Returns where it was found.
pub fn init_mac_io() -> Option<DevFn> {
    let devfn = find(HEATHROW_MAC_IO)?;
    map_bar(devfn, REG_BAR0, MAC_IO_BASE as u32);
    Some(devfn)
}
