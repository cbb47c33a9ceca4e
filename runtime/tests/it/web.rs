//! The browser viewer (`boxforge web`) in headless Chromium (WebGPU on
//! SwiftShader, Chrome's Tint compiling the WGSL), driven over the DevTools
//! protocol: every module of the site compiles in Tint, and the page's
//! canvas shows the same image as `boxforge render` on lavapipe for bcc7,
//! fcc6 and cc_tricubic isosurfaces and a bcc7 volume rendering. Also takes the README's screenshot, into
//! the target folder (scripts/refresh-docs-pictures.sh copies it to docs/web-viewer.png). Needs Debian's chromium (scripts/test.sh installs it).

#[path = "web/cdp.rs"]
mod cdp;

use base64::Engine as _;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_boxforge");
/// Background colour of a miss (the ray caster's clear colour, as bytes).
const MISS: [u8; 3] = [20, 20, 26];

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("boxforge-web-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    assert_eq!(info.color_type, png::ColorType::Rgba, "boxforge render writes RGBA");
    (info.width, info.height, buf)
}

/// Kills the server when the test ends.
struct Served(std::process::Child);
impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_viewer_compiles_every_module_in_tint_and_matches_the_native_renderer() {
    // `scripts/test.sh --quick` leaves the browser out of the inner loop;
    // the full command (and CI) never sets this.
    if std::env::var_os("BOXFORGE_NO_BROWSER").is_some() {
        eprintln!("skipped: BOXFORGE_NO_BROWSER is set (scripts/test.sh --quick)");
        return;
    }
    let chromium = cdp::chromium();
    assert!(
        Path::new(&chromium).exists(),
        "{chromium} is missing: this test needs Chromium (sudo apt-get install -y chromium; scripts/test.sh installs it when run as root)"
    );
    let dir = temp("site");
    let site = dir.join("site");
    let out = Command::new(BIN).args(["web", "-o"]).arg(&site).output().unwrap();
    assert!(out.status.success(), "boxforge web failed: {}", String::from_utf8_lossy(&out.stderr));
    // Serve it on any free port; the first stdout line names the URL.
    let mut child = Command::new(BIN)
        .args(["web", "--serve", "--port", "0", "-o"])
        .arg(&site)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let _served = Served(child);
    let mut line = String::new();
    std::io::BufReader::new(stdout).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://127.0.0.1:")).expect("a URL").to_string();

    eprintln!("web: site served at {url}; starting {chromium}");
    let mut browser = cdp::Browser::open(&url, 1000).expect("chromium with WebGPU");
    eprintln!("web: page open");
    // The page loads its module asynchronously: wait for the hooks, then for the viewer's start.
    let started = std::time::Instant::now();
    while browser.eval("typeof window.boxforge === 'object'").ok() != Some(serde_json::Value::Bool(true)) {
        assert!(
            started.elapsed().as_secs() < 60,
            "the page defined no window.boxforge within 60 s; page log:\n{}",
            browser.log.join("\n")
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    browser
        .eval("Promise.race([window.boxforge.ready.then(() => true), new Promise((_, no) => setTimeout(() => no(new Error('the viewer was not ready after 60 s')), 60000))])")
        .expect("the viewer starts");

    // 1. Tint accepts every module of the catalog (all layouts and variants)
    // and every ray-casting shader of the viewer.
    eprintln!("web: viewer ready; compiling every module in Tint");
    let compiled = browser.eval("window.boxforge.compileAll()").expect("compileAll");
    let compiled = compiled.as_array().expect("a list");
    let catalog: serde_json::Value =
        serde_json::from_slice(&std::fs::read(site.join("catalog.json")).unwrap()).unwrap();
    let viewer_shaders: usize = catalog["filters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["shaders"].as_object().unwrap().values().map(|l| l.as_object().unwrap().len()).sum::<usize>())
        .sum();
    assert_eq!(
        compiled.len(),
        catalog["modules"].as_array().unwrap().len() + viewer_shaders,
        "every module and viewer shader (iso step, iso exact, DVR per layout) was compiled"
    );
    assert!(viewer_shaders >= 6 * 3, "the viewer shaders of bcc7, fcc6 and cc_tricubic at least");
    let failures: Vec<String> = compiled
        .iter()
        .filter(|c| !c["errors"].as_array().unwrap().is_empty())
        .map(|c| {
            format!(
                "{}:\n{}",
                c["file"],
                c["errors"].as_array().unwrap().iter().map(|e| e.as_str().unwrap_or("")).collect::<Vec<_>>().join("\n")
            )
        })
        .collect();
    assert!(
        failures.is_empty(),
        "Chrome's WGSL compiler (Tint) refuses {} module(s):\n{}",
        failures.len(),
        failures.join("\n\n")
    );

    // 2. The same scene in the page and with `boxforge render` on lavapipe.
    let size = 160u32;
    for filter in ["bcc7", "fcc6", "cc_tricubic"] {
        let scene = serde_json::json!({ "filter": filter, "mlN": 41, "iso": 0.5, "size": size, "view": [30, 25], "hit": "step", "frames": 2 });
        let web = browser
            .eval(&format!("window.boxforge.renderForTest({scene})"))
            .unwrap_or_else(|e| panic!("{filter}: {e}"));
        let rgba = base64::engine::general_purpose::STANDARD.decode(web["rgba"].as_str().unwrap()).unwrap();
        assert_eq!(rgba.len(), (size * size * 4) as usize);
        let png = dir.join(format!("{filter}.png"));
        let native = Command::new(BIN)
            .args(["render", "--filter", filter, "--volume", "ml:41", "--iso", "0.5", "--view", "30,25", "--size"])
            .arg(size.to_string())
            .arg("--out")
            .arg(&png)
            .output()
            .unwrap();
        assert!(native.status.success(), "{filter}: {}", String::from_utf8_lossy(&native.stderr));
        let (w, h, reference) = read_png(&png);
        assert_eq!((w, h), (size, size));
        let sq: f64 = rgba.iter().zip(&reference).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum();
        let rms = (sq / rgba.len() as f64).sqrt();
        let miss = |p: &[u8]| p[..3] == MISS;
        let hits_web = rgba.chunks(4).filter(|p| !miss(p)).count();
        let differ = rgba.chunks(4).zip(reference.chunks(4)).filter(|(a, b)| miss(a) != miss(b)).count();
        let share = differ as f64 / (size * size) as f64;
        eprintln!(
            "{filter}: browser vs native RMS {:.3}/255, hit/miss differs at {differ} pixels ({:.3}%), {hits_web} hits; {} samples, {:.1} ms/frame at {size}^2 on {}",
            rms,
            100.0 * share,
            web["samples"],
            web["ms"].as_f64().unwrap_or(0.0),
            web["adapter"]
        );
        assert!(hits_web > (size * size / 20) as usize, "{filter}: the page shows the surface ({hits_web} hit pixels)");
        assert!(rms < 3.0, "{filter}: browser vs native RMS {rms:.3}/255 (want < 3)");
        assert!(share < 0.01, "{filter}: hit/miss differs at {:.2}% of pixels (want < 1%)", 100.0 * share);
    }

    // DVR: the same pre-integrated volume rendering in the page and natively.
    let scene = serde_json::json!({ "filter": "bcc7", "mlN": 41, "mode": "dvr", "tf": "marschner-lobb", "size": size, "view": [30, 25], "frames": 2 });
    let web = browser.eval(&format!("window.boxforge.renderForTest({scene})")).expect("bcc7 DVR in the page");
    let rgba = base64::engine::general_purpose::STANDARD.decode(web["rgba"].as_str().unwrap()).unwrap();
    let step = catalog["dvr"]["step"].as_f64().unwrap().to_string();
    let png = dir.join("bcc7-dvr.png");
    let native = Command::new(BIN)
        .args([
            "render",
            "--mode",
            "dvr",
            "--tf",
            "marschner-lobb",
            "--filter",
            "bcc7",
            "--volume",
            "ml:41",
            "--view",
            "30,25",
        ])
        .args(["--step", &step, "--size", &size.to_string(), "--out"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(native.status.success(), "bcc7 DVR: {}", String::from_utf8_lossy(&native.stderr));
    let (_, _, reference) = read_png(&png);
    assert_eq!(rgba.len(), reference.len());
    let sq: f64 = rgba.iter().zip(&reference).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum();
    let rms = (sq / rgba.len() as f64).sqrt();
    let shown = rgba.chunks(4).filter(|p| p[..3] != MISS).count();
    eprintln!(
        "bcc7 DVR: browser vs native RMS {rms:.3}/255, {shown} pixels not background, {:.1} ms/frame",
        web["ms"].as_f64().unwrap_or(0.0)
    );
    assert!(shown > (size * size / 20) as usize, "bcc7 DVR: the page shows the volume ({shown} pixels)");
    assert!(rms < 3.0, "bcc7 DVR: browser vs native RMS {rms:.3}/255 (want < 3)");

    // The speed figure: a 256^2 bcc7 isosurface frame (no target on SwiftShader; reported).
    let t = browser
        .eval(&format!(
            "window.boxforge.renderForTest({})",
            serde_json::json!({ "filter": "bcc7", "mlN": 41, "iso": 0.5, "size": 256, "view": [30, 25], "frames": 3 })
        ))
        .expect("256^2 frame");
    eprintln!(
        "bcc7 ML 41, 256^2 isosurface: {:.1} ms/frame (median of 3) on {}",
        t["ms"].as_f64().unwrap_or(0.0),
        t["adapter"]
    );

    // The README's screenshot: the page as a user sees it.
    browser
        .eval(&format!(
            "window.boxforge.renderForTest({})",
            serde_json::json!({ "filter": "bcc7", "mlN": 41, "iso": 0.5, "size": 512, "view": [30, 25] })
        ))
        .expect("512^2 frame");
    let shot = browser.screenshot().expect("screenshot");
    assert!(shot.starts_with(b"\x89PNG"), "a PNG screenshot");
    // Into the target folder: tests never write tracked files. The README's
    // picture is refreshed on purpose by scripts/refresh-docs-pictures.sh,
    // which names its destination in BOXFORGE_WEB_SCREENSHOT.
    let shot_path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("web-viewer.png");
    std::fs::write(&shot_path, &shot).unwrap();
    if let Some(dest) = std::env::var_os("BOXFORGE_WEB_SCREENSHOT") {
        std::fs::write(&dest, &shot).unwrap_or_else(|e| panic!("cannot write the screenshot to {dest:?}: {e}"));
    }
    eprintln!("screenshot: {}", shot_path.display());
    let _ = std::fs::remove_dir_all(&dir);
}
