//! The coset-packed layout of lattice samples (one word per sample, each
//! coset's grid one tile of an r32float texture, as the emitted `<f>_fetch`
//! of templates/fetch_packed.wgsl.j2 reads it) and the memory sizes of the
//! packed and embedded layouts.

use super::error::checked_count;
use super::{LatticeVolume, VolumeError};
use boxforge::emit::{coset_of, coset_pivots};

/// A volume in the packed layout: the texture's words and size and the
/// grid uniform of the emitted `<f>_grid`.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedVolume {
    /// Texels, x fastest: coset c's grid is the tile at (m + (r & p) * g)
    /// for its parity vector r, p = 1 on the pivot axes.
    pub words: Vec<f32>,
    /// Texture size: g on the other axes, 2 g on the pivot axes.
    pub texture: [usize; 3],
    /// `<f>_grid.size`: the coset grid g and, in w, the words per coset.
    pub grid: [i32; 4],
}

impl LatticeVolume {
    /// Coset grid size g = ceil(dims / 2) per axis and the coset pivots, checked to fit i32.
    fn packed_shape(&self) -> Result<([usize; 3], usize, Vec<usize>), VolumeError> {
        let err = |message: String| VolumeError::Packed { lattice: self.lattice.name.clone(), message };
        if self.lattice.dim() != 3 {
            return Err(VolumeError::LatticeDim { lattice: self.lattice.name.clone(), dim: self.lattice.dim() });
        }
        let pivots = coset_pivots(&self.lattice).map_err(|e| err(e.to_string()))?;
        let g = self.dims.map(|n| n.div_ceil(2));
        let words = g[0] * g[1] * g[2];
        let total = words.checked_mul(1 << pivots.len());
        match total {
            Some(t) if t <= i32::MAX as usize && !g.contains(&0) => Ok((g, words, pivots)),
            _ => Err(err(format!(
                "dims {:?} need more than i32::MAX words (or are empty); use a smaller volume",
                self.dims
            ))),
        }
    }

    /// Packed layout for the texture of the emitted `<f>_fetch` (see
    /// templates/fetch_packed.wgsl.j2): coset grid size g = ceil(dims / 2) per axis; sample j
    /// of the coset with parity vector r stored at texel t = (j >> 1) + (r & p) * g, p = 1 on
    /// the pivot axes (so each coset's grid is one tile), in a texture of g (2 g on the pivot
    /// axes) texels per axis, index (t.z * ty + t.y) * tx + t.x.
    ///
    /// With an odd dim, a coset whose points on that axis are odd has one slot past the box;
    /// it holds the value of the same-coset point two steps back, so the shader's clamped
    /// fetch replicates the boundary of each coset (a coset with no point on an axis of
    /// size 1 gets 0).
    pub fn packed(&self) -> Result<PackedVolume, VolumeError> {
        let (g, words, pivots) = self.packed_shape()?;
        let expected = checked_count(self.dims)?;
        if self.data.len() != expected {
            return Err(VolumeError::DataLength { dims: self.dims, len: self.data.len(), expected });
        }
        let cosets = 1usize << pivots.len();
        let texture: [usize; 3] = std::array::from_fn(|a| if pivots.contains(&a) { 2 * g[a] } else { g[a] });
        // Parity vector of each coset: parities on the pivot axes from the coset id,
        // the others fixed by membership (the parity patterns of L are spanned by
        // the reduced basis, so the pivot bits determine the rest).
        let mut parity = vec![None; cosets];
        for bits in 0..8usize {
            let r = [(bits & 1) as i64, ((bits >> 1) & 1) as i64, ((bits >> 2) & 1) as i64];
            if self.lattice.contains(&r) {
                parity[coset_of(&pivots, &r)].get_or_insert(r);
            }
        }
        let mut buf = vec![0f32; cosets * words];
        let [nx, ny, _] = self.dims;
        for r in parity.iter().flatten() {
            // The tile's corner: g on each pivot axis whose parity is odd.
            let o: [usize; 3] = std::array::from_fn(|a| if pivots.contains(&a) { r[a] as usize * g[a] } else { 0 });
            for mz in 0..g[2] {
                for my in 0..g[1] {
                    for mx in 0..g[0] {
                        let m = [mx, my, mz];
                        let mut j = [0usize; 3];
                        let mut inside = true;
                        for a in 0..3 {
                            let mut v = 2 * m[a] + r[a] as usize;
                            if v >= self.dims[a] {
                                // Past the box (odd dim): replicate the last same-parity point.
                                match v.checked_sub(2) {
                                    Some(w) => v = w,
                                    None => inside = false,
                                }
                            }
                            j[a] = v;
                        }
                        if inside {
                            let t = [mx + o[0], my + o[1], mz + o[2]];
                            buf[(t[2] * texture[1] + t[1]) * texture[0] + t[0]] =
                                self.data[j[0] + nx * (j[1] + ny * j[2])];
                        }
                    }
                }
            }
        }
        Ok(PackedVolume { words: buf, texture, grid: [g[0] as i32, g[1] as i32, g[2] as i32, words as i32] })
    }

