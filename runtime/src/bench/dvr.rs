//! Direct volume rendering rows of `boxforge bench`: TF-aware skipping ÷ no
//! skipping and pre-integrated vs point-sampled, ms/frame in interleaved
//! rounds on the MNI head with the `mni-tissue` preset (Marschner-Lobb with
//! the `marschner-lobb` preset when the run has no MNI head, e.g. smoke),
//! and the pre-integration quality: RMS of step-1.0 images, with and
//! without pre-integration, against a step-0.1 point-sampled reference, on
//! that volume and (with the head) on Marschner-Lobb, whose thin shell shows
//! slab artifacts.

use super::stats::{median, round_order, Ratio};
use super::{BenchError, BenchOptions, BenchRow};
use crate::gpu::Gpu;
use crate::render::dvr::transfer::TransferFunction;
use crate::render::dvr::{rms, DvrOptions, DvrScene};
use crate::volume::{LatticeVolume, Volume};
use boxforge::derive::Derivation;
use boxforge::emit::Layout;

/// Prefix of the DVR rows' `kind`.
pub const KIND: &str = "dvr";
/// Segment length of the timed frames and of the coarse quality images.
pub const STEP: f32 = 1.0;
/// Segment length of the quality reference.
pub const FINE_STEP: f32 = 0.1;

/// Pre-integration quality on one volume: RMS (1/255) of step-[`STEP`]
/// images against a step-[`FINE_STEP`] point-sampled reference.
#[derive(Clone, Copy, Debug)]
pub struct Quality {
    pub preintegrated: f64,
    pub point_sampled: f64,
}

/// Measures [`Quality`] on a prepared scene.
pub fn quality(scene: &DvrScene, tf: &TransferFunction, o: &DvrOptions) -> Result<Quality, BenchError> {
    let o = DvrOptions { frames: 0, progress: false, ..o.clone() };
    let fine = scene.render(tf, &DvrOptions { step: FINE_STEP, preintegrate: false, ..o.clone() })?;
    let pi = scene.render(tf, &DvrOptions { step: STEP, preintegrate: true, ..o.clone() })?;
    let point = scene.render(tf, &DvrOptions { step: STEP, preintegrate: false, ..o })?;
    Ok(Quality { preintegrated: rms(&pi.rgba, &fine.rgba), point_sampled: rms(&point.rgba, &fine.rgba) })
}

