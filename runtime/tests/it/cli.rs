//! The `boxforge` binary: reports, JSON shape, determinism, bad input.

use std::process::Command;

fn boxforge(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_boxforge")).args(args).output().expect("run boxforge")
}

#[test]
fn inspect_all_json_has_the_documented_keys_and_is_deterministic() {
    let a = boxforge(&["inspect", "--all", "--json"]);
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    let b = boxforge(&["inspect", "--all", "--json"]);
    assert_eq!(a.stdout, b.stdout, "same input, same bytes");
    let v: serde_json::Value = serde_json::from_slice(&a.stdout).unwrap();
    let arr = v.as_array().unwrap();
    assert!(arr.len() >= 10);
    for f in arr {
        for key in [
            "name",
            "dimension",
            "lattice_det",
            "degree",
            "approximation_order",
            "continuity",
            "support_volume",
            "knot_planes",
            "grid_offset",
            "cube_classes",
            "cells_per_fundamental_domain",
            "polynomial_pieces_per_fundamental_domain",
            "symmetry_order",
            "reference_pieces",
            "max_stencil_size",
            "prefilter",
        ] {
            assert!(f.get(key).is_some(), "{} lacks {key}", f["name"]);
        }
        for r in f["reference_pieces"].as_array().unwrap() {
            for key in ["vertices", "is_simplex", "stencil", "bb"] {
                assert!(r.get(key).is_some());
            }
        }
        // Rationals are strings like "-1/24".
        for w in f["prefilter"].as_array().unwrap() {
            assert!(w["w"].is_string());
        }
    }
    let bcc7 = arr.iter().find(|f| f["name"] == "bcc7").unwrap();
    assert_eq!(bcc7["reference_pieces"][0]["stencil"].as_array().unwrap().len(), 30);
    assert_eq!(bcc7["knot_planes"].as_array().unwrap().len(), 9);
}

