//! Constant queries on a configuration, for tables the image builds at compile time: indices
//! and ids of partitions and ports by name, and the sizes of the kernel's port storage.

use crate::{Port, SystemConfig};

/// Index of the partition named `name` (const, for tables built from the configuration).
pub const fn partition_index(config: &SystemConfig, name: &str) -> Option<usize> {
    let mut p = 0;
    while p < config.partitions.len() {
        if str_eq(config.partitions[p].name, name) {
            return Some(p);
        }
        p += 1;
    }
    None
}

/// Index of the port named `name`.
pub const fn port_index(config: &SystemConfig, name: &str) -> Option<usize> {
    let mut i = 0;
    while i < config.ports.len() {
        if str_eq(config.ports[i].name, name) {
            return Some(i);
        }
        i += 1;
    }
    None
}

/// The id of the port named `name`, for `const` items: partitions name their ports, and the
/// id is derived from the configuration at compile time (a name the configuration does not
/// have stops the build).
pub const fn port_id(config: &SystemConfig, name: &str) -> usize {
    match port_index(config, name) {
        Some(i) => i,
        None => panic!("kernel configuration: no port of that name"),
    }
}

/// The largest message of any port of `config`, in bytes (sizes the partitions' buffers).
pub const fn max_port_message(config: &SystemConfig) -> usize {
    let mut largest = 0;
    let mut i = 0;
    while i < config.ports.len() {
        if config.ports[i].message_size as usize > largest {
            largest = config.ports[i].message_size as usize;
        }
        i += 1;
    }
    largest
}

/// Bytes of kernel RAM all port buffers need (each slot: message bytes rounded up to 4, plus
/// a 16-byte header).
pub const fn port_storage_bytes(config: &SystemConfig) -> usize {
    let mut total = 0;
    let mut i = 0;
    while i < config.ports.len() {
        total += port_slot_bytes(&config.ports[i]) * config.ports[i].depth as usize;
        i += 1;
    }
    total
}

/// Bytes one message slot of `port` takes.
pub const fn port_slot_bytes(port: &Port) -> usize {
    PORT_SLOT_HEADER + ((port.message_size as usize + 3) & !3)
}

/// Bytes of the per-slot header in port storage (length, sender generation, timestamp).
pub const PORT_SLOT_HEADER: usize = 16;

pub(crate) const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}
