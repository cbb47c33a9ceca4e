//! PERM (`render --mode dvr --cache perm`): the memory the cache reports
//! against the paper's formula applied to our counts, the image against
//! direct evaluation, the candidate cells and cached densities against CPU
//! computations, and the bad `--cache`/`--qc` inputs on the CLI.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::{Tf1d, TransferFunction};
use boxforge_runtime::render::dvr::{rms, DvrOptions, DvrScene};
use boxforge_runtime::render::perm::{formula, PermCache, Quant};
use boxforge_runtime::volume::LatticeVolume;

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

fn gpu() -> &'static Gpu {
    crate::common::gpu()
}

/// Marschner-Lobb's opaque shell at 0.5 and nothing else: most cells are
/// transparent, so the selection, the dilation and the substitutes matter.
fn shell() -> TransferFunction {
    TransferFunction::parse(
        r#"{"range": [0, 1], "points": [
            {"value": 0, "color": [0, 0, 0], "opacity": 0}, {"value": 0.4, "color": [0.2, 0.4, 0.9], "opacity": 0},
            {"value": 0.5, "color": [1, 0.7, 0.3], "opacity": 0.7}, {"value": 0.6, "color": [0.9, 0.2, 0.2], "opacity": 0},
            {"value": 1, "color": [0, 0, 0], "opacity": 0}]}"#,
        "shell",
    )
    .unwrap()
}

fn options() -> DvrOptions {
    DvrOptions { width: 48, height: 48, frames: 0, ..DvrOptions::default() }
}

#[test]
fn reported_memory_is_the_papers_formula_applied_to_our_counts() {
    let gpu = gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [16, 16, 16]).unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    let table = shell().table();
    for quant in
        [Quant { density: 3, gradient: 3 }, Quant { density: 5, gradient: 3 }, Quant { density: 2, gradient: 4 }]
    {
        let cache = PermCache::build(&scene, &table, quant, 0.5, true).unwrap();
        let c = cache.counts;
        assert_eq!(c.cells, 16 * 16 * 16);
        assert_eq!(c.rows, 16 * 16);
        assert!(c.candidates > 0 && c.candidates < c.cells, "{} of {} cells", c.candidates, c.cells);
        let (n3, m3) = (quant.density.pow(3) as u64, quant.gradient.pow(3) as u64);
        // Equation 6 written out here: S b_iv + rows b_sat + N_cc (N^3 b_db + M^3 (3 b_gb + b_sb)).
        let paper = c.cells * 2 + c.rows * 4 + c.candidates * (n3 * 2 + m3 * 4);
        assert_eq!(formula(&c).total(), paper);
        let got = cache.memory.total();
        let err = (got as f64 - paper as f64).abs() / paper as f64;
        eprintln!("N={} M={}: {} vs formula {paper} bytes", quant.density, quant.gradient, cache.memory.describe());
        assert!(err < 0.01, "reported {got} bytes, formula {paper}: {:.3}% off", err * 100.0);
        for (part, want) in [
            (cache.memory.density, c.candidates * n3 * 2),
            (cache.memory.gradient, c.candidates * m3 * 3),
            (cache.memory.sign, c.candidates * m3),
        ] {
            // Each part within 1% (a texture rounds its words up to whole rows).
            assert!(part >= want && (part - want) * 100 <= want, "part {part} vs {want}");
        }
    }
}

#[test]
fn perm_image_matches_direct_evaluation_at_n_10() {
    let gpu = gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    for tf in [shell(), TransferFunction::preset("marschner-lobb")] {
        let o = options();
        let table = tf.table();
        let pi = table.preintegrate(o.step as f64);
        let direct = scene.render_tables(&table, Some(&pi), &o).unwrap();
        let mut errors = vec![];
        for n in [1, 10] {
            let cache = PermCache::build(&scene, &table, Quant { density: n, gradient: n }, o.step, true).unwrap();
            let frame = cache.render(&scene, &table, Some(&pi), &o).unwrap();
            errors.push(rms(&frame.rgba, &direct.rgba));
        }
        eprintln!("{}: RMS PERM vs direct, N=1 {:.2}/255, N=10 {:.2}/255", tf.name, errors[0], errors[1]);
        assert!(errors[1] < 2.0, "{}: N=10 RMS {:.2}/255 against direct evaluation", tf.name, errors[1]);
        // The comparison can fail: one position per cell is visibly off.
        assert!(errors[0] > 2.0 * errors[1] && errors[0] > 2.0, "{}: N=1 RMS {:.2}/255", tf.name, errors[0]);
    }
    // Without pre-integration (no dilation) too.
    let o = DvrOptions { preintegrate: false, ..options() };
    let table = shell().table();
    let direct = scene.render_tables(&table, None, &o).unwrap();
    let cache = PermCache::build(&scene, &table, Quant { density: 10, gradient: 10 }, o.step, false).unwrap();
    let e = rms(&cache.render(&scene, &table, None, &o).unwrap().rgba, &direct.rgba);
    assert!(e < 2.0, "point-sampled: RMS {e:.2}/255");
    // A cache refuses options it was not built for.
    assert!(cache.render(&scene, &table, Some(&table.preintegrate(0.5)), &options()).is_err());
}

