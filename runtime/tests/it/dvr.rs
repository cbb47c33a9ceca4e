//! Direct volume rendering: the GPU image against the CPU reference (f64,
//! exact evaluator), TF-aware skipping that changes speed but not the image,
//! pre-integration against slab artifacts, and `--tf` errors on the CLI.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::blocks::SkipMap;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::{cpu_render, rms, DvrOptions, DvrScene};
use boxforge_runtime::volume::{LatticeVolume, Volume};

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

fn gpu() -> &'static Gpu {
    crate::common::gpu()
}

/// Fraction of pixels that are not the background (20, 20, 26).
fn covered(img: &[u8]) -> f64 {
    img.chunks(4).filter(|p| p[..3] != [20, 20, 26]).count() as f64 / (img.len() / 4) as f64
}

#[test]
fn gpu_dvr_matches_the_cpu_reference() {
    let gpu = gpu();
    let tf = TransferFunction::preset("marschner-lobb");
    for (name, edge, perspective) in [("bcc7", 36, false), ("fcc6", 30, true)] {
        let d = derive(name);
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [edge, edge, edge]).unwrap();
        let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
        for preintegrate in [true, false] {
            let o = DvrOptions { width: 48, height: 48, perspective, preintegrate, frames: 0, ..DvrOptions::default() };
            let frame = scene.render(&tf, &o).unwrap();
            let reference = cpu_render(&d, &vol, &tf, &o);
            assert!(covered(&reference) > 0.3, "{name}: the volume is in view ({:.2})", covered(&reference));
            let e = rms(&frame.rgba, &reference);
            eprintln!("{name} preintegrate={preintegrate}: RMS GPU vs CPU {e:.3}/255");
            assert!(e < 2.0, "{name} (pre-integrated: {preintegrate}): RMS {e:.2}/255 against the CPU reference");
        }
    }
    // The packed layout gives the same image.
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [36, 36, 36]).unwrap();
    let o = DvrOptions { width: 32, height: 32, frames: 0, ..DvrOptions::default() };
    let packed = DvrScene::new(gpu, &d, &vol, Layout::Packed, 4).unwrap().render(&tf, &o).unwrap();
    let e = rms(&packed.rgba, &cpu_render(&d, &vol, &tf, &o));
    assert!(e < 2.0, "packed: RMS {e:.2}/255 against the CPU reference");
}

#[test]
fn shading_and_the_transfer_function_change_the_image() {
    // The reference is not insensitive to its inputs: another TF or view
    // gives a different image.
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).unwrap();
    let o = DvrOptions { width: 24, height: 24, frames: 0, ..DvrOptions::default() };
    let ml = TransferFunction::preset("marschner-lobb");
    let a = cpu_render(&d, &vol, &ml, &o);
    let mut dim = ml.clone();
    dim.points.iter_mut().for_each(|p| p.opacity *= 0.3);
    assert!(rms(&a, &cpu_render(&d, &vol, &dim, &o)) > 3.0);
    assert!(rms(&a, &cpu_render(&d, &vol, &ml, &DvrOptions { azimuth: 75.0, ..o.clone() })) > 3.0);
}

fn mni() -> Volume {
    let path = boxforge_runtime::scene::data_file("mni152_t1_1mm.nii.gz").expect("data/mni152_t1_1mm.nii.gz");
    Volume::load_nifti(&path).unwrap()
}