    /// Size of the packed texture (g per axis, 2 g on the pivot axes: at most the
    /// embedded texture's size with dims rounded up to even); `None` when the lattice has
    /// no packed layout.
    pub fn packed_texture_size(&self) -> Option<[usize; 3]> {
        let (g, _, pivots) = self.packed_shape().ok()?;
        Some(std::array::from_fn(|a| if pivots.contains(&a) { 2 * g[a] } else { g[a] }))
    }

    /// Bytes of the embedded texture (4 per integer point of the box), for memory reports.
    pub fn embedded_bytes(&self) -> usize {
        4 * self.dims.iter().product::<usize>()
    }

    /// Bytes of the packed texture (4 per word; one word per sample when dims are even;
    /// 0 when the lattice has no packed layout).
    pub fn packed_bytes(&self) -> usize {
        self.packed_shape().map(|(_, words, pivots)| 4 * (words << pivots.len())).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::testutil::{expected_samples, lattice, member, mni_path, test_volume};
    use crate::volume::Volume;
    use boxforge::spec::lattice::Lattice;

    /// The pivot mask p of the shader's tile offset, per lattice.
    fn mask(name: &str) -> [i64; 3] {
        match name {
            "bcc" => [1, 0, 0],
            "fcc" => [1, 1, 0],
            "cc" => [1, 1, 1],
            _ => unreachable!(),
        }
    }

    /// The shader's packed fetch (templates/fetch_packed.wgsl.j2), written out
    /// by hand per lattice: grid position m = j >> 1 clamped to the coset grid,
    /// texel t = m + (j & p) * g, index (t.z * ty + t.y) * tx + t.x.
    fn shader_index(name: &str, size: [i32; 4], j: [i64; 3]) -> usize {
        let p = mask(name);
        let g = [size[0] as i64, size[1] as i64, size[2] as i64];
        let t: Vec<i64> = (0..3).map(|a| (j[a] >> 1).clamp(0, g[a] - 1) + (j[a] & p[a]) * g[a]).collect();
        let tex: Vec<i64> = (0..3).map(|a| g[a] * (1 + p[a])).collect();
        ((t[2] * tex[1] + t[1]) * tex[0] + t[0]) as usize
    }

    fn shader_fetch(name: &str, buf: &[f32], size: [i32; 4], j: [i64; 3]) -> f32 {
        buf[shader_index(name, size, j)]
    }

    #[test]
    fn packed_layout_matches_the_shader_index() {
        assert_eq!(coset_pivots(&lattice("bcc")).unwrap(), vec![0]);
        assert_eq!(coset_pivots(&lattice("fcc")).unwrap(), vec![0, 1]);
        assert_eq!(coset_pivots(&lattice("cc")).unwrap(), vec![0, 1, 2]);
        for name in ["cc", "bcc", "fcc"] {
            for dims in [[8, 8, 8], [7, 6, 5], [10, 4, 6], [1, 2, 3]] {
                let l = LatticeVolume::subset(&lattice(name), &test_volume(dims)).unwrap();
                let PackedVolume { words: buf, texture, grid: size } = l.packed().unwrap();
                let g = dims.map(|n| n.div_ceil(2) as i32);
                assert_eq!(size, [g[0], g[1], g[2], g[0] * g[1] * g[2]]);
                let p = mask(name);
                assert_eq!(texture, std::array::from_fn(|a| g[a] as usize * (1 + p[a] as usize)));
                assert_eq!(l.packed_texture_size(), Some(texture));
                assert_eq!(texture.iter().product::<usize>(), buf.len());
                // Never larger than the embedded texture with dims rounded up to even.
                assert!((0..3).all(|a| texture[a] <= dims[a] + dims[a] % 2), "{name} {dims:?} {texture:?}");
                let cosets = 8 / l.lattice.det() as usize;
                assert_eq!(buf.len(), cosets * size[3] as usize);
                assert_eq!(l.packed_bytes(), 4 * buf.len());
                assert_eq!(l.embedded_bytes(), 4 * dims.iter().product::<usize>());
                // Every lattice point of the box is found where the shader looks.
                let mut seen = vec![false; buf.len()];
                for k in 0..dims[2] as i64 {
                    for j in 0..dims[1] as i64 {
                        for i in 0..dims[0] as i64 {
                            if member(name, [i as usize, j as usize, k as usize]) {
                                assert_eq!(shader_fetch(name, &buf, size, [i, j, k]), l.get(&[i, j, k]));
                                let idx = shader_index(name, size, [i, j, k]);
                                assert!(!seen[idx], "two samples share word {idx}");
                                seen[idx] = true;
                            }
                        }
                    }
                }
                let used = seen.iter().filter(|&&s| s).count();
                assert_eq!(used, l.samples());
                if dims.iter().all(|n| n % 2 == 0) {
                    // Exactly one word per sample; the embedded texture costs det x.
                    assert_eq!(buf.len(), l.samples());
                    assert_eq!(l.packed_bytes(), 4 * l.samples());
                    assert_eq!(l.embedded_bytes(), l.packed_bytes() * l.lattice.det() as usize);
                }
                // Outside the box, the fetch replicates the nearest in-box point of
                // the same coset (same parity per axis), when there is one.
                for k in -2..dims[2] as i64 + 2 {
                    for j in -2..dims[1] as i64 + 2 {
                        for i in -2..dims[0] as i64 + 2 {
                            let p = [i, j, k];
                            if !l.is_lattice(&p) {
                                continue;
                            }
                            let near: Option<Vec<i64>> = (0..3)
                                .map(|a| {
                                    let n = dims[a] as i64;
                                    let par = p[a].rem_euclid(2);
                                    let hi = if (n - 1) % 2 == par { n - 1 } else { n - 2 };
                                    (hi >= par).then(|| p[a].clamp(par, hi))
                                })
                                .collect();
                            if let Some(q) = near {
                                assert_eq!(shader_fetch(name, &buf, size, p), l.get(&q), "{name} {dims:?} {p:?}");
                            }
                        }
                    }
                }
            }
        }
        // The real-world sizes: BCC / FCC subsets of the MNI head.
        let vol = Volume::load_nifti(&mni_path()).unwrap();
        for (name, det) in [("bcc", 4), ("fcc", 2)] {
            let l = LatticeVolume::subset(&lattice(name), &vol).unwrap();
            let buf = l.packed().unwrap().words;
            assert_eq!(l.samples(), expected_samples(name, vol.dims));
            // Odd dims waste at most a boundary layer per coset.
            assert!(buf.len() >= l.samples() && buf.len() < l.samples() * 103 / 100, "{name}");
            let ratio = l.embedded_bytes() as f64 / l.packed_bytes() as f64;
            assert!((ratio - det as f64).abs() < 0.05 * det as f64, "{name}: embedded/packed = {ratio}");
        }
    }

    #[test]
    fn packed_rejects_lattices_without_2z3() {
        // det 3: 2Z^3 is not a sublattice.
        let l3 = Lattice::from_generators("custom", vec![vec![1, 0, 0], vec![0, 1, 0], vec![1, 1, 3]]).unwrap();
        let v = LatticeVolume::subset(&l3, &test_volume([6, 6, 6])).unwrap();
        assert_eq!(v.samples(), (0..216).filter(|&i| l3.contains(&[i % 6, (i / 6) % 6, i / 36])).count());
        let e = v.packed().unwrap_err();
        assert!(matches!(e, VolumeError::Packed { .. }), "{e}");
        assert!(e.to_string().contains("embedded"), "{e}");
        assert_eq!(v.packed_bytes(), 0);
        assert_eq!(v.packed_texture_size(), None);
        // Hand-built inconsistent struct: errors, not panics.
        let bad = LatticeVolume { lattice: lattice("bcc"), dims: [4, 4, 4], data: vec![1.0; 10] };
        assert!(matches!(bad.packed(), Err(VolumeError::DataLength { .. })));
        assert_eq!(bad.get(&[3, 3, 3]), 0.0);
    }
}
