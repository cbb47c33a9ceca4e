//! The precision of linear (hardware-filtered) fetches in the report: the
//! CPU emulation of the filtered fetch beside the exact evaluator.

use crate::derive::Derivation;
use serde::Serialize;

/// Precision of `fetch = linear` (Sigg & Hadwiger's scheme, derived): the
/// CPU emulation of the hardware's interpolation, exact and with weights
/// rounded to 8 fractional bits (CUDA documents 9-bit fixed point with 8
/// fractional bits; lavapipe filters in float), at seeded random points on
/// random data in [0, 1].
#[derive(Clone, Debug, Serialize)]
pub struct LinearFetchReport {
    /// Hardware-filtered fetches per evaluation: ceil(n_i / 2) per axis.
    pub fetches: usize,
    /// Exact loads per evaluation the filtered fetches replace.
    pub exact_loads: usize,
    /// Number of seeded random points the errors are measured at.
    pub points: usize,
    /// Largest absolute error against the exact evaluator with unrounded weights.
    pub max_error_float_weights: f64,
    /// Largest absolute error with weights rounded to 8 fractional bits.
    pub max_error_8bit_weights: f64,
    /// RMS error with weights rounded to 8 fractional bits.
    pub rms_error_8bit_weights: f64,
}

/// Precision of `fetch = linear` on the packed layout (every filter whose
/// stencil has samples adjacent in a coset grid): pairs per coset, the
/// exact evidence that their weights are non-negative, and the CPU
/// emulation of the interpolation as for [`LinearFetchReport`].
#[derive(Clone, Debug, Serialize)]
pub struct PackedLinearFetchReport {
    /// Hardware-filtered fetches per evaluation: the most any used reference needs.
    pub fetches: usize,
    /// Exact loads per evaluation (the plan's fetches) they replace.
    pub exact_loads: usize,
    /// How the non-negativity of every fetch weight was established.
    pub non_negative: crate::emit::linear::NonNegativity,
    /// Number of seeded random points the errors are measured at.
    pub points: usize,
    /// Largest absolute error against the exact evaluator with unrounded weights.
    pub max_error_float_weights: f64,
    /// Largest absolute error with weights rounded to 8 fractional bits.
    pub max_error_8bit_weights: f64,
    /// RMS error with weights rounded to 8 fractional bits.
    pub rms_error_8bit_weights: f64,
}

/// Deterministic numbers in [0, 1) (SplitMix64 of the input).
fn hash01(mut z: u64) -> f64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as f64 / u64::MAX as f64
}

/// Random data in [0, 1) per lattice point.
fn hashed_data(j: &[i64]) -> f64 {
    hash01(j.iter().fold(17u64, |h, &x| h.wrapping_mul(1_000_003).wrapping_add(x as u64)))
}

const PRECISION_POINTS: usize = 2000;

/// (max error with float weights, max and RMS error with 8-bit weights) of
/// `linear(x, frac_bits)` against the exact evaluator at seeded points.
fn linear_errors(d: &Derivation, linear: &dyn Fn(&[f64], Option<u32>) -> f64) -> (f64, f64, f64) {
    let s = d.facts.dim;
    let (mut max_f, mut max_8, mut sum2) = (0f64, 0f64, 0f64);
    for i in 0..PRECISION_POINTS {
        let x: Vec<f64> = (0..s).map(|c| 20.0 * hash01((i * 7 + c) as u64)).collect();
        let exact = d.eval_f64(&x, &hashed_data).0;
        max_f = max_f.max((linear(&x, None) - exact).abs());
        let e8 = (linear(&x, Some(8)) - exact).abs();
        max_8 = max_8.max(e8);
        sum2 += e8 * e8;
    }
    (max_f, max_8, (sum2 / PRECISION_POINTS as f64).sqrt())
}

pub(super) fn linear_fetch_report(d: &Derivation) -> Option<LinearFetchReport> {
    let fac = d.factorisation()?;
    if !fac.supports_linear_fetch() {
        return None;
    }
    let (max_f, max_8, rms) = linear_errors(d, &|x, bits| fac.eval_linear_f64(x, &hashed_data, bits));
    Some(LinearFetchReport {
        fetches: fac.linear_fetches(),
        exact_loads: fac.fetches(),
        points: PRECISION_POINTS,
        max_error_float_weights: max_f,
        max_error_8bit_weights: max_8,
        rms_error_8bit_weights: rms,
    })
}

pub(super) fn packed_linear_fetch_report(
    d: &Derivation,
    plan: &crate::emit::plan::Plan,
) -> Option<PackedLinearFetchReport> {
    crate::emit::coset_pivots(&d.filter.lattice).ok()?;
    let lin = crate::emit::linear::LinearPlan::new(d);
    if lin.fetches(plan) >= plan.fetches() {
        return None;
    }
    let (max_f, max_8, rms) = linear_errors(d, &|x, bits| lin.eval_f64(d, plan, x, &hashed_data, bits));
    Some(PackedLinearFetchReport {
        fetches: lin.fetches(plan),
        exact_loads: plan.fetches(),
        non_negative: lin.proof.clone(),
        points: PRECISION_POINTS,
        max_error_float_weights: max_f,
        max_error_8bit_weights: max_8,
        rms_error_8bit_weights: rms,
    })
}
