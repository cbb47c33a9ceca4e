//! How a store of lattice samples (`boxforge convert --lattice bcc|fcc`)
//! lays them out, and the `boxforge` attribute that says so.
//!
//! **The convention.** A lattice L that contains the period grid p Z^3
//! (p = (2, 2, 2) for BCC and FCC) is the union of its cosets r + p Z^3,
//! one per residue r mod p that is a lattice point (BCC: (0,0,0) and
//! (1,1,1); FCC: (0,0,0), (1,1,0), (1,0,1), (0,1,1)). Each coset is a
//! Cartesian grid, stored as one channel of a (c, z, y, x) array: channel
//! c at (i, j, k) holds lattice point p (i, j, k) + r_c. Every channel has
//! the shape ceil(n / p) of the lattice box n; a coset's entries past the
//! box (odd n) hold the fill value 0 and are never read. The level's
//! `scale` is the grid's spacing (p times the lattice points' spacing) and
//! its `translation` is where lattice point 0 sits; the residues and each
//! level's lattice box are in the group's `boxforge` attribute, so a
//! generic OME-Zarr reader sees a valid image with one channel per coset
//! (each a coarser view of the whole volume) and boxforge sees the lattice.

use super::write::space_axis;
use super::ZarrError;
use super::{PyramidOptions, Reduction};
use crate::volume::convert::Membership;
use boxforge::spec::lattice::Lattice;
use std::path::Path;
use std::sync::Arc;
use zarrs::filesystem::FilesystemStore;

/// Version of the `boxforge` attribute's layout.
const LAYOUT_VERSION: u64 = 1;

/// The `boxforge` attribute of a store of lattice samples.
#[derive(Clone, Debug, PartialEq)]
pub struct LatticeLayout {
    /// The lattice's name (`bcc`, `fcc`, or a spec's lattice).
    pub lattice: String,
    /// The period grid p (x, y, z).
    pub period: [usize; 3],
    /// The residues r_c of the stored cosets (x, y, z), in channel order.
    pub cosets: Vec<[usize; 3]>,
    /// Each level's lattice box (x, y, z), finest first.
    pub dims: Vec<[usize; 3]>,
    /// The filter whose prefilter the stored samples went through, if any:
    /// the samples are that filter's spline coefficients.
    pub prefilter: Option<String>,
}

impl LatticeLayout {
    /// The layout of `lattice`'s cosets for levels of `dims`.
    pub(crate) fn new(
        lattice: &Lattice,
        dims: Vec<[usize; 3]>,
        prefilter: Option<String>,
    ) -> Result<LatticeLayout, crate::volume::VolumeError> {
        let m = Membership::new(lattice)?;
        Ok(LatticeLayout { lattice: lattice.name.clone(), period: m.period(), cosets: m.residues(), dims, prefilter })
    }

    /// The shape (x, y, z) every coset channel of a level of `dims` has.
    pub fn coset_shape(&self, dims: [usize; 3]) -> [usize; 3] {
        std::array::from_fn(|a| dims[a].div_ceil(self.period[a]))
    }

    /// Channel of each residue class in the period box (x fastest), None
    /// for residues off the lattice.
    pub(crate) fn channel_table(&self) -> Vec<Option<usize>> {
        let p = self.period;
        let mut t = vec![None; p[0] * p[1] * p[2]];
        for (c, r) in self.cosets.iter().enumerate() {
            t[r[0] + p[0] * (r[1] + p[1] * r[2])] = Some(c);
        }
        t
    }

    /// Whether `lattice` is the one this layout stores (same name and cosets).
    pub fn stores(&self, lattice: &Lattice) -> bool {
        Membership::new(lattice).is_ok_and(|m| m.period() == self.period && m.residues() == self.cosets)
            && lattice.name == self.lattice
    }

    /// The attribute's JSON; `scales` is each level's lattice scale (the
    /// Cartesian level's voxels per lattice unit), written for readers.
    pub(super) fn to_json(&self, scales: &[f64]) -> serde_json::Value {
        let levels: Vec<serde_json::Value> =
            self.dims.iter().zip(scales).map(|(d, s)| serde_json::json!({"dims": d, "lattice_scale": s})).collect();
        serde_json::json!({
            "version": LAYOUT_VERSION,
            "lattice": self.lattice,
            "period": self.period,
            "cosets": self.cosets,
            "levels": levels,
            "prefilter": self.prefilter,
            "layout": "channel c at (z, y, x) = (k, j, i) holds lattice point period * (i, j, k) + cosets[c] (x, y, z order); \
                       entries past a level's dims are 0 and not samples",
            "resampling": "level k is the matched-count trilinear resampling of the Cartesian level k \
                           (lattice point j at Cartesian voxel j * lattice_scale), then the prefilter, if any",
        })
    }

