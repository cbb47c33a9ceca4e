//! The process's resident host memory, as the kernel counts it: for the
//! memory bounds the out-of-core paths state (a volume streamed from disk
//! keeps about one box resident, whatever the file size) and the tests and
//! benchmarks that check them.
//!
//! Both read `/proc/self/status` (Linux); elsewhere they answer `None`.

/// The peak resident set size of this process so far (`VmHWM`), in bytes;
/// `None` where `/proc/self/status` is absent or has no such line.
pub fn peak_resident_bytes() -> Option<u64> {
    status_bytes("VmHWM")
}

/// The current resident set size of this process (`VmRSS`: anonymous,
/// file-backed and shared pages mapped now), in bytes; `None` where
/// `/proc/self/status` is absent or has no such line.
pub fn current_resident_bytes() -> Option<u64> {
    status_bytes("VmRSS")
}

/// Prints the process's memory at a step of the out-of-core set-up when
/// `BOXFORGE_MEMORY_TRACE` is set (how the out-of-core bound was tracked down).
pub(crate) fn trace_memory(what: &str) {
    if std::env::var_os("BOXFORGE_MEMORY_TRACE").is_some() {
        eprintln!("{what}: RSS {:?} HWM {:?}", current_resident_bytes(), peak_resident_bytes());
    }
}

/// Hands the heap memory this process has freed back to the kernel where
/// the allocator keeps it (glibc's `malloc_trim`; a no-op elsewhere). The
/// out-of-core paths free tens of MiB of preprocessing tables before they
/// fill the brick pool: kept mapped, that memory would count on top of the
/// budget in the peak resident set.
pub fn release_free_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks and shrinks the allocator's own free
    // lists; it takes no pointers from us.
    unsafe {
        glibc::malloc_trim(0);
    }
}

/// Has the allocator give every block of 1 MiB or more its own mapping,
/// unmapped when freed (glibc's M_MMAP_THRESHOLD, which otherwise rises
/// with each large free until such blocks come from the heap, where a
/// freed table can stay resident; a no-op elsewhere). The out-of-core
/// paths set it before their preprocessing tables, so the memory those
/// tables held is gone before the brick pool fills.
pub fn map_large_allocations() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes the allocator's tuning parameters.
    unsafe {
        glibc::mallopt(glibc::M_MMAP_THRESHOLD, 1 << 20);
    }
}

/// Has every thread of this process allocate from one heap arena (glibc's
/// M_ARENA_MAX = 1; a no-op elsewhere). Why: glibc gives threads that
/// contend for the heap arenas of their own, each holding its freed memory;
/// lavapipe's worker threads made the peak resident set of the same
/// out-of-core render vary by 20 MB from run to run (107 to 129 MB for a
/// tiny volume, measured), over the budget's bound at times. With one
/// arena the same runs agreed within 0.5 MB and peaked 15 to 30 MB lower.
/// Call it before the device starts its threads; later calls only cap
/// arenas not yet made.
pub fn one_heap_arena() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes the allocator's tuning parameters.
    unsafe {
        glibc::mallopt(glibc::M_ARENA_MAX, 1);
    }
}

/// The three glibc allocator calls above, declared here rather than taken
/// from the `libc` crate: a host of the library should not pay a dependency
/// for two functions. Signatures and constants as glibc's `<malloc.h>`
/// declares them (`int malloc_trim(size_t)`, `int mallopt(int, int)`,
/// `M_MMAP_THRESHOLD` -3, `M_ARENA_MAX` -8); other C libraries lack them,
/// hence the cfg.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod glibc {
    pub const M_MMAP_THRESHOLD: i32 = -3;
    pub const M_ARENA_MAX: i32 = -8;
    extern "C" {
        pub fn malloc_trim(pad: usize) -> i32;
        pub fn mallopt(param: i32, value: i32) -> i32;
    }
}

fn status_bytes(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_status(&text, key)
}

