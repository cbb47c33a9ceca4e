//! OME-Zarr in and out, against implementations nobody here wrote: stores
//! Python's `ome-zarr` wrote (committed under tests/fixtures/ome-zarr, with
//! values from a closed formula, scripts/zarr-peers/README.md) read as the
//! formula says, at every level, channel and time point; the pyramids
//! `write_pyramid` writes hold the source exactly at level 0 and the
//! binomial reduction, computed here directly in 3D, above it; they pass
//! `ome-zarr-models` and read back identically with Python's `zarr` (a venv
//! scripts/zarr-peers/ensure-venv.sh makes); a store renders the image its
//! samples render as a raw file; bad stores are one line and exit 2.

use boxforge::spec::lattice::Lattice;
use boxforge_runtime::volume::zarr::{
    write_pyramid, OmeZarr, PyramidOptions, Reduction, Selection, ZarrType, ZarrVolume,
};
use boxforge_runtime::volume::{BrickSource, LatticeVolume};
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ome-zarr").join(name)
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("boxforge-zarr-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn cc() -> Lattice {
    Lattice::builtin("cc").unwrap()
}

/// The fixtures' level-0 value at (x, y, z, c, t) before the type's offset.
fn formula(x: usize, y: usize, z: usize, c: usize, t: usize) -> f32 {
    ((3 * x + 5 * y + 7 * z + 11 * c + 13 * t) % 200) as f32
}

/// Every sample of a box that overhangs the level by one voxel on each
/// side, against the formula at the clamped voxel.
fn check_level(v: &ZarrVolume, level: usize, c: usize, t: usize, offset: f32) {
    let d = v.dims();
    let size = d.map(|n| n + 2);
    let mut out = vec![0f32; size.iter().product()];
    v.read_box([-1, -1, -1], size, &mut out).unwrap();
    let f = 1usize << level;
    let mut i = 0;
    for z in 0..size[2] {
        for y in 0..size[1] {
            for x in 0..size[0] {
                let j = [x, y, z].map(|p| p.saturating_sub(1));
                let j: [usize; 3] = std::array::from_fn(|a| j[a].min(d[a] - 1));
                let want = formula(j[0] * f, j[1] * f, j[2] * f, c, t) + offset;
                assert_eq!(out[i], want, "level {level} channel {c} time {t} at {j:?}");
                i += 1;
            }
        }
    }
}

#[test]
fn stores_python_ome_zarr_wrote_read_as_their_formula() {
    // (store, level-0 dims (x, y, z), levels, channels, times, offset, level-0 spacing (x, y, z))
    let cases = [
        ("v04-u16.zarr", [16, 10, 12], 3, 1, 1, 0.0, [1.0, 1.0, 2.0]),
        ("v05-f32-czyx.zarr", [16, 10, 12], 2, 2, 1, 0.25, [1.0, 1.0, 2.0]),
        ("v05-i16-tczyx.zarr", [8, 8, 8], 1, 1, 2, -100.0, [1.0, 1.0, 1.0]),
    ];
    for (name, dims0, levels, channels, times, offset, spacing0) in cases {
        let image = OmeZarr::open(&fixture(name)).unwrap();
        assert_eq!((image.levels().len(), image.channels(), image.times()), (levels, channels, times), "{name}");
        for level in 0..levels {
            for channel in 0..channels {
                for time in 0..times {
                    let v = ZarrVolume::new(&image, Selection { level, channel, time }, &cc()).unwrap();
                    let f = 1usize << level;
                    assert_eq!(v.dims(), dims0.map(|n: usize| n.div_ceil(f)), "{name} level {level}");
                    assert_eq!(v.spacing(), spacing0.map(|s: f64| s * f as f64), "{name} level {level}");
                    check_level(&v, level, channel, time, offset);
                }
            }
        }
        let err = ZarrVolume::new(&image, Selection { level: levels, ..Default::default() }, &cc()).err().unwrap();
        assert!(err.to_string().contains(&format!("has {levels} levels")), "{err}");
    }
}

