//! The bricked layout and compact sample formats: a bricked volume renders
//! the in-core image (every catalog filter, Marschner-Lobb and the head,
//! bricks so small that every ray crosses many, slots wrapping in a small
//! pool); a halo narrower than the stencils' reach is caught; u8, u16 and
//! f16 samples evaluate within their stated resolution of f32, at a
//! fraction of the memory, and prefilter and bound in the same formats.

use boxforge::derive::Derivation;
use boxforge::emit::bricks::brick_halo;
use boxforge::emit::{emit, EmitOptions, Layout};
use boxforge_runtime::render::blocks::block_bounds;
use boxforge_runtime::render::dvr::{transfer::TransferFunction, DvrOptions};
use boxforge_runtime::render::iso::{render, RenderOptions};
use boxforge_runtime::verify::{brick_face_points, random_points, PointEvaluator};
use boxforge_runtime::volume::{BrickShape, DeviceVolume, LatticeVolume, SampleFormat, Volume, VolumeOptions};

fn derive(name: &str) -> Derivation {
    Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
}

/// Bricks of edge `edge` with the filter's own halo in a pool `slots` slots wide.
fn small_bricks(d: &Derivation, edge: usize, slots: Option<usize>) -> VolumeOptions {
    let bricks = BrickShape { edge, halo: brick_halo(d) };
    VolumeOptions { bricks, max_pool_edge: slots.map(|s| s * bricks.slot()), ..Default::default() }
}

fn is_hit(px: &[u8]) -> bool {
    !(px[0] == 20 && px[1] == 20 && px[2] == 26)
}

/// (pixels whose hit/miss differ, RMS over all channels in 1/255 units).
fn compare(a: &[u8], b: &[u8]) -> (usize, f64) {
    let flips = a.chunks(4).zip(b.chunks(4)).filter(|(p, q)| is_hit(p) != is_hit(q)).count();
    let sq: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum();
    (flips, (sq / a.len() as f64).sqrt())
}

/// The head, every other voxel (91 x 109 x 91), on `d`'s lattice.
fn head(d: &Derivation) -> LatticeVolume {
    let path = boxforge_runtime::scene::data_file("mni152_t1_1mm.nii.gz").expect("data/mni152_t1_1mm.nii.gz");
    let full = Volume::load_nifti(&path).unwrap();
    let dims = full.dims.map(|n| n.div_ceil(2));
    let mut data = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                data.push(full.get(2 * x as i64, 2 * y as i64, 2 * z as i64));
            }
        }
    }
    let half = Volume::new(dims, data).unwrap();
    boxforge_runtime::scene::from_cartesian(&half, &d.filter.lattice, boxforge_runtime::scene::Conversion::Subset)
        .unwrap()
}

#[test]
fn bricked_images_equal_the_in_core_images_for_every_filter() {
    let gpu = crate::common::gpu();
    for name in boxforge::spec::catalog::names() {
        let d = derive(name);
        if d.facts.dim != 3 {
            continue;
        }
        let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24]).unwrap();
        let o = RenderOptions { width: 40, height: 40, frames: 0, ..RenderOptions::default() };
        let in_core = render(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
        let hits = in_core.rgba.chunks(4).filter(|p| is_hit(p)).count();
        assert!(hits > 100, "{name}: the surface is in view ({hits} pixels)");
        // Bricks of 4 texels (6^3 bricks), the pool 7 slots wide: the slots
        // wrap; as they are, and coset-packed (against the packed layout).
        let bricked = RenderOptions { volume: small_bricks(&d, 4, Some(7)), ..o.clone() };
        let frame = render(gpu, &d, &vol, Layout::Bricked, &bricked).unwrap();
        let (flips, rms) = compare(&in_core.rgba, &frame.rgba);
        assert!(flips == 0 && rms < 0.5, "{name}: bricked image differs ({flips} hit/miss flips, RMS {rms:.3}/255)");
        let packed = render(gpu, &d, &vol, Layout::Packed, &o).unwrap();
        // Coset-packed slots have an even halo: the same wrap with that slot.
        let mut even = small_bricks(&d, 4, None);
        even.bricks.halo = even.bricks.halo.next_multiple_of(2);
        even.max_pool_edge = Some(7 * even.bricks.slot());
        let bricked = RenderOptions { volume: even, ..o.clone() };
        let frame = render(gpu, &d, &vol, Layout::BrickedPacked, &bricked).unwrap();
        let (flips, rms) = compare(&packed.rgba, &frame.rgba);
        assert!(flips == 0 && rms < 0.5, "{name}: bricked-packed image differs ({flips} flips, RMS {rms:.3}/255)");
    }
}

