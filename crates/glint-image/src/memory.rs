//! The memory budget's limits as the operating system states them (Linux: /proc and the
//! cgroup file system). The budget itself and the parsers are `glint_core::memory`; this is the
//! I/O that feeds them, called once by the front ends. A file that is missing or unreadable
//! (another OS, a container without /proc) means "no limit from there", never an error.

use glint_core::memory::{
    Budget, LimitSource, parse_cgroup_limit, parse_limits_address_space, parse_meminfo_total, parse_status_vm_size,
};
use std::fs;

/// The budget of this process: the smallest of `max_memory` (`--max-memory`), the physical
/// RAM, the address-space limit less the address space mapped now, and the cgroup's limit less
/// its current use.
#[must_use]
pub fn system_budget(max_memory: Option<u64>) -> Budget {
    let read = |path: &str| fs::read_to_string(path).ok();
    let ram = read("/proc/meminfo").as_deref().and_then(parse_meminfo_total);
    let mapped = read("/proc/self/status").as_deref().and_then(parse_status_vm_size).unwrap_or(0);
    let address_space = read("/proc/self/limits")
        .as_deref()
        .and_then(parse_limits_address_space)
        .map(|limit| limit.saturating_sub(mapped));
    Budget::smallest(&[
        (max_memory, LimitSource::Option),
        (ram, LimitSource::PhysicalRam),
        (address_space, LimitSource::AddressSpace),
        (cgroup_room(), LimitSource::Cgroup),
    ])
}

/// What the process's control group still allows: v2's `memory.max − memory.current` for the
/// group named in /proc/self/cgroup, else v1's `memory.limit_in_bytes − memory.usage_in_bytes`.
fn cgroup_room() -> Option<u64> {
    let groups = fs::read_to_string("/proc/self/cgroup").ok()?;
    let read = |path: String| fs::read_to_string(path).ok();
    for line in groups.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let path = path.trim_end();
        if controllers.is_empty() {
            let dir = format!("/sys/fs/cgroup{path}");
            if let Some(max) = read(format!("{dir}/memory.max")).as_deref().and_then(parse_cgroup_limit) {
                let used = read(format!("{dir}/memory.current")).and_then(|t| t.trim().parse().ok()).unwrap_or(0u64);
                return Some(max.saturating_sub(used));
            }
        } else if controllers.split(',').any(|c| c == "memory") {
            let dir = format!("/sys/fs/cgroup/memory{path}");
            if let Some(max) = read(format!("{dir}/memory.limit_in_bytes")).as_deref().and_then(parse_cgroup_limit) {
                let used =
                    read(format!("{dir}/memory.usage_in_bytes")).and_then(|t| t.trim().parse().ok()).unwrap_or(0u64);
                return Some(max.saturating_sub(used));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_option_caps_the_system_budget() {
        let b = system_budget(Some(1 << 20));
        assert_eq!(b, Budget { bytes: 1 << 20, source: LimitSource::Option });
        // Without the option some limit applies on Linux (the RAM at least).
        if cfg!(target_os = "linux") {
            assert_ne!(system_budget(None).source, LimitSource::Unlimited);
        }
    }
}
