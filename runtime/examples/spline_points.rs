//! The generator's f64 evaluator (`Derivation::eval_f64`) at points read
//! from a file, on samples read from a file: the Rust side that
//! python/tests/test_spline.py compares `boxforge.Spline` with bit for bit,
//! and that python/bench/spline_speed.py times `Spline.eval` against.
//!
//! ```text
//! spline_points SPEC SAMPLES NX NY NZ POINTS OUT          # value, gradient, Hessian
//! spline_points SPEC SAMPLES NX NY NZ POINTS --time REPS  # ns per point, as JSON
//! ```
//!
//! SAMPLES: NX * NY * NZ little-endian f32, x fastest, sample (i, j, k) at
//! (i, j, k) and fetched clamped into the box. POINTS: little-endian f64
//! triples (x, y, z). OUT: per point, little-endian f64 value, gradient
//! (3) and Hessian (9, row-major), all along (x, y, z). `--time`: the best
//! of REPS runs of the values at every point, one thread, and over every
//! core with `boxforge_runtime::par::par_map`; wall and CPU time per point.

use boxforge::derive::Derivation;
use std::time::Instant;

fn bytes(path: &str) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: spline_points SPEC SAMPLES NX NY NZ POINTS (OUT | --time REPS)";
    assert!(args.len() == 7 || (args.len() == 8 && args[6] == "--time"), "{usage}");
    let d = Derivation::new(&boxforge::spec::resolve(&args[0]).expect("a spec")).expect("a derivation");
    let n: Vec<usize> = args[2..5].iter().map(|a| a.parse().expect("NX NY NZ are whole numbers")).collect();
    let data: Vec<f32> = bytes(&args[1]).chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    assert_eq!(data.len(), n[0] * n[1] * n[2], "SAMPLES holds NX * NY * NZ floats");
    let coordinates: Vec<f64> =
        bytes(&args[5]).chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect();
    let points: Vec<[f64; 3]> = coordinates.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let fetch = |j: &[i64]| {
        let c = |a: usize| j[a].clamp(0, n[a] as i64 - 1) as usize;
        f64::from(data[c(0) + n[0] * (c(1) + n[1] * c(2))])
    };
    if args[6] != "--time" {
        let mut out = Vec::with_capacity(points.len() * 13 * 8);
        for p in &points {
            let (v, g) = d.eval_f64(p, &fetch);
            let (_, _, h) = d.eval_f64_hessian(p, &fetch);
            for x in std::iter::once(v).chain(g).chain(h) {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        std::fs::write(&args[6], out).expect("OUT is writable");
        return;
    }
    let reps: usize = args[7].parse().expect("REPS is a whole number");
    // Wall and CPU seconds (every thread of the process), each the least of REPS runs.
    let best = |f: &dyn Fn() -> Vec<f64>| {
        (0..reps).fold((f64::INFINITY, f64::INFINITY), |(wall, cpu), _| {
            let (t, c) = (Instant::now(), cpu_seconds());
            std::hint::black_box(f());
            (wall.min(t.elapsed().as_secs_f64()), cpu.min(cpu_seconds() - c))
        })
    };
    let one = best(&|| points.iter().map(|p| d.eval_f64(p, &fetch).0).collect());
    let all = best(&|| boxforge_runtime::par::par_map(&points, |p| d.eval_f64(p, &fetch).0));
    let ns = |s: f64| s * 1e9 / points.len() as f64;
    println!(
        "{{\"points\": {}, \"one_thread_ns\": {:.2}, \"par_map_ns\": {:.2}, \"one_thread_cpu_ns\": {:.2}, \"par_map_cpu_ns\": {:.2}}}",
        points.len(),
        ns(one.0),
        ns(all.0),
        ns(one.1),
        ns(all.1)
    );
}

/// CPU seconds of the process so far, user and system, every thread (Linux:
/// /proc/self/stat, in clock ticks of 10 ms).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("/proc/self/stat (Linux)");
    // The fields after the command's closing parenthesis; utime and stime are the 12th and 13th.
    let rest = &stat[stat.rfind(')').expect("(comm)") + 2..];
    let f: Vec<f64> = rest.split(' ').skip(11).take(2).map(|x| x.parse().expect("a tick count")).collect();
    (f[0] + f[1]) / 100.0
}
