//! Volumes streamed from disk: a Cartesian volume file (headerless raw or
//! NIfTI-1 `.nii`; a `.nii.gz` is decompressed once into a cache file)
//! memory-mapped and read lazily, box by box, as its lattice subset, through
//! [`BrickSource`].
//!
//! The values are those of the in-memory path,
//! `LatticeVolume::subset(lattice, &Volume::load_raw(..))` (or `load_nifti`):
//! the sample at lattice points, 0 elsewhere, converted to f32 as the loaders
//! do (NIfTI: `raw as f32 * scl_slope + scl_inter` when `scl_slope != 0`,
//! the `nifti` crate's rule).

use super::convert::Membership;
use super::error::{checked_count, io_err};
use super::gz_cache::{cache_name, decompress_into};
use super::nifti_header::{nifti_err, parse_nifti_header, NIFTI1_HEADER};
use super::source::check_box_len;
use super::stored::{decode, Sample};
use super::{parse_raw_spec, BrickSource, RawType, VolumeError};
use boxforge::spec::lattice::Lattice;
use memmap2::Mmap;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Samples decoded per step of the streaming pass of
/// [`BrickSource::sample_range`] (a 1 MiB f32 buffer).
const RANGE_CHUNK: usize = 1 << 18;

/// A Cartesian volume file memory-mapped and read lazily as the lattice
/// subset of its samples (the sample at lattice points, 0 elsewhere).
///
/// **Host memory bound.** Nothing of the file is read at open (a NIfTI
/// header only). [`read_box`](BrickSource::read_box) copies the rows of the
/// box out of the mapping one z-slice at a time and then tells the OS it no
/// longer needs those pages (`madvise(MADV_DONTNEED)` on the shared,
/// read-only mapping: the pages leave this process; the kernel's page cache
/// keeps or reclaims them as for any file read). So the process's resident
/// memory for a `MappedVolume` is at most the pages of one z-slice of the box
/// being read (rows `y0..=y1` of one slice, plus the pages the kernel maps
/// around a fault, within 2 MiB each side) while a read runs, none after it
/// (the dropped ranges are widened to 2 MiB windows to take the fault-around
/// pages too), plus the caller's output buffer, one decoded row
/// of the box and the lattice's membership table
/// ([`resident_bytes`](BrickSource::resident_bytes)) — whatever the file
/// size. [`sample_range`](BrickSource::sample_range) streams the file in
/// 256 Ki-sample chunks and drops each chunk's pages the same way. (On
/// non-Unix targets the pages are left to the OS. Threads reading nearby
/// boxes at once may drop each other's pages: they fault back in from the
/// page cache, a cost in time only.)
///
/// **A file modified while mapped.** Reading a mapped page past the end of a
/// file that shrank kills the process with SIGBUS; every z-slice of a box
/// (and every chunk of the range pass) is read only after checking the open
/// file's current length, answering [`VolumeError::Shrunk`]
/// instead. (The check and the copy are not atomic: a file truncated in the
/// microseconds between them can still fault; do not modify a volume while
/// it is rendered.)
///
/// NaN or infinite samples: `read_box` refuses one met at a lattice point
/// ([`VolumeError::NonFiniteAt`]); `sample_range` checks every sample as the
/// loaders do ([`VolumeError::NonFinite`]).
pub struct MappedVolume {
    /// The mapped file (the cache file for a `.nii.gz`).
    path: PathBuf,
    /// The file the caller opened (the `.nii.gz` itself for a cached one).
    source: PathBuf,
    file: File,
    map: Mmap,
    /// The file length when mapped.
    len: u64,
    /// Byte offset of the first sample.
    offset: usize,
    dims: [usize; 3],
    ty: Sample,
    big_endian: bool,
    /// NIfTI (scl_slope, scl_inter) when the slope is non-zero.
    scale: Option<(f32, f32)>,
    /// Voxel size (x, y, z) and space unit from a NIfTI header (1 and none for raw files).
    voxel: [f64; 3],
    unit: Option<&'static str>,
    lattice: Lattice,
    member: Membership,
    range: OnceLock<(f32, f32)>,
    from_cache: bool,
}

impl std::fmt::Debug for MappedVolume {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MappedVolume")
            .field("path", &self.path)
            .field("source", &self.source)
            .field("dims", &self.dims)
            .field("type", &self.ty.name())
            .field("big_endian", &self.big_endian)
            .field("scale", &self.scale)
            .field("lattice", &self.lattice.name)
            .field("from_cache", &self.from_cache)
            .finish()
    }
}

