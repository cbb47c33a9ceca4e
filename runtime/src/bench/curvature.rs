//! Curvature fidelity (`boxforge bench --curvature`, and the demo's plot):
//! the error of the principal curvatures k1, k2 of the spline's isosurface
//! against the analytic ones as the sample spacing h shrinks, with the f64
//! evaluator (f32 round-off in curvature grows like eps / h^2 and would
//! flatten the curve). The signal is the radial f(x) = exp(-|x|^2 / 2),
//! whose isosurfaces are spheres (k1 = k2 = 1/r, positive: bright inside),
//! sampled at x = j h on the lattice and prefiltered with the filter's
//! quasi-interpolation prefilter, so the spline approximates f to its full
//! order m and the curvature (second derivatives) to order m - 2.

use crate::pictures::plots::log_slope;
use crate::render::iso::curvature::principal_curvatures;
use crate::verify::Rng;
use boxforge::derive::Derivation;
use glam::{DMat3, DVec3};
use serde::Serialize;
use std::fmt::Write as _;

/// Marks the section in BENCHMARKS.md.
pub const SECTION_START: &str = "<!-- curvature-bench:start -->";
/// Marks the end of the section.
pub const SECTION_END: &str = "<!-- curvature-bench:end -->";

/// Radius of the sphere whose curvature is measured.
pub const SPHERE_RADIUS: f64 = 1.0;

/// Samples per unit length (h = 1/n) of the measured range.
pub const CELLS_PER_UNIT: [f64; 4] = [6.0, 8.0, 11.0, 16.0];

/// Samples per unit length of the Marschner-Lobb range (n = 20 is the
/// classic 41^3 over [-1, 1]^3).
pub const ML_CELLS_PER_UNIT: [f64; 4] = [20.0, 28.0, 40.0, 56.0];

/// A signal with known isosurface curvature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    /// exp(-|x|^2 / 2): spheres, k1 = k2 = 1/r; measured on |x| = [`SPHERE_RADIUS`].
    Sphere,
    /// Marschner-Lobb (alpha 0.25, f_M 6) and its analytic Hessian;
    /// measured on its isosurface 0.5 inside [-0.9, 0.9]^3 where |grad| >= 1.
    MarschnerLobb,
}

impl Signal {
    fn value(self, x: DVec3) -> f64 {
        match self {
            Signal::Sphere => (-0.5 * x.length_squared()).exp(),
            Signal::MarschnerLobb => crate::volume::marschner_lobb(x.to_array()),
        }
    }

    fn gradient(self, x: DVec3) -> DVec3 {
        match self {
            Signal::Sphere => -x * self.value(x),
            Signal::MarschnerLobb => DVec3::from_array(crate::volume::marschner_lobb_grad(x.to_array())),
        }
    }

    /// (k1, k2) of the signal's isosurface through x.
    fn curvature(self, x: DVec3) -> (f64, f64) {
        match self {
            Signal::Sphere => (1.0 / x.length(), 1.0 / x.length()),
            Signal::MarschnerLobb => {
                let h = crate::volume::marschner_lobb_hessian(x.to_array());
                principal_curvatures(self.gradient(x), DMat3::from_cols_array_2d(&h))
            }
        }
    }

    /// The spacings measured (samples per unit length).
    pub fn cells_per_unit(self) -> &'static [f64] {
        match self {
            Signal::Sphere => &CELLS_PER_UNIT,
            Signal::MarschnerLobb => &ML_CELLS_PER_UNIT,
        }
    }

    /// `count` seeded points on the measured isosurface.
    fn points(self, count: usize) -> Vec<DVec3> {
        let mut rng = Rng(17);
        let mut out = Vec::with_capacity(count);
        while out.len() < count {
            match self {
                Signal::Sphere => {
                    // A uniform direction (normalised Gaussian triple by Box-Muller).
                    let mut g = || {
                        let (u, v) = (rng.next_f64().max(1e-12), rng.next_f64());
                        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
                    };
                    out.push(DVec3::new(g(), g(), g()).normalize() * SPHERE_RADIUS);
                }
                Signal::MarschnerLobb => {
                    // Newton along the gradient onto f = 0.5 from a random start.
                    let mut x = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.8 - 0.9;
                    for _ in 0..30 {
                        let g = self.gradient(x);
                        x -= (self.value(x) - 0.5) * g / g.length_squared().max(1e-12);
                    }
                    let inside = x.abs().max_element() <= 0.9;
                    if inside && (self.value(x) - 0.5).abs() < 1e-12 && self.gradient(x).length() >= 1.0 {
                        out.push(x);
                    }
                }
            }
        }
        out
    }
}