#[test]
fn a_non_cartesian_lattice_reads_the_subset_and_zero_elsewhere() {
    let bcc = Lattice::builtin("bcc").unwrap();
    let image = OmeZarr::open(&fixture("v04-u16.zarr")).unwrap();
    let v = ZarrVolume::new(&image, Selection::default(), &bcc).unwrap();
    let d = v.dims();
    let mut out = vec![0f32; d.iter().product()];
    v.read_box([0, 0, 0], d, &mut out).unwrap();
    let (mut on, mut off) = (0, 0);
    for (i, &got) in out.iter().enumerate() {
        let j = [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])];
        if bcc.contains(&j.map(|p| p as i64)) {
            assert_eq!(got, formula(j[0], j[1], j[2], 0, 0), "{j:?}");
            on += 1;
        } else {
            assert_eq!(got, 0.0, "{j:?} is not a bcc point");
            off += 1;
        }
    }
    assert!(on > 0 && off > 0);
    // The in-memory path reads the same samples.
    let whole = v.to_volume().unwrap();
    assert_eq!(whole.dims, d);
    assert_eq!(whole.data[1], formula(1, 0, 0, 0, 0));
}

fn read_all(v: &ZarrVolume) -> Vec<f32> {
    let d = v.dims();
    let mut out = vec![0f32; d.iter().product()];
    v.read_box([0, 0, 0], d, &mut out).unwrap();
    out
}

/// Level k+1 from level k by the 3D binomial kernel directly (not separably).
fn binomial_3d(fine: &[f32], n: [usize; 3]) -> (Vec<f64>, [usize; 3]) {
    let w = [1.0, 4.0, 6.0, 4.0, 1.0].map(|v: f64| v / 16.0);
    let mirror = |p: i64, n: usize| {
        let last = n as i64 - 1;
        (if p < 0 {
            -p
        } else if p > last {
            2 * last - p
        } else {
            p
        })
        .clamp(0, last) as usize
    };
    let m = n.map(|v| v.div_ceil(2));
    let mut out = Vec::new();
    for k in 0..m[2] {
        for j in 0..m[1] {
            for i in 0..m[0] {
                let mut s = 0.0;
                for (c, wc) in w.iter().enumerate() {
                    for (b, wb) in w.iter().enumerate() {
                        for (a, wa) in w.iter().enumerate() {
                            let x = mirror(2 * i as i64 + a as i64 - 2, n[0]);
                            let y = mirror(2 * j as i64 + b as i64 - 2, n[1]);
                            let z = mirror(2 * k as i64 + c as i64 - 2, n[2]);
                            s += wa * wb * wc * f64::from(fine[x + n[0] * (y + n[1] * z)]);
                        }
                    }
                }
                out.push(s);
            }
        }
    }
    (out, m)
}

#[test]
fn written_pyramids_hold_the_source_and_its_binomial_reduction() {
    let dims = [13, 10, 9];
    let source = LatticeVolume::subset(&cc(), &crate::common::ripple_volume(dims)).unwrap();
    for shard in [None, Some(8)] {
        let out = temp(&format!("pyramid-{shard:?}")).join("p.zarr");
        let o = PyramidOptions {
            chunk: 4,
            shard,
            levels: Some(3),
            reduction: Reduction::Binomial,
            ty: ZarrType::F32,
            spacing: [0.5, 0.5, 1.5],
            ..Default::default()
        };
        let report = write_pyramid(&source, &out, &o, &|_, _| {}).unwrap();
        assert_eq!(report.levels, [[13, 10, 9], [7, 5, 5], [4, 3, 3]]);
        // The same input gives the same bytes (a shard's chunks in C
        // order, not in the order parallel encoders finish).
        let again = out.with_file_name("again.zarr");
        write_pyramid(&source, &again, &o, &|_, _| {}).unwrap();
        assert_eq!(
            crate::common::store_files(&out),
            crate::common::store_files(&again),
            "two writes differ ({shard:?})"
        );
        let image = OmeZarr::open(&out).unwrap();
        let level = |k| ZarrVolume::new(&image, Selection { level: k, ..Default::default() }, &cc()).unwrap();
        let l0 = read_all(&level(0));
        assert_eq!(l0, crate::common::ripple_volume(dims).data, "level 0 is the source ({shard:?})");
        assert_eq!(level(2).spacing(), [2.0, 2.0, 6.0]);
        let mut fine = (l0, dims);
        for k in 1..3 {
            let (want, m) = binomial_3d(&fine.0, fine.1);
            let got = read_all(&level(k));
            assert_eq!(level(k).dims(), m);
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!((f64::from(*g) - w).abs() < 1e-4, "level {k} sample {i}: {g} vs {w} ({shard:?})");
            }
            fine = (got, m);
        }
        let _ = std::fs::remove_dir_all(out.parent().unwrap());
    }
}