/// Maps a whole file read-only.
fn map_file(path: &Path) -> Result<(File, Mmap, u64), VolumeError> {
    let file = File::open(path).map_err(io_err(path))?;
    let len = file.metadata().map_err(io_err(path))?.len();
    // SAFETY: the mapping is read-only and shared; the file may be changed by
    // another process while mapped, which is why every access first checks
    // the file's length (`check_len`) and copies the bytes out at once.
    let map = unsafe { Mmap::map(&file) }.map_err(io_err(path))?;
    if map.len() as u64 != len {
        return Err(VolumeError::Shrunk { path: path.to_path_buf(), old: len, new: map.len() as u64 });
    }
    Ok((file, map, len))
}

impl MappedVolume {
    /// Maps a headerless raw file of `dims` samples of `ty` (x fastest; u16
    /// and f32 little endian). Refuses a file whose length is not exactly
    /// `dims * size` bytes, as [`Volume::load_raw`](super::Volume::load_raw) does.
    pub fn open_raw(
        path: &Path,
        dims: [usize; 3],
        ty: RawType,
        lattice: &Lattice,
    ) -> Result<MappedVolume, VolumeError> {
        let count = checked_count(dims)?;
        let member = Membership::new(lattice)?;
        let expected = (count as u64).saturating_mul(ty.size() as u64);
        let actual = std::fs::metadata(path).map_err(io_err(path))?.len();
        if actual != expected {
            return Err(VolumeError::RawSize { path: path.to_path_buf(), dims, ty: ty.name(), expected, actual });
        }
        let (file, map, len) = map_file(path)?;
        if len != expected {
            // The file changed between the size check and the mapping.
            return Err(VolumeError::RawSize { path: path.to_path_buf(), dims, ty: ty.name(), expected, actual: len });
        }
        Ok(MappedVolume {
            path: path.to_path_buf(),
            source: path.to_path_buf(),
            file,
            map,
            len,
            offset: 0,
            dims,
            ty: Sample::from_raw(ty),
            big_endian: false,
            scale: None,
            voxel: [1.0; 3],
            unit: None,
            lattice: lattice.clone(),
            member,
            range: OnceLock::new(),
            from_cache: false,
        })
    }

    /// Maps an uncompressed single-file NIfTI-1 volume (`.nii`): either byte
    /// order, the real scalar datatypes (uint8, int16, uint16, float32, and
    /// int8, (u)int32, (u)int64, float64), `scl_slope`/`scl_inter` applied
    /// as the NIfTI loader does. 3-D only (trailing dims of 1 are dropped).
    pub fn open_nifti(path: &Path, lattice: &Lattice) -> Result<MappedVolume, VolumeError> {
        Self::open_nifti_named(path, path, lattice)
    }

    /// [`open_nifti`](Self::open_nifti) of `path`, with header errors naming `name`.
    fn open_nifti_named(path: &Path, name: &Path, lattice: &Lattice) -> Result<MappedVolume, VolumeError> {
        let member = Membership::new(lattice)?;
        let (file, map, len) = map_file(path)?;
        let head = &map[..map.len().min(NIFTI1_HEADER)];
        let h = parse_nifti_header(head, name)?;
        drop_pages(&map, 0, head.len());
        let count = checked_count(h.dims)?;
        let need = (count as u64).saturating_mul(h.ty.size() as u64).saturating_add(h.offset as u64);
        if need > len {
            return Err(nifti_err(
                name,
                format!(
                    "its header declares {}x{}x{} {} samples from byte {}, {need} bytes in all, but the file has {len} (it is truncated)",
                    h.dims[0],
                    h.dims[1],
                    h.dims[2],
                    h.ty.name(),
                    h.offset
                ),
            ));
        }
        Ok(MappedVolume {
            path: path.to_path_buf(),
            source: name.to_path_buf(),
            file,
            map,
            len,
            offset: h.offset,
            dims: h.dims,
            ty: h.ty,
            big_endian: h.big_endian,
            scale: h.scale,
            voxel: h.voxel,
            unit: h.unit,
            lattice: lattice.clone(),
            member,
            range: OnceLock::new(),
            from_cache: false,
        })
    }