/// The median over `points` points of the signal's measured isosurface of
/// the principal curvatures' error sqrt(((k1 - k1*)^2 + (k2 - k2*)^2) / 2)
/// (the median: Marschner-Lobb's few points near umbilics and saddles of
/// huge curvature would rule a mean),
/// for each n in `cells_per_unit` (samples at x = j / n, j on the lattice,
/// prefiltered straight from the signal).
pub fn curvature_errors(d: &Derivation, signal: Signal, cells_per_unit: &[f64], points: usize) -> Vec<f64> {
    let taps: Vec<(Vec<i64>, f64)> = d.prefilter.taps.iter().map(|(k, w)| (k.clone(), w.to_f64())).collect();
    let pts = signal.points(points);
    let exact: Vec<(f64, f64)> = pts.iter().map(|&x| signal.curvature(x)).collect();
    cells_per_unit
        .iter()
        .map(|&n| {
            // The prefiltered sample at lattice point j, straight from the signal.
            let data = |j: &[i64]| -> f64 {
                taps.iter()
                    .map(|(k, w)| {
                        let x = DVec3::new((j[0] - k[0]) as f64, (j[1] - k[1]) as f64, (j[2] - k[2]) as f64) / n;
                        w * signal.value(x)
                    })
                    .sum()
            };
            let errors: Vec<f64> = pts
                .iter()
                .zip(&exact)
                .map(|(&x, &(e1, e2))| {
                    let (_, grad, hess) = d.eval_f64_hessian(&(x * n).to_array(), &data);
                    let (k1, k2) = principal_curvatures(DVec3::from_slice(&grad), DMat3::from_cols_slice(&hess));
                    // d/dx = n d/dq: curvature scales by n.
                    (((n * k1 - e1).powi(2) + (n * k2 - e2).powi(2)) / 2.0).sqrt()
                })
                .collect();
            super::stats::median(&errors)
        })
        .collect()
}

/// One filter's curvature convergence.
#[derive(Clone, Debug, Serialize)]
pub struct CurvatureOrderRow {
    pub filter: String,
    /// `Sphere` or `MarschnerLobb`.
    pub signal: String,
    pub continuity: i64,
    pub approximation_order: usize,
    /// Approximation order - 2.
    pub theory: f64,
    pub cells_per_unit: Vec<f64>,
    pub rms_errors: Vec<f64>,
    /// Least-squares slope of log error against log h.
    pub measured_order: f64,
}

/// [`curvature_errors`] of the sphere over [`CELLS_PER_UNIT`] and its slope.
pub fn curvature_order(d: &Derivation, points: usize) -> CurvatureOrderRow {
    curvature_order_of(d, Signal::Sphere, points)
}

/// [`curvature_errors`] of `signal` over its spacings and their slope.
pub fn curvature_order_of(d: &Derivation, signal: Signal, points: usize) -> CurvatureOrderRow {
    let ns = signal.cells_per_unit();
    let errs = curvature_errors(d, signal, ns, points);
    let pts: Vec<(f64, f64)> = ns.iter().zip(&errs).map(|(n, e)| (1.0 / n, *e)).collect();
    CurvatureOrderRow {
        signal: format!("{signal:?}"),
        filter: d.filter.name.clone(),
        continuity: d.facts.continuity,
        approximation_order: d.facts.approximation_order,
        theory: d.facts.approximation_order as f64 - 2.0,
        cells_per_unit: ns.to_vec(),
        rms_errors: errs,
        measured_order: log_slope(&pts).unwrap_or(f64::NAN),
    }
}

