//! The limits the library checks before it reaches wgpu or the allocator:
//! `ml:N` volumes, host sample counts and volumes against an adapter. Each
//! refusal is a [`LimitError`] that names the value, the limit and the fix
//! in terms of the volume (a front end adds its own option names).

/// Largest `N` of `ml:N` (about N^3 samples).
pub const MAX_ML_N: u32 = 1024;
/// Largest volume built on the host, in samples (1 GiB of f32).
pub const MAX_SAMPLES: u64 = 1 << 28;

/// A volume request over one of the limits.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LimitError {
    /// `ml:N` whose N is not a whole number.
    #[error("ml:{text}: ml:N needs a whole number N (about N^3 samples), e.g. ml:41")]
    MlNotWhole { text: String },
    /// `ml:N` whose N is outside 2..=[`MAX_ML_N`].
    #[error("ml:{text}: ml:N needs N between 2 and {MAX_ML_N} (about N^3 samples), e.g. ml:41")]
    MlRange { text: String },
    /// A host volume over [`MAX_SAMPLES`] (or past u64).
    #[error(
        "{what}: {}x{}x{} samples is over the cap of {MAX_SAMPLES} samples (1 GiB of f32); use a smaller ml:N or resample a smaller volume",
        dims[0], dims[1], dims[2]
    )]
    Samples { what: String, dims: [usize; 3] },
    /// An embedded volume with an edge over the adapter's 3D texture limit.
    #[error(
        "the volume is {}x{}x{} samples, over this adapter's 3D texture limit of {max} per edge; use the bricked layout (bricks of any volume in a pool that fits), the packed layout, resample or a smaller ml:N",
        dims[0], dims[1], dims[2]
    )]
    TextureEdge { dims: [usize; 3], max: usize },
    /// A packed volume whose texture (a tile per coset) has an edge over the
    /// adapter's 3D texture limit.
    #[error(
        "the packed volume of {}x{}x{} samples is a {}x{}x{} texture (one tile per coset), over this adapter's 3D texture limit of {max} per edge; resample or use a smaller ml:N",
        dims[0], dims[1], dims[2], texture[0], texture[1], texture[2]
    )]
    PackedTextureEdge { dims: [usize; 3], texture: [usize; 3], max: usize },
}

/// `N` of `ml:N`, parsed and bounded.
pub fn parse_ml_n(text: &str) -> Result<u32, LimitError> {
    let n: i64 = text.trim().parse().map_err(|_| LimitError::MlNotWhole { text: text.to_string() })?;
    if n < 2 || n > MAX_ML_N as i64 {
        return Err(LimitError::MlRange { text: text.to_string() });
    }
    Ok(n as u32)
}

/// Samples of a volume with these dimensions, refused past [`MAX_SAMPLES`]
/// (checked arithmetic, so no dimension overflows the count).
pub fn check_samples(dims: [usize; 3], what: &str) -> Result<u64, LimitError> {
    let n = dims.iter().try_fold(1u64, |acc, &d| acc.checked_mul(d as u64));
    match n {
        Some(n) if n <= MAX_SAMPLES => Ok(n),
        _ => Err(LimitError::Samples { what: what.to_string(), dims }),
    }
}

/// A volume of `dims` samples against the adapter: the edges of its texture
/// in `layout` (`texture`: the dims when embedded,
/// `LatticeVolume::packed_texture_size` when packed).
pub fn check_volume_limits(
    dims: [usize; 3],
    texture: [usize; 3],
    layout: boxforge::emit::Layout,
    limits: &wgpu::Limits,
) -> Result<(), LimitError> {
    let max = limits.max_texture_dimension_3d as usize;
    if texture.iter().all(|&d| d <= max) {
        return Ok(());
    }
    Err(match layout {
        // A bricked pool is refolded to fit; its caller checks the pool's own size.
        boxforge::emit::Layout::Embedded | boxforge::emit::Layout::Bricked | boxforge::emit::Layout::BrickedPacked => {
            LimitError::TextureEdge { dims, max }
        }
        boxforge::emit::Layout::Packed => LimitError::PackedTextureEdge { dims, texture, max },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use boxforge::emit::Layout::{Embedded, Packed};

    #[test]
    fn ml_n_and_samples_are_bounded() {
        assert_eq!(parse_ml_n("41"), Ok(41));
        for bad in ["-3", "0", "1", "100000", "x", "4.5", ""] {
            assert!(parse_ml_n(bad).is_err(), "{bad}");
        }
        assert!(check_samples([usize::MAX, 2, 2], "v").is_err(), "no overflow");
        assert!(check_samples([64, 64, 64], "v").is_ok());
    }

    #[test]
    fn volume_limits_are_checked_before_any_upload() {
        let limits = wgpu::Limits::downlevel_defaults();
        let edge = limits.max_texture_dimension_3d as usize + 1;
        assert!(check_volume_limits([edge, 4, 4], [edge, 4, 4], Embedded, &limits).is_err());
        assert!(check_volume_limits([64, 64, 64], [64, 64, 64], Embedded, &limits).is_ok());
        // Packed: the texture's edges count, not the volume's.
        assert!(check_volume_limits([edge, 4, 4], [edge / 2, 2, 2], Packed, &limits).is_ok());
        let e = check_volume_limits([edge, 4, 4], [edge + 1, 2, 2], Packed, &limits).unwrap_err();
        assert!(matches!(e, LimitError::PackedTextureEdge { .. }), "{e}");
    }

    #[test]
    fn texts_name_no_option() {
        let limits = wgpu::Limits::downlevel_defaults();
        let errors = [
            parse_ml_n("x").unwrap_err(),
            parse_ml_n("1").unwrap_err(),
            check_samples([usize::MAX, 2, 2], "v").unwrap_err(),
            check_volume_limits([1 << 20, 4, 4], [1 << 20, 4, 4], Embedded, &limits).unwrap_err(),
            check_volume_limits([1 << 20, 4, 4], [1 << 20, 2, 2], Packed, &limits).unwrap_err(),
        ];
        for e in errors {
            let text = e.to_string();
            assert!(!text.contains("--") && !text.contains('\n'), "{text}");
        }
    }
}
