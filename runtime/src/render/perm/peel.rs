//! Opaque-boundary peeling (the paper's section 5, `--peel`).

use crate::render::dvr::transfer::Tf1d;
use crate::render::dvr::{skip_flags, widen_bounds};

/// Opaque-boundary peeling: clears `candidate` for every cell that no ray
/// entering the volume from outside samples before its opacity reaches
/// `termination`; returns how many it cleared.
///
/// The bound: with `tau(c)` the smallest extinction (per cell length) the
/// table gives over the values of cell c and of the cells within
/// ceil(step) of it (every segment with an end in c ramps between values
/// in that hull, pre-integrated or not), let R_t be the cells with
/// tau >= t. A cell whose Chebyshev neighbourhood of radius d - 1 lies in
/// R_t (the volume's outside counts as outside R_t) is reached only along a
/// path of length >= d - 1 inside R_t, whose optical depth is >= t (d - 1 -
/// 2 step) once the two partial segments at its ends are discounted; the ray
/// caster tests the opacity before each segment, so a segment ending in the
/// cell is never taken when t (d - 1 - 3 step) >= -ln(1 - termination).
/// Each t of a geometric ladder below the largest extinction is tried; a
/// cell is peeled when one proves it.
pub fn peel(
    bounds: &[[f32; 2]],
    dims: [usize; 3],
    table: &Tf1d,
    step: f32,
    termination: f32,
    candidate: &mut [bool],
) -> u64 {
    if !(0.0..1.0).contains(&termination) {
        return 0;
    }
    let reach = (step.ceil() as usize).max(1);
    let hull = widen_bounds(bounds, dims, 1, reach);
    let n = table.entries.len();
    let tau: Vec<f64> = hull
        .iter()
        .map(|b| {
            if b[0].is_nan() || b[1].is_nan() || b[0] > b[1] {
                return 0.0;
            }
            let lo = table.coord(b[0] as f64).floor() as usize;
            let hi = (table.coord(b[1] as f64).ceil() as usize).min(n - 1);
            table.entries[lo.min(hi)..=hi].iter().map(|e| e[3] as f64).fold(f64::INFINITY, f64::min)
        })
        .collect();
    let depth_needed = -(1.0 - termination as f64).ln();
    let tmax = tau.iter().cloned().fold(0.0f64, f64::max);
    let cells = dims[0] * dims[1] * dims[2];
    let mut peeled = vec![false; cells];
    let largest = *dims.iter().min().unwrap_or(&0);
    for k in 0..12 {
        let t = tmax / f64::from(1u32 << k);
        if t <= 0.0 {
            break;
        }
        // Cells whose neighbourhood of radius d - 1 lies in R_t.
        let d = (1.0 + 3.0 * step as f64 + depth_needed / t).ceil() as usize;
        if 2 * d > largest + 1 {
            continue; // no cell of this volume is that deep
        }
        let inside: Vec<u32> = tau.iter().map(|&x| u32::from(x >= t)).collect();
        let deep = skip_flags(&inside, dims.map(|v| v as i32), (d - 1) as i32);
        // skip_flags treats the volume's edge as inside; cells within d - 1
        // of the edge are reached from outside.
        for (i, p) in peeled.iter_mut().enumerate() {
            let c = [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
            let edge = (0..3).any(|a| c[a] + 1 < d || c[a] + d > dims[a]);
            *p |= deep[i] != 0 && !edge;
        }
    }
    let mut count = 0;
    for (c, p) in candidate.iter_mut().zip(&peeled) {
        if *c && *p {
            *c = false;
            count += 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::dvr::transfer::TransferFunction;

    #[test]
    fn peeling_drops_exactly_the_cells_deeper_than_the_bound() {
        // A table whose values above 0.5 have extinction 1.5 per cell, below clear.
        let tf = TransferFunction::parse(
            r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
                {"value": 0.49, "color": [1, 1, 1], "opacity": 0}, {"value": 0.51, "color": [1, 1, 1], "opacity": 0.7769},
                {"value": 1, "color": [1, 1, 1], "opacity": 0.7769}]}"#,
            "t",
        )
        .unwrap()
        .table();
        let dims = [30usize, 28, 26];
        let n: usize = dims.iter().product();
        let cell = |i: usize| [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
        // A solid box [4, 24)^3 of value 0.8, clear elsewhere.
        let solid = |c: [usize; 3]| (0..3).all(|a| (4..24).contains(&c[a]));
        let bounds: Vec<[f32; 2]> = (0..n).map(|i| if solid(cell(i)) { [0.8, 0.8] } else { [0.0, 0.0] }).collect();
        let tau = tf.entries.iter().map(|e| e[3]).fold(0.0f32, f32::max) as f64;
        assert!((tau - 1.5).abs() < 0.01, "extinction {tau}");
        for (step, termination) in [(0.5f32, 0.99f32), (1.0, 0.9)] {
            let mut candidate = vec![true; n];
            let peeled = peel(&bounds, dims, &tf, step, termination, &mut candidate);
            // Brute force: the tau of a cell is over its hull (reach ceil(step)), so
            // a cell is in R when every cell within ceil(step) is solid; the bound
            // asks for radius d - 1 of R around it, d = ceil(1 + 3 step + D / tau).
            let reach = step.ceil() as i64;
            let d = (1.0 + 3.0 * step as f64 - (1.0 - termination as f64).ln() / tau).ceil() as i64;
            let depth_ok = |c: [usize; 3]| {
                // distance from c to the nearest non-solid cell (outside the volume included), Chebyshev
                let to_clear = (0..3).map(|a| (c[a] as i64 - 3).min(24 - c[a] as i64)).min().unwrap();
                to_clear > d - 1 + reach
            };
            let mut want = 0;
            for (i, &c) in candidate.iter().enumerate() {
                let expect = depth_ok(cell(i));
                want += expect as u64;
                assert_eq!(!c, expect, "cell {:?}, step {step}, termination {termination}", cell(i));
            }
            assert!(peeled == want && peeled > 0, "{peeled} vs {want}");
        }
        // A translucent box proves nothing deep enough: nothing is peeled.
        let faint: Vec<[f32; 2]> = bounds.iter().map(|b| [b[0] * 0.62, b[1] * 0.62]).collect();
        let mut candidate = vec![true; n];
        assert_eq!(peel(&faint, dims, &tf, 0.5, 0.99, &mut candidate), 0);
    }
}
