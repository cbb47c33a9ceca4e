//! The streamed volumes read as the in-memory loaders do, and within their host-memory bound.

use super::*;
use crate::memory::current_resident_bytes;
use crate::volume::gz_cache::default_cache_dir;
use crate::volume::stored::Sample;
use crate::volume::testutil::{lattice, Temp};
use crate::volume::{LatticeVolume, Volume};
use std::cell::RefCell;
use std::io::Write;
use std::sync::Mutex;

/// Serializes the tests that hold tens of MiB (the resident-memory test
/// measures the whole process).
static BIG: Mutex<()> = Mutex::new(());

fn big_lock() -> std::sync::MutexGuard<'static, ()> {
    BIG.lock().unwrap_or_else(|e| e.into_inner())
}

/// A unique temp directory, removed with its files on drop.
struct TempDir(PathBuf);
impl TempDir {
    fn new(name: &str) -> TempDir {
        let p = std::env::temp_dir().join(format!("boxforge-stream-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
    fn files(&self) -> Vec<PathBuf> {
        std::fs::read_dir(&self.0).unwrap().map(|e| e.unwrap().path()).collect()
    }
}
impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Boxes crossing every face of a volume of `d` (negative lo, past the
/// end, wholly outside, the whole volume with a margin) and inside it.
fn boxes(d: [usize; 3]) -> Vec<([i64; 3], [usize; 3])> {
    let n = d.map(|v| v as i64);
    vec![
        ([-2, -2, -2], [d[0] + 4, d[1] + 4, d[2] + 4]),
        ([-3, 1, 1], [4, 2, 2]),
        ([1, -3, 1], [2, 4, 2]),
        ([1, 1, -3], [2, 2, 4]),
        ([n[0] - 2, 0, 1], [5, 2, 2]),
        ([0, n[1] - 1, 1], [2, 3, 3]),
        ([1, 0, n[2] - 2], [3, 2, 4]),
        ([-6, -6, -6], [2, 3, 2]),
        ([n[0] + 2, n[1] + 3, n[2] + 4], [2, 2, 3]),
        ([-1, n[1] - 2, -2], [d[0] + 2, 4, 3]),
        ([1, 1, 1], [1, 1, 1]),
        ([0, 0, 0], [d[0], d[1], d[2]]),
    ]
}

/// Every box read from `mapped` equals the in-memory volume's read, and so does the range.
fn assert_same(mapped: &MappedVolume, mem: &LatticeVolume, what: &str) {
    assert_eq!(BrickSource::dims(mapped), mem.dims, "{what}");
    assert_eq!(mapped.lattice().name, mem.lattice.name, "{what}");
    for (lo, size) in boxes(mem.dims) {
        let n = size.iter().product();
        let (mut a, mut b) = (vec![f32::NAN; n], vec![f32::NAN; n]);
        mapped.read_box(lo, size, &mut a).unwrap();
        mem.read_box(lo, size, &mut b).unwrap();
        assert_eq!(a, b, "{what}: box {lo:?} + {size:?}");
    }
    let r = BrickSource::sample_range(mapped).unwrap();
    assert_eq!(r, mem.sample_range(), "{what}");
    assert_eq!(BrickSource::sample_range(mapped).unwrap(), r, "{what}: the remembered range");
    assert!(mapped.resident_bytes() < 4096, "{what}: {} bytes", mapped.resident_bytes());
}

const DIMS: [usize; 3] = [7, 6, 5];

#[test]
fn stream_raw_files_read_as_the_in_memory_subset() {
    let n: usize = DIMS.iter().product();
    let u8s: Vec<u8> = (0..n).map(|i| (i * 37 % 251) as u8).collect();
    let u16s: Vec<u8> = (0..n).flat_map(|i| ((i * 997 + 3) as u16).to_le_bytes()).collect();
    let f32s: Vec<u8> = (0..n).flat_map(|i| ((i as f32 - 90.0) * 0.731).to_le_bytes()).collect();
    for (ty, bytes) in [(RawType::U8, &u8s), (RawType::U16, &u16s), (RawType::F32, &f32s)] {
        let f = Temp::new(&format!("stream-raw.{}", ty.name()), bytes);
        let vol = Volume::load_raw(&f.0, DIMS, ty).unwrap();
        for name in ["cc", "bcc", "fcc"] {
            let l = lattice(name);
            let mem = LatticeVolume::subset(&l, &vol).unwrap();
            let mapped = MappedVolume::open_raw(&f.0, DIMS, ty, &l).unwrap();
            assert_same(&mapped, &mem, &format!("raw {} {name}", ty.name()));
            let spec = format!("7,6,5,{}", ty.name());
            let by_spec = MappedVolume::open(&f.0, Some(&spec), &l, Path::new("/nonexistent"), &|_, _| {}).unwrap();
            assert_same(&by_spec, &mem, &format!("raw {} {name} through open", ty.name()));
        }
    }
}

/// A single-file NIfTI-1 volume: `shape` (dim[1..]), `datatype`, the
/// encoded samples, scl_slope/scl_inter, vox_offset and byte order.
fn nifti(shape: &[i16], datatype: i16, data: &[u8], scl: (f32, f32), vox: usize, big: bool) -> Vec<u8> {
    let i16b = |v: i16| if big { v.to_be_bytes() } else { v.to_le_bytes() };
    let f32b = |v: f32| if big { v.to_be_bytes() } else { v.to_le_bytes() };
    let mut h = vec![0u8; vox.max(352)];
    h[0..4].copy_from_slice(&if big { 348i32.to_be_bytes() } else { 348i32.to_le_bytes() });
    let mut d = [1i16; 8];
    d[0] = shape.len() as i16;
    d[1..=shape.len()].copy_from_slice(shape);
    for (i, &x) in d.iter().enumerate() {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&i16b(x));
    }
    h[70..72].copy_from_slice(&i16b(datatype));
    let bits = Sample::from_nifti(datatype).map(|t| 8 * t.size() as i16).unwrap_or(64);
    h[72..74].copy_from_slice(&i16b(bits));
    if vox > 352 {
        // One extension filling the gap to vox_offset (the nifti crate
        // reads the data right after the header when the extender says
        // there are none, whatever vox_offset says).
        h[348] = 1;
        let esize = vox as i32 - 352;
        h[352..356].copy_from_slice(&if big { esize.to_be_bytes() } else { esize.to_le_bytes() });
    }
    h[108..112].copy_from_slice(&f32b(vox as f32));
    h[112..116].copy_from_slice(&f32b(scl.0));
    h[116..120].copy_from_slice(&f32b(scl.1));
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend_from_slice(data);
    h
}

/// The NIfTI test volumes: (label, file bytes, the f32 values the loader gives).
fn nifti_cases() -> Vec<(&'static str, Vec<u8>, Vec<f32>)> {
    let n: usize = DIMS.iter().product();
    let shape = [7i16, 6, 5];
    let mut cases = Vec::new();
    let v: Vec<u8> = (0..n).map(|i| (i * 13 % 256) as u8).collect();
    cases.push(("uint8", nifti(&shape, 2, &v, (0.0, 0.0), 352, false), v.iter().map(|&b| b as f32).collect()));
    let v: Vec<i16> = (0..n).map(|i| i as i16 * 91 - 9000).collect();
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    let want = v.iter().map(|&x| x as f32 * 0.5 - 3.0).collect();
    cases.push(("int16 scaled", nifti(&shape, 4, &bytes, (0.5, -3.0), 352, false), want));
    let v: Vec<u16> = (0..n).map(|i| (i * 307) as u16).collect();
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_be_bytes()).collect();
    let shape4 = [7i16, 6, 5, 1];
    let want = v.iter().map(|&x| x as f32).collect();
    cases.push(("uint16 big endian 4-D", nifti(&shape4, 512, &bytes, (1.0, 0.0), 352, true), want));
    let v: Vec<f32> = (0..n).map(|i| (i as f32).sin() * 40.0).collect();
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    let want = v.iter().map(|&x| x * 2.0 + 1.0).collect();
    cases.push(("float32 offset 416", nifti(&shape, 16, &bytes, (2.0, 1.0), 416, false), want));
    let v: Vec<f64> = (0..n).map(|i| i as f64 * 0.25 - 20.0).collect();
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_be_bytes()).collect();
    let want = v.iter().map(|&x| x as f32).collect();
    cases.push(("float64 big endian", nifti(&shape, 64, &bytes, (0.0, 7.0), 352, true), want));
    cases
}

#[test]
fn stream_nifti_files_read_as_the_in_memory_subset() {
    for (label, bytes, want) in nifti_cases() {
        let f = Temp::new(&format!("stream-{}.nii", label.replace(' ', "-")), &bytes);
        let vol = Volume::new(DIMS, want).unwrap();
        #[cfg(feature = "nifti")]
        assert_eq!(Volume::load_nifti(&f.0).unwrap(), vol, "{label}: the NIfTI loader's values");
        for name in ["bcc", "fcc"] {
            let l = lattice(name);
            let mem = LatticeVolume::subset(&l, &vol).unwrap();
            let mapped = MappedVolume::open_nifti(&f.0, &l).unwrap();
            assert!(!mapped.from_cache());
            assert_same(&mapped, &mem, &format!("{label} {name}"));
            let any = MappedVolume::open(&f.0, None, &l, Path::new("/nonexistent"), &|_, _| panic!()).unwrap();
            assert_same(&any, &mem, &format!("{label} {name} through open"));
        }
    }
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

#[test]
fn stream_nifti_gz_decompresses_once_into_the_cache() {
    let cache = TempDir::new("gz-cache");
    for (label, bytes, want) in nifti_cases() {
        let gz = gzip(&bytes);
        let f = Temp::new(&format!("stream-{}.nii.gz", label.replace(' ', "-")), &gz);
        let vol = Volume::new(DIMS, want).unwrap();
        for name in ["bcc", "fcc"] {
            let l = lattice(name);
            let mem = LatticeVolume::subset(&l, &vol).unwrap();
            let calls = RefCell::new(Vec::new());
            let progress = |done, total| calls.borrow_mut().push((done, total));
            let mapped = MappedVolume::open_nifti_gz(&f.0, &l, &cache.0, &progress).unwrap();
            let calls = calls.into_inner();
            let total = gz.len() as u64;
            if name == "bcc" {
                // The first open decompresses, reporting compressed bytes.
                assert!(!mapped.from_cache(), "{label}");
                assert_eq!(calls.first(), Some(&(0, total)), "{label}");
                assert_eq!(calls.last(), Some(&(total, total)), "{label}");
                assert!(calls.windows(2).all(|w| w[0].0 <= w[1].0 && w[0].1 == total), "{label}: {calls:?}");
            } else {
                assert!(mapped.from_cache(), "{label}: the second open maps the cache file");
                assert!(calls.is_empty(), "{label}: no decompression, no progress: {calls:?}");
            }
            assert_eq!(std::fs::read(mapped.mapped_path()).unwrap(), bytes, "{label}: the cache file is the .nii");
            assert!(mapped.mapped_path().starts_with(&cache.0) && mapped.source_path() == f.0);
            assert_same(&mapped, &mem, &format!("{label} {name} .nii.gz"));
            let again = MappedVolume::open(&f.0, None, &l, &cache.0, &|_, _| panic!("decompressed again")).unwrap();
            assert!(again.from_cache());
        }
    }
    let files = cache.files();
    assert_eq!(files.len(), nifti_cases().len(), "one cache file per volume, no temp files left: {files:?}");
    assert!(files.iter().all(|p| p.extension().is_some_and(|e| e == "nii")), "{files:?}");

    // A changed file (new size and mtime) is decompressed again; a
    // damaged cache file is written again.
    let (_, bytes, _) = nifti_cases().remove(0);
    let f = Temp::new("stream-changed.nii.gz", &gzip(&bytes));
    let l = lattice("bcc");
    let first = MappedVolume::open_nifti_gz(&f.0, &l, &cache.0, &|_, _| {}).unwrap();
    assert!(!first.from_cache());
    let cached = first.mapped_path().to_path_buf();
    drop(first);
    std::fs::write(&cached, b"not a volume").unwrap();
    let redone = MappedVolume::open_nifti_gz(&f.0, &l, &cache.0, &|_, _| {}).unwrap();
    assert!(!redone.from_cache(), "a damaged cache file is replaced");
    assert_eq!(std::fs::read(&cached).unwrap(), bytes);
    let mut longer = bytes.clone();
    longer.extend_from_slice(&[0; 16]);
    std::fs::write(&f.0, gzip(&longer)).unwrap();
    let changed = MappedVolume::open_nifti_gz(&f.0, &l, &cache.0, &|_, _| {}).unwrap();
    assert!(!changed.from_cache(), "a changed file gets a new cache file");
    assert_ne!(changed.mapped_path(), cached);

    // A truncated gzip stream names the file; nothing is left in the cache.
    let gz = gzip(&bytes);
    let cut = Temp::new("stream-cut.nii.gz", &gz[..gz.len() / 2]);
    let before = cache.files().len();
    let e = MappedVolume::open_nifti_gz(&cut.0, &l, &cache.0, &|_, _| {}).unwrap_err();
    assert!(matches!(e, VolumeError::Gzip { .. }), "{e}");
    assert!(e.to_string().contains("stream-cut.nii.gz") && e.to_string().contains("complete .nii.gz"), "{e}");
    assert_eq!(cache.files().len(), before, "{:?}", cache.files());
}

#[cfg(feature = "nifti")]
#[test]
fn stream_the_mni_head_reads_as_loaded() {
    let _big = big_lock();
    let cache = TempDir::new("mni-cache");
    let path = crate::volume::testutil::mni_path();
    let vol = Volume::load_nifti(&path).unwrap();
    for name in ["bcc", "fcc"] {
        let l = lattice(name);
        let mem = LatticeVolume::subset(&l, &vol).unwrap();
        let mapped = MappedVolume::open(&path, None, &l, &cache.0, &|_, _| {}).unwrap();
        assert_eq!(mapped.from_cache(), name == "fcc");
        for (lo, size) in [([-3, -3, -3], [20, 20, 20]), ([90, 100, 80], [32, 32, 32]), ([180, 220, 170], [24, 24, 24])]
        {
            let n = size.iter().product();
            let (mut a, mut b) = (vec![0f32; n], vec![0f32; n]);
            mapped.read_box(lo, size, &mut a).unwrap();
            mem.read_box(lo, size, &mut b).unwrap();
            assert_eq!(a, b, "MNI {name} {lo:?}");
        }
        assert_eq!(BrickSource::sample_range(&mapped).unwrap(), mem.sample_range());
    }
}

#[test]
fn stream_a_file_that_shrinks_is_an_error_not_a_crash() {
    let n: usize = DIMS.iter().product();
    let bytes: Vec<u8> = (0..n).flat_map(|i| (i as f32).to_le_bytes()).collect();
    let f = Temp::new("stream-shrink.f32", &bytes);
    let l = lattice("bcc");
    let v = MappedVolume::open_raw(&f.0, DIMS, RawType::F32, &l).unwrap();
    let mut out = vec![0f32; 8];
    v.read_box([0, 0, 0], [2, 2, 2], &mut out).unwrap();
    std::fs::OpenOptions::new().write(true).open(&f.0).unwrap().set_len(100).unwrap();
    let e = v.read_box([4, 4, 3], [2, 2, 2], &mut out).unwrap_err();
    assert!(matches!(e, VolumeError::Shrunk { old: 840, new: 100, .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("stream-shrink.f32") && msg.contains("shrank from 840 to 100 bytes"), "{msg}");
    assert!(msg.contains("do not modify a volume while it is rendered"), "{msg}");
    assert!(matches!(BrickSource::sample_range(&v), Err(VolumeError::Shrunk { .. })));

    let (_, nii, _) = nifti_cases().remove(3);
    let f = Temp::new("stream-shrink.nii", &nii);
    let v = MappedVolume::open_nifti(&f.0, &l).unwrap();
    std::fs::OpenOptions::new().write(true).open(&f.0).unwrap().set_len(0).unwrap();
    let e = BrickSource::sample_range(&v).unwrap_err();
    assert!(matches!(e, VolumeError::Shrunk { new: 0, .. }), "{e}");
    assert!(matches!(v.read_box([-1, -1, -1], [2, 2, 2], &mut out), Err(VolumeError::Shrunk { .. })));
}

#[test]
fn stream_bad_files_are_clear_errors() {
    let l = lattice("fcc");
    let f = Temp::new("stream-short.u16", &[0u8; 7 * 6 * 5]);
    let e = MappedVolume::open_raw(&f.0, DIMS, RawType::U16, &l).unwrap_err();
    assert!(matches!(e, VolumeError::RawSize { expected: 420, actual: 210, .. }), "{e}");
    assert!(e.to_string().contains("need 420 bytes"), "{e}");
    let e = MappedVolume::open(&f.0, Some("7,6,u16"), &l, Path::new("."), &|_, _| {}).unwrap_err();
    assert!(matches!(e, VolumeError::BadRawSpec { .. }), "{e}");
    let e = MappedVolume::open_raw(Path::new("/nonexistent/v.u8"), DIMS, RawType::U8, &l).unwrap_err();
    assert!(matches!(e, VolumeError::Io { .. }) && e.to_string().contains("/nonexistent/v.u8"), "{e}");
    let e = MappedVolume::open_raw(&f.0, [0, 6, 5], RawType::U8, &l).unwrap_err();
    assert!(matches!(e, VolumeError::BadDims { .. }), "{e}");

    let n: usize = DIMS.iter().product();
    let zeros = vec![0u8; 8 * n];
    let shape = [7i16, 6, 5];
    let complex = Temp::new("stream-complex.nii", &nifti(&shape, 32, &zeros, (0.0, 0.0), 352, false));
    let e = MappedVolume::open_nifti(&complex.0, &l).unwrap_err();
    assert!(matches!(e, VolumeError::UnsupportedNiftiType { .. }), "{e}");
    assert!(e.to_string().contains("complex64") && e.to_string().contains("convert the volume to float32"), "{e}");
    let odd = Temp::new("stream-odd.nii", &nifti(&shape, 999, &zeros, (0.0, 0.0), 352, false));
    let e = MappedVolume::open_nifti(&odd.0, &l).unwrap_err();
    assert!(e.to_string().contains("unknown datatype code 999"), "{e}");
    let short = Temp::new("stream-trunc.nii", &nifti(&shape, 16, &zeros[..4 * n - 1], (0.0, 0.0), 352, false));
    let e = MappedVolume::open_nifti(&short.0, &l).unwrap_err();
    assert!(matches!(e, VolumeError::Nifti { .. }) && e.to_string().contains("truncated"), "{e}");
    let four = Temp::new("stream-4d.nii", &nifti(&[7, 6, 1, 5], 2, &zeros[..n], (0.0, 0.0), 352, false));
    let e = MappedVolume::open_nifti(&four.0, &l).unwrap_err();
    assert!(matches!(e, VolumeError::NotThreeD { rank: 4, .. }), "{e}");
    let mut bad = nifti(&shape, 2, &zeros[..n], (0.0, 0.0), 352, false);
    bad[344..348].copy_from_slice(b"ni1\0");
    let pair = Temp::new("stream-pair.nii", &bad);
    let e = MappedVolume::open_nifti(&pair.0, &l).unwrap_err();
    assert!(e.to_string().contains(".hdr/.img pair"), "{e}");
    let mut bad = nifti(&shape, 2, &zeros[..n], (0.0, 0.0), 352, false);
    bad[72..74].copy_from_slice(&16i16.to_le_bytes());
    let bitpix = Temp::new("stream-bitpix.nii", &bad);
    let e = MappedVolume::open_nifti(&bitpix.0, &l).unwrap_err();
    assert!(e.to_string().contains("bitpix is 16 but uint8 samples have 8 bits"), "{e}");
    let junk = Temp::new("stream-junk.nii", &[7u8; 400]);
    let e = MappedVolume::open_nifti(&junk.0, &l).unwrap_err();
    assert!(matches!(e, VolumeError::Nifti { .. }) && e.to_string().contains("sizeof_hdr"), "{e}");
    let tiny = Temp::new("stream-tiny.nii", &[0u8; 10]);
    let e = MappedVolume::open_nifti(&tiny.0, &l).unwrap_err();
    assert!(e.to_string().contains("less than a 348-byte"), "{e}");

    // NaN samples: read_box names the voxel it met; the range pass counts them all.
    let mut vals: Vec<f32> = (0..n).map(|i| i as f32).collect();
    vals[0] = f32::NAN; // (0, 0, 0): on every lattice
    vals[1] = f32::INFINITY; // (1, 0, 0): not on fcc
    let bytes: Vec<u8> = vals.iter().flat_map(|x| x.to_le_bytes()).collect();
    let nan = Temp::new("stream-nan.f32", &bytes);
    let v = MappedVolume::open_raw(&nan.0, DIMS, RawType::F32, &l).unwrap();
    let mut out = vec![0f32; 8];
    let e = v.read_box([-1, -1, -1], [2, 2, 2], &mut out).unwrap_err();
    assert!(matches!(e, VolumeError::NonFiniteAt { voxel: [0, 0, 0], .. }), "{e}");
    v.read_box([1, 1, 1], [2, 2, 2], &mut out).unwrap();
    let e = BrickSource::sample_range(&v).unwrap_err();
    assert!(matches!(e, VolumeError::NonFinite { count: 2, total: 210, first: [0, 0, 0], .. }), "{e}");
    assert!(v.read_box([0, 0, 0], [2, 2, 2], &mut out[..7]).is_err(), "a buffer of the wrong length");
}

#[test]
fn stream_default_cache_dir_is_under_a_cache_home() {
    let d = default_cache_dir();
    assert!(d.ends_with("boxforge") && d.is_absolute(), "{d:?}");
}

/// The resident bytes of the mapping holding `ptr`, from /proc/self/smaps.
fn mapping_rss(ptr: *const u8) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/smaps").ok()?;
    let addr = ptr as u64;
    let mut inside = false;
    for line in text.lines() {
        let first = line.split_whitespace().next().unwrap_or("");
        if let Some((a, b)) = first.split_once('-') {
            if let (Ok(a), Ok(b)) = (u64::from_str_radix(a, 16), u64::from_str_radix(b, 16)) {
                inside = a <= addr && addr < b;
                continue;
            }
        }
        if inside {
            if let Some(rest) = line.strip_prefix("Rss:") {
                return rest.split_whitespace().next()?.parse::<u64>().ok().map(|k| k * 1024);
            }
        }
    }
    None
}

#[test]
fn stream_reading_a_64_mib_file_keeps_about_one_box_resident() {
    let _big = big_lock();
    if current_resident_bytes().is_none() {
        eprintln!("no /proc/self/status here: skipped");
        return;
    }
    const MIB: u64 = 1 << 20;
    let dims = [512usize, 512, 256];
    let byte = |i: usize| (i % 251) as u8 ^ (i >> 17) as u8;
    let dir = TempDir::new("rss");
    let path = dir.0.join("big.u8");
    {
        // Written 1 MiB at a time (a 64 MiB buffer would be resident itself).
        let mut w = File::create(&path).unwrap();
        let mut chunk = vec![0u8; MIB as usize];
        for c in 0..64 {
            for (k, b) in chunk.iter_mut().enumerate() {
                *b = byte(c * MIB as usize + k);
            }
            w.write_all(&chunk).unwrap();
        }
    }
    let l = lattice("bcc");
    let v = MappedVolume::open_raw(&path, dims, RawType::U8, &l).unwrap();
    let b = [64usize, 64, 64];
    let mut out = vec![0f32; b.iter().product()];
    out.fill(1.0); // resident before the baseline
                   // One pass over all boxes: the largest VmRSS growth above the start
                   // and the largest resident size of the mapping itself (every 8th box).
    let read_all = |out: &mut [f32]| -> (u64, Option<u64>) {
        let start = current_resident_bytes().unwrap();
        let (mut growth, mut mapped, mut boxes) = (0, None::<u64>, 0);
        for z in (0..dims[2]).step_by(b[2]) {
            for y in (0..dims[1]).step_by(b[1]) {
                for x in (0..dims[0]).step_by(b[0]) {
                    v.read_box([x as i64, y as i64, z as i64], b, out).unwrap();
                    // Spot checks against the file's formula.
                    for &(dx, dy, dz) in &[(0usize, 0usize, 0usize), (1, 1, 1), (63, 2, 5), (7, 63, 63)] {
                        let j = [x + dx, y + dy, z + dz];
                        let on = l.contains(&j.map(|c| c as i64));
                        let want = if on { byte(j[0] + 512 * (j[1] + 512 * j[2])) as f32 } else { 0.0 };
                        assert_eq!(out[dx + 64 * (dy + 64 * dz)], want, "box {x},{y},{z} texel {dx},{dy},{dz}");
                    }
                    growth = growth.max(current_resident_bytes().unwrap().saturating_sub(start));
                    boxes += 1;
                    if boxes % 8 == 0 {
                        if let Some(r) = mapping_rss(v.map.as_ptr()) {
                            mapped = Some(mapped.unwrap_or(0).max(r));
                        }
                    }
                }
            }
        }
        (growth, mapped)
    };
    // Other test threads can allocate meanwhile: the VmRSS bound must
    // hold in one of three passes, each started with none of the file
    // resident. The mapping's own pages (from /proc/self/smaps, immune to
    // other threads) must stay within one box slice and the 2 MiB
    // windows around it in every pass.
    let mut growths = Vec::new();
    for _ in 0..3 {
        drop_pages(&v.map, 0, v.map.len());
        let (g, mapped) = read_all(&mut out);
        growths.push(g);
        if let Some(m) = mapped {
            assert!(m <= 8 * MIB, "{m} bytes of the mapping resident while reading box by box");
        }
        if g < 16 * MIB {
            break;
        }
    }
    eprintln!("VmRSS growth reading 64 MiB box by box: {growths:?} bytes");
    assert!(growths.iter().any(|&g| g < 16 * MIB), "VmRSS grew by {growths:?} bytes reading a 64 MiB file");
    let start = current_resident_bytes().unwrap();
    let (lo, hi) = BrickSource::sample_range(&v).unwrap();
    let range_growth = current_resident_bytes().unwrap().saturating_sub(start);
    assert!(range_growth < 16 * MIB, "the range pass grew VmRSS by {range_growth} bytes");
    assert_eq!((lo, hi), (0.0, 255.0));

    // The mapping's own resident pages (immune to other threads): none
    // after the reads; all 64 MiB once touched without dropping them,
    // which shows the measurement sees them.
    if let Some(after) = mapping_rss(v.map.as_ptr()) {
        assert!(after <= MIB, "{after} bytes of the mapping resident after the reads");
        let sum: u64 = v.map.iter().step_by(4096).map(|&b| b as u64).sum();
        std::hint::black_box(sum);
        let touched = mapping_rss(v.map.as_ptr()).unwrap();
        assert!(touched >= 60 * MIB, "touching every page left only {touched} bytes resident");
        drop_pages(&v.map, 0, v.map.len());
        let dropped = mapping_rss(v.map.as_ptr()).unwrap();
        assert!(dropped <= MIB, "{dropped} bytes resident after dropping the pages");
    }
}
