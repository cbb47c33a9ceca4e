//! Panics are bugs: every bad input gets exit code 2 and one line on stderr
//! that names the problem, never a panic, a hang or silent garbage. None of
//! these needs a GPU: each is refused before a device is opened.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

fn fixtures() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("boxforge-bad-input-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("a_directory")).unwrap();
    let w = |name: &str, bytes: &[u8]| std::fs::write(dir.join(name), bytes).unwrap();
    w("empty.toml", b"");
    w("syntax.toml", b"name = \"x\"\nlattice = \"cc\"\ndirections = [[1,0,0]\n");
    w("zero.toml", b"name = \"z\"\nlattice = \"cc\"\ndirections = [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]\n");
    w("offlattice.toml", b"name = \"o\"\nlattice = \"bcc\"\ndirections = [[1,0,0],[0,2,0],[0,0,2]]\n");
    w("flat.toml", b"name = \"f\"\nlattice = \"cc\"\ndirections = [[1,0,0],[2,0,0],[0,1,0]]\n");
    w("huge.toml", b"name = \"h\"\nlattice = \"cc\"\ndirections = [[1000,0,0],[0,1,0],[0,0,1]]\n");
    w("badname.toml", b"name = \"../x\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1,0],[0,0,1]]\n");
    w("unknownlattice.toml", b"name = \"u\"\nlattice = \"hex\"\ndirections = [[1,0,0],[0,1,0],[0,0,1]]\n");
    w("float.toml", b"name = \"f\"\nlattice = \"cc\"\ndirections = [[1.5,0,0],[0,1,0],[0,0,1]]\n");
    let many = format!("name = \"m\"\nlattice = \"cc\"\ndirections = [{}]\n", vec!["[1,0,0]"; 17].join(","));
    w("many.toml", many.as_bytes());
    w(
        "seven.toml",
        b"name = \"seven\"\nlattice = \"cc\"\ndirections = [[-2,0,-2],[1,1,1],[1,-1,-2],[1,-2,1],[1,2,-2],[1,0,-1],[2,-2,0]]\n",
    );
    w(
        "degree.toml",
        b"name = \"d\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1,0],[0,0,1],[1,1,1]]\n[caps]\nmax_degree = 0\n",
    );
    w(
        "unknowncap.toml",
        b"name = \"c\"\nlattice = \"cc\"\ndirections = [[1,0,0],[0,1,0],[0,0,1]]\n[caps]\nmax_speed = 3\n",
    );
    w("empty.nii.gz", b"");
    w("truncated.nii.gz", &[0x1f, 0x8b, 0x08, 0x00, 0x00]);
    w("notnifti.nii", b"this is not a nifti file at all, just text that is long enough to look like a header");
    w("small.raw", &[0u8; 100]);
    // 4^3 f32 samples past f16's range.
    w("big_f32.raw", &[1.0e5f32; 64].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
    w("nan.raw", &f32::NAN.to_le_bytes().repeat(8));
    w("a_file", b"x");
    dir
}

/// (arguments, a fragment the one-line message must contain).
fn cases(dir: &Path) -> Vec<(Vec<String>, &'static str)> {
    let p = |name: &str| dir.join(name).display().to_string();
    let out = dir.join("out.png").display().to_string();
    let render = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> =
            ["render", "--filter", "bcc7", "--volume", "ml:8", "--out", &out].map(String::from).to_vec();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let volume = |vol: String, extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = ["render", "--filter", "bcc7", "--out", &out, "--volume"].map(String::from).to_vec();
        v.push(vol);
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    vec![
        // inspect / generate: filters and specs
        (args(&["inspect"]), "name a filter"),
        (args(&["inspect", "no_such_filter"]), "unknown filter"),
        (args(&["inspect", &p("a_directory")]), "cannot read"),
        (args(&["inspect", &p("missing.toml")]), "cannot read"),
        (args(&["inspect", &p("empty.toml")]), "malformed spec"),
        (args(&["inspect", &p("syntax.toml")]), "malformed spec"),
        (args(&["inspect", &p("zero.toml")]), "zero vector"),
        (args(&["inspect", &p("offlattice.toml")]), "not a point of the bcc lattice"),
        (args(&["inspect", &p("flat.toml")]), "rank"),
        (args(&["inspect", &p("huge.toml")]), "beyond"),
        (args(&["inspect", &p("badname.toml")]), "name"),
        (args(&["inspect", &p("unknownlattice.toml")]), "unknown lattice"),
        (args(&["inspect", &p("float.toml")]), "non-integer"),
        (args(&["inspect", &p("many.toml")]), "max_directions"),
        (args(&["inspect", &p("seven.toml")]), "max_polynomials"),
        (args(&["inspect", &p("degree.toml")]), "max_degree"),
        (args(&["inspect", &p("unknowncap.toml")]), "max_speed"),
        (args(&["inspect", "--bogus"]), "unexpected argument"),
        (args(&["generate", "bcc7"]), "--out"),
        (args(&["generate", "bcc7", "-o", &p("a_file")]), "is a file"),
        (args(&["generate", "bcc7", "--layout", "diagonal", "-o", &p("gen")]), "diagonal"),
        (args(&["generate", "bcc7", "--form", "fancy", "-o", &p("gen")]), "fancy"),
        (args(&["generate", "bcc7", "--target", "cuda", "-o", &p("gen")]), "cuda"),
        (
            args(&["generate", "bcc7", "--layout", "packed", "--fetch", "linear", "--target", "hlsl", "-o", &p("gen")]),
            "(--fetch exact) for hlsl",
        ),
        (args(&["generate", &p("missing.toml"), "-o", &p("gen")]), "cannot read"),
        (args(&["generate", &p("seven.toml"), "-o", &p("gen")]), "max_polynomials"),
        // validate
        (args(&["validate", &p("missing.wgsl")]), "cannot read"),
        (args(&["validate", &p("a_directory")]), "cannot read"),
        // verify
        (args(&["verify"]), "--filter"),
        (args(&["verify", "--filter", "no_such_filter"]), "unknown filter"),
        (args(&["verify", "--filter", "bcc7", "--points", "0"]), "--points 0"),
        (args(&["verify", "--filter", "bcc7", "--points", "abc"]), "abc"),
        (args(&["verify", "--filter", "bcc7", "--points", "-5"]), "-5"),
        (args(&["verify", "--filter", "bcc7", "--points", "2000000000"]), "at most"),
        (args(&["verify", "--filter", "bcc7", "--layout", "sideways"]), "sideways"),
        // render: numbers
        (render(&["--size", "100000"]), "--size 100000"),
        (render(&["--size", "0"]), "--size 0"),
        (render(&["--size", "-4"]), "-4"),
        (render(&["--iso", "nan"]), "--iso NaN"),
        (render(&["--iso", "inf"]), "--iso inf"),
        (render(&["--step", "0"]), "--step 0"),
        (render(&["--step", "-1"]), "--step -1"),
        (render(&["--step", "1e-9"]), "--step"),
        (render(&["--view", "30"]), "--view 30"),
        (render(&["--view", "nan,10"]), "--view"),
        (render(&["--view", "30,200"]), "elevation"),
        // render: volumes
        (volume("ml:100000".into(), &[]), "ml:100000"),
        (volume("ml:-3".into(), &[]), "ml:-3"),
        (volume("ml:abc".into(), &[]), "ml:abc"),
        (volume("ml:1".into(), &[]), "ml:1"),
        (volume(p("missing.nii.gz"), &[]), "cannot read"),
        (volume(p("a_directory"), &[]), "a_directory"),
        (volume(p("empty.nii.gz"), &[]), "empty.nii.gz"),
        (volume(p("truncated.nii.gz"), &[]), "truncated.nii.gz"),
        (volume(p("notnifti.nii"), &[]), "notnifti.nii"),
        (volume(p("small.raw"), &["--raw", "10,10,10,u8"]), "bytes"),
        (volume(p("big_f32.raw"), &["--raw", "4,4,4,f32", "--format", "f16"]), "65504"),
        (render(&["--brick", "8"]), "--layout bricked"),
        (render(&["--layout", "bricked", "--brick", "1"]), "--brick 1"),
        (render(&["--format", "u9"]), "u9"),
        (render(&["--gpu-budget", "12parsecs"]), "--gpu-budget 12parsecs"),
        (render(&["--gpu-budget", "64MiB", "--hit", "exact"]), "--hit step"),
        (render(&["--gpu-budget", "64MiB", "--mode", "dvr", "--cache", "perm"]), "out of core"),
        (render(&["--gpu-budget", "64MiB", "--resample"]), "--resample"),
        (volume(p("small.raw"), &["--raw", "10,10,u8"]), "raw volume spec"),
        (volume(p("small.raw"), &["--raw", "10,10,1,f64"]), "f64"),
        (volume(p("nan.raw"), &["--raw", "2,2,2,f32"]), "NaN"),
        (volume(p("small.raw"), &["--raw", "0,10,10,u8"]), "0"),
        // render --shade: curvature needs a Hessian and the ray caster
        (render(&["--shade", "wobbly"]), "wobbly"),
        (render(&["--shade", "mean", "--mode", "dvr", "--tf", "marschner-lobb"]), "--mode dvr"),
        (render(&["--shade", "curvature", "--curvature-radius", "0"]), "radius"),
        (render(&["--shade", "contours", "--contour-thickness", "-1"]), "thickness"),
        (render(&["--shade", "ridges", "--gpu-budget", "64MiB"]), "--gpu-budget"),
        (render(&["--tf-curvature"]), "--mode dvr"),
        (render(&["--tf-curvature", "--mode", "dvr", "--tf", "marschner-lobb", "--cache", "perm"]), "--cache perm"),
        (args(&["render", "--filter", "bcc_linear", "--volume", "ml:8", "--shade", "mean", "--out", &out]), "degree 1"),
        // render: filters, lattices, outputs
        (args(&["render", "--filter", "courant", "--volume", "ml:8", "--out", &out]), "2D"),
        (args(&["render", "--filter", "bcc7", "--volume", "ml:8", "--lattice", "fcc", "--out", &out]), "lattice"),
        (args(&["render", "--filter", "bcc7", "--volume", "ml:8", "--lattice", "hex", "--out", &out]), "hex"),
        (args(&["render", "--filter", "bcc7", "--volume", "ml:8", "--out", &p("a_directory")]), "directory"),
        (args(&["render", "--filter", "bcc7", "--volume", "ml:8", "--out", &p("a_file/x.png")]), "is a file"),
        // render --filter mattausch_bilinear[_spatial]: hand-written, ray-cast DVR only
        (args(&["render", "--filter", "mattausch_bilinear", "--volume", "ml:8", "--out", &out]), "--mode iso"),
        (
            args(&[
                "render",
                "--filter",
                "mattausch_bilinear_spatial",
                "--volume",
                "ml:8",
                "--mode",
                "dvr",
                "--tf",
                "marschner-lobb",
                "--renderer",
                "pt",
                "--out",
                &out,
            ]),
            "drop --renderer pt",
        ),
        (
            args(&[
                "render",
                "--filter",
                "mattausch_bilinear",
                "--volume",
                "ml:8",
                "--mode",
                "dvr",
                "--tf",
                "marschner-lobb",
                "--cache",
                "perm",
                "--out",
                &out,
            ]),
            "drop --cache",
        ),
        (
            args(&[
                "render",
                "--filter",
                "mattausch_bilinear",
                "--volume",
                "ml:8",
                "--mode",
                "dvr",
                "--tf",
                "marschner-lobb",
                "--layout",
                "packed",
                "--out",
                &out,
            ]),
            "--layout packed",
        ),
        // render --renderer pt (projected tetrahedra)
        (render(&["--renderer", "pt"]), "--mode dvr"),
        (render(&["--mode", "dvr", "--tf", "marschner-lobb", "--renderer", "pt", "--perspective"]), "orthographic"),
        (render(&["--mode", "dvr", "--tf", "marschner-lobb", "--renderer", "pt", "--cache", "perm"]), "--cache perm"),
        (
            args(&[
                "render",
                "--filter",
                "fcc6",
                "--volume",
                "ml:8",
                "--mode",
                "dvr",
                "--tf",
                "marschner-lobb",
                "--renderer",
                "pt",
                "--out",
                &out,
            ]),
            "BCC and CC",
        ),
        // Refused from the flags alone, before the volume is read (the volume is missing) or the
        // transfer function loaded: each was refused only after them before.
        (
            volume(
                p("missing.nii.gz"),
                &["--mode", "dvr", "--tf", "marschner-lobb", "--renderer", "pt", "--format", "u8"],
            ),
            "--format and --layout bricked",
        ),
        (
            volume(
                p("missing.nii.gz"),
                &["--mode", "dvr", "--tf", "marschner-lobb", "--renderer", "pt", "--layout", "bricked"],
            ),
            "--format and --layout bricked",
        ),
        (
            args(&[
                "render",
                "--filter",
                "mattausch_bilinear",
                "--volume",
                &p("missing.nii.gz"),
                "--mode",
                "dvr",
                "--format",
                "u16",
                "--out",
                &out,
            ]),
            "--format and --layout bricked",
        ),
        (render(&["--mode", "dvr", "--tf", &p("missing.json"), "--shade", "mean"]), "--shade mean"),
        (render(&["--mode", "dvr", "--tf", &p("missing.json"), "--gpu-budget", "12parsecs"]), "--gpu-budget 12parsecs"),
        (render(&["--cache", "lru"]), "lru"),
        (
            args(&["render", "--filter", "d4star8", "--volume", &p("missing.nii.gz"), "--frames", "0", "--out", &out]),
            "--frames 0",
        ),
        // A 4D filter's --tf is loaded before the series (it was after it and the device), as in 3D.
        (
            args(&[
                "render",
                "--filter",
                "d4star8",
                "--volume",
                &p("missing.nii.gz"),
                "--mode",
                "dvr",
                "--tf",
                &p("missing.json"),
                "--out",
                &out,
            ]),
            "missing.json",
        ),
        // bench and demo
        (args(&["bench", "--wgsl", &p("missing.wgsl")]), "--entry"),
        (args(&["bench", "--wgsl", &p("missing.wgsl"), "--entry", "f", "--like", "bcc7"]), "cannot read"),
        (args(&["bench", "--wgsl", &p("a_file"), "--entry", "f", "--like", "no_such"]), "unknown filter"),
        (args(&["bench", "--filters", "no_such_filter"]), "unknown filter"),
        (args(&["bench", "--specs", "3"]), "--derive"),
        (args(&["bench", "--smoke", "--markdown", &p("a_directory")]), "directory"),
        (args(&["demo", "--size", "0"]), "--size 0"),
        (args(&["demo", "--out", &p("a_file")]), "is a file"),
        (args(&["frobnicate"]), "frobnicate"),
    ]
}

pub(crate) fn run_bounded(args: &[String]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(args)
        // No device may be needed: point Vulkan at nothing.
        .env("VK_ICD_FILENAMES", "/nonexistent.json")
        .env("VK_DRIVER_FILES", "/nonexistent.json")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run boxforge");
    let started = std::time::Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if started.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("boxforge {args:?} hangs (over 60 s)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn every_bad_input_is_one_clear_line_with_exit_code_2() {
    let dir = fixtures();
    let cases = cases(&dir);
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let mut failures = Vec::new();
    for (args, fragment) in &cases {
        let out = run_bounded(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let stdout = String::from_utf8_lossy(&out.stdout);
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        let ok = out.status.code() == Some(2)
            && lines.len() == 1
            && lines[0].starts_with("error: ")
            && lines[0].contains(fragment)
            && !stderr.contains("panicked")
            && !stdout.contains("panicked")
            && !stderr.contains("RUST_BACKTRACE");
        if !ok {
            failures.push(format!("boxforge {}\n  exit {:?}, stderr: {stderr}", args.join(" "), out.status.code()));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{} of {} cases failed:\n{}", failures.len(), cases.len(), failures.join("\n"));
}

use proptest::prelude::*;

/// Words the random argument vectors are built from: subcommands (not
/// `demo` or `generate`, which write into the working directory, nor
/// `bench` without `--wgsl`, which measures for minutes), flags, and values
/// good and bad.
const WORDS: &[&str] = &[
    "inspect",
    "verify",
    "render",
    "validate",
    "list",
    "bench",
    "--filter",
    "bcc7",
    "fcc6",
    "courant",
    "zp",
    "no_such",
    "--volume",
    "ml:8",
    "ml:-1",
    "ml:0",
    "ml:99999999999",
    "--size",
    "0",
    "1",
    "16",
    "-1",
    "99999999",
    "--iso",
    "nan",
    "inf",
    "-inf",
    "0.5",
    "1e40",
    "--step",
    "0.25",
    "1e-30",
    "--view",
    "30,25",
    ",",
    "nan,nan",
    "--points",
    "1",
    "--layout",
    "packed",
    "embedded",
    "--raw",
    "1,1,1,u8",
    "x,y",
    "--json",
    "--all",
    "--form",
    "power",
    "--seed",
    "18446744073709551615",
    "--out",
    "/dev/null/x.png",
    "--wgsl",
    "--entry",
    "--like",
    "",
    "--",
    "-",
    "--help",
];

fn proptest_cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(48)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: proptest_cases(), max_shrink_iters: 16, ..ProptestConfig::default() })]

    /// Random argument vectors never panic: exit 0 (or 1 for an invalid
    /// shader), or exit 2 with one `error:` line.
    #[test]
    fn random_argument_vectors_never_panic(picks in prop::collection::vec(0..WORDS.len(), 1..7)) {
        let mut args: Vec<String> = picks.iter().map(|&i| WORDS[i].to_string()).collect();
        if args[0] == "bench" && !args.iter().any(|a| a == "--wgsl") {
            args[0] = "inspect".into();
        }
        let out = run_bounded(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        prop_assert!(!stderr.contains("panicked") && !stderr.contains("RUST_BACKTRACE"), "boxforge {:?}: {}", args, stderr);
        let code = out.status.code();
        prop_assert!(matches!(code, Some(0..=2)), "boxforge {:?}: exit {:?}: {}", args, code, stderr);
        if code == Some(2) && !stderr.contains("Usage:") {
            let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
            prop_assert!(lines.len() == 1 && lines[0].starts_with("error: "), "boxforge {:?}: {}", args, stderr);
        }
    }
}