#[test]
fn box_reduction_averages_blocks_and_integers_round() {
    let dims = [8, 6, 4];
    let source = LatticeVolume::subset(&cc(), &crate::common::ripple_volume(dims)).unwrap();
    let out = temp("box").join("b.zarr");
    let o =
        PyramidOptions { chunk: 4, levels: Some(2), reduction: Reduction::Box, ty: ZarrType::U8, ..Default::default() };
    write_pyramid(&source, &out, &o, &|_, _| {}).unwrap();
    let image = OmeZarr::open(&out).unwrap();
    let l0 = read_all(&ZarrVolume::new(&image, Selection::default(), &cc()).unwrap());
    let src = crate::common::ripple_volume(dims).data;
    for (g, s) in l0.iter().zip(&src) {
        assert_eq!(*g, s.round().clamp(0.0, 255.0));
    }
    let l1 = read_all(&ZarrVolume::new(&image, Selection { level: 1, ..Default::default() }, &cc()).unwrap());
    let at = |x: usize, y: usize, z: usize| l0[x + 8 * (y + 6 * z)];
    for (i, g) in l1.iter().enumerate() {
        let (x, y, z) = (i % 4, (i / 4) % 3, i / 12);
        let mut s = 0.0;
        for c in 0..8 {
            s += at(2 * x + (c & 1), 2 * y + ((c >> 1) & 1), 2 * z + (c >> 2));
        }
        assert_eq!(*g, (s / 8.0).round(), "block {x},{y},{z}");
    }
    let _ = std::fs::remove_dir_all(out.parent().unwrap());
}

/// The Python of the peer venv (made once by scripts/zarr-peers/ensure-venv.sh).
fn peer_python() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new("bash").arg("scripts/zarr-peers/ensure-venv.sh").current_dir(&root).output().unwrap();
    assert!(out.status.success(), "ensure-venv.sh failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap().trim().to_string()
}