    /// The layout a group's attributes declare, if any.
    pub(super) fn from_attributes(
        store: &Path,
        attributes: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Option<LatticeLayout>, ZarrError> {
        let Some(v) = attributes.get("boxforge") else {
            return Ok(None);
        };
        let bad = |what: &str| ZarrError::Metadata {
            path: store.to_path_buf(),
            reason: format!("its boxforge attribute (a lattice store's layout) has {what}"),
        };
        let version = v.get("version").and_then(|x| x.as_u64());
        if version != Some(LAYOUT_VERSION) {
            return Err(bad(&format!("version {version:?}, and this boxforge reads version {LAYOUT_VERSION}")));
        }
        let triple = |x: &serde_json::Value| -> Option<[usize; 3]> {
            let a = x.as_array().filter(|a| a.len() == 3)?;
            let n: Vec<usize> = a.iter().map(|e| e.as_u64().map(|u| u as usize)).collect::<Option<_>>()?;
            Some([n[0], n[1], n[2]])
        };
        let lattice = v.get("lattice").and_then(|x| x.as_str()).ok_or_else(|| bad("no lattice name"))?.to_string();
        let period = v.get("period").and_then(triple).filter(|p| p.iter().all(|&x| (1..=64).contains(&x)));
        let period = period.ok_or_else(|| bad("no period of three numbers from 1 to 64"))?;
        let cosets: Vec<[usize; 3]> = v
            .get("cosets")
            .and_then(|x| x.as_array())
            .and_then(|a| a.iter().map(triple).collect::<Option<_>>())
            .filter(|c: &Vec<[usize; 3]>| !c.is_empty() && c.iter().all(|r| (0..3).all(|a| r[a] < period[a])))
            .ok_or_else(|| bad("no list of cosets (residues below the period)"))?;
        let dims: Vec<[usize; 3]> = v
            .get("levels")
            .and_then(|x| x.as_array())
            .and_then(|a| a.iter().map(|l| l.get("dims").and_then(triple)).collect::<Option<_>>())
            .filter(|d: &Vec<[usize; 3]>| d.iter().all(|x| !x.contains(&0)))
            .ok_or_else(|| bad("no list of levels with their dims"))?;
        let prefilter = v.get("prefilter").and_then(|x| x.as_str()).map(str::to_string);
        Ok(Some(LatticeLayout { lattice, period, cosets, dims, prefilter }))
    }
}

/// The group's `zarr.json`: OME-Zarr 0.5 multiscales over (c, z, y, x)
/// (or (z, y, x) for one coset) with each level's coset-grid scale and the
/// position of lattice point 0, and the `boxforge` layout attribute.
pub(super) fn write_lattice_group(
    store: &Arc<FilesystemStore>,
    layout: &LatticeLayout,
    matched: &[([usize; 3], f64)],
    channels: Option<usize>,
    o: &PyramidOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    let s0 = [o.spacing[2], o.spacing[1], o.spacing[0]];
    let p = [layout.period[2], layout.period[1], layout.period[0]];
    let lead: Vec<f64> = channels.map(|_| 1.0).into_iter().collect();
    let datasets: Vec<serde_json::Value> = matched
        .iter()
        .enumerate()
        .map(|(k, &(_, lattice_scale))| {
            let f = (1u64 << k) as f64;
            let scale: Vec<f64> = (0..3).map(|a| p[a] as f64 * lattice_scale * f * s0[a]).collect();
            let scale = [lead.clone(), scale].concat();
            let mut transforms = vec![serde_json::json!({"type": "scale", "scale": scale})];
            if o.reduction == Reduction::Box && k > 0 {
                let shift: Vec<f64> = s0.iter().map(|s| s * (f - 1.0) / 2.0).collect();
                let shift = [lead.iter().map(|_| 0.0).collect(), shift].concat();
                transforms.push(serde_json::json!({"type": "translation", "translation": shift}));
            }
            serde_json::json!({"path": k.to_string(), "coordinateTransformations": transforms})
        })
        .collect();
    let space = |name: &str| space_axis(name, o);
    let mut axes: Vec<serde_json::Value> =
        channels.map(|_| serde_json::json!({"name": "c", "type": "channel"})).into_iter().collect();
    axes.extend([space("z"), space("y"), space("x")]);
    let ome = serde_json::json!({
        "version": "0.5",
        "multiscales": [{
            "name": format!("boxforge {} samples", layout.lattice),
            "axes": axes,
            "datasets": datasets,
            "type": o.reduction.name(),
            "metadata": {"method": "boxforge lattice store", "reduction": o.reduction.name()},
        }],
    });
    let scales: Vec<f64> = matched.iter().map(|m| m.1).collect();
    let mut group = zarrs::group::GroupBuilder::new().build(store.clone(), "/")?;
    group.attributes_mut().insert("ome".into(), ome);
    group.attributes_mut().insert("boxforge".into(), layout.to_json(&scales));
    group.store_metadata()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bcc_and_fcc_are_two_and_four_cosets_of_the_even_grid() {
        let layout = |name: &str| LatticeLayout::new(&Lattice::builtin(name).unwrap(), vec![[5, 4, 3]], None).unwrap();
        let bcc = layout("bcc");
        assert_eq!((bcc.period, bcc.cosets.clone()), ([2, 2, 2], vec![[0, 0, 0], [1, 1, 1]]));
        let fcc = layout("fcc");
        assert_eq!(fcc.cosets, vec![[0, 0, 0], [1, 1, 0], [1, 0, 1], [0, 1, 1]]);
        assert_eq!(fcc.coset_shape([5, 4, 3]), [3, 2, 2]);
        assert!(fcc.stores(&Lattice::builtin("fcc").unwrap()) && !fcc.stores(&Lattice::builtin("bcc").unwrap()));
        // The JSON reads back as written; a broken one is refused with a reason.
        let json = fcc.to_json(&[0.6]);
        let attrs = serde_json::Map::from_iter([("boxforge".to_string(), json.clone())]);
        assert_eq!(LatticeLayout::from_attributes(Path::new("s.zarr"), &attrs).unwrap(), Some(fcc));
        let mut broken = json;
        broken["cosets"] = serde_json::json!([[2, 0, 0]]);
        let attrs = serde_json::Map::from_iter([("boxforge".to_string(), broken)]);
        let e = LatticeLayout::from_attributes(Path::new("s.zarr"), &attrs).unwrap_err().to_string();
        assert!(e.contains("cosets"), "{e}");
    }
}
