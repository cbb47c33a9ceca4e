//! Every request of the CLI is checked here before it reaches wgpu or the
//! allocator: numbers must be finite and in range, sizes must fit the
//! adapter's limits, and each refusal is one line that names the flag, the
//! value, the limit and the fix. Nothing here needs a device (the limits are
//! passed in). The library's own checks ([`boxforge_runtime::limits`]) name
//! no flags: [`volume_limit`] words them for the command line.

use crate::choices::{CacheArg, ModeArg, RendererArg};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::limits::{self, LimitError};
use boxforge_runtime::render::iso::Shade;
use boxforge_runtime::render::perm::{
    formula, Counts, PermError, Quant, B_DB, B_GB, B_SB, DEFAULT_QC, MAX_BYTES, MAX_ROW,
};
use boxforge_runtime::volume::LatticeVolume;

/// Largest image edge `render` accepts (before the adapter's own limits).
pub const MAX_IMAGE_EDGE: u32 = 16_384;
/// Ray steps, in cells: below the minimum a frame would take hours.
pub const STEP_RANGE: (f32, f32) = (0.01, 8.0);
/// Most points `verify` evaluates (streamed in dispatches of
/// [`boxforge_runtime::verify::POINTS_PER_DISPATCH`], so memory stays bounded).
pub const MAX_POINTS: usize = 1_000_000_000;

/// Image edge, ray step, iso-value and view angles of `render`.
pub fn check_render_numbers(size: u32, step: f32, iso: f32, azimuth: f32, elevation: f32) -> Result<(), String> {
    check_image_edge(size)?;
    if !step.is_finite() || step < STEP_RANGE.0 || step > STEP_RANGE.1 {
        return Err(format!(
            "--step {step}: the ray step must be a number of cells between {} and {} (e.g. --step 0.25)",
            STEP_RANGE.0, STEP_RANGE.1
        ));
    }
    if !iso.is_finite() {
        return Err(format!("--iso {iso}: the iso-value must be a finite number (e.g. --iso 0.5)"));
    }
    if !azimuth.is_finite() || !elevation.is_finite() {
        return Err(format!(
            "--view {azimuth},{elevation}: the view angles must be finite degrees (e.g. --view 30,25)"
        ));
    }
    if elevation.abs() > 90.0 {
        return Err(format!("--view {azimuth},{elevation}: the elevation must be within -90..90 degrees"));
    }
    Ok(())
}

/// `--size` of `render` and `demo`.
pub fn check_image_edge(size: u32) -> Result<(), String> {
    if size == 0 || size > MAX_IMAGE_EDGE {
        return Err(format!("--size {size}: the image edge must be between 1 and {MAX_IMAGE_EDGE} pixels"));
    }
    Ok(())
}

/// The image against the adapter: its buffer and the workgroup counts.
pub fn check_image_limits(size: u32, limits: &wgpu::Limits) -> Result<(), String> {
    let bytes = size as u64 * size as u64 * 4;
    let binding = limits.max_storage_buffer_binding_size;
    if bytes > binding.min(limits.max_buffer_size) {
        return Err(format!(
            "--size {size}: the {size}x{size} image needs {bytes} bytes, over this adapter's storage buffer limit of {} bytes; use a smaller --size",
            binding.min(limits.max_buffer_size)
        ));
    }
    if size.div_ceil(8) > limits.max_compute_workgroups_per_dimension {
        return Err(format!(
            "--size {size}: over this adapter's {} workgroups per dimension; use a smaller --size",
            limits.max_compute_workgroups_per_dimension
        ));
    }
    Ok(())
}

/// `--points` of `verify`.
pub fn check_points(points: usize) -> Result<(), String> {
    if points == 0 {
        return Err("--points 0: verify needs at least one point (default 100000)".into());
    }
    if points > MAX_POINTS {
        return Err(format!("--points {points}: at most {MAX_POINTS} points per run; run several seeds instead"));
    }
    Ok(())
}

