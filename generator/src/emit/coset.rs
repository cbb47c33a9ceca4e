//! Cosets of 2Z^s in the lattice (the packed layout) and the integer helper
//! functions every module carries.

use super::writer::*;
use crate::emit::plan::Plan;
use crate::error::{Error, Result};
use crate::math::linalg::IVec;
use crate::spec::lattice::Lattice;
use std::fmt::Write;

/// Parity pivots of the cosets of 2Z^s in L: coordinates whose parity bits
/// number the cosets 0..2^k. Errors if 2Z^s is not a sublattice of L.
///
/// # Errors
///
/// [`Error::Spec`] when 2Z^s is not a sublattice of L.
pub fn coset_pivots(lattice: &Lattice) -> Result<Vec<usize>> {
    let s = lattice.dim();
    for i in 0..s {
        let mut e = vec![0; s];
        e[i] = 2;
        if !lattice.contains(&e) {
            return Err(Error::Spec {
                origin: format!("lattice {}", lattice.name),
                message: "the packed layout needs 2Z^s inside the lattice; use the embedded layout (layout = embedded)"
                    .into(),
            });
        }
    }
    // Parity patterns in L form a GF(2) subspace; reduce to find pivots.
    let mut basis: Vec<u32> = Vec::new();
    for bits in 0u32..(1 << s) {
        let v: IVec = (0..s).map(|i| ((bits >> i) & 1) as i64).collect();
        if !lattice.contains(&v) {
            continue;
        }
        let mut x = bits;
        for b in &basis {
            if x & (1 << b.trailing_zeros()) != 0 {
                x ^= b;
            }
        }
        if x != 0 {
            // Keep the basis reduced on pivots.
            let p = x.trailing_zeros();
            for b in basis.iter_mut() {
                if *b & (1 << p) != 0 {
                    *b ^= x;
                }
            }
            basis.push(x);
        }
    }
    let mut pivots: Vec<usize> = basis.iter().map(|b| b.trailing_zeros() as usize).collect();
    pivots.sort();
    Ok(pivots)
}

/// Coset id of a lattice point from its parity (host-side mirror of the shader).
pub fn coset_of(pivots: &[usize], j: &[i64]) -> usize {
    pivots.iter().enumerate().map(|(i, &p)| ((j[p].rem_euclid(2)) as usize) << i).sum()
}

pub(crate) fn helpers(sh: &Shapes, plan: &Plan, name: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "/// floor(a / b) for b > 0, with integer arithmetic only.");
    let _ = writeln!(out, "fn {name}_floor_div(a: i32, b: i32) -> i32 {{");
    let _ = writeln!(out, "    return (a - ((a % b) + b) % b) / b;");
    let _ = writeln!(out, "}}\n");
    let _ = writeln!(out, "/// Is j a point of the lattice? (Hermite reduction to zero.)");
    let _ = writeln!(out, "fn {name}_is_lattice(j: {}) -> bool {{", sh.veci);
    let mut r = "j".to_string();
    for i in 0..sh.s {
        let h = plan.hermite[i][i];
        let _ = writeln!(
            out,
            "    let r{i} = {r} - {name}_floor_div({r}.{}, {h}) * {};",
            AXES[i],
            sh.ivec(&plan.hermite[i])
        );
        r = format!("r{i}");
    }
    let _ = writeln!(out, "    return all({r} == {}(0));", sh.veci);
    let _ = writeln!(out, "}}\n");
    out
}
