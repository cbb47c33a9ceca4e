//! Out of core: a frame rendered in passes through a pool far smaller than
//! the volume (bricks paged in as rays reach them, least recently requested
//! evicted) equals the in-core image, for every catalog filter and on the
//! head, in f32 and in u8; a budget too small for the pool is refused.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::render::iso::{render, RenderOptions};
use boxforge_runtime::render::paged::{PagedIsoRenderer, PagedOptions};
use boxforge_runtime::volume::{LatticeVolume, SampleFormat, VolumeOptions};

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

fn is_hit(px: &[u8]) -> bool {
    !(px[0] == 20 && px[1] == 20 && px[2] == 26)
}

/// (hit/miss flips, RMS in 1/255).
fn compare(a: &[u8], b: &[u8]) -> (usize, f64) {
    let flips = a.chunks(4).zip(b.chunks(4)).filter(|(p, q)| is_hit(p) != is_hit(q)).count();
    let sq: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum();
    (flips, (sq / a.len() as f64).sqrt())
}

/// The in-core image and the paged one (bricks of `brick`, a pool of `slots`^3
/// slots) of `vol`, with their stats.
fn both(
    d: &Derivation,
    vol: &LatticeVolume,
    o: &RenderOptions,
    format: SampleFormat,
    slots: usize,
    brick: usize,
) -> (Vec<u8>, Vec<u8>, boxforge_runtime::render::paged::PagedStats) {
    let gpu = crate::common::gpu();
    let in_core = RenderOptions { volume: VolumeOptions { format, ..Default::default() }, ..o.clone() };
    let a = render(gpu, d, vol, Layout::Embedded, &in_core).unwrap();
    let slot = brick + 2 * boxforge::emit::bricks::brick_halo(d);
    let options = PagedOptions {
        iso: o.iso,
        step: o.step,
        block: o.block,
        brick,
        format,
        budget: 1 << 30,
        max_pixels: (o.width * o.height) as u64,
        max_pool_edge: Some(slots * slot),
        bounds_cache: None,
    };
    let mut r = PagedIsoRenderer::new(gpu, d, vol, options, &|_, _| {}).unwrap();
    let (frame, stats) = r.render(vol, o).unwrap();
    (a.rgba, frame.rgba, stats)
}

#[test]
fn paged_frames_equal_in_core_frames_for_every_filter() {
    for name in boxforge::spec::catalog::names() {
        let d = derive(name);
        if d.facts.dim != 3 {
            continue;
        }
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).unwrap();
        let o = RenderOptions { width: 40, height: 40, frames: 0, ..RenderOptions::default() };
        let (a, b, stats) = both(&d, &vol, &o, SampleFormat::F32, 3, 4);
        eprintln!("{name}: {stats:?}");
        let (flips, rms) = compare(&a, &b);
        assert!(flips == 0 && rms < 0.5, "{name}: paged image differs ({flips} flips, RMS {rms:.3}/255, {stats:?})");
        assert!(
            stats.passes > 2,
            "{name}: a pool of {} slots for {} bricks needs passes ({stats:?})",
            stats.slots,
            stats.bricks
        );
        assert!(
            stats.uploads > stats.slots && stats.evictions > 0,
            "{name}: bricks were evicted and re-read ({stats:?})"
        );
        assert!(stats.uploads <= stats.occupied_bricks * stats.passes, "{name}: only occupied bricks are uploaded");
    }
}

#[test]
fn a_paged_head_in_u8_equals_the_in_core_u8_head() {
    let d = derive("bcc7");
    let path = boxforge_runtime::scene::data_file("mni152_t1_1mm.nii.gz").unwrap();
    let full = boxforge_runtime::volume::Volume::load_nifti(&path).unwrap();
    let vol =
        boxforge_runtime::scene::from_cartesian(&full, &d.filter.lattice, boxforge_runtime::scene::Conversion::Subset)
            .unwrap();
    let (lo, hi) = vol.sample_range();
    let o = RenderOptions {
        width: 48,
        height: 48,
        iso: lo + 0.35 * (hi - lo),
        step: 0.5,
        azimuth: 200.0,
        elevation: 15.0,
        frames: 0,
        ..RenderOptions::default()
    };
    let (a, b, stats) = both(&d, &vol, &o, SampleFormat::U8, 4, 8);
    eprintln!("head: {stats:?}");
    let (flips, rms) = compare(&a, &b);
    assert!(flips == 0 && rms < 0.5, "head: paged u8 differs ({flips} flips, RMS {rms:.3}/255, {stats:?})");
    assert!(stats.occupied_bricks < stats.bricks, "the air around the head is never uploaded ({stats:?})");
}