#[test]
fn bricked_head_equals_in_core_for_iso_and_dvr() {
    let gpu = crate::common::gpu();
    for name in ["bcc7", "cc_tricubic"] {
        let d = derive(name);
        let vol = head(&d);
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
        let in_core = render(gpu, &d, &vol, Layout::Embedded, &o).unwrap();
        let bricked = RenderOptions { volume: small_bricks(&d, 8, None), ..o.clone() };
        let frame = render(gpu, &d, &vol, Layout::Bricked, &bricked).unwrap();
        let hits = in_core.rgba.chunks(4).filter(|p| is_hit(p)).count();
        assert!(hits > 300, "{name}: the head is in view ({hits} pixels)");
        let (flips, rms) = compare(&in_core.rgba, &frame.rgba);
        assert!(flips == 0 && rms < 0.5, "{name} head iso: {flips} flips, RMS {rms:.3}/255");

        let tf = TransferFunction::preset("mni-tissue");
        let dvr = DvrOptions {
            width: 40,
            height: 40,
            step: 1.0,
            azimuth: 200.0,
            elevation: 15.0,
            frames: 0,
            ..DvrOptions::default()
        };
        let a = boxforge_runtime::render::dvr::render(gpu, &d, &vol, Layout::Embedded, &tf, &dvr).unwrap();
        let b = boxforge_runtime::render::dvr::render(
            gpu,
            &d,
            &vol,
            Layout::Bricked,
            &tf,
            &DvrOptions { volume: small_bricks(&d, 8, None), ..dvr.clone() },
        )
        .unwrap();
        let (_, rms) = compare(&a.rgba, &b.rgba);
        assert!(rms < 0.5, "{name} head DVR: RMS {rms:.3}/255");
    }
}

/// Values of `d`'s eval at `points` on `dv` (the module emitted for it).
fn eval(d: &Derivation, dv: &DeviceVolume, points: &[[f32; 4]]) -> Vec<f32> {
    let gpu = crate::common::gpu();
    let opts = EmitOptions { kernels: false, ..dv.emit_options("boxforge-runtime tests") };
    let m = emit(d, &opts).unwrap();
    PointEvaluator::new(gpu, &m.source, &m.file_name, &d.filter.name, dv).unwrap().eval(points).unwrap().0
}

#[test]
fn a_halo_narrower_than_the_stencils_reach_reads_wrong_samples() {
    let gpu = crate::common::gpu();
    let d = derive("bcc7");
    let vol = boxforge_runtime::verify::random_volume(&d, 5);
    let base = random_points(&d, &vol, 600, 9);
    let points = brick_face_points(&d, &vol, &base, 4);
    let embedded = eval(&d, &DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap(), &points);
    let worst = |halo: usize| {
        let options = VolumeOptions { bricks: BrickShape { edge: 4, halo }, ..Default::default() };
        let dv = DeviceVolume::with_options(gpu, &vol, Layout::Bricked, &options).unwrap();
        let v = eval(&d, &dv, &points);
        embedded.iter().zip(&v).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max)
    };
    let h = brick_halo(&d);
    assert!(worst(h) < 1e-6, "the derived halo {h} reads the in-core samples: {}", worst(h));
    // One texel of the halo is the f32 margin at a face; two fewer is short.
    assert!(worst(h - 2) > 1e-3, "a halo of {} must read wrong samples near the faces", h - 2);
    // And the renderers refuse a volume whose halo is too narrow.
    let options = VolumeOptions { bricks: BrickShape { edge: 4, halo: h - 1 }, ..Default::default() };
    let dv = DeviceVolume::with_options(gpu, &vol, Layout::Bricked, &options).unwrap();
    let e = dv.check_filter(&d).unwrap_err().to_string();
    assert!(e.contains("halo"), "{e}");
}

