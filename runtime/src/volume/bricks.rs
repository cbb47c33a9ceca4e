//! The bricked layout on the host: the lattice texels cut into bricks of
//! B^3, each brick's texels plus a halo of h on every side copied into one
//! slot of a pool, and the page table that maps bricks to slots, as the
//! emitted `<f>_page` / `<f>_fetch_in` of templates/fetch_bricked.wgsl.j2
//! read them. Halo texels past the volume hold the clamped samples, so a
//! fetch from a slot equals the embedded layout's clamped fetch.

use super::{LatticeVolume, VolumeError};
use boxforge::emit::bricks::{max_slots_per_axis, page_word, MISSING_PAGE};

/// The shape of the bricks: edge B and halo h, in lattice texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BrickShape {
    /// Brick edge B (texels per axis a brick owns).
    pub edge: usize,
    /// Halo h on every side (at least the filter's
    /// [`boxforge::emit::bricks::brick_halo`]).
    pub halo: usize,
}

impl BrickShape {
    /// The default brick edge: 32 texels (a slot of (32 + 2h)^3 wastes
    /// (1 + 2h/32)^3 - 1 of the pool on halos, 42% at h = 2).
    pub const DEFAULT_EDGE: usize = 32;

    /// Edge [`Self::DEFAULT_EDGE`] and the halo `filter` needs.
    pub fn for_filter(d: &boxforge::derive::Derivation) -> BrickShape {
        BrickShape { edge: Self::DEFAULT_EDGE, halo: boxforge::emit::bricks::brick_halo(d) }
    }

    /// Texels per axis of one slot.
    pub fn slot(&self) -> usize {
        self.edge + 2 * self.halo
    }

    /// Refuses an edge of 0 or a halo of 0 (no filter reaches nowhere).
    pub fn check(&self) -> Result<(), VolumeError> {
        if self.edge == 0 || self.halo == 0 {
            return Err(VolumeError::BrickShape { edge: self.edge, halo: self.halo });
        }
        Ok(())
    }
}

/// A volume in the bricked layout: the pool's texels, its size, the page
/// table and the uniform of the emitted `<f>_bricks`.
#[derive(Clone, Debug, PartialEq)]
pub struct BrickedVolume {
    /// The brick shape.
    pub shape: BrickShape,
    /// Bricks per axis (ceil(dims / B)).
    pub bricks: [usize; 3],
    /// Slots per axis of the pool.
    pub slots: [usize; 3],
    /// Pool texels, x fastest (slots * slot edge per axis).
    pub pool: Vec<f32>,
    /// One page word per brick, x fastest ([`MISSING_PAGE`] when not resident).
    pub pages: Vec<u32>,
    /// `<f>_bricks`: (volume size or coset grid, B) and (bricks per axis, h).
    pub uniform: [i32; 8],
    /// The pool's texels per axis when slots are not cubes (coset-packed).
    pub pool_size: Option<[usize; 3]>,
}

impl BrickedVolume {
    /// Pool texels per axis.
    pub fn pool_size(&self) -> [usize; 3] {
        self.pool_size.unwrap_or(self.slots.map(|s| s * self.shape.slot()))
    }
}

/// Slots per axis for `count` slots of edge `slot` in a texture of at most
/// `max_edge` texels per axis: as many as fit along x, then y, then z.
pub fn slot_grid(count: usize, slot: usize, max_edge: usize) -> Option<[usize; 3]> {
    let per_axis = (max_edge / slot).min(max_slots_per_axis(3));
    if per_axis == 0 {
        return None;
    }
    let sx = per_axis.min(count.max(1));
    let sy = per_axis.min(count.max(1).div_ceil(sx));
    let sz = count.max(1).div_ceil(sx * sy);
    (sz <= per_axis).then_some([sx, sy, sz])
}

impl LatticeVolume {
    /// The bricked layout of every brick (in core), slots assigned in brick
    /// order through a pool of at most `max_edge` texels per axis.
    pub fn bricked(&self, shape: BrickShape, max_edge: usize) -> Result<BrickedVolume, VolumeError> {
        self.bricked_where(shape, max_edge, |_| true)
    }

