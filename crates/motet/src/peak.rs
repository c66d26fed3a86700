//! The process's own peak memory, as `motet run` prints it and `motet bench`
//! reads it back.

/// This process's peak resident memory so far, MiB (Linux: `VmHWM` in
/// `/proc/self/status`, which starts afresh at exec); `None` where the
/// system does not say.
pub fn own_peak_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// What `motet run` prints before its peak memory.
pub const PEAK_LINE: &str = "peak memory ";
