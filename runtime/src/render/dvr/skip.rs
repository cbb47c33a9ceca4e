//! Empty-space skipping: which blocks the transfer function leaves
//! transparent, which of them a segment may jump over, and block bounds
//! widened for functions that reach beyond a block.

use crate::render::blocks::{skip_map, SkipMap, SkipMapStats};
use crate::render::dvr::transfer::Tf1d;

/// Per-block flags (1 = every value in the block maps to zero opacity) from
/// the [min, max] bounds of each block.
pub fn empty_flags(bounds: &[[f32; 2]], table: &Tf1d) -> Vec<u32> {
    bounds.iter().map(|b| table.transparent(b[0] as f64, b[1] as f64) as u32).collect()
}

/// The skipping flags: a block is skipped when it and every block within
/// `radius` blocks (Chebyshev distance, clamped at the grid's faces) are
/// empty; `blocks` is the grid's size, x fastest. With radius
/// ceil(step / block edge), a segment that starts in a skipped block ends in
/// empty blocks, so the shader skips every segment starting there.
pub fn skip_flags(empty: &[u32], blocks: [i32; 3], radius: i32) -> Vec<u32> {
    let [nx, ny, nz] = blocks.map(|n| n as usize);
    assert_eq!(empty.len(), nx * ny * nz, "one flag per block");
    let mut f = empty.to_vec();
    let r = radius.max(0) as usize;
    // A separable min filter, one axis at a time.
    for (n, stride) in [(nx, 1), (ny, nx), (nz, nx * ny)] {
        let prev = f.clone();
        for (i, out) in f.iter_mut().enumerate() {
            let c = (i / stride) % n;
            let (lo, hi) = (c.saturating_sub(r), (c + r).min(n - 1));
            *out = (lo..=hi).all(|q| prev[i - c * stride + q * stride] != 0) as u32;
        }
    }
    f
}

/// The skipping map of the DVR caster (templates/dvr.wgsl.j2, `_dflags`):
/// per block, s = (Chebyshev distance to the nearest non-empty block) -
/// `radius`, at least 0. Where s > 0 the block is skipped (s > 0 exactly
/// where [`skip_flags`] is 1), and so is every block of the box of
/// half-width s - 1 around it: each block of that box and every block
/// within `radius` of it are empty, so a ray jumps over every segment that
/// starts in the box. `map` picks the distances, one block at a time, or
/// (testing) a wrong map.
pub fn skip_distances(empty: &[u32], blocks: [i32; 3], radius: i32, map: SkipMap) -> (Vec<u32>, SkipMapStats) {
    skip_map(empty, blocks, radius.max(0) as u32, map)
}