    /// [`LatticeVolume::bricked`] with only the bricks `resident` accepts in
    /// the pool (brick index k, x fastest); the others' pages are
    /// [`MISSING_PAGE`] and take no slot.
    pub fn bricked_where(
        &self,
        shape: BrickShape,
        max_edge: usize,
        resident: impl Fn([usize; 3]) -> bool,
    ) -> Result<BrickedVolume, VolumeError> {
        shape.check()?;
        if self.lattice.dim() != 3 {
            return Err(VolumeError::LatticeDim { lattice: self.lattice.name.clone(), dim: self.lattice.dim() });
        }
        let bricks = self.dims.map(|n| n.div_ceil(shape.edge));
        let nb = bricks[0] * bricks[1] * bricks[2];
        let mut pages = vec![MISSING_PAGE; nb];
        let mut order = Vec::new();
        for bz in 0..bricks[2] {
            for by in 0..bricks[1] {
                for bx in 0..bricks[0] {
                    if resident([bx, by, bz]) {
                        order.push([bx, by, bz]);
                    }
                }
            }
        }
        let s = shape.slot();
        let slots = slot_grid(order.len(), s, max_edge).ok_or(VolumeError::PoolFull {
            bricks: order.len(),
            slot: s,
            max_edge,
        })?;
        let size = slots.map(|n| n * s);
        let texels = size[0].checked_mul(size[1]).and_then(|t| t.checked_mul(size[2]));
        let texels = texels
            .filter(|&t| t <= i32::MAX as usize)
            .ok_or(VolumeError::PoolTooLarge { texels: size.iter().map(|&n| n as u128).product() })?;
        let mut pool = vec![0f32; texels];
        let (h, b) = (shape.halo as i64, shape.edge as i64);
        for (i, k) in order.iter().enumerate() {
            let slot = [i % slots[0], (i / slots[0]) % slots[1], i / (slots[0] * slots[1])];
            pages[k[0] + bricks[0] * (k[1] + bricks[1] * k[2])] = page_word(&slot);
            for tz in 0..s {
                for ty in 0..s {
                    let row = slot[0] * s + size[0] * (slot[1] * s + ty + size[1] * (slot[2] * s + tz));
                    for tx in 0..s {
                        let j = [
                            k[0] as i64 * b - h + tx as i64,
                            k[1] as i64 * b - h + ty as i64,
                            k[2] as i64 * b - h + tz as i64,
                        ];
                        pool[row + tx] = self.get(&j);
                    }
                }
            }
        }
        let uniform = [
            self.dims[0] as i32,
            self.dims[1] as i32,
            self.dims[2] as i32,
            shape.edge as i32,
            bricks[0] as i32,
            bricks[1] as i32,
            bricks[2] as i32,
            shape.halo as i32,
        ];
        Ok(BrickedVolume { shape, bricks, slots, pool, pages, uniform, pool_size: None })
    }
}

