//! Nothing lost: `render` writes its PNG atomically (temporary file, then
//! rename), so a run killed at any moment leaves the old file or the new one.

use std::process::{Command, Stdio};
use std::time::Duration;

const PNG_SIGNATURE: &[u8] = &[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];

#[test]
fn a_killed_render_leaves_the_old_file_or_the_new_one() {
    let dir = std::env::temp_dir().join(format!("boxforge-atomic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("image.png");
    let old = b"the previous image".to_vec();
    let render = |size: &str| {
        Command::new(env!("CARGO_BIN_EXE_boxforge"))
            .args(["render", "--filter", "bcc_linear", "--volume", "ml:16", "--size", size, "--out"])
            .arg(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("run boxforge")
    };
    // Kill runs at several moments: the file is always one whole version.
    for delay_ms in [50u64, 200, 400, 800] {
        std::fs::write(&out, &old).unwrap();
        let mut child = render("96");
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = child.kill();
        let _ = child.wait();
        let now = std::fs::read(&out).unwrap();
        assert!(now == old || now.starts_with(PNG_SIGNATURE), "killed after {delay_ms} ms: a partial file");
    }
    // Left to finish, the run replaces the file with a whole PNG.
    std::fs::write(&out, &old).unwrap();
    let status = render("24").wait().unwrap();
    if status.success() {
        let now = std::fs::read(&out).unwrap();
        assert!(now.starts_with(PNG_SIGNATURE) && now.len() > 60);
        let decoder = png::Decoder::new(std::io::Cursor::new(now));
        let reader = decoder.read_info().expect("a whole PNG");
        assert_eq!((reader.info().width, reader.info().height), (24, 24));
    } else {
        // No Vulkan driver here: the old file must be untouched.
        assert_eq!(std::fs::read(&out).unwrap(), old);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