#[test]
fn compact_formats_evaluate_within_their_resolution_at_a_fraction_of_the_memory() {
    let gpu = crate::common::gpu();
    for name in ["bcc7", "cc_tricubic"] {
        let d = derive(name);
        // Data with a range away from [0, 1], so the map's offset and scale matter.
        let mut vol = boxforge_runtime::verify::random_volume(&d, 3);
        vol.data.iter_mut().for_each(|v| *v = 40.0 + 300.0 * *v);
        let points = random_points(&d, &vol, 800, 4);
        let (lo, hi) = vol.sample_range();
        for layout in [Layout::Embedded, Layout::Bricked, Layout::Packed, Layout::BrickedPacked] {
            let base = VolumeOptions { bricks: BrickShape { edge: 4, halo: brick_halo(&d) }, ..Default::default() };
            let f32_dv = DeviceVolume::with_options(gpu, &vol, layout, &base).unwrap();
            let exact = eval(&d, &f32_dv, &points);
            // Every format in the layouts with one sample a texel; u8 (four a
            // texel, each layout's own byte positions) in the packed ones too.
            let formats: &[SampleFormat] = match layout {
                Layout::Embedded | Layout::Bricked => &[SampleFormat::F16, SampleFormat::U16, SampleFormat::U8],
                Layout::Packed | Layout::BrickedPacked => &[SampleFormat::U8],
            };
            for &format in formats {
                if format == SampleFormat::U16
                    && !gpu.device.features().contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM)
                {
                    continue;
                }
                let dv = DeviceVolume::with_options(gpu, &vol, layout, &VolumeOptions { format, ..base }).unwrap();
                let got = eval(&d, &dv, &points);
                let err = exact.iter().zip(&got).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
                // The weights are non-negative and sum to 1: the stored error
                // bounds the value error (plus f32 round-off of the map).
                let bound = format.max_error(lo, hi) + 4.0 * f32::EPSILON as f64 * hi as f64;
                assert!(err <= bound, "{name} {layout:?} {}: error {err:.3e} over {bound:.3e}", format.name());
                assert!(err > 0.0, "{name} {}: the data is not exact in the format", format.name());
                if layout == Layout::Embedded {
                    // u8 rows are padded to whole 4-sample words: at most 3 samples more a row.
                    let nx = vol.dims[0];
                    let (got, quarter) = (dv.bytes * 4, f32_dv.bytes * format.bytes());
                    assert!(
                        got >= quarter && got * nx <= quarter * (nx + 3),
                        "{}: {} bytes for {} f32 bytes",
                        format.name(),
                        dv.bytes,
                        f32_dv.bytes
                    );
                }
            }
        }
    }
}