#[test]
fn inspect_one_filter_prints_text_and_json() {
    let t = boxforge(&["inspect", "fcc6"]);
    assert!(t.status.success());
    let text = String::from_utf8(t.stdout).unwrap();
    assert!(text.contains("fcc6") && text.contains("knot planes") && text.contains("prefilter"));
    let j = boxforge(&["inspect", "zp", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&j.stdout).unwrap();
    assert_eq!(v["name"], "zp");
    assert_eq!(v["grid_offset"][0], "1/2");
}

#[test]
fn spec_files_work_and_bad_input_is_one_clear_line_with_exit_code_2() {
    let dir = std::env::temp_dir().join(format!("boxforge-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    let good = write("good.toml", "name = \"mine\"\nlattice = \"quincunx\"\ndirections = [[1,1],[1,-1],[2,0]]\n");
    let out = boxforge(&["inspect", &good, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let cases = [
        (write("a.toml", "name = \"a\"\nlattice = \"bcc\"\ndirections = [[1,0,0],[0,2,0],[0,0,2]]\n"), "not a point of the bcc lattice"),
        (write("b.toml", "name = \"b\"\nlattice = \"cc\"\ndirections = [[1,0,0],[2,0,0],[0,1,0]]\n"), "rank 2"),
        (write("c.toml", "name = \"c\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,0.5,0],[0,0,1]]\n"), "non-integer"),
        (write("d.toml", "name = \"d\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1],[0,0,1]]\n"), "mixed dimensions"),
        (write("e.toml", "name = \"e\"\nlattice = \"cc\"\ndirections = [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]\n"), "zero vector"),
        (write("f.toml", "name = \"f\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1,0],[0,0,1],[1,0,0]]\n[caps]\nmax_degree = 0\n"), "exceeds the cap"),
        (write("g.toml", "name = \"g\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1,0],[0,0,1],[1,0,0],[0,1,0],[0,0,1]]\n[caps]\nmax_stencil = 4\n"), "over the cap"),
        (write("h.toml", "name = \"h\"\nlattice = \"cc\"\ndirections = [[1,0,0]\n"), "malformed spec"),
        (write("i.toml", "name = \"i\"\nlattice = { generators = [[1,1],[2,2]] }\ndirections = [[1,0],[0,1]]\n"), "singular"),
        ("no_such_filter".to_string(), "unknown filter"),
        (dir.join("missing.toml").display().to_string(), "cannot read"),
    ];
    for (arg, needle) in cases {
        let out = boxforge(&["inspect", &arg]);
        assert_eq!(out.status.code(), Some(2), "{arg}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "one line for {arg}: {err}");
        assert!(err.contains(needle), "{arg}: expected '{needle}' in: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_volume_input_is_one_clear_line() {
    let dir = std::env::temp_dir().join(format!("boxforge-vol-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let raw = dir.join("v.raw");
    std::fs::write(&raw, vec![0u8; 100]).unwrap();
    let nan = dir.join("nan.raw");
    let mut bytes = Vec::new();
    for i in 0..8 {
        let v: f32 = if i == 3 { f32::NAN } else { 1.0 };
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&nan, bytes).unwrap();
    let bad_header = dir.join("bad.nii");
    std::fs::write(&bad_header, b"definitely not nifti").unwrap();
    let raw_s = raw.display().to_string();
    let nan_s = nan.display().to_string();
    let bad_s = bad_header.display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--volume", &raw_s, "--raw", "8,8,8,u8"], "bytes"),
        (vec!["--volume", &nan_s, "--raw", "2,2,2,f32"], "NaN"),
        (vec!["--volume", &bad_s], "bad.nii"),
        (vec!["--volume", "ml:abc"], "ml:N"),
    ];
    for (args, needle) in cases {
        let mut all = vec!["render", "--filter", "bcc7", "--size", "8"];
        all.extend(args.iter().copied());
        let out = boxforge(&all);
        assert_eq!(out.status.code(), Some(2), "{all:?}: {}", String::from_utf8_lossy(&out.stderr));
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{all:?}: {err}");
        assert!(err.contains(needle), "{all:?}: expected '{needle}' in {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_spec_too_large_to_derive_is_refused_with_its_estimate_and_timings_are_opt_in() {
    let dir = std::env::temp_dir().join(format!("boxforge-cli-caps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("seven.toml");
    std::fs::write(
        &spec,
        "name = \"seven\"\nlattice = \"cc\"\ndirections = [[-2,0,-2],[1,1,1],[1,-1,-2],[1,-2,1],[1,2,-2],[1,0,-1],[2,-2,0]]\n",
    )
    .unwrap();
    let out = boxforge(&["inspect", spec.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("polynomials") && err.contains("caps.max_polynomials"), "{err}");
    let text = boxforge(&["inspect", "bcc7"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("derived in"), "the text report has the time");
    let json = boxforge(&["inspect", "bcc7", "--json", "--timings"]);
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert!(v["derivation_seconds"].as_f64().is_some());
    assert_eq!(v["work"]["polynomials"], 30);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_reader_that_stops_early_is_not_a_panic() {
    use std::io::Read;
    let mut child = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["inspect", "--all", "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 16];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap(); // then the pipe closes
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
}

/// `generate --fetch linear` writes the linear modules where they apply
/// (bcc7: packed only; cc_tricubic: both layouts); forcing the embedded
/// layout on bcc7 is one line naming the packed layout.
#[test]
fn generate_with_linear_fetches_picks_the_layouts_that_apply() {
    let dir = std::env::temp_dir().join(format!("boxforge-cli-linear-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let out = boxforge(&["generate", "bcc7", "cc_tricubic", "--fetch", "linear", "-o", d]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut files: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    files.sort();
    let wgsl: Vec<&String> = files.iter().filter(|f| f.ends_with(".wgsl")).collect();
    assert_eq!(wgsl, ["bcc7.packed.linear.wgsl", "cc_tricubic.embedded.linear.wgsl", "cc_tricubic.packed.linear.wgsl"]);
    let src = std::fs::read_to_string(dir.join("bcc7.packed.linear.wgsl")).unwrap();
    assert!(src.contains("--fetch linear") && src.contains("bcc7_fetch_pair"));
    let refused = boxforge(&["generate", "bcc7", "--fetch", "linear", "--layout", "embedded", "-o", d]);
    assert_eq!(refused.status.code(), Some(2));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--layout packed"), "the generator's option told as the flag: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_view_dependent_filter_picks_its_variant_from_the_view_and_says_which() {
    let dir = std::env::temp_dir().join(format!("boxforge-view-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("v.png").display().to_string();
    // Azimuth 0 looks along -x (mostly), elevation 80 along -z.
    for (view, axis, signs) in
        [("0,10", "reference z along x", "signs (-, +, -)"), ("30,80", "reference z along z", "signs (-, -, -)")]
    {
        let out = boxforge(&[
            "render",
            "--filter",
            "bcc_sheared_trilinear",
            "--volume",
            "ml:8",
            "--size",
            "16",
            "--view",
            view,
            "--out",
            &png,
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "--view {view}: {err}");
        assert!(err.contains(axis) && err.contains(signs), "--view {view}: expected '{axis}' and '{signs}' in {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