/// Block bounds from cell bounds (`cells`, one per unit cube of `dims`, x
/// fastest): each block of `block`^3 cells gets the union over its cells
/// and every cell within `reach` of it, the bound of a function whose value
/// at a point is a convex combination of values within `reach` cells of it.
pub fn widen_bounds(cells: &[[f32; 2]], dims: [usize; 3], block: usize, reach: usize) -> Vec<[f32; 2]> {
    let blocks = dims.map(|n| n.div_ceil(block));
    // Separable: widen along x, then y, then z, over the window of each block.
    let window = |b: usize, n: usize| (b * block).saturating_sub(reach)..((b + 1) * block + reach).min(n);
    let mut cur = cells.to_vec();
    let mut shape = dims;
    for axis in 0..3 {
        let mut next_shape = shape;
        next_shape[axis] = blocks[axis];
        let stride = |s: [usize; 3]| [1, s[0], s[0] * s[1]];
        let (si, so) = (stride(shape), stride(next_shape));
        let mut next = vec![[f32::INFINITY, f32::NEG_INFINITY]; next_shape.iter().product()];
        for z in 0..next_shape[2] {
            for y in 0..next_shape[1] {
                for x in 0..next_shape[0] {
                    let o = [x, y, z];
                    let mut b = [f32::INFINITY, f32::NEG_INFINITY];
                    for c in window(o[axis], dims[axis]) {
                        let mut i = o;
                        i[axis] = c;
                        let v = cur[i[0] * si[0] + i[1] * si[1] + i[2] * si[2]];
                        b = [b[0].min(v[0]), b[1].max(v[1])];
                    }
                    next[x * so[0] + y * so[1] + z * so[2]] = b;
                }
            }
        }
        cur = next;
        shape = next_shape;
    }
    cur
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widened_bounds_are_the_union_over_the_block_and_its_reach() {
        let dims = [7usize, 5, 6];
        let n = dims.iter().product::<usize>();
        let cells: Vec<[f32; 2]> = (0..n)
            .map(|i| {
                let v = ((i * 37) % 23) as f32;
                [v, v + ((i * 11) % 5) as f32]
            })
            .collect();
        for (block, reach) in [(2usize, 2usize), (4, 1), (3, 0)] {
            let got = widen_bounds(&cells, dims, block, reach);
            let blocks = dims.map(|d| d.div_ceil(block));
            assert_eq!(got.len(), blocks.iter().product::<usize>());
            for (k, g) in got.iter().enumerate() {
                let b = [k % blocks[0], (k / blocks[0]) % blocks[1], k / (blocks[0] * blocks[1])];
                let mut want = [f32::INFINITY, f32::NEG_INFINITY];
                for (i, c) in cells.iter().enumerate() {
                    let p = [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
                    let inside = (0..3).all(|a| p[a] + reach >= b[a] * block && p[a] < (b[a] + 1) * block + reach);
                    if inside {
                        want = [want[0].min(c[0]), want[1].max(c[1])];
                    }
                }
                assert_eq!(*g, want, "block {b:?}, edge {block}, reach {reach}");
            }
        }
    }

    #[test]
    fn skip_flags_shrink_the_empty_region_by_the_radius() {
        // 5 x 1 x 1 blocks: empty, empty, full, empty, empty.
        let empty = [1, 1, 0, 1, 1];
        assert_eq!(skip_flags(&empty, [5, 1, 1], 0), empty);
        assert_eq!(skip_flags(&empty, [5, 1, 1], 1), [1, 0, 0, 0, 1]);
        assert_eq!(skip_flags(&empty, [5, 1, 1], 2), [0, 0, 0, 0, 0]);
        // Along z in a 1 x 1 x 3 grid, and clamped at the faces.
        assert_eq!(skip_flags(&[1, 1, 0], [1, 1, 3], 1), [1, 0, 0]);
    }

    #[test]
    fn skip_distances_skip_where_the_flags_do() {
        let b = [8, 6, 5];
        let n = (b[0] * b[1] * b[2]) as usize;
        let empty: Vec<u32> = (0..n).map(|i| ((i * 7919) % 61 != 0) as u32).collect();
        for r in 0..4 {
            let (d, _) = skip_distances(&empty, b, r, SkipMap::Distance);
            let flags: Vec<u32> = d.iter().map(|&v| (v > 0) as u32).collect();
            assert_eq!(flags, skip_flags(&empty, b, r), "radius {r}");
            // Every block of the box of half-width s - 1 is skipped with the flags of radius r.
            let f = skip_flags(&empty, b, r);
            for (i, &s) in d.iter().enumerate() {
                let p = [i as i32 % b[0], (i as i32 / b[0]) % b[1], i as i32 / (b[0] * b[1])];
                for (j, &fj) in f.iter().enumerate() {
                    let q = [j as i32 % b[0], (j as i32 / b[0]) % b[1], j as i32 / (b[0] * b[1])];
                    if s > 0 && (0..3).all(|a| (p[a] - q[a]).abs() < s as i32) {
                        assert_eq!(fj, 1, "radius {r}: block {q:?} in the box of {p:?} (s {s})");
                    }
                }
            }
        }
    }
}