#[test]
fn tf_aware_skipping_skips_the_air_of_the_head_and_keeps_the_image() {
    let gpu = gpu();
    let d = derive("bcc7");
    let vol = boxforge_runtime::scene::from_cartesian(
        &mni(),
        &d.filter.lattice,
        boxforge_runtime::scene::Conversion::Resample,
    )
    .unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    let tf = TransferFunction::preset("mni-tissue");
    let o = DvrOptions {
        width: 64,
        height: 64,
        step: 1.0,
        azimuth: 200.0,
        elevation: 15.0,
        frames: 0,
        ..DvrOptions::default()
    };
    let skip = scene.render(&tf, &o).unwrap();
    let no_skip = scene.render(&tf, &DvrOptions { skip: false, ..o.clone() }).unwrap();
    assert!(skip.empty_blocks > 0.4, "air blocks are skipped: {:.2}", skip.empty_blocks);
    assert!(covered(&skip.rgba) > 0.08, "the head is in view ({:.2})", covered(&skip.rgba));
    let e = rms(&skip.rgba, &no_skip.rgba);
    assert!(e < 0.5, "skipping changed the image: RMS {e:.3}/255");
    // The skipped GPU image against the CPU reference (which never skips), on real data.
    let small = DvrOptions { width: 40, height: 40, ..o.clone() };
    let gpu_small = scene.render(&tf, &small).unwrap();
    let e = rms(&gpu_small.rgba, &cpu_render(&d, &vol, &tf, &small));
    eprintln!("MNI head, TF skipping: RMS GPU vs CPU {e:.3}/255");
    assert!(e < 2.0, "MNI head: RMS {e:.2}/255 against the CPU reference");
    // An opaque TF everywhere leaves no block empty.
    let mut opaque = tf.clone();
    opaque.points.iter_mut().for_each(|p| p.opacity = 0.5);
    let all = scene.render(&opaque, &DvrOptions { width: 8, height: 8, ..o }).unwrap();
    assert_eq!(all.empty_blocks, 0.0);
}

#[test]
fn preintegration_removes_slab_artifacts_at_step_one() {
    let gpu = gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [40, 40, 40]).unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    let tf = TransferFunction::preset("marschner-lobb");
    let o = DvrOptions { width: 64, height: 64, frames: 0, ..DvrOptions::default() };
    let fine = scene.render(&tf, &DvrOptions { step: 0.1, preintegrate: false, ..o.clone() }).unwrap();
    let pi = scene.render(&tf, &DvrOptions { step: 1.0, preintegrate: true, ..o.clone() }).unwrap();
    let point = scene.render(&tf, &DvrOptions { step: 1.0, preintegrate: false, ..o }).unwrap();
    let (e_pi, e_point) = (rms(&pi.rgba, &fine.rgba), rms(&point.rgba, &fine.rgba));
    eprintln!("step 1.0 against step 0.1: pre-integrated RMS {e_pi:.2}/255, point-sampled {e_point:.2}/255");
    assert!(e_pi < 0.7 * e_point, "pre-integrated {e_pi:.2} vs point-sampled {e_point:.2}");
}

/// `boxforge` with no Vulkan driver: the TF must be refused before a device is needed.
fn run(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(args)
        .env("VK_ICD_FILENAMES", "/nonexistent.json")
        .env("VK_DRIVER_FILES", "/nonexistent.json")
        .output()
        .expect("run boxforge")
}