/// The section as Markdown: per signal and filter the errors, the measured
/// order beside the theoretical one, and the target (sphere: within 0.3,
/// C^2 filters; Marschner-Lobb: reported, no target).
pub fn markdown(rows: &[CurvatureOrderRow], points: usize, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{SECTION_START}\n## Curvature fidelity\n");
    let _ = writeln!(s, "Generated by `{command}` (CPU, the exact pieces evaluated in f64).\n");
    let _ = writeln!(
        s,
        "Each signal sampled at x = j h on each lattice (j a lattice point, h = 1/n in lattice units) and prefiltered with the filter's quasi-interpolation prefilter; k1, k2 of the spline's isosurface through {points} seeded points of the signal's isosurface, from `eval_f64_hessian` (f32 round-off, about eps/h^2 in curvature, is kept out), against the analytic k1, k2; the median over the points of sqrt(((k1 - k1*)^2 + (k2 - k2*)^2) / 2). Measured order: the least-squares slope of log error against log h. Theory: approximation order - 2.\n"
    );
    for (signal, title) in [
        (Signal::Sphere, format!("**Sphere** (exp(-|x|^2/2), points on |x| = {SPHERE_RADIUS}, k1 = k2 = {:.1}). Target: the measured order within 0.3 of the theory for every C^2 filter.", 1.0 / SPHERE_RADIUS)),
        (Signal::MarschnerLobb, "**Marschner-Lobb** (alpha 0.25, f_M 6, its analytic Hessian; points on the 0.5 isosurface in [-0.9, 0.9]^3 where |grad f| >= 1; n = 20 is the classic 41^3 over [-1, 1]^3). Reported, no target: the ripples are barely resolved at the coarse end, so the errors fall faster than the asymptotic order while they become resolved (pre-asymptotic).".to_string()),
    ] {
        let rows: Vec<&CurvatureOrderRow> = rows.iter().filter(|r| r.signal == format!("{signal:?}")).collect();
        if rows.is_empty() {
            continue;
        }
        let _ = writeln!(s, "{title}\n");
        let ns = signal.cells_per_unit();
        let head: Vec<String> = ns.iter().map(|n| format!("median error, n = {n}")).collect();
        let _ = writeln!(s, "| filter | smoothness | {} | measured order | theory | target |", head.join(" | "));
        let _ = writeln!(s, "|---|---|{}---:|---:|---|", "---:|".repeat(ns.len()));
        for r in rows {
            let target = match (signal, r.continuity >= 2) {
                (Signal::MarschnerLobb, _) => "(reported)".to_string(),
                (_, false) => format!("(C^{}: the Hessian jumps across knot planes; no target)", r.continuity),
                (_, true) if (r.measured_order - r.theory).abs() <= 0.3 => "within 0.3: met".to_string(),
                _ => format!("within 0.3: missed by {:.2}", (r.measured_order - r.theory).abs() - 0.3),
            };
            let errs: Vec<String> = r.rms_errors.iter().map(|e| format!("{e:.3e}")).collect();
            let _ = writeln!(
                s,
                "| {} | C^{} | {} | {:.2} | {:.0} | {target} |",
                r.filter,
                r.continuity,
                errs.join(" | "),
                r.measured_order,
                r.theory
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "{SECTION_END}");
    s
}

/// `file` with this section replaced (or appended).
pub fn splice(file: &str, section: &str) -> String {
    super::derive::splice_between(file, section, SECTION_START, SECTION_END)
}

/// This section of `file`, if it has one.
pub fn existing_section(file: &str) -> Option<&str> {
    super::derive::section_between(file, SECTION_START, SECTION_END)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derive(name: &str) -> Derivation {
        Derivation::new(&boxforge::spec::catalog::get(name).unwrap()).unwrap()
    }

    /// The measured order of a C^2 filter is its approximation order - 2
    /// (both C^2 lattices' representatives), and the errors shrink.
    #[test]
    fn curvature_converges_at_the_approximation_order_minus_two() {
        for name in ["bcc7", "cc_tricubic"] {
            let r = curvature_order(&derive(name), 60);
            assert!(r.rms_errors.windows(2).all(|w| w[1] < w[0]), "{r:?}");
            assert!((r.measured_order - r.theory).abs() <= 0.3, "{r:?}");
        }
    }

    /// A filter whose pieces are too coarse for curvature (trilinear: its
    /// Hessian inside a cell does not converge) shows no convergence: the
    /// measurement can tell.
    #[test]
    fn trilinear_curvature_does_not_converge() {
        let r = curvature_order(&derive("cc_trilinear"), 60);
        assert!(r.measured_order.abs() < 0.5 && r.rms_errors[3] > 0.1, "{r:?}");
    }
}
