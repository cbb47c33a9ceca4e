//! Nothing lost: `render` writes its PNG atomically (temporary file, then
//! rename), so a run killed at any moment leaves the old file or the new one.

use std::process::{Command, Stdio};
use std::time::Duration;

/// The size of the image when the whole PNG decodes (every row, the final
/// chunk and its checksum), None otherwise: a file cut anywhere, even after
/// its signature and header, does not decode.
fn whole_png(bytes: &[u8]) -> Option<(u32, u32)> {
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().ok()?;
    let mut buf = vec![0; reader.output_buffer_size()?];
    reader.next_frame(&mut buf).ok()?;
    reader.finish().ok()?;
    Some((reader.info().width, reader.info().height))
}

#[test]
fn the_check_rejects_a_truncated_png() {
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, 8, 8);
        enc.set_color(png::ColorType::Rgba);
        enc.write_header().unwrap().write_image_data(&[7; 8 * 8 * 4]).unwrap();
    }
    assert_eq!(whole_png(&bytes), Some((8, 8)));
    for cut in [9, 40, bytes.len() / 2, bytes.len() - 1] {
        assert_eq!(whole_png(&bytes[..cut]), None, "cut at {cut} of {}", bytes.len());
    }
}

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
        assert!(now == old || whole_png(&now) == Some((96, 96)), "killed after {delay_ms} ms: a partial file");
    }
    // Left to finish, the run replaces the file with a whole PNG.
    std::fs::write(&out, &old).unwrap();
    let status = render("24").wait().unwrap();
    if status.success() {
        assert_eq!(whole_png(&std::fs::read(&out).unwrap()), Some((24, 24)));
    } else {
        // No Vulkan driver here: the old file must be untouched.
        assert_eq!(std::fs::read(&out).unwrap(), old);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