/// An output file path: not a directory, and its folder is not a file (so a
/// render fails before minutes of work rather than after).
pub fn check_output_file(path: &std::path::Path, flag: &str) -> Result<(), String> {
    if path.is_dir() {
        return Err(format!(
            "{flag} {}: is a directory; give a file name, e.g. {}/out.png",
            path.display(),
            path.display()
        ));
    }
    let mut dir = path.parent();
    while let Some(d) = dir.filter(|d| !d.as_os_str().is_empty()) {
        if d.exists() {
            if !d.is_dir() {
                return Err(format!("{flag} {}: {} is a file, not a folder", path.display(), d.display()));
            }
            let probe = d.join(format!(".boxforge-write-test-{}", std::process::id()));
            return match std::fs::write(&probe, b"") {
                Ok(()) => {
                    let _ = std::fs::remove_file(&probe);
                    Ok(())
                }
                Err(e) => Err(format!("{flag} {}: cannot write in {}: {e}", path.display(), d.display())),
            };
        }
        dir = d.parent();
    }
    Ok(())
}

/// An output folder: not a file, and writable where it exists.
pub fn check_output_dir(dir: &std::path::Path, flag: &str) -> Result<(), String> {
    if dir.exists() && !dir.is_dir() {
        return Err(format!("{flag} {}: is a file, not a folder", dir.display()));
    }
    check_output_file(&dir.join("probe"), flag)
}

/// The transfer function `--mode dvr` draws with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TfChoice {
    /// No --tf: the default ramp over the data's range (chosen once the
    /// volume is loaded).
    Ramp,
    /// `--tf NAME`: a preset or a JSON file (loaded after the checks).
    Named(String),
}

/// `--mode` with `--tf` and `--no-preintegration` of `render`: Some(the
/// transfer function) for `--mode dvr`, None for `iso`.
pub fn check_render_mode(mode: ModeArg, tf: Option<&str>, no_preintegration: bool) -> Result<Option<TfChoice>, String> {
    match (mode, tf) {
        (ModeArg::Dvr, Some(tf)) => Ok(Some(TfChoice::Named(tf.to_string()))),
        (ModeArg::Dvr, None) => Ok(Some(TfChoice::Ramp)),
        (ModeArg::Iso, Some(tf)) => Err(format!("--tf {tf}: a transfer function is for --mode dvr; add --mode dvr")),
        (ModeArg::Iso, None) if no_preintegration => {
            Err("--no-preintegration is for --mode dvr; add --mode dvr --tf ...".into())
        }
        (ModeArg::Iso, None) => Ok(None),
    }
}

/// `--renderer`: true for projected tetrahedra, which need `--mode dvr`,
/// no cache and an orthographic view.
pub fn check_renderer(
    renderer: RendererArg,
    mode: ModeArg,
    cache: CacheArg,
    perspective: bool,
) -> Result<bool, String> {
    if renderer == RendererArg::Raycast {
        return Ok(false);
    }
    if mode != ModeArg::Dvr {
        return Err("--renderer pt renders volumes, not isosurfaces: add --mode dvr --tf ...".into());
    }
    if cache != CacheArg::None {
        return Err(format!(
            "--renderer pt draws the tetrahedra directly; drop --cache {} (it is for the ray caster)",
            cache.name()
        ));
    }
    if perspective {
        return Err("--renderer pt is orthographic (the back-to-front traversal is a visibility order for parallel projection only): drop --perspective".into());
    }
    Ok(true)
}

/// `--curvature-radius` and `--contour-thickness` (worded as the library's
/// [`boxforge_runtime::render::iso::check_shade`] does, checked before the
/// derivation).
pub fn check_shade_numbers(shade: &Shade) -> Result<(), String> {
    if !(shade.radius.is_finite() && shade.radius > 0.0 && shade.thickness.is_finite() && shade.thickness > 0.0) {
        return Err(format!(
            "curvature radius {} and contour thickness {} must be finite and > 0",
            shade.radius, shade.thickness
        ));
    }
    Ok(())
}

