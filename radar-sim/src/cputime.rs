//! Process CPU time and load average for benchmarks on a shared machine (Linux; elsewhere
//! the functions return 0 and an empty string).

/// CPU seconds used so far by all threads of this process (live and exited), user + system:
/// the process CPU-time clock (`CLOCK_PROCESS_CPUTIME_ID`, nanosecond resolution).
pub fn process_cpu_s() -> f64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_PROCESS_CPUTIME_ID)
        .map(|t| t.tv_sec() as f64 + t.tv_nsec() as f64 * 1e-9)
        .unwrap_or(0.0)
}

/// CPU seconds used so far by the calling thread (`CLOCK_THREAD_CPUTIME_ID`).
pub fn thread_cpu_s() -> f64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_THREAD_CPUTIME_ID)
        .map(|t| t.tv_sec() as f64 + t.tv_nsec() as f64 * 1e-9)
        .unwrap_or(0.0)
}

/// The 1-, 5- and 15-minute load averages with two decimals, as `/proc/loadavg` shows them
/// (e.g. "3.10 4.00 5.20"; from `sysinfo(2)`).
pub fn load_average() -> String {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    if let Ok(info) = nix::sys::sysinfo::sysinfo() {
        let (a, b, c) = info.load_average();
        return format!("{a:.2} {b:.2} {c:.2}");
    }
    String::new()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_grows_with_work() {
        let a = process_cpu_s();
        let ta = thread_cpu_s();
        let mut x = 0u64;
        let t = std::time::Instant::now();
        while t.elapsed().as_millis() < 60 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let b = process_cpu_s();
        let tb = thread_cpu_s();
        if cfg!(target_os = "linux") {
            assert!(b - a > 0.01, "{a} -> {b}");
            assert!(tb - ta > 0.01, "{ta} -> {tb}");
            // the process clock counts this thread's time and the others'
            assert!(b >= tb, "{b} < {tb}");
        }
    }

    /// CPU time of threads that have exited still counts.
    #[test]
    fn exited_threads_count() {
        let a = process_cpu_s();
        std::thread::spawn(|| {
            let t = std::time::Instant::now();
            let mut x = 1u64;
            while t.elapsed().as_millis() < 60 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            std::hint::black_box(x);
        })
        .join()
        .unwrap();
        if cfg!(target_os = "linux") {
            assert!(process_cpu_s() - a > 0.01);
        }
    }

    #[test]
    fn load_average_has_three_numbers() {
        let s = load_average();
        if cfg!(target_os = "linux") {
            let v: Vec<f64> = s.split(' ').map(|x| x.parse().unwrap()).collect();
            assert_eq!(v.len(), 3, "{s}");
            assert!(v.iter().all(|x| *x >= 0.0), "{s}");
        }
    }
}
