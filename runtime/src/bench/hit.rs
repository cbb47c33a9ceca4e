//! Bench rows of the exact first hit (`--hit exact`): its time against the
//! fixed step of 0.25 cell on the Marschner-Lobb render, and the pixels that
//! fixed steps of 0.5 cell miss on a volume with thin features, counted
//! against the CPU reference of the exact walk.

use super::stats::{median, round_order, Ratio};
use super::{BenchError, BenchRow};
use crate::gpu::Gpu;
use crate::render::iso::{self as render, HitMode, RenderOptions};
use crate::volume::LatticeVolume;
use boxforge::derive::Derivation;
use boxforge::emit::Layout;

/// The filters whose exact hit is benched.
pub const FILTERS: [&str; 2] = ["bcc7", "cc_tricubic"];

/// Radius of the thin shell (fraction of the box edge) and its profile width (samples).
const SHELL_RADIUS: f64 = 0.3;
const SHELL_WIDTH: f64 = 0.5;
/// The iso-value as a fraction of the median spline value on the shell's
/// ridge: close to the peak, so the surface is a slab much thinner than
/// half a cell with holes where the peak dips below it.
pub const SHELL_ISO_FRACTION: f64 = 0.98;

/// A thin spherical shell on the filter's lattice (edge samples per axis)
/// and an iso-value near the spline's peak on it.
pub fn thin_shell_scene(d: &Derivation, edge: usize) -> Result<(LatticeVolume, f32), BenchError> {
    thin_shell_scene_at(d, edge, SHELL_ISO_FRACTION)
}

/// [`thin_shell_scene`] with the iso-value at `fraction` of the median
/// spline value on the shell's ridge.
pub fn thin_shell_scene_at(d: &Derivation, edge: usize, fraction: f64) -> Result<(LatticeVolume, f32), BenchError> {
    let vol = LatticeVolume::thin_shell(&d.filter.lattice, [edge; 3], SHELL_RADIUS, SHELL_WIDTH)?;
    let c = (edge as f64 - 1.0) / 2.0;
    let big_r = SHELL_RADIUS * edge as f64;
    let data = |j: &[i64]| vol.get(j) as f64;
    // Points on the ridge r = R (a golden-angle spiral).
    let count = 257;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let ridge: Vec<f64> = (0..count)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let rho = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            let p = [c + big_r * rho * a.cos(), c + big_r * rho * a.sin(), c + big_r * z];
            d.eval_f64(&p, &data).0
        })
        .collect();
    let m = median(&ridge);
    Ok((vol, (fraction * m) as f32))
}

/// Pixels hit in one depth image (t >= 0) against a reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Misses {
    /// Pixels the reference hits.
    pub reference_hits: usize,
    /// Pixels the reference hits and this image misses.
    pub missed: usize,
    /// Pixels this image hits and the reference misses.
    pub extra: usize,
}

/// Compares the hit masks of two depth images (-1 marks a miss).
pub fn misses(reference: &[f32], depth: &[f32]) -> Misses {
    assert_eq!(reference.len(), depth.len(), "same image size");
    let mut m = Misses { reference_hits: 0, missed: 0, extra: 0 };
    for (&r, &x) in reference.iter().zip(depth) {
        m.reference_hits += (r >= 0.0) as usize;
        m.missed += (r >= 0.0 && x < 0.0) as usize;
        m.extra += (r < 0.0 && x >= 0.0) as usize;
    }
    m
}

/// For bcc7 and cc_tricubic: exact and step 0.25 on the Marschner-Lobb
/// volume `ml` at the largest of `sizes`, timed in interleaved rounds (the
/// ratio exact ÷ step time), and the missed pixels of step 0.5 and exact on
/// the thin shell (128^2) against the CPU reference.
pub fn rows(
    gpu: &Gpu,
    d: &Derivation,
    ml: &LatticeVolume,
    sizes: &[u32],
    rounds: usize,
    progress: &dyn Fn(&str),
) -> Result<Vec<BenchRow>, BenchError> {
    let name = d.filter.name.as_str();
    let Some(&size) = sizes.iter().max() else { return Ok(vec![]) };
    if !FILTERS.contains(&name) {
        return Ok(vec![]);
    }
    let mut out = Vec::new();
    progress(&format!("{name} render Marschner-Lobb {size}^2, exact hit vs step 0.25, {rounds} rounds"));
    let ro = |hit| RenderOptions { width: size, height: size, hit, step: 0.25, frames: 1, ..RenderOptions::default() };
    let modes = [HitMode::Exact, HitMode::Step];
    let mut ms = [Vec::new(), Vec::new()];
    for r in 0..rounds.max(1) {
        for k in round_order(2, r) {
            ms[k].push(render::render(gpu, d, ml, Layout::Embedded, &ro(modes[k]))?.ms_per_frame);
        }
    }
    let ratio = Ratio::of_rates(&ms[0], &ms[1]);
    let kind = format!("hit_ml_{size}");
    out.push(BenchRow::render(
        name,
        &kind,
        "exact hit".into(),
        median(&ms[0]),
        Some(ratio),
        Some("exact ÷ step 0.25 (time)".into()),
    ));
    out.push(BenchRow::render(name, &kind, "step 0.25".into(), median(&ms[1]), None, None));

    // Thin features: missed pixels against the CPU reference.
    let edge = 40;
    let px = 128;
    progress(&format!("{name} thin shell {edge}^3 at {px}^2: step 0.5 and exact against the CPU reference"));
    let (shell, iso) = thin_shell_scene(d, edge)?;
    let base = RenderOptions { width: px, height: px, iso, frames: 1, ..RenderOptions::default() };
    let (_, reference) =
        render::cpu_render_with_depth(d, &shell, &RenderOptions { hit: HitMode::Exact, ..base.clone() });
    let kind = format!("hit_thin_shell_{px}");
    for (label, o) in [
        ("exact hit", RenderOptions { hit: HitMode::Exact, ..base.clone() }),
        ("step 0.5", RenderOptions { hit: HitMode::Step, step: 0.5, ..base.clone() }),
    ] {
        let (frame, depth) = render::render_with_depth(gpu, d, &shell, Layout::Embedded, &o)?;
        let m = misses(&reference, &depth);
        out.push(BenchRow::render(
            name,
            &kind,
            format!("{label}: {} of {} reference hits missed, {} extra", m.missed, m.reference_hits, m.extra),
            frame.ms_per_frame,
            None,
            None,
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn misses_count_each_side() {
        let m = misses(&[1.0, -1.0, 2.0, -1.0, 0.0], &[1.5, 3.0, -1.0, -1.0, -1.0]);
        assert_eq!(m, Misses { reference_hits: 3, missed: 2, extra: 1 });
    }
}