/// The DVR bench rows (none when the run renders nothing). `rounds`
/// interleaved rounds of three contenders: pre-integrated with skipping,
/// pre-integrated without, point-sampled with skipping.
pub fn rows(gpu: &Gpu, o: &BenchOptions, rounds: usize, progress: &dyn Fn(&str)) -> Result<Vec<BenchRow>, BenchError> {
    let Some(&size) = o.render_sizes.first() else {
        return Ok(vec![]);
    };
    // bcc7 when the run has it, else its first 3D filter.
    let mut names: Vec<&str> = o.filters.iter().map(String::as_str).collect();
    names.sort_by_key(|n| *n != "bcc7");
    let Some((name, d)) = names.into_iter().find_map(|n| {
        let d = Derivation::new(&boxforge::spec::resolve(n).ok()?).ok()?;
        (d.facts.dim == 3).then_some((n, d))
    }) else {
        return Ok(vec![]);
    };
    let (vol, tf, what, view) = match &o.mni {
        Some(path) => {
            let head = Volume::load_nifti(std::path::Path::new(path))?;
            let v = crate::scene::from_cartesian(&head, &d.filter.lattice, crate::scene::Conversion::Resample)?;
            (v, TransferFunction::preset("mni-tissue"), "mni", (200.0, 15.0))
        }
        None => {
            let v = LatticeVolume::marschner_lobb(&d.filter.lattice, [24, 24, 24])?;
            (v, TransferFunction::preset("marschner-lobb"), "ml", (30.0, 25.0))
        }
    };
    let kind = format!("{KIND}_{what}_{size}");
    progress(&format!("{name} DVR {what} {size}^2 ({}), skipping and pre-integration, {rounds} rounds", tf.name));
    let scene = DvrScene::new(gpu, &d, &vol, Layout::Embedded, 4)?;
    let base = DvrOptions {
        width: size,
        height: size,
        azimuth: view.0,
        elevation: view.1,
        step: STEP,
        frames: 1,
        ..DvrOptions::default()
    };
    let table = tf.table();
    let pi = table.preintegrate(STEP as f64);
    let contenders = [
        (DvrOptions { skip: true, ..base.clone() }, true),
        (DvrOptions { skip: false, ..base.clone() }, true),
        (DvrOptions { skip: true, ..base.clone() }, false),
    ];
    let mut ms = vec![vec![]; contenders.len()];
    let mut empty = 0.0;
    let mut map = None;
    for r in 0..rounds.max(1) {
        for k in round_order(contenders.len(), r) {
            let (opts, with_pi) = &contenders[k];
            let f = scene.render_tables(&table, with_pi.then_some(&pi), opts)?;
            empty = f.empty_blocks;
            if k == 0 {
                map = f.skip_map;
            }
            ms[k].push(f.ms_per_frame);
        }
    }
    progress(&format!("{name} DVR {what} {size}^2: pre-integration quality (step {STEP} vs {FINE_STEP})"));
    let q = quality(&scene, &tf, &base)?;
    // Slab artifacts show on a thin shell: the Marschner-Lobb preset on
    // Marschner-Lobb too, when the timed volume is the head.
    let ml_q = if what == "ml" {
        None
    } else {
        progress(&format!("{name} DVR Marschner-Lobb {size}^2: pre-integration quality (step {STEP} vs {FINE_STEP})"));
        let ml = LatticeVolume::marschner_lobb(&d.filter.lattice, [40, 40, 40])?;
        let ml_scene = DvrScene::new(gpu, &d, &ml, Layout::Embedded, 4)?;
        let ml_o = DvrOptions { azimuth: 30.0, elevation: 25.0, ..base.clone() };
        Some(quality(&ml_scene, &TransferFunction::preset("marschner-lobb"), &ml_o)?)
    };
    let skipping = Ratio::of_rates(&ms[1], &ms[0]);
    let preint = Ratio::of_rates(&ms[0], &ms[2]);
    let row = |variant: String, k: usize, ratio: Option<Ratio>, baseline: Option<String>| {
        BenchRow::render(name, &kind, variant, median(&ms[k]), ratio, baseline)
    };
    let map_text = map.map_or(String::new(), |m: crate::render::blocks::SkipMapStats| {
        format!(
            "; distance map built in {:.2} ms, {} bytes, mean jump {:.1} blocks",
            m.build_ms, m.bytes, m.mean_distance
        )
    });
    let mut first = row(
        format!("DVR step {STEP}, pre-integrated, TF skipping ({:.0}% of blocks transparent{map_text})", empty * 100.0),
        0,
        None,
        None,
    );
    first.bytes = map.map(|m| m.bytes);
    Ok(vec![
        first,
        row(
            format!("DVR step {STEP}, pre-integrated, no skipping"),
            1,
            Some(skipping),
            Some("DVR no skipping ÷ TF skipping (time)".into()),
        ),
        row(
            format!("DVR step {STEP}, point-sampled, TF skipping"),
            2,
            Some(preint),
            Some(format!(
                "DVR pre-integrated ÷ point-sampled (time); RMS of step {STEP} against step {FINE_STEP}: pre-integrated {:.2}/255, point-sampled {:.2}/255 ({}){}",
                q.preintegrated,
                q.point_sampled,
                tf.name,
                ml_q.map(|m| format!(
                    "; Marschner-Lobb 40^3 (marschner-lobb): pre-integrated {:.2}/255, point-sampled {:.2}/255",
                    m.preintegrated, m.point_sampled
                ))
                .unwrap_or_default()
            )),
        ),
    ])
}

/// The markdown paragraph on the DVR rows of a report (empty without them).
pub fn markdown(rows: &[BenchRow]) -> String {
    let dvr: Vec<&BenchRow> = rows.iter().filter(|r| r.kind.starts_with(KIND) && r.ms_per_frame.is_some()).collect();
    if dvr.is_empty() {
        return String::new();
    }
    let lines: Vec<String> = dvr
        .iter()
        .filter_map(|r| Some(format!("{} {}: {}", r.filter, r.kind, r.baseline.as_ref()?)).zip(r.ratio))
        .map(|(text, ratio)| format!("- {text}: {}", ratio.display()))
        .collect();
    format!(
        "\n### Direct volume rendering\n\n`render --mode dvr` (emission-absorption, early termination at opacity 0.99, gradient shading), ms/frame in the rows `{KIND}_*` above, timed in interleaved rounds. TF skipping jumps over blocks whose [min, max] the transfer function maps to zero opacity; pre-integration looks segments up in a (front, back) table instead of point-sampling the transfer function; the RMS compares step-{STEP} images with a step-{FINE_STEP} point-sampled reference (lower: fewer slab artifacts).\n\n{}\n",
        lines.join("\n")
    )
}