/// check_store.py's verdict on `store`, with each level's bytes in `raw`.
fn peer_check(python: &str, store: &Path, raw: &Path) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/zarr-peers/check_store.py");
    let out = Command::new(python).arg(script).arg(store).arg("--raw-out").arg(raw).output().unwrap();
    assert!(
        out.status.success(),
        "ome-zarr-models / zarr refuse {}: {}",
        store.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn converted_stores_pass_ome_zarr_models_and_read_back_with_python_zarr() {
    let python = peer_python();
    let dir = temp("peers");
    // u16 samples written by the CLI from a raw file.
    let dims = [11usize, 7, 6];
    let values: Vec<u16> = (0..dims.iter().product::<usize>()).map(|i| ((i * 37) % 1000) as u16).collect();
    let raw = dir.join("in.raw");
    std::fs::write(&raw, values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    let store = dir.join("out.zarr");
    let status = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args([
            "convert",
            raw.to_str().unwrap(),
            store.to_str().unwrap(),
            "--raw",
            "11,7,6,u16",
            "--chunk",
            "4",
            "--shard",
            "8",
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let levels = dir.join("levels");
    let verdict = peer_check(&python, &store, &levels);
    assert_eq!(verdict["version"], "0.5");
    assert_eq!(verdict["levels"][0]["shape"], serde_json::json!([6, 7, 11]));
    assert_eq!(verdict["levels"][0]["dtype"], "uint16");
    // Level 0 as Python's zarr reads it is the input file, byte for byte.
    assert_eq!(std::fs::read(levels.join("0.raw")).unwrap(), std::fs::read(&raw).unwrap());
    // Every level as Python reads it is what boxforge reads.
    let image = OmeZarr::open(&store).unwrap();
    for (k, level) in image.levels().iter().enumerate() {
        let ours = read_all(&ZarrVolume::new(&image, Selection { level: k, ..Default::default() }, &cc()).unwrap());
        let bytes = std::fs::read(levels.join(format!("{}.raw", level.path))).unwrap();
        let theirs: Vec<f32> = bytes.chunks(2).map(|b| f32::from(u16::from_le_bytes([b[0], b[1]]))).collect();
        assert_eq!(ours, theirs, "level {k}");
    }
    // The committed fixtures are valid too, and Python reads what boxforge reads.
    for name in ["v04-u16.zarr", "v05-f32-czyx.zarr"] {
        let v = peer_check(&python, &fixture(name), &dir.join(name));
        assert!(v["levels"].as_array().unwrap().len() >= 2, "{name}: {v}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A single-file NIfTI-1 of `dims` uint8 samples with voxel size `pixdim`
/// (x, y, z) in millimetres.
fn nifti_u8(dims: [usize; 3], pixdim: [f32; 3], data: &[u8]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (i, d) in [3, dims[0] as i16, dims[1] as i16, dims[2] as i16, 1, 1, 1, 1].iter().enumerate() {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes()); // uint8
    h[72..74].copy_from_slice(&8i16.to_le_bytes());
    for (i, p) in [1.0f32, pixdim[0], pixdim[1], pixdim[2]].iter().enumerate() {
        h[76 + 4 * i..80 + 4 * i].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[123] = 2; // xyzt_units: millimetres
    h[344..348].copy_from_slice(b"n+1\0");
    [h, data.to_vec()].concat()
}

#[test]
fn a_nifti_files_voxel_size_and_unit_become_the_stores_scale() {
    let python = peer_python();
    let dir = temp("pixdim");
    let dims = [6usize, 5, 4];
    let data: Vec<u8> = (0..dims.iter().product::<usize>()).map(|i| (i * 7 % 251) as u8).collect();
    let nii = dir.join("aniso.nii");
    std::fs::write(&nii, nifti_u8(dims, [0.5, 2.0, 3.0], &data)).unwrap();
    let store = dir.join("aniso.zarr");
    let o = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["convert", nii.to_str().unwrap(), store.to_str().unwrap(), "--chunk", "4"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // What Python reads: each level's scale (z, y, x) is the voxel size times 2^k.
    let verdict = peer_check(&python, &store, &dir.join("levels"));
    assert_eq!(verdict["levels"][0]["scale"], serde_json::json!([3.0, 2.0, 0.5]));
    assert_eq!(verdict["levels"][1]["scale"], serde_json::json!([6.0, 4.0, 1.0]));
    assert_eq!(std::fs::read(dir.join("levels/0.raw")).unwrap(), data, "level 0 is the file's samples");
    // What boxforge reads back, unit included, and carries on through a store-to-store convert.
    let image = OmeZarr::open(&store).unwrap();
    assert_eq!(image.metadata().space_unit.as_deref(), Some("millimeter"));
    let again = dir.join("again.zarr");
    let o = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["convert", store.to_str().unwrap(), again.to_str().unwrap(), "--lod", "1"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let image = OmeZarr::open(&again).unwrap();
    assert_eq!(image.levels()[0].spacing, [1.0, 4.0, 6.0]);
    assert_eq!(image.metadata().space_unit.as_deref(), Some("millimeter"));
    let _ = std::fs::remove_dir_all(&dir);
}

fn render(args: &[&str], out: &Path) -> Vec<u8> {
    let o = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["render", "--filter", "bcc7", "--size", "48", "--out", out.to_str().unwrap()])
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "render {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    std::fs::read(out).unwrap()
}

#[test]
fn a_store_renders_as_its_samples_do_from_a_raw_file_in_core_and_out_of_core() {
    let dir = temp("render");
    // Level 1 of the Python store, written out as a raw file from the formula.
    let (d, f) = ([8usize, 5, 6], 2usize);
    let mut bytes = Vec::new();
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                bytes.extend((formula(x * f, y * f, z * f, 0, 0) as u16).to_le_bytes());
            }
        }
    }
    let raw = dir.join("l1.raw");
    std::fs::write(&raw, bytes).unwrap();
    let store = fixture("v04-u16.zarr");
    let (store, raw) = (store.to_str().unwrap(), raw.to_str().unwrap());
    for extra in [&[][..], &["--gpu-budget", "64MiB"][..]] {
        let mut a: Vec<&str> = vec!["--iso", "90", "--volume", store, "--lod", "1"];
        a.extend(extra);
        let from_store = render(&a, &dir.join("a.png"));
        let mut b: Vec<&str> = vec!["--iso", "90", "--volume", raw, "--raw", "8,5,6,u16"];
        b.extend(extra);
        let from_raw = render(&b, &dir.join("b.png"));
        assert_eq!(from_store, from_raw, "{extra:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A copy of a fixture store in a fresh folder, to break.
fn copy_store(name: &str, into: &Path) -> PathBuf {
    std::fs::create_dir_all(into).unwrap();
    let to = into.join(name);
    let status = Command::new("cp").arg("-r").arg(fixture(name)).arg(&to).status().unwrap();
    assert!(status.success());
    to
}

fn edit(path: &Path, from: &str, to: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains(from), "{} has no {from}", path.display());
    std::fs::write(path, text.replacen(from, to, 1)).unwrap();
}

#[test]
fn bad_stores_are_one_line_and_exit_2_and_a_missing_chunk_reads_as_fill() {
    let dir = temp("bad");
    let corrupt = copy_store("v04-u16.zarr", &dir.join("corrupt"));
    std::fs::write(corrupt.join("s0/0/0/0"), b"not a blosc frame").unwrap();
    let dtype = copy_store("v05-i16-tczyx.zarr", &dir.join("dtype"));
    edit(&dtype.join("s0/zarr.json"), "\"int16\"", "\"int64\"");
    let scales = copy_store("v04-u16.zarr", &dir.join("scales"));
    edit(&scales.join(".zattrs"), "4.0,\n", "1.0,\n");
    let huge = copy_store("v05-i16-tczyx.zarr", &dir.join("huge"));
    edit(&huge.join("s0/zarr.json"), "    8,\n    8,\n    8\n", "    100000000,\n    100000000,\n    100000000\n");
    let plain = dir.join("plain.zarr");
    std::fs::create_dir_all(&plain).unwrap();
    std::fs::write(plain.join("zarr.json"), br#"{"zarr_format": 3, "node_type": "group", "attributes": {}}"#).unwrap();
    let out = dir.join("o.png").display().to_string();
    let p = |s: &Path| s.display().to_string();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec![p(&corrupt)], "corrupt"),
        (vec![p(&dtype)], "int64"),
        (vec![p(&scales)], "level"),
        (vec![p(&huge)], "100000000"),
        (vec![p(&huge), "--gpu-budget".into(), "64MiB".into()], "past the"),
        (vec![p(&plain)], "without OME-Zarr multiscales"),
        (vec![p(&dir.join("missing.zarr"))], "missing.zarr"),
        (vec![p(&fixture("v04-u16.zarr")), "--channel".into(), "1".into()], "has 1 channels"),
        (
            vec![p(&fixture("v04-u16.zarr")), "--gpu-budget".into(), "64MiB".into(), "--lod".into(), "3".into()],
            "has 3 levels",
        ),
    ];
    let mut failures = Vec::new();
    for (volume, fragment) in &cases {
        let mut args: Vec<String> =
            ["render", "--filter", "bcc7", "--out", &out, "--volume"].map(String::from).to_vec();
        args.extend(volume.iter().cloned());
        let o = crate::bad_input::run_bounded(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        if !(o.status.code() == Some(2)
            && lines.len() == 1
            && lines[0].starts_with("error: ")
            && lines[0].contains(fragment))
        {
            failures.push(format!("{volume:?}: exit {:?}: {stderr}", o.status.code()));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // A chunk that is not there reads as the fill value (0), the rest as stored.
    let holes = copy_store("v04-u16.zarr", &dir.join("holes"));
    std::fs::remove_file(holes.join("s0/0/0/0")).unwrap();
    let image = OmeZarr::open(&holes).unwrap();
    let v = ZarrVolume::new(&image, Selection::default(), &cc()).unwrap();
    let all = read_all(&v);
    let d = v.dims();
    assert_eq!(all[1 + d[0] * (1 + d[1])], 0.0, "inside the missing chunk");
    assert_eq!(all[9 + d[0] * (1 + d[1])], formula(9, 1, 1, 0, 0), "in the next chunk");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_4d_filter_draws_a_stores_time_points_as_it_draws_the_same_raw_frames() {
    let dir = temp("four");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for t in 0..2 {
        let mut bytes = Vec::new();
        for z in 0..8 {
            for y in 0..8 {
                for x in 0..8 {
                    bytes.extend((formula(x, y, z, 0, t) - 100.0).to_le_bytes());
                }
            }
        }
        std::fs::write(frames.join(format!("frame_{t}.raw")), bytes).unwrap();
    }
    let store = fixture("v05-i16-tczyx.zarr");
    let args = ["--filter", "z4_cubic", "--iso", "0", "--time", "0.5", "--size", "48"];
    let run = |extra: &[&str], out: &Path| {
        let o = Command::new(env!("CARGO_BIN_EXE_boxforge"))
            .arg("render")
            .args(args)
            .args(extra)
            .arg("--out")
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(out).unwrap()
    };
    let from_store = run(&["--volume", store.to_str().unwrap()], &dir.join("a.png"));
    let from_raw = run(&["--volume", frames.to_str().unwrap(), "--raw", "8,8,8,f32"], &dir.join("b.png"));
    assert_eq!(from_store, from_raw);
    let _ = std::fs::remove_dir_all(&dir);
}
