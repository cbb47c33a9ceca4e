//! Volume rendering out of core: a frame rendered in passes through a pool
//! far smaller than the volume equals the in-core volume rendering (the
//! same segments, skipping and compositing), on each lattice and on the head
//! in u8; a transfer function transparent over the data uploads nothing.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::{DvrLook, DvrOptions};
use boxforge_runtime::render::paged::{PagedDvrRenderer, PagedOptions, PagedStats};
use boxforge_runtime::volume::{LatticeVolume, SampleFormat, VolumeOptions};

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

/// RMS difference in 1/255.
fn rms(a: &[u8], b: &[u8]) -> f64 {
    let sq: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum();
    (sq / a.len() as f64).sqrt()
}

/// The in-core frame and the paged one (bricks of `brick`, a pool of
/// `slots`^3 slots) of `vol` under `tf`, with the paged frame's stats.
fn both(
    d: &Derivation,
    vol: &LatticeVolume,
    tf: &TransferFunction,
    o: &DvrOptions,
    format: SampleFormat,
    slots: usize,
    brick: usize,
) -> (Vec<u8>, Vec<u8>, PagedStats) {
    let gpu = crate::common::gpu();
    let in_core = DvrOptions { volume: VolumeOptions { format, ..Default::default() }, frames: 0, ..o.clone() };
    let a = boxforge_runtime::render::dvr::render(gpu, d, vol, Layout::Embedded, tf, &in_core).unwrap();
    let slot = brick + 2 * boxforge::emit::bricks::brick_halo(d);
    let options = PagedOptions {
        brick,
        format,
        max_pixels: (o.width * o.height) as u64,
        max_pool_edge: Some(slots * slot),
        ..PagedOptions::default()
    };
    let mut r = PagedDvrRenderer::new(gpu, d, vol, tf.table(), DvrLook::from(o), options, &|_, _| {}).unwrap();
    let (frame, stats) = r.render(vol, o).unwrap();
    (a.rgba, frame.rgba, stats)
}

#[test]
fn paged_volume_renderings_equal_in_core_ones_on_every_lattice() {
    let tf = TransferFunction::preset("marschner-lobb");
    for name in ["bcc7", "cc_tricubic", "fcc6"] {
        let d = derive(name);
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [20, 20, 20]).unwrap();
        let o = DvrOptions { width: 36, height: 36, ..DvrOptions::default() };
        let (a, b, stats) = both(&d, &vol, &tf, &o, SampleFormat::F32, 3, 4);
        eprintln!("{name}: {stats:?}");
        let e = rms(&a, &b);
        assert!(e < 0.5, "{name}: the paged volume rendering differs (RMS {e:.3}/255, {stats:?})");
        assert!(stats.passes > 2 && stats.evictions > 0, "{name}: a pool of {} slots pages ({stats:?})", stats.slots);
    }
}

#[test]
fn a_paged_head_in_u8_equals_the_in_core_one_and_skips_the_air() {
    let d = derive("bcc7");
    let path = boxforge_runtime::scene::data_file("mni152_t1_1mm.nii.gz").unwrap();
    let full = boxforge_runtime::volume::Volume::load_nifti(&path).unwrap();
    let vol =
        boxforge_runtime::scene::from_cartesian(&full, &d.filter.lattice, boxforge_runtime::scene::Conversion::Subset)
            .unwrap();
    let tf = TransferFunction::preset("mni-tissue");
    let o = DvrOptions { width: 40, height: 40, step: 1.0, azimuth: 200.0, elevation: 15.0, ..DvrOptions::default() };
    let (a, b, stats) = both(&d, &vol, &tf, &o, SampleFormat::U8, 5, 8);
    eprintln!("head: {stats:?}");
    let e = rms(&a, &b);
    assert!(e < 0.5, "head: the paged u8 volume rendering differs (RMS {e:.3}/255, {stats:?})");
    assert!(
        stats.occupied_bricks < stats.bricks && stats.uploads < stats.bricks,
        "bricks of air are never uploaded ({stats:?})"
    );
}

#[test]
fn a_transfer_function_transparent_over_the_data_uploads_no_brick() {
    let gpu = crate::common::gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [16, 16, 16]).unwrap();
    // Marschner-Lobb lies in [0, 1]; this function is transparent up to 2.
    use boxforge_runtime::render::dvr::transfer::ControlPoint;
    let point = |value: f64, opacity: f64| ControlPoint { value, color: [1.0, 0.5, 0.2], opacity };
    let tf = TransferFunction {
        name: "transparent below 2".into(),
        range: [0.0, 4.0],
        points: vec![point(0.0, 0.0), point(2.0, 0.0), point(4.0, 1.0)],
    };
    let o = DvrOptions { width: 24, height: 24, ..DvrOptions::default() };
    let options = PagedOptions { brick: 4, max_pixels: 576, ..PagedOptions::default() };
    let mut r = PagedDvrRenderer::new(gpu, &d, &vol, tf.table(), DvrLook::from(&o), options, &|_, _| {}).unwrap();
    let (frame, stats) = r.render(&vol, &o).unwrap();
    assert_eq!((stats.uploads, stats.passes, stats.occupied_bricks), (0, 1, 0), "{stats:?}");
    assert!(frame.rgba.chunks(4).all(|p| p == frame.rgba[..4].to_vec()), "background only");
}

#[test]
fn render_dvr_with_a_budget_renders_out_of_core_from_the_cli() {
    let dir = std::env::temp_dir().join(format!("boxforge-paged-dvr-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("dvr.png");
    // With a transfer function, and without one (the default ramp).
    for tf in [&["--tf", "marschner-lobb"][..], &[]] {
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_boxforge"))
            .args(["render", "--filter", "bcc7", "--volume", "ml:24", "--mode", "dvr"])
            .args(tf)
            .args(["--size", "32", "--gpu-budget", "2MiB", "--brick", "8", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{stderr}");
        // A volume rendering (its bricks hold visible blocks), not an isosurface.
        assert!(stderr.contains("out of core") && stderr.contains("visible blocks"), "{stderr}");
        assert_eq!(tf.is_empty(), stderr.contains("no --tf given"), "{stderr}");
        let png = std::fs::read(&out).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
