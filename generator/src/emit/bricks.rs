//! The bricked layout: the volume cut into bricks of B^s lattice texels,
//! each stored in a slot of a pool texture with a halo around it, and a page
//! table that maps a brick to its slot. An evaluation looks its brick up
//! once (by the brick holding its position) and every fetch of its stencil
//! then reads that one slot: the halo is as wide as the stencils reach, so
//! no fetch leaves the slot (docs/BOX_SPLINES.md §5).

use crate::derive::Derivation;
use crate::math::exact::Q;

/// How far (in lattice texels, the same on every axis) the slot of a brick
/// must extend beyond the brick so that every fetch of an evaluation at a
/// point of the brick lands in it.
///
/// Derived from the stencils: for every reference piece, the largest
/// |j_a - v_a| between one of its stencil's lattice points j and one of its
/// vertices v, over the axes a. A point x of a cell lies in the hull of its
/// vertices, so every fetch for x lies within that reach of x on each axis;
/// the symmetry maps of the other cells are signed permutations of the axes,
/// so the maximum over axes covers them too. The halo is floor(reach) + 1:
/// the brick is chosen in f32 as floor(x / B), which may put a point a
/// rounding error past the brick's face into it, and the extra texel covers
/// that point's stencil (a stencil point lies at an integer, so a reach of
/// exactly r needs r texels, a reach just above r needs r + 1).
pub fn brick_halo(d: &Derivation) -> usize {
    let mut reach = Q::int(0);
    for r in &d.references {
        for k in &r.stencil {
            for v in &r.vertices {
                for a in 0..k.len() {
                    let gap = (&Q::int(r.corner[a] + k[a]) - &v[a]).abs();
                    if gap > reach {
                        reach = gap;
                    }
                }
            }
        }
    }
    let floor = reach.floor_i64().expect("a stencil's reach is a small rational");
    floor as usize + 1
}

/// The page-table word of a brick stored in slot `slot` (slots per axis of
/// the pool): 10 bits per axis in 3D, 16 in 2D; [`MISSING_PAGE`] marks a
/// brick that is not in the pool.
pub fn page_word(slot: &[usize]) -> u32 {
    let bits = if slot.len() == 3 { 10 } else { 16 };
    slot.iter().enumerate().map(|(a, &s)| (s as u32) << (bits * a)).sum()
}

/// Slots per axis the page word can address.
pub fn max_slots_per_axis(dim: usize) -> usize {
    if dim == 3 {
        1 << 10
    } else {
        1 << 16
    }
}

/// The page word of a brick that is not resident.
pub const MISSING_PAGE: u32 = u32::MAX;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::catalog;

    /// The halo covers the support: a sample whose shifted support meets a
    /// point of the brick lies within half the support's width (per axis,
    /// the sum of |xi_a| / 2 over the directions) of that point, and the
    /// halo is that bound's floor + 1 (for the f32 brick choice), no wider.
    #[test]
    fn halo_is_the_support_reach_plus_one() {
        for name in ["bcc7", "cc_tricubic", "fcc6", "bcc_linear", "courant", "cc_trilinear"] {
            let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
            let s = d.facts.dim;
            let half = (0..s).map(|a| Q::frac(d.facts.directions.iter().map(|x| x[a].abs()).sum(), 2)).max().unwrap();
            let bound = half.floor_i64().unwrap() as usize + 1;
            let h = brick_halo(&d);
            assert!(h <= bound, "{name}: halo {h} wider than the support bound {bound}");
            assert!(h >= 2, "{name}: halo {h} narrower than one texel plus the rounding texel");
        }
    }

    #[test]
    fn page_words_pack_each_axis() {
        assert_eq!(page_word(&[1, 2, 3]), 1 | (2 << 10) | (3 << 20));
        assert_eq!(page_word(&[5, 7]), 5 | (7 << 16));
        assert_ne!(page_word(&[1023, 1023, 1023]), MISSING_PAGE);
    }
}
