//! Stores of lattice samples (`convert --lattice bcc|fcc --prefilter F`):
//! each level holds the matched-count resampling of the Cartesian level,
//! prefiltered, chunk seams included (against the whole-volume functions
//! `render --resample` and the prefilter benches use); the coset layout
//! as Python's `zarr` reads the arrays is the documented one, and the
//! store passes `ome-zarr-models`; a lattice store renders as the same
//! samples do from a raw file, in core and out of core, and as `render
//! --resample` of the Cartesian store; bad combinations are one line and
//! exit 2.

use boxforge::derive::Derivation;
use boxforge::spec::lattice::Lattice;
use boxforge_runtime::prefilter::prefilter_cpu;
use boxforge_runtime::scene::{from_cartesian, Conversion};
use boxforge_runtime::volume::zarr::{
    write_lattice_pyramid, write_pyramid, LatticeOptions, OmeZarr, PyramidOptions, Selection, StorePlan, ZarrType,
    ZarrVolume,
};
use boxforge_runtime::volume::{BrickSource, LatticeVolume};
use std::path::{Path, PathBuf};
use std::process::Command;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("boxforge-zlat-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn lattice(name: &str) -> Lattice {
    Lattice::builtin(name).unwrap()
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// A lattice store written unit by unit, each level's units in reverse
/// order, through its `StorePlan` (as the Dask workers of the Python package
/// write it), is `write_lattice_pyramid`'s store byte for byte.
#[test]
fn a_store_written_unit_by_unit_in_any_order_is_the_whole_writers() {
    let dir = temp("units");
    let vol = crate::common::ripple_volume([13, 11, 9]);
    let source = LatticeVolume::subset(&lattice("cc"), &vol).unwrap();
    let l = lattice("bcc");
    let d = Derivation::new(&boxforge::spec::resolve("bcc7").unwrap()).unwrap();
    let o = PyramidOptions { chunk: 4, levels: Some(3), ty: ZarrType::F32, ..PyramidOptions::default() };
    let whole = dir.join("whole.zarr");
    write_lattice_pyramid(&source, &whole, &o, LatticeOptions { lattice: &l, prefilter: Some(&d) }, &|_, _| {})
        .unwrap();
    let store = dir.join("units.zarr");
    let plan = StorePlan::new(&store, [13, 11, 9], &o, Some((&l, Some("bcc7".to_string())))).unwrap();
    let pass = plan.cartesian_pass().unwrap();
    plan.make_folder().unwrap();
    plan.create().unwrap();
    pass.make_folder().unwrap();
    pass.create().unwrap();
    for lo in pass.unit_boxes(0).collect::<Vec<_>>().into_iter().rev() {
        pass.write_unit(0, &source, lo).unwrap();
    }
    for k in 1..3 {
        for lo in pass.unit_boxes(k).collect::<Vec<_>>().into_iter().rev() {
            pass.write_reduced_unit(k, lo).unwrap();
        }
    }
    pass.finish().unwrap();
    for k in (0..3).rev() {
        for lo in plan.unit_boxes(k).collect::<Vec<_>>().into_iter().rev() {
            plan.write_lattice_unit(k, lo, Some(&d)).unwrap();
        }
    }
    // A unit that is not one, and a prefilter the plan does not name, are refused.
    assert!(plan.write_lattice_unit(0, [1, 0, 0], Some(&d)).is_err());
    assert!(plan.write_lattice_unit(0, [0, 0, 0], None).is_err());
    plan.finish().unwrap();
    plan.remove_cartesian_pass().unwrap();
    assert_eq!(crate::common::store_files(&store), crate::common::store_files(&whole));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The Python of the peer venv (made once by scripts/zarr-peers/ensure-venv.sh).
fn peer_python() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new("bash").arg("scripts/zarr-peers/ensure-venv.sh").current_dir(&root).output().unwrap();
    assert!(out.status.success(), "ensure-venv.sh failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap().trim().to_string()
}

#[test]
fn lattice_stores_hold_each_levels_resampled_prefiltered_samples_as_cosets() {
    let python = peer_python();
    let dir = temp("levels");
    let vol = crate::common::ripple_volume([13, 11, 9]);
    let source = LatticeVolume::subset(&lattice("cc"), &vol).unwrap();
    // The Cartesian levels, as the plain pyramid holds them (float32).
    let o = PyramidOptions { chunk: 4, levels: Some(3), ty: ZarrType::F32, ..PyramidOptions::default() };
    write_pyramid(&source, &dir.join("grid.zarr"), &o, &|_, _| {}).unwrap();
    let cc_image = OmeZarr::open(&dir.join("grid.zarr")).unwrap();
    for (name, filter, shard) in
        [("bcc", Some("bcc7"), None), ("fcc", None, Some(8)), ("cc", Some("cc_tricubic"), None)]
    {
        let l = lattice(name);
        let d = filter.map(|f| Derivation::new(&boxforge::spec::resolve(f).unwrap()).unwrap());
        let store = dir.join(format!("{name}.zarr"));
        let o = PyramidOptions { shard, ..o.clone() };
        let options = LatticeOptions { lattice: &l, prefilter: d.as_ref() };
        let report = write_lattice_pyramid(&source, &store, &o, options, &|_, _| {}).unwrap();
        assert!(!store.join(".boxforge-cartesian").exists(), "the Cartesian pass is removed");
        let image = OmeZarr::open(&store).unwrap();
        let layout = image.layout().expect("a lattice store says so").clone();
        assert_eq!(layout.prefilter.as_deref(), filter);
        assert_eq!(image.levels().len(), 3);
        // Python's zarr reads each level's coset arrays; ome-zarr-models validates the group.
        let raw = dir.join(format!("{name}-levels"));
        let out = Command::new(&python)
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/zarr-peers/check_store.py"))
            .arg(&store)
            .arg("--raw-out")
            .arg(&raw)
            .output()
            .unwrap();
        assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
        let verdict: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for k in 0..3 {
            let cartesian = ZarrVolume::new(&cc_image, Selection { level: k, ..Default::default() }, &lattice("cc"))
                .unwrap()
                .to_volume()
                .unwrap();
            let resampled = from_cartesian(&cartesian, &l, Conversion::Resample).unwrap();
            let want = match &d {
                Some(d) => prefilter_cpu(d, &resampled),
                None => resampled,
            };
            assert_eq!(report.levels[k], want.dims, "{name} level {k}");
            let got = ZarrVolume::new(&image, Selection { level: k, ..Default::default() }, &l).unwrap();
            assert_eq!(got.dims(), want.dims);
            let got = got.to_lattice_volume().unwrap();
            assert_eq!(bits(&got.data), bits(&want.data), "{name} level {k}: seams or values differ");
            // The documented layout, as an independent reader sees it:
            // channel c at (k, j, i) is lattice point period * (i, j, k) + cosets[c].
            let bytes = std::fs::read(raw.join(format!("{k}.raw"))).unwrap();
            let stored: Vec<f32> = bytes.chunks(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            let shape: Vec<usize> = verdict["levels"][k]["shape"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_u64().unwrap() as usize)
                .collect();
            let grid = [shape[shape.len() - 1], shape[shape.len() - 2], shape[shape.len() - 3]];
            let (p, n) = (layout.period, want.dims);
            let mut i = 0;
            for r in &layout.cosets {
                for gz in 0..grid[2] {
                    for gy in 0..grid[1] {
                        for gx in 0..grid[0] {
                            let q = [p[0] * gx + r[0], p[1] * gy + r[1], p[2] * gz + r[2]];
                            if (0..3).all(|a| q[a] < n[a]) {
                                let v = want.get(&q.map(|x| x as i64));
                                assert_eq!(stored[i].to_bits(), v.to_bits(), "{name} level {k} coset {r:?} at {q:?}");
                            }
                            i += 1;
                        }
                    }
                }
            }
            assert_eq!(i, stored.len(), "{name} level {k}: one channel per coset");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn boxforge(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_boxforge")).args(args).output().unwrap()
}

fn render(args: &[&str], out: &Path) -> Vec<u8> {
    let o = boxforge(
        &[&["render", "--filter", "bcc7", "--size", "40", "--iso", "0.45", "--out", out.to_str().unwrap()], args]
            .concat(),
    );
    assert!(o.status.success(), "render {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    std::fs::read(out).unwrap()
}

#[test]
fn a_bcc_store_renders_as_resampling_the_cartesian_store_and_as_its_samples_from_a_raw_file() {
    let dir = temp("render");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (cc, bcc) = (dir.join("cc.zarr"), dir.join("bcc.zarr"));
    for (store, extra) in [(&cc, &[][..]), (&bcc, &["--lattice", "bcc"][..])] {
        let o = boxforge(&[&["convert", "ml:18", &s(store), "--chunk", "8"], extra].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    // The same samples as a raw file of the embedded lattice volume (0 off the lattice).
    let image = OmeZarr::open(&bcc).unwrap();
    let level = ZarrVolume::new(&image, Selection::default(), &lattice("bcc")).unwrap().to_lattice_volume().unwrap();
    let raw = dir.join("bcc.raw");
    std::fs::write(&raw, level.data.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    let d = level.dims;
    let raw_spec = format!("{},{},{},f32", d[0], d[1], d[2]);
    let png = |n: &str| dir.join(n);
    let from_store = render(&["--volume", &s(&bcc)], &png("a.png"));
    let resampled = render(&["--volume", &s(&cc), "--resample"], &png("b.png"));
    assert_eq!(from_store, resampled, "the store is what render --resample makes of the Cartesian store");
    let from_raw = render(&["--volume", &s(&raw), "--raw", &raw_spec], &png("c.png"));
    assert_eq!(from_store, from_raw, "in core");
    let budget = ["--gpu-budget", "64MiB"];
    let paged_store = render(&[&["--volume", &s(&bcc)][..], &budget].concat(), &png("d.png"));
    let paged_raw = render(&[&["--volume", &s(&raw), "--raw", &raw_spec][..], &budget].concat(), &png("e.png"));
    assert_eq!(paged_store, paged_raw, "out of core");
    // Bad combinations: one line, exit 2.
    let bad = |args: &[&str], says: &str| {
        let o = crate::bad_input::run_bounded(&args.iter().map(|a| a.to_string()).collect::<Vec<_>>());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    };
    let fresh = s(&dir.join("x.zarr"));
    bad(
        &["convert", "ml:8", &fresh, "--lattice", "fcc", "--prefilter", "bcc7"],
        "is a filter on bcc, not on --lattice fcc",
    );
    bad(&["convert", "ml:8", &fresh, "--prefilter", "bcc7", "--dtype", "u8"], "store them as float32");
    bad(&["convert", "ml:8", &fresh, "--lattice", "hexagonal"], "hexagonal");
    bad(
        &["render", "--filter", "fcc6", "--volume", &s(&bcc), "--iso", "0.5", "--out", &s(&png("f.png"))],
        "holds bcc lattice samples",
    );
    bad(
        &["render", "--filter", "bcc7", "--volume", &s(&bcc), "--resample", "--iso", "0.5", "--out", &s(&png("g.png"))],
        "resampled when the store was written",
    );
    assert!(!dir.join("x.zarr").join("zarr.json").exists(), "nothing written on refusal");
    let _ = std::fs::remove_dir_all(&dir);
}