/// Visible by dense sampling with the exact evaluator: a sampled value the
/// table does not map to zero.
fn cpu_visible(d: &Derivation, vol: &LatticeVolume, table: &Tf1d, cell: [usize; 3], k: usize) -> (bool, f64, f64) {
    let data = |j: &[i64]| vol.get(j) as f64;
    let (mut vis, mut lo, mut hi) = (false, f64::INFINITY, f64::NEG_INFINITY);
    for s in 0..k * k * k {
        let q = [s % k, (s / k) % k, s / (k * k)];
        let p: Vec<f64> = (0..3).map(|a| cell[a] as f64 + (q[a] as f64 + 0.5) / k as f64).collect();
        let v = d.eval_f64(&p, &data).0;
        vis |= !table.transparent(v, v);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (vis, lo, hi)
}

#[test]
fn candidate_cells_and_cached_values_match_cpu_computations() {
    let gpu = gpu();
    for name in ["bcc_linear", "cc_tricubic"] {
        let d = derive(name);
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [12, 12, 12]).unwrap();
        let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
        let table = shell().table();
        let quant = Quant { density: 3, gradient: 2 };
        let cache = PermCache::build(&scene, &table, quant, 0.5, true).unwrap();
        let [nx, ny, nz] = vol.dims;
        let cell = |i: usize| [i % nx, (i / nx) % ny, i / (nx * ny)];
        // Every cell the exact evaluator shows is visible, and a visible
        // cell's sampled values are not all far inside a transparent stretch.
        let mut shown = 0;
        for i in 0..nx * ny * nz {
            let (vis, _, _) = cpu_visible(&d, &vol, &table, cell(i), 4);
            if vis {
                shown += 1;
                assert!(cache.visible[i], "{name}: cell {:?} shows values but was not selected", cell(i));
            }
        }
        let visible = cache.visible.iter().filter(|&&v| v).count();
        eprintln!("{name}: {shown} cells shown by sampling, {visible} visible, {} candidates", cache.counts.candidates);
        assert!(shown > 0 && visible < nx * ny * nz, "{name}: the shell shows, not everything");
        // Candidates: the visible cells dilated by ceil(0.5) = 1 cell, brute force.
        for i in 0..nx * ny * nz {
            let c = cell(i).map(|v| v as i64);
            let near = (0..nx * ny * nz).any(|j| {
                let e = cell(j).map(|v| v as i64);
                cache.visible[j] && (0..3).all(|a| (c[a] - e[a]).abs() <= 1)
            });
            assert_eq!(cache.index.slot(i, nx).is_some(), near, "{name}: cell {:?}", cell(i));
        }
        // The cached densities (computed on the device) are the exact
        // evaluator's at the sub-cell centres, to 16-bit fixed point.
        let dens = cache.densities(gpu, &table).unwrap();
        let n = quant.density as usize;
        let data = |j: &[i64]| vol.get(j) as f64;
        let mut worst = 0f64;
        for (slot, &ci) in cache.index.cells.iter().enumerate().step_by(7) {
            let c = cell(ci as usize);
            for s in 0..n * n * n {
                let q = [s % n, (s / n) % n, s / (n * n)];
                let p: Vec<f64> = (0..3).map(|a| c[a] as f64 + (q[a] as f64 + 0.5) / n as f64).collect();
                let want = d.eval_f64(&p, &data).0.clamp(0.0, 1.0);
                worst = worst.max((dens[slot * n * n * n + s] as f64 - want).abs());
            }
        }
        assert!(worst < 2e-5, "{name}: cached density off by {worst}");
    }
}