#[test]
fn prefilter_and_bounds_in_a_compact_format_match_f32_within_its_resolution() {
    let gpu = crate::common::gpu();
    let d = derive("bcc7");
    let mut vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [16, 16, 16]).unwrap();
    vol.data.iter_mut().for_each(|v| *v = 10.0 + 50.0 * *v);
    let (lo, hi) = vol.sample_range();
    let f32_pre = boxforge_runtime::prefilter::prefilter_gpu(gpu, &d, &vol, Layout::Embedded).unwrap();
    let u8_opts = VolumeOptions { format: SampleFormat::U8, ..Default::default() };
    let u8_pre = boxforge_runtime::prefilter::prefilter_gpu_with(gpu, &d, &vol, Layout::Embedded, &u8_opts).unwrap();
    // The taps' absolute sum scales the stored error.
    let taps: f64 = d.prefilter.taps.iter().map(|(_, w)| w.to_f64().abs()).sum();
    let bound = SampleFormat::U8.max_error(lo, hi) * taps + 1e-4 * (hi - lo) as f64;
    let err = f32_pre.data.iter().zip(&u8_pre.data).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
    assert!(err <= bound && err > 0.0, "u8 prefilter error {err:.3e}, bound {bound:.3e}");

    // Bounds from the u8 samples contain the u8 spline and sit within the
    // format's error of the f32 bounds.
    let dv32 = DeviceVolume::new(gpu, &vol, Layout::Embedded).unwrap();
    let dv8 = DeviceVolume::with_options(gpu, &vol, Layout::Embedded, &u8_opts).unwrap();
    let bounds = |dv: &DeviceVolume| {
        let m = emit(&d, &dv.emit_options("t")).unwrap();
        let shader = gpu.compile(&m.file_name, &m.source).unwrap();
        block_bounds(gpu, &shader, "bcc7", dv, vol.dims, 4).unwrap()
    };
    let (b32, b8) = (bounds(&dv32), bounds(&dv8));
    let tol = SampleFormat::U8.max_error(lo, hi) + 1e-4 * (hi - lo) as f64;
    for (a, b) in b32.iter().zip(&b8) {
        assert!(((a[0] - b[0]).abs() as f64) <= tol && ((a[1] - b[1]).abs() as f64) <= tol, "{a:?} vs {b:?}");
    }
    assert!(b8.iter().any(|b| b[0] >= 10.0 - 1e-3 && b[1] <= 60.0 + 1e-3), "bounds are in data units");
}

/// DVR and PERM read compact samples too: the u8 images (the same emitted
/// module with the map) are within a small RMS of the f32 ones, and the
/// bricked u8 DVR equals the embedded u8 DVR.
#[test]
fn dvr_and_perm_in_u8_match_f32_and_bricks_match_embedded() {
    let gpu = crate::common::gpu();
    let d = derive("bcc7");
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [28, 28, 28]).unwrap();
    let tf = TransferFunction::preset("marschner-lobb");
    let o = DvrOptions { width: 40, height: 40, frames: 0, ..DvrOptions::default() };
    let u8o = VolumeOptions { format: SampleFormat::U8, ..Default::default() };
    let dvr = |layout: Layout, volume: VolumeOptions| {
        boxforge_runtime::render::dvr::render(gpu, &d, &vol, layout, &tf, &DvrOptions { volume, ..o.clone() })
            .unwrap()
            .rgba
    };
    let f32_img = dvr(Layout::Embedded, VolumeOptions::default());
    let u8_img = dvr(Layout::Embedded, u8o);
    let (_, rms) = compare(&f32_img, &u8_img);
    assert!(rms < 3.0 && f32_img != u8_img, "u8 DVR against f32: RMS {rms:.3}/255");
    let bricked = dvr(Layout::Bricked, VolumeOptions { format: SampleFormat::U8, ..small_bricks(&d, 8, None) });
    let (_, rms) = compare(&u8_img, &bricked);
    assert!(rms < 0.5, "bricked u8 DVR against embedded u8: RMS {rms:.3}/255");

    let quant = boxforge_runtime::render::perm::Quant { density: 5, gradient: 3 };
    let perm = |volume: VolumeOptions| {
        boxforge_runtime::render::perm::render(
            gpu,
            &d,
            &vol,
            Layout::Embedded,
            &tf,
            &DvrOptions { volume, ..o.clone() },
            quant,
            false,
        )
        .unwrap()
        .0
        .rgba
    };
    let (_, rms) = compare(&perm(VolumeOptions::default()), &perm(u8o));
    assert!(rms < 3.0, "u8 PERM against f32 PERM: RMS {rms:.3}/255");
}
