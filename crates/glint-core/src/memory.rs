//! The memory budget: one number every large allocation is checked against before it is made,
//! so that a request too big for the machine is refused with a message instead of aborting the
//! process (Rust aborts when an infallible allocation fails).
//!
//! The budget is the smallest of the limits that apply — `--max-memory`, the physical RAM, the
//! address-space limit (`ulimit -v`, RLIMIT_AS) and a cgroup's memory limit — each remembered
//! with its [`LimitSource`] so the refusal can say which one set it. This module holds the pure
//! parts (the parsers, the process-wide budget, the checks); reading `/proc` and the cgroup files
//! is I/O and lives in `glint_image::memory`, which the front ends call once at start-up. Until a
//! budget is installed, every check passes and only the fallible reservation guards.

use std::fmt;
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};

/// Which limit set the budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitSource {
    /// No limit was found or installed.
    Unlimited,
    /// `--max-memory`.
    Option,
    /// The machine's physical RAM (`MemTotal` in /proc/meminfo).
    PhysicalRam,
    /// The process's address-space limit (RLIMIT_AS, `ulimit -v`), less what is mapped already.
    AddressSpace,
    /// The control group's memory limit (`memory.max`, or v1's `memory.limit_in_bytes`), less
    /// what the group uses already.
    Cgroup,
}

impl LimitSource {
    const ALL: [LimitSource; 5] = [Self::Unlimited, Self::Option, Self::PhysicalRam, Self::AddressSpace, Self::Cgroup];

    fn describe(self) -> &'static str {
        match self {
            Self::Unlimited => "no limit",
            Self::Option => "--max-memory",
            Self::PhysicalRam => "the physical RAM",
            Self::AddressSpace => "the address-space limit (ulimit -v)",
            Self::Cgroup => "the cgroup's memory limit",
        }
    }
}

/// A number of bytes and the limit it comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    pub bytes: u64,
    pub source: LimitSource,
}

impl Budget {
    pub const UNLIMITED: Budget = Budget { bytes: u64::MAX, source: LimitSource::Unlimited };

    /// The smallest of the limits given (`None`: that limit does not apply).
    #[must_use]
    pub fn smallest(limits: &[(Option<u64>, LimitSource)]) -> Budget {
        limits
            .iter()
            .filter_map(|&(bytes, source)| bytes.map(|bytes| Budget { bytes, source }))
            .fold(Budget::UNLIMITED, |best, b| if b.bytes < best.bytes { b } else { best })
    }
}

impl fmt::Display for Budget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.source == LimitSource::Unlimited {
            write!(f, "unlimited")
        } else {
            write!(f, "{} (set by {})", ByteSize(self.bytes), self.source.describe())
        }
    }
}

/// A byte count printed in binary units ("9.66 GiB").
#[derive(Clone, Copy, Debug)]
pub struct ByteSize(pub u64);

impl fmt::Display for ByteSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
        let mut value = self.0 as f64;
        let mut unit = 0;
        while value >= 1024.0 && unit + 1 < UNITS.len() {
            value /= 1024.0;
            unit += 1;
        }
        if unit == 0 { write!(f, "{} bytes", self.0) } else { write!(f, "{value:.2} {}", UNITS[unit]) }
    }
}

/// A large allocation that was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryError {
    /// What the memory was for ("the film of a 32768 × 4096 image").
    pub what: String,
    /// Bytes asked for (saturated at `u64::MAX` when the count overflows).
    pub needed: u64,
    pub budget: Budget,
    /// The budget allowed it but the allocator could not provide it.
    pub allocation_failed: bool,
}

impl fmt::Display for MemoryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.allocation_failed {
            write!(
                f,
                "out of memory: {} needs {}, which the system could not provide (memory budget {})",
                self.what,
                ByteSize(self.needed),
                self.budget
            )
        } else {
            write!(f, "{} needs {}, more than the memory budget of {}", self.what, ByteSize(self.needed), self.budget)
        }
    }
}

impl std::error::Error for MemoryError {}

static BUDGET_BYTES: AtomicU64 = AtomicU64::new(u64::MAX);
static BUDGET_SOURCE: AtomicU8 = AtomicU8::new(0);