/// A curvature shading (`--shade ...`, `--tf-curvature`) needs second
/// derivatives: a filter of degree 2 or more.
pub fn check_shade_degree(d: &Derivation, shade: &Shade) -> Result<(), String> {
    if shade.mode.needs_hessian() && d.facts.degree < 2 {
        return Err(format!(
            "--shade {} needs second derivatives, but {} has degree {} (its pieces are linear, its Hessian zero); \
             use a filter of degree >= 2 such as bcc7 or cc_tricubic",
            shade.mode.name(),
            d.filter.name,
            d.facts.degree
        ));
    }
    Ok(())
}

/// A warning (not an error) when the transfer function is transparent over
/// all of the data's values [lo, hi].
pub fn tf_warning(table: &boxforge_runtime::render::dvr::transfer::Tf1d, lo: f32, hi: f32) -> Option<String> {
    table.transparent(lo as f64, hi as f64).then(|| {
        format!(
            "warning: the transfer function is transparent over the volume's values [{lo}, {hi}]: the image will be empty"
        )
    })
}

/// A warning (not an error) when the iso-value lies outside the data.
pub fn iso_warning(iso: f32, lo: f32, hi: f32) -> Option<String> {
    (iso < lo || iso > hi).then(|| {
        format!("warning: --iso {iso} is outside the volume's values [{lo}, {hi}]: the image will show no surface")
    })
}

/// `render --filter mattausch_bilinear[_spatial]`: the hand-written
/// plane-stack schemes are ray cast in DVR only, on the embedded layout.
pub fn check_scheme(name: &str, mode: ModeArg, cache: CacheArg, pt: bool, layout: Layout) -> Result<(), String> {
    if mode != ModeArg::Dvr {
        return Err(format!(
            "--filter {name} is a hand-written scheme that the DVR ray caster runs; --mode {} needs a catalog filter: add --mode dvr --tf ..., or pick a filter from `boxforge list`",
            mode.name()
        ));
    }
    if pt {
        return Err(format!("--filter {name} is ray cast; projected tetrahedra interpolate on tetrahedra: drop --renderer pt (or use --filter bcc_linear with it)"));
    }
    if cache != CacheArg::None {
        return Err(format!("--filter {name}: --cache {} caches catalog filters only; drop --cache", cache.name()));
    }
    if layout != Layout::Embedded {
        return Err(format!("--filter {name} reads the embedded layout; drop --layout {}", layout.name()));
    }
    Ok(())
}

/// A refusal of the library's [`limits`], worded with the flags that fix it.
pub fn volume_limit(e: &LimitError) -> String {
    match e {
        LimitError::Samples { what, dims } => format!(
            "{what}: {}x{}x{} samples is over the cap of {} samples (1 GiB of f32); use a smaller ml:N or --resample a smaller volume",
            dims[0],
            dims[1],
            dims[2],
            limits::MAX_SAMPLES
        ),
        LimitError::TextureEdge { dims, max } => format!(
            "the volume is {}x{}x{} samples, over this adapter's 3D texture limit of {max} per edge; use --layout packed, --resample or a smaller ml:N",
            dims[0], dims[1], dims[2]
        ),
        LimitError::PackedTextureEdge { dims, texture, max } => format!(
            "the packed volume of {}x{}x{} samples is a {}x{}x{} texture (one tile per coset), over this adapter's 3D texture limit of {max} per edge; use --resample or a smaller ml:N",
            dims[0], dims[1], dims[2], texture[0], texture[1], texture[2]
        ),
        LimitError::MlNotWhole { .. } | LimitError::MlRange { .. } => e.to_string(),
    }
}

/// `--volume ml:N`: N and the host sample count, checked as
/// [`boxforge_runtime::scene::load`] does, with the flags named.
pub fn check_ml_volume(spec: &str, lattice: &boxforge::spec::lattice::Lattice) -> Result<(), String> {
    let Some(n) = spec.strip_prefix("ml:") else { return Ok(()) };
    let n = limits::parse_ml_n(n).map_err(|e| volume_limit(&e))?;
    let e = boxforge_runtime::scene::matched_edge(lattice, (n as f64).powi(3));
    limits::check_samples([e, e, e], spec).map_err(|e| volume_limit(&e))?;
    Ok(())
}