#[test]
fn a_budget_smaller_than_the_pool_needs_is_refused_with_the_size_it_needs() {
    let gpu = crate::common::gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [16, 16, 16]).unwrap();
    let options = PagedOptions { budget: 4096, ..PagedOptions::default() };
    let e = PagedIsoRenderer::new(gpu, &d, &vol, options, &|_, _| {}).err().expect("refused").to_string();
    assert!(e.contains("budget") && e.contains("give at least"), "{e}");
}

#[test]
fn a_memory_mapped_file_renders_out_of_core_as_the_loaded_volume_in_core() {
    let gpu = crate::common::gpu();
    let d = derive("fcc6");
    // A u8 raw file of Marschner-Lobb, written here and read lazily.
    let dims = [40usize, 36, 32];
    let mut bytes = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = boxforge_runtime::volume::ml_position(dims, [x as f64, y as f64, z as f64]);
                bytes.push((boxforge_runtime::volume::marschner_lobb(p) * 255.0).round() as u8);
            }
        }
    }
    let path = std::env::temp_dir().join(format!("boxforge-paged-{}.raw", std::process::id()));
    let cache = std::env::temp_dir().join(format!("boxforge-paged-bounds-{}", std::process::id()));
    std::fs::write(&path, &bytes).unwrap();
    let ty = boxforge_runtime::volume::RawType::U8;
    let mapped = boxforge_runtime::volume::MappedVolume::open_raw(&path, dims, ty, &d.filter.lattice).unwrap();
    let loaded =
        LatticeVolume::subset(&d.filter.lattice, &boxforge_runtime::volume::Volume::load_raw(&path, dims, ty).unwrap())
            .unwrap();
    let o = RenderOptions { width: 40, height: 40, iso: 127.5, frames: 0, ..RenderOptions::default() };
    let in_core = render(gpu, &d, &loaded, Layout::Embedded, &o).unwrap();
    let slot = 4 + 2 * boxforge::emit::bricks::brick_halo(&d);
    let options = PagedOptions {
        iso: o.iso,
        step: o.step,
        block: o.block,
        brick: 4,
        format: SampleFormat::F32,
        budget: 1 << 30,
        max_pixels: 1600,
        max_pool_edge: Some(3 * slot),
        bounds_cache: Some(cache.clone()),
    };
    let mut r = PagedIsoRenderer::new(gpu, &d, &mapped, options.clone(), &|_, _| {}).unwrap();
    assert!(!r.bounds_cached(), "the first render computes the bounds");
    let (frame, stats) = r.render(&mapped, &o).unwrap();
    let (flips, rms) = compare(&in_core.rgba, &frame.rgba);
    assert!(stats.passes > 2, "{stats:?}");
    assert!(flips == 0 && rms < 0.5, "mapped paged image differs ({flips} flips, RMS {rms:.3}/255, {stats:?})");
    // The second render of the same file reads the bounds from the cache: same image.
    let mut again = PagedIsoRenderer::new(gpu, &d, &mapped, options.clone(), &|_, _| {}).unwrap();
    assert!(again.bounds_cached(), "the second render reads the cached bounds");
    let (frame2, _) = again.render(&mapped, &o).unwrap();
    assert_eq!(frame2.rgba, frame.rgba);
    // Another storage (u8 samples) is another entry: computed again.
    let u8_options = PagedOptions { format: SampleFormat::U8, ..options.clone() };
    assert!(!PagedIsoRenderer::new(gpu, &d, &mapped, u8_options, &|_, _| {}).unwrap().bounds_cached());
    // A file changed in place (same length) is another source: its bounds are computed again.
    drop((r, again, mapped));
    std::thread::sleep(std::time::Duration::from_millis(20));
    bytes.iter_mut().for_each(|b| *b = 255 - *b);
    std::fs::write(&path, &bytes).unwrap();
    let changed = boxforge_runtime::volume::MappedVolume::open_raw(&path, dims, ty, &d.filter.lattice).unwrap();
    assert!(!PagedIsoRenderer::new(gpu, &d, &changed, options, &|_, _| {}).unwrap().bounds_cached());
    drop(changed);
    let _ = std::fs::remove_file(&path);
    let _ = std::fs::remove_dir_all(&cache);
}
