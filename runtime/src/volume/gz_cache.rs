//! The cache a `.nii.gz` is decompressed into once, so that it can be
//! memory-mapped ([`MappedVolume::open_nifti_gz`](super::MappedVolume::open_nifti_gz)):
//! where the cache lives, the name of a file's entry (a stable hash of what
//! identifies that file's contents) and the decompression into it.

use super::error::io_err;
use super::VolumeError;
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Decompressed bytes per write while a `.nii.gz` is unpacked into the cache.
pub(super) const GZ_CHUNK: usize = 1 << 18;

/// The directory `.nii.gz` volumes are decompressed into:
/// `$XDG_CACHE_HOME/boxforge`, else `$HOME/.cache/boxforge`, else
/// `boxforge` in the temp dir (empty or relative variables count as unset).
pub fn default_cache_dir() -> PathBuf {
    let var = |name: &str| std::env::var_os(name).map(PathBuf::from).filter(|p| p.is_absolute());
    if let Some(x) = var("XDG_CACHE_HOME") {
        return x.join("boxforge");
    }
    if let Some(h) = var("HOME") {
        return h.join(".cache").join("boxforge");
    }
    std::env::temp_dir().join("boxforge")
}

/// Counts the bytes read through it (the compressed bytes consumed).
pub(super) struct Counting<R> {
    inner: R,
    n: u64,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let k = self.inner.read(buf)?;
        self.n += k as u64;
        Ok(k)
    }
}

/// 64-bit FNV-1a: a hash that is the same in every build (the cache names
/// outlive the binary that wrote them).
pub(super) fn fnv1a(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The cache file name of a `.nii.gz`: a hash of its canonical path, size
/// and modification time (a changed file gets a new name).
pub(super) fn cache_name(canonical: &Path, meta: &std::fs::Metadata) -> String {
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| (d.as_secs(), d.subsec_nanos()))
        .unwrap_or((0, 0));
    let mut h = 0xcbf2_9ce4_8422_2325;
    h = fnv1a(b"boxforge nii.gz cache v1\0", h);
    h = fnv1a(canonical.to_string_lossy().as_bytes(), h);
    h = fnv1a(&[0], h);
    h = fnv1a(&meta.len().to_le_bytes(), h);
    h = fnv1a(&mtime.0.to_le_bytes(), h);
    h = fnv1a(&mtime.1.to_le_bytes(), h);
    let stem = canonical.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let stem: String = stem.trim_end_matches(".gz").trim_end_matches(".nii").chars().take(40).collect();
    let stem: String =
        stem.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect();
    format!("{stem}-{h:016x}.nii")
}

/// Decompresses `gz` into `dest` through a temp file in the same directory
/// renamed into place (so a reader never sees a partial cache file).
pub(super) fn decompress_into(
    gz: &Path,
    dest: &Path,
    total: u64,
    progress: &dyn Fn(u64, u64),
) -> Result<(), VolumeError> {
    let dir = dest.parent().unwrap_or(Path::new("."));
    let cache = |source| VolumeError::Cache { path: dest.to_path_buf(), source };
    std::fs::create_dir_all(dir).map_err(|source| VolumeError::Cache { path: dir.to_path_buf(), source })?;
    static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let seq = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(
        ".{}.{}.{seq}.tmp",
        dest.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        std::process::id()
    ));
    let result = (|| {
        let input = File::open(gz).map_err(io_err(gz))?;
        let mut dec = flate2::read::MultiGzDecoder::new(Counting { inner: input, n: 0 });
        let mut out = File::create(&tmp).map_err(cache)?;
        let mut buf = vec![0u8; GZ_CHUNK];
        progress(0, total);
        loop {
            let k = match dec.read(&mut buf) {
                Ok(0) => break,
                Ok(k) => k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(source) => return Err(VolumeError::Gzip { path: gz.to_path_buf(), source }),
            };
            out.write_all(&buf[..k]).map_err(cache)?;
            progress(dec.get_ref().n.min(total), total);
        }
        out.sync_all().map_err(cache)?;
        drop(out);
        std::fs::rename(&tmp, dest).map_err(cache)?;
        progress(total, total);
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