/// The value of a `Key:   1234 kB` line of a `/proc/<pid>/status` text, in bytes.
fn parse_status(text: &str, key: &str) -> Option<u64> {
    text.lines().find_map(|line| {
        let rest = line.strip_prefix(key)?.strip_prefix(':')?;
        let mut words = rest.split_whitespace();
        let n: u64 = words.next()?.parse().ok()?;
        let unit = match words.next() {
            None => 1,
            Some(u) if u.eq_ignore_ascii_case("kb") => 1024,
            Some(u) if u.eq_ignore_ascii_case("mb") => 1024 * 1024,
            Some(_) => return None,
        };
        n.checked_mul(unit)
    })
}

/// Bytes as KiB, MiB or GiB.
pub fn human(bytes: u64) -> String {
    const K: f64 = 1024.0;
    let b = bytes as f64;
    if b >= K * K * K {
        format!("{:.2} GiB", b / (K * K * K))
    } else if b >= K * K {
        format!("{:.1} MiB", b / (K * K))
    } else if b >= K {
        format!("{:.1} KiB", b / K)
    } else {
        format!("{bytes} B")
    }
}

/// Bytes from a size such as "2GiB", "256MiB", "512MB", "64KiB" or a
/// plain byte count (the inverse of [`human`]; what `--gpu-budget` and the
/// Python package's `gpu_budget` take). None: not a size of at least one byte.
pub fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let scale: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "kib" | "k" => 1024.0,
        "mib" | "m" => 1024.0 * 1024.0,
        "gib" | "g" => 1024.0 * 1024.0 * 1024.0,
        "kb" => 1e3,
        "mb" => 1e6,
        "gb" => 1e9,
        _ => return None,
    };
    match num.parse::<f64>() {
        Ok(n) if n.is_finite() && n * scale >= 1.0 && n * scale < 1e15 => Some((n * scale) as u64),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_and_decimal_units_and_nonsense_does_not() {
        assert_eq!(parse_size("256MiB"), Some(256 << 20));
        assert_eq!(parse_size(" 1.5 KiB"), Some(1536));
        assert_eq!(parse_size("1GB"), Some(1_000_000_000));
        assert_eq!(parse_size("500000"), Some(500_000));
        assert_eq!(parse_size(&human(64 << 20).replace(' ', "")), Some(64 << 20));
        for bad in ["", "MiB", "12 parsecs", "-5", "0", "0.1", "1e30", "nan"] {
            assert_eq!(parse_size(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn memory_status_lines_parse() {
        let text = "Name:\tboxforge\nVmPeak:\t  900 kB\nVmHWM:\t    5120 kB\nVmRSS:\t    4096 kB\nThreads:\t3\n";
        assert_eq!(parse_status(text, "VmHWM"), Some(5120 * 1024));
        assert_eq!(parse_status(text, "VmRSS"), Some(4096 * 1024));
        assert_eq!(parse_status(text, "VmSwap"), None);
        assert_eq!(parse_status(text, "Threads"), Some(3));
        assert_eq!(parse_status("VmRSS:\tlots kB\n", "VmRSS"), None);
        assert_eq!(parse_status("VmRSSX:\t1 kB\n", "VmRSS"), None, "a longer key is another line");
    }

    #[test]
    fn memory_resident_bytes_follow_the_process() {
        let Some(text) = std::fs::read_to_string("/proc/self/status").ok() else {
            eprintln!("no /proc/self/status here: skipped");
            assert_eq!(current_resident_bytes(), None);
            return;
        };
        let (rss, hwm) = (parse_status(&text, "VmRSS").unwrap(), parse_status(&text, "VmHWM").unwrap());
        assert!(rss > 0 && hwm >= rss, "VmRSS {rss} <= VmHWM {hwm} in one reading");
        // 32 MiB touched page by page: the peak afterwards covers them (other
        // test threads only add to it).
        let before = current_resident_bytes().unwrap();
        let mut block = vec![0u8; 32 << 20];
        for i in (0..block.len()).step_by(4096) {
            block[i] = 1;
        }
        let during = current_resident_bytes().unwrap();
        let peak = peak_resident_bytes().unwrap();
        assert_eq!(std::hint::black_box(&block).iter().step_by(4096).filter(|&&b| b == 1).count(), 8192);
        assert!(peak >= during && peak >= before + (24 << 20), "peak {peak}, before {before}, during {during}");
    }
}
