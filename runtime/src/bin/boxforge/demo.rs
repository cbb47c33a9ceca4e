//! `boxforge demo`: the README's main job.

use boxforge::build::output::{default_layouts, generated_files, write_files, ALL_VARIANTS};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::pictures::html::{self, Block};
use boxforge_runtime::pictures::plots::{self, log_slope, Series};
use boxforge_runtime::pictures::text::Typeface;
use boxforge_runtime::pictures::{self, Image, Tile};
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::DvrOptions;
use boxforge_runtime::render::iso::{self as render, RenderOptions, Shade, ShadeMode};
use boxforge_runtime::scene::{self, matched_edge, Conversion};
use boxforge_runtime::volume::{LatticeVolume, Volume};
use std::path::Path;
use std::time::Instant;

mod measure;
use measure::{error_slice, evals_per_second, ml_error};

const FILTERS: [&str; 4] = ["cc_tricubic", "bcc7", "bcc8", "fcc6"];
/// Marschner-Lobb budget: about 41^3 samples on every lattice.
const ML_EDGE: f64 = 41.0;
const MNI_FILE: &str = "mni152_t1_1mm.nii.gz";
const MNI_ISO: f32 = 90.0;

struct Row {
    filter: String,
    lattice: String,
    ml_samples: usize,
    rms: f64,
    max_err: f64,
    ml_ms: f64,
    mni_samples: usize,
    mni_ms: f64,
}