/// The refusal of [`boxforge_runtime::volume::DeviceVolume::new`] (a GPU
/// error) for a volume over the adapter's limits, with the flags named.
pub fn device_limit(e: &LimitError) -> String {
    format!("GPU error: {}", volume_limit(e))
}

/// Why uploading `vol` in `layout` fails on an adapter with `limits`, if
/// it does: the text the CLI prints.
pub fn volume_over_limits(vol: &LatticeVolume, layout: Layout, limits: &wgpu::Limits) -> Option<String> {
    let texture = match layout {
        Layout::Embedded => vol.dims,
        // No packed layout: DeviceVolume::new says why.
        Layout::Packed => vol.packed_texture_size()?,
        // Bricks refold into a pool that fits; the pool's own refusal says why not.
        Layout::Bricked | Layout::BrickedPacked => return None,
    };
    limits::check_volume_limits(vol.dims, texture, layout, limits).err().map(|e| device_limit(&e))
}

/// The `--cache`, `--qc` and `--qc-grad` options, checked before any GPU
/// work: `None` for `--cache none`. The memory check here is the cache of
/// a single candidate cell (a lower bound); [`boxforge_runtime::render::perm::PermCache::build`] checks the
/// exact size once the candidates are known.
pub fn check_cache(
    cache: CacheArg,
    mode: ModeArg,
    qc: Option<u32>,
    qc_grad: Option<u32>,
) -> Result<Option<Quant>, String> {
    if cache == CacheArg::None {
        return match (qc, qc_grad) {
            (None, None) => Ok(None),
            _ => Err("--qc and --qc-grad size the PERM cache: add --cache perm (with --mode dvr)".into()),
        };
    }
    if mode != ModeArg::Dvr {
        return Err(format!(
            "--cache perm precomputes the values direct volume rendering samples; --mode {} has no such cache: add --mode dvr --tf ..., or drop --cache perm",
            mode.name()
        ));
    }
    let n = qc.unwrap_or(DEFAULT_QC);
    let quant = Quant { density: n, gradient: qc_grad.unwrap_or(n) };
    for (flag, v) in [("--qc", quant.density), ("--qc-grad", quant.gradient)] {
        if v == 0 {
            return Err(format!(
                "{flag} 0: a cell needs at least one quantized position per axis; use 1 or more (the paper uses 5, and 3 for gradients)"
            ));
        }
    }
    let one = formula(&Counts { cells: 0, rows: 0, candidates: 1, quant }).total();
    if one > MAX_BYTES {
        let largest = (1..)
            .take_while(|&k| {
                formula(&Counts { cells: 0, rows: 0, candidates: 1, quant: Quant { density: k, gradient: k } }).total()
                    <= MAX_BYTES
            })
            .last()
            .unwrap_or(1);
        return Err(format!(
            "--qc {} --qc-grad {}: one candidate cell alone needs {one} bytes of PERM cache ({}^3 x {B_DB} + {}^3 x {}), over the limit of {MAX_BYTES} bytes; use --qc {largest} or less",
            quant.density,
            quant.gradient,
            quant.density,
            quant.gradient,
            3 * B_GB + B_SB
        ));
    }
    Ok(Some(quant))
}

/// A PERM build's refusal, worded with the flags that size the cache (a
/// GPU error, as the CLI has always printed it).
pub fn perm_failure(e: &PermError) -> String {
    match e {
        PermError::RowTooLong { cells } => format!(
            "GPU error: --cache perm: the volume is {cells} cells along x, over the {MAX_ROW} a 15-bit row index addresses"
        ),
        PermError::TooLarge { counts, need, limit } => format!(
            "GPU error: --qc {} --qc-grad {}: the PERM cache of {} candidate cells needs {}, over the limit of {limit} bytes; use a smaller --qc or --qc-grad",
            counts.quant.density,
            counts.quant.gradient,
            counts.candidates,
            need.describe()
        ),
        PermError::IndexVolume { cells, bytes, binding } => format!(
            "GPU error: --cache perm: the index volume of {cells} cells needs {bytes} bytes, over this device's storage-binding limit of {binding} bytes; downsample the volume"
        ),
        PermError::Texture { label, words, max } => format!(
            "GPU error: --cache perm: the {label} need {words} words, more than a 3D texture of {max}^3 texels holds; use a smaller --qc or --qc-grad"
        ),
        PermError::Gpu(e) => e.to_string(),
        PermError::Render(e) => e.to_string(),
        PermError::Volume(e) => e.to_string(),
    }
}