/// An opaque ball (0.9 inside radius 12, 0.1 outside radius 16, a smooth rim) on CC.
fn ball(n: usize) -> LatticeVolume {
    let lattice = boxforge::spec::lattice::Lattice::builtin("cc").unwrap();
    let c = (n as f64 - 1.0) / 2.0;
    let mut data = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let r = ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2)).sqrt();
                let t = ((r - 14.0) / 2.0).clamp(-1.0, 1.0);
                data.push((0.5 - 0.4 * t) as f32);
            }
        }
    }
    LatticeVolume { lattice, dims: [n; 3], data }
}

#[test]
fn peeling_drops_unreachable_cells_and_leaves_the_image_unchanged() {
    let gpu = gpu();
    let d = derive("cc_tricubic");
    let vol = ball(40);
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    let tf = TransferFunction::parse(
        r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
            {"value": 0.4, "color": [0.3, 0.5, 0.9], "opacity": 0}, {"value": 0.6, "color": [1, 0.8, 0.5], "opacity": 0.9},
            {"value": 1, "color": [1, 0.8, 0.5], "opacity": 0.9}]}"#,
        "ball",
    )
    .unwrap();
    let table = tf.table();
    let o = options();
    let pi = table.preintegrate(o.step as f64);
    let quant = Quant { density: 3, gradient: 3 };
    let full = PermCache::build(&scene, &table, quant, o.step, true).unwrap();
    let peeled = PermCache::build_peeled(&scene, &table, quant, o.step, true, Some(o.termination)).unwrap();
    eprintln!(
        "ball: {} candidates, {} peeled; memory {} -> {} bytes",
        full.counts.candidates,
        peeled.peeled,
        full.memory.total(),
        peeled.memory.total()
    );
    assert!(peeled.peeled > 100, "the ball's core is unreachable: {} peeled", peeled.peeled);
    assert_eq!(peeled.counts.candidates + peeled.peeled, full.counts.candidates);
    assert!(peeled.memory.total() < full.memory.total());
    for (az, el) in [(30.0, 25.0), (200.0, -40.0), (95.0, 70.0)] {
        let o = DvrOptions { azimuth: az, elevation: el, ..options() };
        let a = full.render(&scene, &table, Some(&pi), &o).unwrap();
        let b = peeled.render(&scene, &table, Some(&pi), &o).unwrap();
        let diff = a.rgba.iter().zip(&b.rgba).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
        assert_eq!(diff, 0, "view ({az}, {el}): peeling changed a pixel by {diff}/255");
    }
    // The image sees the ball (the comparison is not between two empty frames)...
    let direct = scene.render_tables(&table, Some(&pi), &o).unwrap();
    let lit = direct.rgba.chunks(4).filter(|p| p[0] > 100).count();
    assert!(lit > 200, "{lit} bright pixels");
    // ...and rays that would go deeper than the peeling assumed are refused.
    let deeper = DvrOptions { termination: 0.999, ..options() };
    assert!(peeled.render(&scene, &table, Some(&pi), &deeper).is_err());
}

#[test]
fn bad_cache_options_are_one_line_and_exit_2_before_any_gpu_work() {
    let out = std::env::temp_dir().join(format!("boxforge-perm-{}.png", std::process::id()));
    let out = out.display().to_string();
    let base = ["render", "--filter", "bcc7", "--volume", "ml:8", "--out", &out];
    for (extra, fragment) in [
        (&["--mode", "dvr", "--tf", "marschner-lobb", "--cache", "perm", "--qc", "0"][..], "--qc 0"),
        (&["--mode", "dvr", "--tf", "marschner-lobb", "--cache", "perm", "--qc-grad", "0"][..], "--qc-grad 0"),
        (&["--mode", "dvr", "--tf", "marschner-lobb", "--cache", "perm", "--qc", "1000"][..], "6000000000 bytes"),
        (&["--cache", "perm"][..], "--mode iso"),
        (&["--mode", "dvr", "--tf", "marschner-lobb", "--cache", "lru"][..], "'lru' for '--cache"),
        (&["--mode", "dvr", "--tf", "marschner-lobb", "--qc", "5"][..], "add --cache perm"),
        (&["--mode", "dvr", "--tf", "marschner-lobb", "--peel"][..], "--peel peels the PERM cache"),
    ] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_boxforge"))
            .args(base.iter().chain(extra))
            // No device may be needed: point Vulkan at nothing.
            .env("VK_ICD_FILENAMES", "/nonexistent.json")
            .env("VK_DRIVER_FILES", "/nonexistent.json")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(
            lines.len() == 1 && lines[0].starts_with("error: ") && lines[0].contains(fragment),
            "{extra:?}: {stderr}"
        );
    }
}