pub fn run(out: &Path, size: u32, adapter: Option<&str>) -> Result<(), String> {
    let started = Instant::now();
    let steps = boxforge_runtime::progress::Steps::new();
    steps.step("generating the catalog into shaders-out/");
    // 1. The catalog.
    let command = "boxforge generate --all -o shaders-out";
    for name in boxforge::spec::catalog::names() {
        let d = Derivation::new(&boxforge::spec::catalog::get(name).map_err(|e| e.to_string())?)
            .map_err(|e| e.to_string())?;
        let files =
            generated_files(&d, command, &default_layouts(d.facts.dim), &ALL_VARIANTS).map_err(|e| e.to_string())?;
        write_files(Path::new("shaders-out"), &files).map_err(|e| e.to_string())?;
    }
    steps.println(&format!("[demo] catalog generated into shaders-out/ ({:.1} s)", started.elapsed().as_secs_f64()));
    // 2. Device and the real volume.
    let gpu = Gpu::new(adapter).map_err(|e| e.to_string())?;
    steps.println(&format!("[demo] device: {}", gpu.describe()));
    let mni_path = boxforge_runtime::scene::data_file(MNI_FILE)
        .ok_or_else(|| format!("the MNI head data/{MNI_FILE} is missing: run the demo from the repository root"))?;
    let mni = Volume::load_nifti(&mni_path).map_err(|e| format!("{e} (run the demo from the repository root)"))?;
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let face = Typeface::dejavu();
    let mni_tf = TransferFunction::preset("mni-tissue");
    let mut rows = Vec::new();
    let mut images = Vec::new();
    let mut tiles = Vec::new();
    let mut closeups = Vec::new();
    let mut slices = Vec::new();
    let mut rms_vs_samples = Vec::new();
    let mut convergence = Vec::new();
    let mut rates = Vec::new();
    // Marschner-Lobb tiles, then the head's: one row each.
    let mut curvature_tiles: [Vec<Tile>; 2] = [Vec::new(), Vec::new()];
    let mut curvature_series = Vec::new();
    for name in FILTERS {
        steps.step(&format!("{name}: Marschner-Lobb and the MNI head"));
        let d = Derivation::new(&boxforge::spec::catalog::get(name).map_err(|e| e.to_string())?)
            .map_err(|e| e.to_string())?;
        let lat = d.filter.lattice.clone();
        // Marschner-Lobb at a matched sample budget.
        let e = matched_edge(&lat, ML_EDGE.powi(3));
        let ml = LatticeVolume::marschner_lobb(&lat, [e, e, e]).map_err(|e| e.to_string())?;
        let ml_opts = RenderOptions { width: size, height: size, iso: 0.5, step: 0.25, ..RenderOptions::default() };
        let opts = ml_opts.clone();
        let frame = render::render(&gpu, &d, &ml, Layout::Embedded, &opts).map_err(|e| e.to_string())?;
        let ml_png = out.join(format!("ml_{name}.png"));
        render::write_png(&ml_png, frame.width, frame.height, &frame.rgba).map_err(|e| e.to_string())?;
        let (rms, max_err) = ml_error(&gpu, &d, &ml, 100_000)?;
        steps.println(&format!(
            "[demo] {name}: Marschner-Lobb {} samples, {:.1} ms/frame -> {}",
            ml.samples(),
            frame.ms_per_frame,
            ml_png.display()
        ));
        // A close-up: twice the resolution, the middle quarter.
        let big = RenderOptions { width: 2 * size, height: 2 * size, frames: 1, ..opts.clone() };
        let zoom = render::render(&gpu, &d, &ml, Layout::Embedded, &big).map_err(|e| e.to_string())?;
        let zoom = Image::from_rgba(zoom.width, zoom.height, zoom.rgba).crop_zoom(size / 2, size / 4, size, size, 1);
        closeups.push(Tile { image: zoom, caption: vec![caption_head(&d), format!("{} samples", ml.samples())] });
        slices.push((name, error_slice(&gpu, &d, &ml, size)?));
        // RMS against the analytic function at three budgets (samples per axis on Z^3).
        let mut curve = Vec::new();
        for edge in [25.0f64, 33.0, 41.0] {
            let e = matched_edge(&lat, edge.powi(3));
            let v = LatticeVolume::marschner_lobb(&lat, [e, e, e]).map_err(|e| e.to_string())?;
            curve.push((v.samples() as f64, ml_error(&gpu, &d, &v, 20_000)?.0));
        }
        rms_vs_samples.push(Series { name: name.to_string(), points: curve });
        let edges = [12usize, 16, 24];
        let errs = boxforge_runtime::bench::smooth_convergence(&gpu, &d, &edges).map_err(|e| e.to_string())?;
        let pts: Vec<(f64, f64)> = edges.iter().zip(&errs).map(|(&n, &e)| (2.0 / n as f64, e)).collect();
        let order = log_slope(&pts).unwrap_or(f64::NAN);
        convergence.push(Series {
            name: format!("{name} (order {:.1}, theory {})", order, d.facts.approximation_order),
            points: pts,
        });
        rates.push((name.to_string(), evals_per_second(&gpu, &d, &ml)?));
        images.push(frame);
        // The MNI head at a matched sample count (resampled on BCC/FCC).
        let head = scene::from_cartesian(&mni, &lat, Conversion::Resample).map_err(|e| e.to_string())?;
        let opts = RenderOptions {
            width: size,
            height: size,
            iso: MNI_ISO,
            step: 0.5,
            azimuth: 200.0,
            elevation: 15.0,
            frames: 1,
            ..RenderOptions::default()
        };
        let frame = render::render(&gpu, &d, &head, Layout::Embedded, &opts).map_err(|e| e.to_string())?;
        let mni_png = out.join(format!("mni_{name}.png"));
        render::write_png(&mni_png, frame.width, frame.height, &frame.rgba).map_err(|e| e.to_string())?;
        let dvr_opts = DvrOptions {
            width: size,
            height: size,
            azimuth: 200.0,
            elevation: 15.0,
            step: 1.0,
            frames: 1,
            ..Default::default()
        };
        let dvr = boxforge_runtime::render::dvr::render(&gpu, &d, &head, Layout::Embedded, &mni_tf, &dvr_opts)
            .map_err(|e| e.to_string())?;
        let dvr_png = out.join(format!("mni_dvr_{name}.png"));
        render::write_png(&dvr_png, dvr.width, dvr.height, &dvr.rgba).map_err(|e| e.to_string())?;
        steps.println(&format!(
            "[demo] {name}: MNI head {} samples, {:.1} ms/frame iso, {:.1} ms/frame DVR -> {}, {}",
            head.samples(),
            frame.ms_per_frame,
            dvr.ms_per_frame,
            mni_png.display(),
            dvr_png.display()
        ));
        // Curvature (Kindlmann's (k1, k2) colormap from eval_hessian) on both volumes.
        let shade = Shade { mode: ShadeMode::Curvature, ..Shade::default() };
        let ml_curv = render::render(&gpu, &d, &ml, Layout::Embedded, &RenderOptions { shade, ..ml_opts.clone() })
            .map_err(|e| e.to_string())?;
        let head_curv = render::render(&gpu, &d, &head, Layout::Embedded, &RenderOptions { shade, ..opts.clone() })
            .map_err(|e| e.to_string())?;
        let smooth = format!("C^{}{}", d.facts.continuity, if d.facts.continuity >= 2 { "" } else { ": H jumps" });
        for (i, (f, what)) in [(ml_curv, "ML"), (head_curv, "MNI head")].into_iter().enumerate() {
            curvature_tiles[i].push(Tile {
                image: Image::from_rgba(f.width, f.height, f.rgba),
                caption: vec![caption_head(&d), what.into(), smooth.clone()],
            });
        }
        let c = boxforge_runtime::bench::curvature::curvature_order(&d, 400);
        curvature_series.push(Series {
            name: format!("{name} (order {:.2}, theory {})", c.measured_order, c.theory),
            points: c.cells_per_unit.iter().zip(&c.rms_errors).map(|(n, e)| (1.0 / n, *e)).collect(),
        });
        let row = Row {
            filter: name.to_string(),
            lattice: lat.name.clone(),
            ml_samples: ml.samples(),
            rms,
            max_err,
            ml_ms: images.last().map(|f| f.ms_per_frame).unwrap_or(0.0),
            mni_samples: head.samples(),
            mni_ms: frame.ms_per_frame,
        };
        let ml_frame = images.last().expect("pushed above");
        tiles.push(Tile {
            image: Image::from_rgba(ml_frame.width, ml_frame.height, ml_frame.rgba.clone()),
            caption: vec![
                caption_head(&d),
                format!("Marschner-Lobb, {} samples", row.ml_samples),
                format!("RMS {:.4}, max {:.3}", row.rms, row.max_err),
                format!("{:.1} ms/frame", row.ml_ms),
            ],
        });
        tiles.push(Tile {
            image: Image::from_rgba(frame.width, frame.height, frame.rgba.clone()),
            caption: vec![
                caption_head(&d),
                format!("MNI head, iso {MNI_ISO}, {} samples", row.mni_samples),
                String::new(),
                format!("{:.1} ms/frame", row.mni_ms),
            ],
        });
        tiles.push(Tile {
            image: Image::from_rgba(dvr.width, dvr.height, dvr.rgba),
            caption: vec![
                caption_head(&d),
                "MNI head, DVR (mni-tissue)".into(),
                "pre-integrated, step 1.0".into(),
                format!("{:.1} ms/frame", dvr.ms_per_frame),
            ],
        });
        rows.push(row);
        images.push(frame);
    }
    steps.step("renderers of the literature (Mattausch et al.)");
    let literature = literature_sheet(&gpu, &face, size)?;
    pictures::write_png(&out.join("literature.png"), &literature).map_err(|e| e.to_string())?;
    steps.finish();
    // Contact sheet (plain): one column per filter, Marschner-Lobb above the head.
    let sheet = contact_sheet(&images, FILTERS.len(), size);
    let sheet_png = out.join("contact_sheet.png");
    render::write_png(&sheet_png, size * FILTERS.len() as u32, size * 2, &sheet).map_err(|e| e.to_string())?;
    // Pictures with words: labelled sheet, close-ups, error slices, plots, the page.
    let adapter = gpu.describe();
    let labelled = pictures::contact_sheet(
        &face,
        &format!("boxforge: four filters at matched sample counts ({adapter})"),
        &tiles,
        3,
    );
    pictures::write_png(&out.join("contact_sheet_labelled.png"), &labelled).map_err(|e| e.to_string())?;
    let close = pictures::contact_sheet(&face, "Marschner-Lobb close-up (2x, centre)", &closeups, FILTERS.len());
    pictures::write_png(&out.join("closeup.png"), &close).map_err(|e| e.to_string())?;
    // Error slices on one colour scale so the filters compare.
    let max = slices.iter().flat_map(|(_, s)| s.values.iter().copied()).fold(0f64, f64::max);
    let mut error_tiles = Vec::new();
    for (name, s) in &slices {
        let img = pictures::error_image(&face, &s.values, s.width, s.width, max, "|f - ML|");
        pictures::write_png(&out.join(format!("error_{name}.png")), &img).map_err(|e| e.to_string())?;
        error_tiles.push(Tile { image: img, caption: vec![name.to_string(), format!("slice z = {:.1}", s.z)] });
    }
    let errors = pictures::contact_sheet(
        &face,
        "|reconstruction - analytic Marschner-Lobb| on the middle slice",
        &error_tiles,
        FILTERS.len(),
    );
    pictures::write_png(&out.join("errors.png"), &errors).map_err(|e| e.to_string())?;
    let plot_rms = plots::log_log("RMS error vs samples (Marschner-Lobb)", "samples", "RMS error", &rms_vs_samples)
        .map_err(|e| e.to_string())?;
    let plot_conv =
        plots::log_log("Convergence on a smooth signal (prefiltered)", "sample spacing h", "RMS error", &convergence)
            .map_err(|e| e.to_string())?;
    let curvature_sheet = pictures::contact_sheet(
        &face,
        "Curvature (k1, k2) from eval_hessian: convex red, concave blue, saddle green",
        &curvature_tiles.into_iter().flatten().collect::<Vec<_>>(),
        FILTERS.len(),
    );
    pictures::write_png(&out.join("curvature.png"), &curvature_sheet).map_err(|e| e.to_string())?;
    let plot_curvature = plots::log_log(
        "Curvature error on a sphere (f64, prefiltered)",
        "sample spacing h",
        "RMS error of k1, k2",
        &curvature_series,
    )
    .map_err(|e| e.to_string())?;
    let plot_rate = plots::bars(&format!("evals/s on {adapter}"), "evals/s", &rates).map_err(|e| e.to_string())?;
    for (f, svg) in [
        ("plot_rms.svg", &plot_rms),
        ("plot_convergence.svg", &plot_conv),
        ("plot_curvature.svg", &plot_curvature),
        ("plot_evals.svg", &plot_rate),
    ] {
        std::fs::write(out.join(f), svg).map_err(|e| format!("cannot write {}: {e}", out.join(f).display()))?;
    }
    let table = Block::Table {
        header: [
            "filter",
            "lattice",
            "ML samples",
            "RMS (1e5 points)",
            "max error",
            "ms/frame ML",
            "MNI samples",
            "ms/frame MNI",
        ]
        .map(String::from)
        .to_vec(),
        rows: rows
            .iter()
            .map(|r| {
                vec![
                    r.filter.clone(),
                    r.lattice.clone(),
                    r.ml_samples.to_string(),
                    format!("{:.5}", r.rms),
                    format!("{:.4}", r.max_err),
                    format!("{:.1}", r.ml_ms),
                    r.mni_samples.to_string(),
                    format!("{:.1}", r.mni_ms),
                ]
            })
            .collect(),
    };
    let page = html::page(
        "boxforge demo",
        &[
            Block::Paragraph(format!(
                "Generated shaders of four box splines, rendered on {adapter} at matched sample counts. Timings are from this run \
                 (one frame after a warm-up); docs/BENCHMARKS.md has the interleaved benchmark ratios."
            )),
            Block::Heading("Renders".into()),
            Block::Image { src: "contact_sheet_labelled.png".into(), caption: "Marschner-Lobb, MNI head (iso and DVR)".into() },
            Block::Image { src: "closeup.png".into(), caption: "Marschner-Lobb close-up".into() },
            Block::Image {
                src: "literature.png".into(),
                caption: "Renderers of the literature on Marschner-Lobb (DVR, one transfer function): Mattausch et al.'s sheared trilinear and barycentric BCC schemes ray cast, projected tetrahedra on BCC and CC, CC trilinear; `boxforge bench --literature` measures them".into(),
            },
            Block::Image {
                src: "curvature.png".into(),
                caption: "render --shade curvature: principal curvatures from the generated eval_hessian on Marschner-Lobb and the MNI head".into(),
            },
            Block::Heading("Error".into()),
            Block::Image { src: "errors.png".into(), caption: "|reconstruction - analytic| on the middle slice, one scale".into() },
            Block::Heading("Quality".into()),
            table,
            Block::Heading("Plots".into()),
            Block::Svg(plot_rms),
            Block::Svg(plot_conv),
            Block::Svg(plot_curvature),
            Block::Svg(plot_rate),
        ],
    );
    std::fs::write(out.join("index.html"), page).map_err(|e| format!("cannot write index.html: {e}"))?;
    outln!("\n| filter | lattice | ML samples | RMS error (ML, 1e5 points) | max error | ms/frame ML {size}^2 | MNI samples | ms/frame MNI {size}^2 |");
    outln!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        outln!(
            "| {} | {} | {} | {:.5} | {:.4} | {:.1} | {} | {:.1} |",
            r.filter,
            r.lattice,
            r.ml_samples,
            r.rms,
            r.max_err,
            r.ml_ms,
            r.mni_samples,
            r.mni_ms
        );
    }
    outln!(
        "\nImages and page: {} (index.html, contact_sheet_labelled.png, literature.png, closeup.png, errors.png, ml_*.png, mni_*.png, mni_dvr_*.png, plot_*.svg) on {}; total {:.1} s",
        out.display(),
        gpu.describe(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Marschner-Lobb at about 41^3 samples, volume rendered with the
/// marschner-lobb preset by the renderers of Mattausch et al. (2003) side by
/// side: ray-cast sheared trilinear (the variant for this view) and
/// barycentric (`bcc_linear`), projected tetrahedra on BCC and on CC (the
/// Kuhn tetrahedra), and ray-cast CC trilinear.
fn literature_sheet(gpu: &Gpu, face: &Typeface, size: u32) -> Result<Image, String> {
    let tf = TransferFunction::preset("marschner-lobb");
    let o = DvrOptions { width: size, height: size, frames: 1, ..Default::default() };
    let view = render::view_direction(o.azimuth, o.elevation);
    let derive = |f: &boxforge::Filter| Derivation::new(f).map_err(|e| e.to_string());
    let catalog = |n: &str| boxforge::spec::catalog::get(n).map_err(|e| e.to_string());
    let kuhn = boxforge_runtime::render::pt::tets::Grid::Cc.linear_filter();
    let sheared = catalog("bcc_sheared_trilinear")?.view_variant(view).map_err(|e| e.to_string())?.0;
    // (label, filter, projected tetrahedra?)
    let cases = [
        ("sheared trilinear, ray cast", sheared, false),
        ("barycentric (bcc_linear), ray cast", catalog("bcc_linear")?, false),
        ("projected tetrahedra, BCC", boxforge_runtime::render::pt::tets::Grid::Bcc.linear_filter(), true),
        ("projected tetrahedra, CC", kuhn, true),
        ("CC trilinear, ray cast", catalog("cc_trilinear")?, false),
    ];
    let mut tiles = Vec::new();
    for (label, f, pt) in cases {
        let d = derive(&f)?;
        let e = matched_edge(&d.filter.lattice, ML_EDGE.powi(3));
        let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [e, e, e]).map_err(|e| e.to_string())?;
        let frame = if pt {
            boxforge_runtime::render::pt::render::render(
                gpu,
                &d,
                &ml,
                &tf,
                &o,
                boxforge_runtime::render::pt::render::Shading::Phong,
                boxforge_runtime::render::pt::render::Normals::Vertex,
            )
            .map(|(f, _)| f)
        } else {
            boxforge_runtime::render::dvr::render(gpu, &d, &ml, Layout::Embedded, &tf, &o)
        }
        .map_err(|e| e.to_string())?;
        tiles.push(Tile {
            image: Image::from_rgba(frame.width, frame.height, frame.rgba),
            caption: vec![
                label.to_string(),
                format!("{} samples ({})", ml.samples(), d.filter.lattice.name),
                format!("{:.1} ms/frame", frame.ms_per_frame),
            ],
        });
    }
    let n = tiles.len();
    Ok(pictures::contact_sheet(
        face,
        "Renderers of the literature: Marschner-Lobb, DVR (marschner-lobb preset)",
        &tiles,
        n,
    ))
}

fn contact_sheet(frames: &[render::Frame], columns: usize, size: u32) -> Vec<u8> {
    let (w, h) = (size as usize * columns, size as usize * 2);
    let mut out = vec![0u8; w * h * 4];
    for (i, f) in frames.iter().enumerate() {
        let (col, row) = (i / 2, i % 2);
        for y in 0..f.height as usize {
            for x in 0..f.width as usize {
                let src = (y * f.width as usize + x) * 4;
                let dst = ((row * size as usize + y) * w + col * size as usize + x) * 4;
                out[dst..dst + 4].copy_from_slice(&f.rgba[src..src + 4]);
            }
        }
    }
    out
}

/// "bcc7 (bcc)": the filter and its lattice, for captions.
fn caption_head(d: &Derivation) -> String {
    format!("{} ({})", d.filter.name, d.filter.lattice.name)
}
