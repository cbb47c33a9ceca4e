//! NIfTI reading in a build without the `nifti` feature: a clear error.

use super::{Volume, VolumeError};
use std::path::Path;

impl Volume {
    /// Always an error: this build reads no NIfTI files.
    pub fn load_nifti(path: &Path) -> Result<Volume, VolumeError> {
        Err(VolumeError::Nifti {
            path: path.to_path_buf(),
            message: "this build of boxforge-runtime reads no NIfTI files: enable its `nifti` feature".into(),
        })
    }
}
