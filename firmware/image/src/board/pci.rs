//! The Grackle PCI host bridge (driver: `drv_g3beige::pci`): mapping mac-io and the ivshmem
//! devices at boot.
use drv_g3beige::pci::{DevFn, Grackle, SharedMemories};

/// Find mac-io and map it at `drv_g3beige::pci::MAC_IO_BASE`. Returns where it was found.
pub fn init_mac_io() -> Option<DevFn> {
    Grackle::new(super::kernel_mmio()).init_mac_io()
}

/// Find and map the board's ivshmem devices (see `Grackle::init_shared_memories`).
pub fn init_shared_memories(
    nv_base: u32,
    link_base: u32,
    link_bytes: u32,
    is_link: impl Fn() -> bool,
) -> SharedMemories {
    Grackle::new(super::kernel_mmio()).init_shared_memories(nv_base, link_base, link_bytes, is_link)
}
