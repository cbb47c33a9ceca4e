//! Turning a `--volume` argument into lattice samples: Marschner-Lobb at a
//! sample budget, or a real volume (NIfTI / raw) as a lattice subset or
//! resampled at a matched sample count.

use crate::volume::{LatticeVolume, Volume, VolumeError};
use boxforge::spec::lattice::Lattice;
use std::path::Path;

/// How a Cartesian volume becomes data on a non-Cartesian lattice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Conversion {
    /// Keep the lattice points of the Cartesian grid (fewer samples).
    Subset,
    /// Resample (trilinear) on a scaled lattice with the same sample count.
    Resample,
}

/// Box edge so that the lattice has about `samples` points in an n^3 box:
/// n = (samples * |det G|)^(1/3), rounded to an even number.
pub fn matched_edge(lattice: &Lattice, samples: f64) -> usize {
    let n = (samples * lattice.det() as f64).cbrt();
    ((n / 2.0).round() as usize * 2).max(4)
}

/// A file of the repository's `data/` folder: looked up under the working
/// directory, then where this binary was built from, so `bench` and `demo`
/// also work when run outside the repository.
pub fn data_file(name: &str) -> Option<std::path::PathBuf> {
    let here = std::path::Path::new("data").join(name);
    let built = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("data").join(name);
    [here, built].into_iter().find(|p| p.is_file())
}

/// `ml:N` (Marschner-Lobb with about N^3 samples), `path.nii[.gz]`, or a raw
/// file with `raw = Some("nx,ny,nz,type")`.
pub fn load(
    spec: &str,
    raw: Option<&str>,
    lattice: &Lattice,
    conversion: Conversion,
) -> Result<LatticeVolume, VolumeError> {
    if let Some(n) = spec.strip_prefix("ml:") {
        let n =
            crate::limits::parse_ml_n(n).map_err(|e| VolumeError::BadDims { dims: [0; 3], reason: e.to_string() })?;
        let e = matched_edge(lattice, (n as f64).powi(3));
        crate::limits::check_samples([e, e, e], spec)
            .map_err(|e| VolumeError::BadDims { dims: [0; 3], reason: e.to_string() })?;
        return LatticeVolume::marschner_lobb(lattice, [e, e, e]);
    }
    let path = Path::new(spec);
    let vol = match raw {
        Some(r) => {
            let (dims, ty) = crate::volume::parse_raw_spec(r)?;
            Volume::load_raw(path, dims, ty)?
        }
        None => Volume::load_nifti(path)?,
    };
    from_cartesian(&vol, lattice, conversion)
}

/// A Cartesian volume on `lattice`.
pub fn from_cartesian(vol: &Volume, lattice: &Lattice, conversion: Conversion) -> Result<LatticeVolume, VolumeError> {
    if lattice.det() == 1 || conversion == Conversion::Subset {
        return LatticeVolume::subset(lattice, vol);
    }
    let (dims, scale) = crate::volume::matched_lattice(lattice, vol.dims);
    LatticeVolume::resample(lattice, vol, dims, scale)
}

/// Level, channel and time point `s` of the OME-Zarr image at `path`, on
/// `lattice` (the level read whole: for the in-memory renderers); a store
/// of lattice samples (`convert --lattice`) is read as it is.
#[cfg(feature = "zarr")]
pub fn load_zarr(
    path: &Path,
    s: crate::volume::zarr::Selection,
    lattice: &Lattice,
    conversion: Conversion,
) -> Result<LatticeVolume, VolumeError> {
    use crate::volume::zarr::{OmeZarr, ZarrVolume};
    let image = OmeZarr::open(path)?;
    let level = ZarrVolume::new(&image, s, lattice)?;
    if level.is_lattice_store() {
        if conversion == Conversion::Resample && lattice.det() != 1 {
            let (path, lattice) = (path.to_path_buf(), lattice.name.clone());
            return Err(crate::volume::zarr::ZarrError::AlreadyResampled { path, lattice }.into());
        }
        return level.to_lattice_volume();
    }
    from_cartesian(&level.to_volume()?, lattice, conversion)
}