    /// Maps a `.nii.gz`: decompressed once (streaming, `progress(compressed
    /// bytes read, compressed size)`) into a file of `cache_dir` named from
    /// a hash of the file's canonical path, size and modification time,
    /// written to a temp file and renamed into place; a later open of the
    /// same, unchanged file maps that cache file without decompressing
    /// ([`from_cache`](Self::from_cache)). A cache file that no longer maps
    /// as a NIfTI volume is written again.
    pub fn open_nifti_gz(
        path: &Path,
        lattice: &Lattice,
        cache_dir: &Path,
        progress: &dyn Fn(u64, u64),
    ) -> Result<MappedVolume, VolumeError> {
        Membership::new(lattice)?;
        let canonical = std::fs::canonicalize(path).map_err(io_err(path))?;
        let meta = std::fs::metadata(&canonical).map_err(io_err(path))?;
        let cached = cache_dir.join(cache_name(&canonical, &meta));
        if cached.is_file() {
            match Self::open_nifti_named(&cached, path, lattice) {
                Ok(mut v) => {
                    v.from_cache = true;
                    return Ok(v);
                }
                // A damaged cache file: decompress again below.
                Err(VolumeError::Nifti { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        decompress_into(path, &cached, meta.len(), progress)?;
        Self::open_nifti_named(&cached, path, lattice)
    }

    /// Opens a volume file for streaming: a raw file when `raw` is given
    /// (its `NX,NY,NZ,TYPE` spec), else a NIfTI-1 file, `.nii.gz` (or any
    /// gzip file) through the cache in `cache_dir`, `.nii` mapped directly.
    pub fn open(
        path: &Path,
        raw: Option<&str>,
        lattice: &Lattice,
        cache_dir: &Path,
        progress: &dyn Fn(u64, u64),
    ) -> Result<MappedVolume, VolumeError> {
        if let Some(spec) = raw {
            let (dims, ty) = parse_raw_spec(spec)?;
            return Self::open_raw(path, dims, ty, lattice);
        }
        let name = path.to_string_lossy().to_ascii_lowercase();
        let gz = if name.ends_with(".gz") {
            true
        } else if name.ends_with(".nii") {
            false
        } else {
            // No telling extension: the gzip magic decides.
            let mut magic = [0u8; 2];
            let mut f = File::open(path).map_err(io_err(path))?;
            f.read_exact(&mut magic).is_ok() && magic == [0x1f, 0x8b]
        };
        if gz {
            Self::open_nifti_gz(path, lattice, cache_dir, progress)
        } else {
            Self::open_nifti(path, lattice)
        }
    }

    /// Voxel size along x, y, z: a NIfTI header's `pixdim` (1 for raw files
    /// and where the header has none).
    pub fn voxel_size(&self) -> [f64; 3] {
        self.voxel
    }

    /// The space unit a NIfTI header's `xyzt_units` gives (`millimeter`,
    /// `micrometer`, `meter`), if any.
    pub fn space_unit(&self) -> Option<&'static str> {
        self.unit
    }

    /// The stored sample type's name ("uint8", "int16", "float32", ...).
    pub fn stored_type(&self) -> &'static str {
        self.ty.name()
    }

    /// Whether NIfTI scaling (`scl_slope`, `scl_inter`) changes the stored
    /// values (then the samples are not the stored integers); the identity
    /// (1, 0) does not.
    pub fn scaled(&self) -> bool {
        self.scale.is_some_and(|(slope, inter)| slope != 1.0 || inter != 0.0)
    }

    /// Whether this volume maps a cache file written by an earlier open (a
    /// `.nii.gz` not decompressed this time).
    pub fn from_cache(&self) -> bool {
        self.from_cache
    }

    /// The mapped file: the volume file itself, or the cache file of a `.nii.gz`.
    pub fn mapped_path(&self) -> &Path {
        &self.path
    }

    /// The file the volume was opened from.
    pub fn source_path(&self) -> &Path {
        &self.source
    }

    /// Errors when the file is now shorter than when it was mapped.
    fn check_len(&self) -> Result<(), VolumeError> {
        let now = self.file.metadata().map_err(io_err(&self.path))?.len();
        if now < self.len {
            return Err(VolumeError::Shrunk { path: self.path.clone(), old: self.len, new: now });
        }
        Ok(())
    }

    /// Byte offset of voxel (x, y, z) (in the box).
    fn at(&self, x: usize, y: usize, z: usize) -> usize {
        self.offset + (x + self.dims[0] * (y + self.dims[1] * z)) * self.ty.size()
    }
}

/// The alignment (of addresses) the dropped ranges are widened to: a fault
/// maps the neighbouring cached pages too ("fault-around", 64 KiB by
/// default, never across a page-table (PMD) boundary of 2 MiB), so dropping
/// only the bytes copied would leave those neighbours resident.
const DROP_ALIGN: usize = 2 << 20;

/// Tells the OS this process no longer needs the mapped pages of
/// `map[offset..offset + len]`, widened to whole `DROP_ALIGN` windows of
/// the address space (so the fault-around pages go too). The shared file
/// mapping keeps its data: a later access faults the pages back in from the
/// page cache or the file.
#[cfg(unix)]
fn drop_pages(map: &Mmap, offset: usize, len: usize) {
    let len = len.min(map.len().saturating_sub(offset));
    if len == 0 {
        return;
    }
    let base = map.as_ptr() as usize;
    let start = ((base + offset) & !(DROP_ALIGN - 1)).max(base) - base;
    let end = (base + offset + len).next_multiple_of(DROP_ALIGN).min(base + map.len()) - base;
    let (offset, len) = (start, end - start);
    // SAFETY: MADV_DONTNEED on a shared read-only file mapping only unmaps
    // the pages from this process; their contents stay those of the file
    // (for a private or anonymous mapping they would read back as zeros,
    // which is why memmap2 marks the advice unchecked). No reference into
    // these bytes outlives the copies made before this call. A failure only
    // leaves the pages resident.
    let _ = unsafe { map.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, offset, len) };
}

#[cfg(not(unix))]
fn drop_pages(_map: &Mmap, _offset: usize, _len: usize) {}

impl BrickSource for MappedVolume {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The mapped file (canonical path, length, modification time) and
    /// how its bytes are read (offset, dims, type, byte order, NIfTI
    /// scaling, lattice).
    fn identity(&self) -> Option<String> {
        let path = std::fs::canonicalize(&self.path).ok()?;
        let modified = self.file.metadata().ok()?.modified().ok()?;
        let nanos = modified.duration_since(std::time::UNIX_EPOCH).ok()?.as_nanos();
        Some(format!(
            "{}|{}|{nanos}|{}|{:?}|{:?}|{}|{:?}|{}",
            path.display(),
            self.len,
            self.offset,
            self.dims,
            self.ty,
            self.big_endian,
            self.scale,
            self.lattice.name
        ))
    }

    fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    fn read_box(&self, lo: [i64; 3], size: [usize; 3], out: &mut [f32]) -> Result<(), VolumeError> {
        check_box_len(size, out.len())?;
        if out.is_empty() {
            return Ok(());
        }
        let [nx, ny, nz] = self.dims;
        let clamp = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        let end = |a: usize| lo[a].saturating_add(size[a] as i64 - 1);
        // The file columns the rows of the box read (contiguous, clamped).
        let (x0, x1) = (clamp(lo[0], nx), clamp(end(0), nx));
        let (y0, y1) = (clamp(lo[1], ny), clamp(end(1), ny));
        let mut row = vec![0f32; x1 - x0 + 1];
        let row_bytes = row.len() * self.ty.size();
        let mut i = 0;
        for dz in 0..size[2] {
            let z = clamp(lo[2].saturating_add(dz as i64), nz);
            self.check_len()?;
            for dy in 0..size[1] {
                let y = clamp(lo[1].saturating_add(dy as i64), ny);
                let start = self.at(x0, y, z);
                decode(self.ty, self.big_endian, self.scale, &self.map[start..start + row_bytes], &mut row);
                for dx in 0..size[0] {
                    let x = clamp(lo[0].saturating_add(dx as i64), nx);
                    out[i] = if self.member.contains([x, y, z]) {
                        let v = row[x - x0];
                        if !v.is_finite() {
                            return Err(VolumeError::NonFiniteAt { path: self.source.clone(), voxel: [x, y, z] });
                        }
                        v
                    } else {
                        0.0
                    };
                    i += 1;
                }
            }
            // The slice's rows are copied: drop their pages.
            let (first, last) = (self.at(x0, y0, z), self.at(x1, y1, z) + self.ty.size());
            drop_pages(&self.map, first, last - first);
        }
        Ok(())
    }

    fn sample_range(&self) -> Result<(f32, f32), VolumeError> {
        if let Some(&r) = self.range.get() {
            return Ok(r);
        }
        let [nx, ny, nz] = self.dims;
        let total = nx * ny * nz;
        let size = self.ty.size();
        let mut buf = vec![0f32; RANGE_CHUNK.min(total)];
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        let (mut bad, mut first_bad) = (0usize, None);
        let mut start = 0;
        while start < total {
            let n = RANGE_CHUNK.min(total - start);
            self.check_len()?;
            let bytes = self.offset + start * size..self.offset + (start + n) * size;
            decode(self.ty, self.big_endian, self.scale, &self.map[bytes.clone()], &mut buf[..n]);
            drop_pages(&self.map, bytes.start, bytes.len());
            let (mut x, mut y, mut z) = (start % nx, (start / nx) % ny, start / (nx * ny));
            for (k, &v) in buf[..n].iter().enumerate() {
                if !v.is_finite() {
                    bad += 1;
                    first_bad.get_or_insert(start + k);
                } else if self.member.contains([x, y, z]) {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                x += 1;
                if x == nx {
                    x = 0;
                    y += 1;
                    if y == ny {
                        y = 0;
                        z += 1;
                    }
                }
            }
            start += n;
        }
        if let Some(i) = first_bad {
            return Err(VolumeError::NonFinite {
                path: self.source.clone(),
                count: bad,
                total,
                first: [i % nx, (i / nx) % ny, i / (nx * ny)],
            });
        }
        let r = if lo > hi { (0.0, 0.0) } else { (lo, hi) };
        Ok(*self.range.get_or_init(|| r))
    }

    fn resident_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.member.table_bytes()
            + self.path.as_os_str().len()
            + self.source.as_os_str().len()
    }
}

#[cfg(test)]
mod tests;
