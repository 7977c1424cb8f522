//! Process CPU time and load average for benchmarks on a shared machine (Linux `/proc`;
//! elsewhere the functions return 0 and an empty string).

/// CPU seconds used so far by all threads of this process (live and exited), user + system.
///
/// Sums the per-thread run time in nanoseconds from `/proc/self/task/*/schedstat` for the live
/// threads; the clock-tick totals of `/proc/self/stat` (10 ms resolution, but they include
/// exited threads) are used when they are larger.
pub fn process_cpu_s() -> f64 {
    let mut ns = 0u64;
    if let Ok(dir) = std::fs::read_dir("/proc/self/task") {
        for e in dir.flatten() {
            if let Ok(t) = std::fs::read_to_string(e.path().join("schedstat")) {
                ns += t
                    .split_whitespace()
                    .next()
                    .and_then(|v| v.parse::<u64>().ok())
                    .unwrap_or(0);
            }
        }
    }
    let fine = ns as f64 * 1e-9;
    let coarse = std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|t| {
            let after: Vec<&str> = t.rsplit_once(')')?.1.split_whitespace().collect();
            let u: f64 = after.get(11)?.parse().ok()?;
            let s: f64 = after.get(12)?.parse().ok()?;
            Some((u + s) / 100.0)
        })
        .unwrap_or(0.0);
    if coarse > fine + 0.05 {
        coarse
    } else {
        fine
    }
}

/// The 1-, 5- and 15-minute load averages as written in `/proc/loadavg` (e.g. "3.1 4.0 5.2").
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_grows_with_work() {
        let a = process_cpu_s();
        let mut x = 0u64;
        let t = std::time::Instant::now();
        while t.elapsed().as_millis() < 60 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let b = process_cpu_s();
        if cfg!(target_os = "linux") {
            assert!(b - a > 0.01, "{a} -> {b}");
        }
    }
}
