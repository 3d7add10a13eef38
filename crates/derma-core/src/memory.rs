//! How much memory a job may take: the machine's available memory (Linux `/proc/meminfo`), so
//! that a size that cannot fit is refused before any work instead of failing hours in.

/// Available memory in bytes (`MemAvailable`), where the system tells.
pub fn available_bytes() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Whether `need` bytes fit in 90 % of the available memory: `Some((need_gib, have_gib))` when
/// they do not, `None` when they do or the system does not tell.
pub fn shortfall(need: f64) -> Option<(f64, f64)> {
    const GIB: f64 = 1073741824.0;
    match available_bytes() {
        Some(have) if need > 0.9 * have => Some((need / GIB, have / GIB)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_jobs_fit_and_absurd_ones_do_not() {
        assert!(shortfall(1e6).is_none());
        if available_bytes().is_some() {
            let (need, have) = shortfall(1e18).unwrap();
            assert!(need > have && have > 0.0);
        }
    }
}