/// Make `budget` the process's memory budget (the front ends do this once at start-up).
pub fn install(budget: Budget) {
    let index = LimitSource::ALL.iter().position(|s| *s == budget.source).unwrap_or(0);
    BUDGET_SOURCE.store(index as u8, Ordering::Relaxed);
    BUDGET_BYTES.store(budget.bytes, Ordering::Relaxed);
}

/// The process's memory budget ([`Budget::UNLIMITED`] until one is installed).
#[must_use]
pub fn budget() -> Budget {
    let source = LimitSource::ALL.get(usize::from(BUDGET_SOURCE.load(Ordering::Relaxed)));
    Budget { bytes: BUDGET_BYTES.load(Ordering::Relaxed), source: source.copied().unwrap_or(LimitSource::Unlimited) }
}

/// Refuse `needed` bytes for `what` when they exceed the budget.
///
/// # Errors
/// [`MemoryError`] naming `what`, the bytes and the budget.
pub fn check(what: impl FnOnce() -> String, needed: u64) -> Result<(), MemoryError> {
    let budget = budget();
    if needed <= budget.bytes {
        Ok(())
    } else {
        Err(MemoryError { what: what(), needed, budget, allocation_failed: false })
    }
}

/// Bytes for `count` values of `T`, saturating.
#[must_use]
pub fn bytes_of<T>(count: usize) -> u64 {
    (count as u64).saturating_mul(std::mem::size_of::<T>() as u64)
}

/// An empty vector with room for `count` values of `T`: checked against the budget, then
/// reserved fallibly (`try_reserve_exact`).
///
/// # Errors
/// [`MemoryError`] when the budget refuses it or the allocator cannot provide it.
pub fn try_with_capacity<T>(what: impl FnOnce() -> String, count: usize) -> Result<Vec<T>, MemoryError> {
    let needed = bytes_of::<T>(count);
    let mut what = Some(what);
    check(|| what.take().map_or_else(String::new, |w| w()), needed)?;
    let mut v = Vec::new();
    v.try_reserve_exact(count).map_err(|_| MemoryError {
        what: what.take().map_or_else(String::new, |w| w()),
        needed,
        budget: budget(),
        allocation_failed: true,
    })?;
    Ok(v)
}

/// A vector of `count` copies of `value`, made as [`try_with_capacity`] makes its room.
///
/// # Errors
/// As [`try_with_capacity`].
pub fn try_filled<T: Clone>(what: impl FnOnce() -> String, count: usize, value: T) -> Result<Vec<T>, MemoryError> {
    let mut v = try_with_capacity(what, count)?;
    v.resize(count, value);
    Ok(v)
}

/// Parse a size as people write it: `"512M"`, `"2G"`, `"1.5GiB"`, `"100000"` (bytes); the
/// suffixes K, M, G, T (optionally with `B` or `iB`) are binary multiples.
///
/// # Errors
/// A message saying what is wrong with `text`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let shift = match unit.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 0,
        "K" | "KB" | "KIB" => 10,
        "M" | "MB" | "MIB" => 20,
        "G" | "GB" | "GIB" => 30,
        "T" | "TB" | "TIB" => 40,
        other => return Err(format!("{text:?}: unknown unit {other:?} (use K, M, G or T)")),
    };
    let value: f64 = number.parse().map_err(|_| format!("{text:?}: expected a size such as 512M or 4G"))?;
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("{text:?}: the size must be at least 1 byte and below 16 EiB"));
    }
    Ok(bytes as u64)
}

/// `MemTotal` from the text of /proc/meminfo, in bytes.
#[must_use]
pub fn parse_meminfo_total(meminfo: &str) -> Option<u64> {
    meminfo_field(meminfo, "MemTotal:")
}

fn meminfo_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let mut words = line[key.len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => value.checked_mul(1024),
        None => Some(value),
        Some(_) => None,
    }
}

/// `VmSize` (the address space mapped now) from the text of /proc/self/status, in bytes.
#[must_use]
pub fn parse_status_vm_size(status: &str) -> Option<u64> {
    meminfo_field(status, "VmSize:")
}