#[test]
fn bad_transfer_functions_are_one_clear_line_with_exit_code_2() {
    let dir = std::env::temp_dir().join(format!("boxforge-dvr-tf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let w = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    let out = dir.join("out.png").display().to_string();
    let cases = [
        (w("syntax.json", "{\"range\": [0, 1], \"points\": ["), "not a valid transfer function"),
        (w("range.json", r#"{"range": [5, 5], "points": []}"#), "lo < hi"),
        (
            w(
                "order.json",
                r#"{"range": [0, 1], "points": [{"value": 0.6, "color": [0,0,0], "opacity": 0}, {"value": 0.2, "color": [0,0,0], "opacity": 0}]}"#,
            ),
            "increasing value",
        ),
        (dir.join("missing.json").display().to_string(), "cannot read"),
        ("no-such-preset".to_string(), "no such preset"),
    ];
    for (tf, fragment) in &cases {
        let o = run(&["render", "--filter", "bcc7", "--volume", "ml:8", "--mode", "dvr", "--tf", tf, "--out", &out]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(o.status.code(), Some(2), "--tf {tf}: {stderr}");
        assert!(lines.len() == 1 && lines[0].starts_with("error: --tf "), "--tf {tf}: {stderr}");
        assert!(lines[0].contains(fragment), "--tf {tf}: {stderr}");
    }
    // --tf belongs to --mode dvr.
    let o = run(&["render", "--filter", "bcc7", "--volume", "ml:8", "--tf", "mni-tissue", "--out", &out]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--mode dvr"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The issue's numbers, printed (not a pass/fail test: timings vary):
/// `cargo test -p boxforge-runtime --test dvr measure -- --ignored --nocapture`.
#[test]
#[ignore]
fn measure_dvr_targets() {
    let gpu = gpu();
    let mut o = boxforge_runtime::bench::BenchOptions::full();
    o.filters = vec!["bcc7".into()];
    o.runs = 7;
    for row in boxforge_runtime::bench::dvr::rows(gpu, &o, o.runs, &|m| eprintln!("{m}")).unwrap() {
        eprintln!(
            "{} {} {}: {:.1} ms/frame {} {}",
            row.filter,
            row.kind,
            row.variant,
            row.ms_per_frame.unwrap(),
            row.ratio.map(|r| r.display()).unwrap_or_default(),
            row.baseline.unwrap_or_default()
        );
    }
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [40, 40, 40]).unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    let tf = TransferFunction::preset("marschner-lobb");
    let q = boxforge_runtime::bench::dvr::quality(
        &scene,
        &tf,
        &DvrOptions { width: 256, height: 256, ..DvrOptions::default() },
    )
    .unwrap();
    eprintln!("Marschner-Lobb bcc7 256^2, step 1.0 against step 0.1: {q:?}");
}

#[test]
fn bench_rows_and_markdown_for_dvr() {
    let gpu = gpu();
    let o = boxforge_runtime::bench::BenchOptions::smoke();
    let rows = boxforge_runtime::bench::dvr::rows(gpu, &o, 1, &|_| {}).unwrap();
    assert_eq!(rows.len(), 3, "skipping, no skipping, point-sampled");
    assert!(rows.iter().all(|r| r.kind.starts_with("dvr_ml_") && r.ms_per_frame.is_some_and(|m| m > 0.0)));
    assert!(rows[1].ratio.is_some() && rows[2].baseline.as_deref().is_some_and(|b| b.contains("RMS")));
    let md = boxforge_runtime::bench::dvr::markdown(&rows);
    assert!(md.contains("### Direct volume rendering") && md.contains("no skipping ÷ TF skipping"), "{md}");
    assert!(boxforge_runtime::bench::dvr::markdown(&[]).is_empty());
}

#[test]
fn a_dvr_render_writes_its_png() {
    let dir = std::env::temp_dir().join(format!("boxforge-dvr-png-{}", std::process::id()));
    let out = dir.join("ml.png");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["render", "--mode", "dvr", "--tf", "marschner-lobb", "--filter", "bcc_linear", "--volume", "ml:16"])
        .args(["--size", "24", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    assert!(String::from_utf8_lossy(&o.stdout).contains("volume rendering"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn skipping_keeps_a_surface_that_starts_right_past_an_empty_block() {
    // Zero below x = 9, one from x = 9 on: the cubes up to x = 8 are zero, so
    // the block [4, 8) is transparent while the value rises right past its
    // face. Segments of 2 cells that start in that block end in the rise: the
    // skipping must not drop them.
    let gpu = gpu();
    let d = derive("cc_trilinear");
    let n = 24;
    let data = (0..n * n * n).map(|i| if i % n >= 9 { 1.0 } else { 0.0 }).collect();
    let vol = LatticeVolume { lattice: d.filter.lattice.clone(), dims: [n, n, n], data };
    let tf = TransferFunction::parse(
        r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
            {"value": 0.1, "color": [0, 0, 0], "opacity": 0}, {"value": 0.3, "color": [1, 0.5, 0.2], "opacity": 0.6}, {"value": 1, "color": [1, 1, 1], "opacity": 0.6}]}"#,
        "step.json",
    )
    .unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    let o = DvrOptions {
        width: 48,
        height: 48,
        step: 2.0,
        azimuth: 190.0,
        elevation: 20.0,
        frames: 0,
        ..DvrOptions::default()
    };
    for preintegrate in [false, true] {
        let o = DvrOptions { preintegrate, ..o.clone() };
        let skip = scene.render(&tf, &o).unwrap();
        assert!(skip.empty_blocks > 0.2, "{}", skip.empty_blocks);
        let no_skip = scene.render(&tf, &DvrOptions { skip: false, ..o.clone() }).unwrap();
        let e = rms(&skip.rgba, &no_skip.rgba);
        assert!(e < 0.5, "pre-integrated {preintegrate}: skipping changed the image, RMS {e:.2}/255");
        let e = rms(&skip.rgba, &cpu_render(&d, &vol, &tf, &o));
        assert!(e < 2.0, "pre-integrated {preintegrate}: RMS {e:.2}/255 against the CPU reference");
        // The comparison can fail: a skip map one block too far (the block
        // [0, 4) jumping over [4, 8) too) drops the segments that reach the rise.
        let wrong = scene.render(&tf, &DvrOptions { skip_map: SkipMap::Overshoot, ..o.clone() }).unwrap();
        let e = rms(&wrong.rgba, &no_skip.rgba);
        eprintln!("pre-integrated {preintegrate}: a map one block too far, RMS {e:.2}/255");
        assert!(e >= 0.5, "pre-integrated {preintegrate}: a wrong skip map went unnoticed (RMS {e:.3}/255)");
    }
}

#[test]
fn dvr_without_a_transfer_function_uses_the_default_ramp_and_says_so() {
    let dir = std::env::temp_dir().join(format!("boxforge-dvr-default-{}", std::process::id()));
    let out = dir.join("ml.png");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["render", "--mode", "dvr", "--filter", "bcc_linear", "--volume", "ml:16"])
        .args(["--size", "24", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("default transfer function, a ramp over ["), "{stderr}");
    // The ramp shows the data: the image is not the empty background.
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap())).read_info().unwrap();
    let mut rgba = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut rgba).unwrap();
    let distinct: std::collections::BTreeSet<&[u8]> = rgba.chunks(4).collect();
    assert!(distinct.len() > 20, "{} distinct colours: the default ramp shows nothing", distinct.len());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_default_ramp_spans_the_data_and_rises_from_transparent() {
    let tf = TransferFunction::ramp(-2.0, 6.0);
    assert_eq!(tf.range, [-2.0, 6.0]);
    assert_eq!(tf.eval(-2.0).1, 0.0);
    assert!(tf.eval(2.0).1 > 0.0 && tf.eval(6.0).1 > tf.eval(2.0).1);
    // A constant volume still gets a usable (non-empty) range.
    let flat = TransferFunction::ramp(3.0, 3.0);
    assert!(flat.range[1] > flat.range[0]);
}

#[test]
fn distance_skipping_keeps_the_dvr_image_and_a_map_one_block_too_far_is_caught() {
    let gpu = gpu();
    let d = derive("cc_trilinear");
    let vol = LatticeVolume::subset(&d.filter.lattice, &crate::common::sparse_balls(48)).unwrap();
    let tf = TransferFunction::parse(
        r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
            {"value": 0.05, "color": [0, 0, 0], "opacity": 0}, {"value": 0.1, "color": [1, 0.5, 0.2], "opacity": 0.9}, {"value": 1, "color": [1, 1, 1], "opacity": 0.9}]}"#,
        "balls.json",
    )
    .unwrap();
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4).unwrap();
    for (step, perspective) in [(2.0, false), (1.0, true), (0.5, false)] {
        let o = DvrOptions { width: 64, height: 64, step, perspective, frames: 0, ..DvrOptions::default() };
        let no_skip = scene.render(&tf, &DvrOptions { skip: false, ..o.clone() }).unwrap();
        let with = |skip_map| scene.render(&tf, &DvrOptions { skip_map, ..o.clone() }).unwrap();
        let f = with(SkipMap::Distance);
        let map = f.skip_map.expect("a skip map");
        let (e, one, wrong) = (
            rms(&f.rgba, &no_skip.rgba),
            rms(&with(SkipMap::OneBlock).rgba, &no_skip.rgba),
            rms(&with(SkipMap::Overshoot).rgba, &no_skip.rgba),
        );
        eprintln!(
            "step {step}: RMS distance {e:.3}, one block {one:.3}, overshoot {wrong:.3}; {:.0}% empty, mean skip {:.2}",
            f.empty_blocks * 100.0,
            map.mean_distance
        );
        assert!(covered(&f.rgba) > 0.03, "the balls are in view");
        assert!(f.empty_blocks > 0.8 && map.mean_distance > 2.0, "the jumps span several blocks");
        assert!(e < 0.5 && one < 0.5, "step {step}: skipping changed the image: RMS {e:.3} / {one:.3}");
        // Here the wrongly skipped segments reach little opacity (see the
        // next test for one that the comparison catches).
        assert!(wrong > 0.0, "step {step}: a map one block too far changes the image");
    }
}