impl LatticeVolume {
    /// The bricked, coset-packed layout of every brick (in core): each slot
    /// holds its brick's region (edge B + 2h, both even) as the packed layout
    /// stores it, a tile of (B + 2h) / 2 grid points per axis for each coset
    /// along the pivot axes, each grid point the packed layout's clamped one.
    pub fn bricked_packed(&self, shape: BrickShape, max_edge: usize) -> Result<BrickedVolume, VolumeError> {
        shape.check()?;
        if !shape.edge.is_multiple_of(2) || !shape.halo.is_multiple_of(2) {
            return Err(VolumeError::BrickParity { edge: shape.edge, halo: shape.halo });
        }
        let packed = self.packed()?;
        let pivots = boxforge::emit::coset_pivots(&self.lattice)
            .map_err(|e| VolumeError::Packed { lattice: self.lattice.name.clone(), message: e.to_string() })?;
        let g = [packed.grid[0] as usize, packed.grid[1] as usize, packed.grid[2] as usize];
        let mask: [usize; 3] = std::array::from_fn(|a| usize::from(pivots.contains(&a)));
        let gs = shape.slot() / 2;
        let extent: [usize; 3] = std::array::from_fn(|a| gs * (1 + mask[a]));
        let bricks = self.dims.map(|n| n.div_ceil(shape.edge));
        let nb = bricks[0] * bricks[1] * bricks[2];
        let slots = slot_grid(nb, 2 * gs, max_edge).ok_or(VolumeError::PoolFull {
            bricks: nb,
            slot: shape.slot(),
            max_edge,
        })?;
        let size: [usize; 3] = std::array::from_fn(|a| slots[a] * extent[a]);
        let texels = size[0] * size[1] * size[2];
        if texels > i32::MAX as usize {
            return Err(VolumeError::PoolTooLarge { texels: texels as u128 });
        }
        let tex = packed.texture;
        let mut pool = vec![0f32; texels];
        let mut pages = vec![MISSING_PAGE; nb];
        let (b, h) = (shape.edge as i64, shape.halo as i64);
        for (i, page) in pages.iter_mut().enumerate() {
            let k = [i % bricks[0], (i / bricks[0]) % bricks[1], i / (bricks[0] * bricks[1])];
            let slot = [i % slots[0], (i / slots[0]) % slots[1], i / (slots[0] * slots[1])];
            *page = page_word(&slot);
            let origin: [i64; 3] = std::array::from_fn(|a| (k[a] as i64 * b - h) / 2);
            for tile in 0..8usize {
                let t = [tile & 1, (tile >> 1) & 1, (tile >> 2) & 1];
                if (0..3).any(|a| t[a] > mask[a]) {
                    continue;
                }
                for mz in 0..gs {
                    for my in 0..gs {
                        for mx in 0..gs {
                            let m = [mx, my, mz];
                            let src: [usize; 3] = std::array::from_fn(|a| {
                                (origin[a] + m[a] as i64).clamp(0, g[a] as i64 - 1) as usize + t[a] * g[a]
                            });
                            let dst: [usize; 3] = std::array::from_fn(|a| slot[a] * extent[a] + t[a] * gs + m[a]);
                            pool[dst[0] + size[0] * (dst[1] + size[1] * dst[2])] =
                                packed.words[src[0] + tex[0] * (src[1] + tex[1] * src[2])];
                        }
                    }
                }
            }
        }
        let uniform = [
            g[0] as i32,
            g[1] as i32,
            g[2] as i32,
            shape.edge as i32,
            bricks[0] as i32,
            bricks[1] as i32,
            bricks[2] as i32,
            shape.halo as i32,
        ];
        Ok(BrickedVolume { shape, bricks, slots, pool, pages, uniform, pool_size: Some(size) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::ramp_volume;

    /// Reads sample j the way the emitted module does: page of the brick
    /// holding p, slot texel clamp(j) + page.
    fn fetch(v: &BrickedVolume, p: [f32; 3], j: [i64; 3]) -> f32 {
        let (b, h) = (v.shape.edge as i64, v.shape.halo as i64);
        let k: [i64; 3] = std::array::from_fn(|a| ((p[a] / b as f32).floor() as i64).clamp(0, v.bricks[a] as i64 - 1));
        let word = v.pages[(k[0] + v.bricks[0] as i64 * (k[1] + v.bricks[1] as i64 * k[2])) as usize];
        let slot = [word & 1023, (word >> 10) & 1023, (word >> 20) & 1023].map(|x| x as i64);
        let size = v.pool_size().map(|n| n as i64);
        let dims = [v.uniform[0], v.uniform[1], v.uniform[2]].map(|n| n as i64);
        let t: [i64; 3] = std::array::from_fn(|a| j[a].clamp(0, dims[a] - 1) + slot[a] * (b + 2 * h) + h - k[a] * b);
        for a in 0..3 {
            assert!((0..size[a]).contains(&t[a]), "texel {t:?} outside the pool {size:?}");
        }
        v.pool[(t[0] + size[0] * (t[1] + size[1] * t[2])) as usize]
    }

    #[test]
    fn every_fetch_within_the_halo_reads_the_clamped_sample() {
        let vol = ramp_volume("bcc", [11, 9, 7]);
        let shape = BrickShape { edge: 4, halo: 2 };
        // A pool narrower than the brick grid, so slots wrap onto new rows.
        let v = vol.bricked(shape, 3 * shape.slot()).unwrap();
        assert_eq!(v.bricks, [3, 3, 2]);
        for p in [[0.0f32, 0.0, 0.0], [3.999, 4.0, 0.5], [4.0, 7.9, 6.99], [10.9, 8.5, 6.5], [-3.0, 20.0, 3.0]] {
            let c: [i64; 3] = std::array::from_fn(|a| p[a].floor() as i64);
            for dz in -1..=2 {
                for dy in -1..=2 {
                    for dx in -1..=2 {
                        let j = [c[0] + dx, c[1] + dy, c[2] + dz];
                        assert_eq!(fetch(&v, p, j), vol.get(&j), "p {p:?} j {j:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn missing_bricks_take_no_slot_and_bad_shapes_are_refused() {
        let vol = ramp_volume("cc", [8, 8, 8]);
        let shape = BrickShape { edge: 4, halo: 1 };
        let v = vol.bricked_where(shape, 64, |k| k != [1, 1, 1]).unwrap();
        assert_eq!(v.pages.iter().filter(|&&w| w == MISSING_PAGE).count(), 1);
        assert_eq!(v.slots.iter().product::<usize>() * shape.slot().pow(3), v.pool.len());
        assert!(v.slots.iter().product::<usize>() >= 7);
        assert!(vol.bricked(BrickShape { edge: 0, halo: 1 }, 64).is_err());
        assert!(vol.bricked(BrickShape { edge: 4, halo: 1 }, 5).is_err(), "a slot wider than the pool");
        assert!(vol.bricked(BrickShape { edge: 4, halo: 1 }, 12).is_ok(), "8 bricks in a pool of 2x2x2 slots fit");
        assert!(vol.bricked(BrickShape { edge: 2, halo: 1 }, 12).is_err(), "64 bricks in a pool of 3x3x3 slots do not");
    }
}