/// The soft address-space limit from the text of /proc/self/limits (`Max address space`), in
/// bytes; `None` when unlimited or absent.
#[must_use]
pub fn parse_limits_address_space(limits: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    let soft = line["Max address space".len()..].split_whitespace().next()?;
    soft.parse().ok()
}

/// A cgroup memory limit from the text of `memory.max` (v2: a number or `max`) or
/// `memory.limit_in_bytes` (v1: a number, "unlimited" being a huge one); `None` when
/// unlimited.
#[must_use]
pub fn parse_cgroup_limit(text: &str) -> Option<u64> {
    let value: u64 = text.trim().parse().ok()?;
    // cgroup v1 writes "no limit" as the largest page-aligned i64.
    (value < (1u64 << 62)).then_some(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_units() {
        assert_eq!(parse_size("100M"), Ok(100 << 20));
        assert_eq!(parse_size("2G"), Ok(2 << 30));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("4096"), Ok(4096));
        assert_eq!(parse_size(" 64 kb "), Ok(64 << 10));
        assert!(parse_size("-1M").is_err());
        assert!(parse_size("0").is_err());
        assert!(parse_size("12Q").unwrap_err().contains("unknown unit"));
        assert!(parse_size("M").is_err());
        assert!(parse_size("99999999999T").is_err());
    }

    #[test]
    fn proc_files_parse() {
        let meminfo = "MemTotal:       24516752 kB\nMemFree:        22000000 kB\n";
        assert_eq!(parse_meminfo_total(meminfo), Some(24_516_752 * 1024));
        assert_eq!(parse_meminfo_total("MemFree: 1 kB\n"), None);
        let status = "Name:\tglint\nVmPeak:\t  20000 kB\nVmSize:\t   12345 kB\n";
        assert_eq!(parse_status_vm_size(status), Some(12_345 * 1024));
        let limits = "Limit                     Soft Limit           Hard Limit           Units     \n\
                      Max stack size            8388608              unlimited            bytes     \n\
                      Max address space         409600000            unlimited            bytes     \n";
        assert_eq!(parse_limits_address_space(limits), Some(409_600_000));
        let unlimited = "Max address space         unlimited            unlimited            bytes     \n";
        assert_eq!(parse_limits_address_space(unlimited), None);
        assert_eq!(parse_cgroup_limit("max\n"), None);
        assert_eq!(parse_cgroup_limit("536870912\n"), Some(536_870_912));
        assert_eq!(parse_cgroup_limit("9223372036854771712\n"), None);
        assert_eq!(parse_cgroup_limit(""), None);
    }

    #[test]
    fn the_smallest_limit_wins_and_is_named() {
        let b = Budget::smallest(&[
            (Some(8 << 30), LimitSource::PhysicalRam),
            (None, LimitSource::AddressSpace),
            (Some(100 << 20), LimitSource::Option),
            (Some(1 << 30), LimitSource::Cgroup),
        ]);
        assert_eq!(b, Budget { bytes: 100 << 20, source: LimitSource::Option });
        assert_eq!(b.to_string(), "100.00 MiB (set by --max-memory)");
        assert_eq!(Budget::smallest(&[(None, LimitSource::Cgroup)]), Budget::UNLIMITED);
    }

    #[test]
    fn refusals_say_what_and_how_much() {
        let budget = Budget { bytes: 1 << 20, source: LimitSource::AddressSpace };
        let e = MemoryError { what: "the film".into(), needed: 3 << 30, budget, allocation_failed: false };
        assert_eq!(
            e.to_string(),
            "the film needs 3.00 GiB, more than the memory budget of 1.00 MiB (set by the address-space limit (ulimit -v))"
        );
    }

    // The process-wide budget is exercised by the CLI's tests (a separate process each), so
    // that no unit test here changes it under the others.
    #[test]
    fn an_impossible_reservation_is_an_error_not_an_abort() {
        let e = try_with_capacity::<[u8; 1024]>(|| "a test buffer".into(), usize::MAX / 2048).unwrap_err();
        assert!(e.to_string().contains("a test buffer"), "{e}");
    }
}