/// `--brick`: only with `--layout bricked`, and an edge of 2 to 1024 texels.
pub fn check_brick(brick: Option<usize>, layout: Layout) -> Result<(), String> {
    match brick {
        Some(_) if !layout.is_bricked() => {
            Err("--brick sizes the bricks of the bricked layout: add --layout bricked, or drop --brick".into())
        }
        Some(b) if !(2..=1024).contains(&b) => {
            Err(format!("--brick {b}: a brick edge is 2 to 1024 lattice texels; e.g. --brick 32"))
        }
        _ => Ok(()),
    }
}

/// `--gpu-budget SIZE`: bytes from "2GiB", "256MiB", "512MB", "64KiB" or a
/// plain byte count.
pub fn parse_budget(text: &str) -> Result<u64, String> {
    boxforge_runtime::memory::parse_size(text)
        .ok_or_else(|| format!("--gpu-budget {text}: give a size such as 256MiB, 2GiB or 500000000"))
}

/// The renderers `--gpu-budget` works with: the ray caster's isosurfaces
/// (by fixed steps) and its volume renderings.
pub fn check_paged(exact: bool, layout: Layout, other_renderer: bool) -> Result<(), String> {
    if other_renderer {
        return Err("--gpu-budget renders the ray caster's isosurfaces and volume renderings out of core; PERM, the hand-written schemes and --renderer pt are not offered: drop --gpu-budget or --cache/--renderer/the scheme".into());
    }
    if exact {
        return Err(
            "--gpu-budget walks rays by fixed steps; out of core the exact hit is not offered: use --hit step".into()
        );
    }
    if layout == Layout::Packed {
        return Err("--gpu-budget stores the samples in bricks (the bricked layout); drop --layout packed".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_out_of_range_are_refused_with_the_flag_named() {
        assert!(check_render_numbers(512, 0.25, 0.5, 30.0, 25.0).is_ok());
        for (size, step, iso, az, el, flag) in [
            (0, 0.25, 0.5, 30.0, 25.0, "--size"),
            (100_000, 0.25, 0.5, 30.0, 25.0, "--size"),
            (512, 0.0, 0.5, 30.0, 25.0, "--step"),
            (512, f32::NAN, 0.5, 30.0, 25.0, "--step"),
            (512, 0.25, f32::NAN, 30.0, 25.0, "--iso"),
            (512, 0.25, f32::INFINITY, 30.0, 25.0, "--iso"),
            (512, 0.25, 0.5, f32::NAN, 25.0, "--view"),
            (512, 0.25, 0.5, 30.0, 120.0, "--view"),
        ] {
            let e = check_render_numbers(size, step, iso, az, el).unwrap_err();
            assert!(e.starts_with(flag), "{e}");
        }
        assert!(check_points(0).is_err() && check_points(20_000_000).is_ok());
        assert!(iso_warning(2.0, 0.0, 1.0).is_some() && iso_warning(0.5, 0.0, 1.0).is_none());
    }

    #[test]
    fn dvr_flags_go_with_mode_dvr() {
        use ModeArg::{Dvr, Iso};
        assert_eq!(check_render_mode(Iso, None, false), Ok(None));
        assert_eq!(check_render_mode(Dvr, Some("mni-tissue"), false), Ok(Some(TfChoice::Named("mni-tissue".into()))));
        // No --tf: the default ramp, chosen once the data is loaded.
        assert_eq!(check_render_mode(Dvr, None, false), Ok(Some(TfChoice::Ramp)));
        assert!(check_render_mode(Iso, Some("x.json"), false).unwrap_err().starts_with("--tf x.json"));
        assert!(check_render_mode(Iso, None, true).unwrap_err().starts_with("--no-preintegration"));
        // --renderer pt: DVR, no cache, orthographic.
        use {CacheArg::Perm, RendererArg::Pt};
        assert_eq!(check_renderer(RendererArg::Raycast, Iso, Perm, true), Ok(false));
        assert_eq!(check_renderer(Pt, Dvr, CacheArg::None, false), Ok(true));
        assert!(check_renderer(Pt, Iso, CacheArg::None, false).unwrap_err().contains("--mode dvr"));
        assert!(check_renderer(Pt, Dvr, Perm, false).unwrap_err().contains("drop --cache perm"));
        assert!(check_renderer(Pt, Dvr, CacheArg::None, true).unwrap_err().contains("--perspective"));
        let t = boxforge_runtime::render::dvr::transfer::TransferFunction::preset("mni-tissue").table();
        assert!(tf_warning(&t, 0.0, 20.0).is_some() && tf_warning(&t, 0.0, 255.0).is_none());
    }

    #[test]
    fn limits_are_checked_before_any_upload() {
        let limits = wgpu::Limits::downlevel_defaults();
        assert!(check_image_limits(256, &limits).is_ok());
        assert!(check_image_limits(16_384, &limits).is_err());
        let edge = limits.max_texture_dimension_3d as usize + 1;
        let e = device_limit(&LimitError::TextureEdge { dims: [edge, 4, 4], max: edge - 1 });
        assert!(e.contains("use --layout packed, --resample or a smaller ml:N"), "{e}");
    }

    #[test]
    fn bad_cache_options_are_refused_with_the_flag_named() {
        use CacheArg::{None as NoCache, Perm};
        use ModeArg::{Dvr, Iso};
        assert_eq!(check_cache(NoCache, Dvr, None, None), Ok(None));
        assert_eq!(check_cache(Perm, Dvr, None, None), Ok(Some(Quant { density: 5, gradient: 5 })));
        assert_eq!(check_cache(Perm, Dvr, Some(5), Some(3)), Ok(Some(Quant { density: 5, gradient: 3 })));
        // An unknown --cache (e.g. lru) is clap's refusal now: tests/it/bad_input.rs.
        for (cache, mode, qc, qg, fragment) in [
            (Perm, Dvr, Some(0), None, "--qc 0"),
            (Perm, Dvr, Some(4), Some(0), "--qc-grad 0"),
            (Perm, Dvr, Some(1000), None, "over the limit of 2147483648 bytes"),
            (Perm, Iso, None, None, "--mode iso"),
            (NoCache, Dvr, Some(5), None, "add --cache perm"),
        ] {
            let e = check_cache(cache, mode, qc, qg).unwrap_err();
            assert!(e.contains(fragment) && !e.contains('\n'), "{e}");
        }
        // The refusal names the bytes: 1000^3 x 2 + 1000^3 x 4.
        assert!(check_cache(Perm, Dvr, Some(1000), None).unwrap_err().contains("6000000000 bytes"));
        // The largest accepted N is the one the message suggests.
        let e = check_cache(Perm, Dvr, Some(1000), None).unwrap_err();
        let largest: u32 = e.rsplit("--qc ").next().unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!(check_cache(Perm, Dvr, Some(largest), None).is_ok());
        assert!(check_cache(Perm, Dvr, Some(largest + 1), None).is_err());
    }

    #[test]
    fn budgets_parse_with_units_and_bad_ones_name_the_flag() {
        assert_eq!(parse_budget("256MiB"), Ok(256 << 20));
        assert_eq!(parse_budget("2GiB"), Ok(2 << 30));
        assert_eq!(parse_budget("1.5 KiB"), Ok(1536));
        assert_eq!(parse_budget("500000"), Ok(500_000));
        assert_eq!(parse_budget("1GB"), Ok(1_000_000_000));
        for bad in ["", "0", "-1GiB", "12 parsecs", "GiB", "1e400"] {
            let e = parse_budget(bad).unwrap_err();
            assert!(e.contains("--gpu-budget"), "{bad}: {e}");
        }
    }
}
