//! OME-Zarr over HTTP from static servers on 127.0.0.1: Python's
//! `http.server` (which ignores Range) serves an unsharded store that renders
//! as it does from disk, and a sharded one gets a clear refusal; a server
//! that honours Range (here, in the test, counting what it sends) serves a
//! sharded store that renders as from disk, each byte of the store sent at
//! most once; a 404 and a server that never answers are one line, exit 2.

use std::io::Read;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ome-zarr")
}

/// A child process killed when dropped.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// Python's `http.server` on `dir` (it answers Range requests with 200 and the whole file).
fn python_server(dir: &Path) -> (Server, String) {
    let port = free_port();
    let child = Command::new("python3")
        .args(["-m", "http.server", &port.to_string(), "--bind", "127.0.0.1", "--directory"])
        .arg(dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("python3 -m http.server");
    let started = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(started.elapsed() < Duration::from_secs(20), "http.server did not start");
        std::thread::sleep(Duration::from_millis(50));
    }
    (Server(child), format!("http://127.0.0.1:{port}"))
}

/// A static server that honours `Range: bytes=a-b`, `bytes=a-` and
/// `bytes=-n`, counting the body bytes it sends.
fn range_server(root: PathBuf) -> (String, Arc<AtomicU64>) {
    let server = tiny_http::Server::http("127.0.0.1:0").unwrap();
    let port = server.server_addr().to_ip().unwrap().port();
    let sent = Arc::new(AtomicU64::new(0));
    let counter = sent.clone();
    std::thread::spawn(move || {
        for req in server.incoming_requests() {
            let path = root.join(req.url().trim_start_matches('/'));
            let Ok(bytes) = std::fs::read(&path) else {
                let _ = req.respond(tiny_http::Response::empty(404));
                continue;
            };
            let range = req.headers().iter().find(|h| h.field.equiv("Range")).map(|h| h.value.to_string());
            let n = bytes.len();
            let slice = range.as_deref().and_then(|r| r.strip_prefix("bytes=")).map(|r| {
                let (a, b) = r.split_once('-').unwrap();
                match (a.parse::<usize>().ok(), b.parse::<usize>().ok()) {
                    (Some(a), Some(b)) => a..(b + 1).min(n),
                    (Some(a), None) => a..n,
                    (None, Some(k)) => n.saturating_sub(k)..n,
                    (None, None) => 0..n,
                }
            });
            let head = req.method() == &tiny_http::Method::Head;
            let (status, body) = match slice {
                Some(s) => (206, bytes[s].to_vec()),
                None => (200, bytes),
            };
            if !head {
                counter.fetch_add(body.len() as u64, Ordering::Relaxed);
            }
            let _ = req.respond(tiny_http::Response::from_data(body).with_status_code(status));
        }
    });
    (format!("http://127.0.0.1:{port}"), sent)
}

/// `boxforge render` with `args`; (exit code, stderr, the image if written).
fn render(args: &[&str], out: &Path, env: &[(&str, &str)]) -> (Option<i32>, String, Option<Vec<u8>>) {
    let _ = std::fs::remove_file(out);
    let mut child = Command::new(env!("CARGO_BIN_EXE_boxforge"))
        .args(["render", "--filter", "bcc7", "--size", "48", "--out", out.to_str().unwrap()])
        .args(args)
        .envs(env.iter().copied())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(90) {
            let _ = child.kill();
            panic!("render {args:?} hangs");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let code = child.wait().unwrap().code();
    (code, err, std::fs::read(out).ok())
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("boxforge-zarr-http-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn one_error_line(code: Option<i32>, err: &str, fragment: &str) -> bool {
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty() && !l.contains("XDG_RUNTIME_DIR")).collect();
    code == Some(2) && lines.len() == 1 && lines[0].starts_with("error: ") && lines[0].contains(fragment)
}

#[test]
fn an_unsharded_store_renders_from_python_http_server_as_from_disk_and_a_sharded_one_is_refused() {
    let dir = temp("python");
    let (_server, base) = python_server(&fixtures());
    let disk = fixtures().join("v04-u16.zarr");
    let url = format!("{base}/v04-u16.zarr");
    for extra in [&[][..], &["--gpu-budget", "64MiB"][..]] {
        let mut a = vec!["--iso", "90", "--volume", disk.to_str().unwrap()];
        a.extend(extra);
        let (code, err, from_disk) = render(&a, &dir.join("a.png"), &[]);
        assert_eq!(code, Some(0), "{err}");
        let mut b = vec!["--iso", "90", "--volume", &url];
        b.extend(extra);
        let (code, err, from_url) = render(&b, &dir.join("b.png"), &[]);
        assert_eq!(code, Some(0), "{err}");
        assert_eq!(from_disk, from_url, "{extra:?}");
    }
    let sharded = format!("{base}/v05-f32-czyx.zarr");
    let (code, err, _) = render(&["--volume", &sharded], &dir.join("c.png"), &[]);
    assert!(one_error_line(code, &err, "Range"), "exit {code:?}: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_sharded_store_renders_from_a_range_server_fetching_each_byte_at_most_once() {
    let dir = temp("range");
    let (base, sent) = range_server(fixtures());
    let disk = fixtures().join("v05-f32-czyx.zarr");
    let url = format!("{base}/v05-f32-czyx.zarr");
    let args = |v: &str| ["--iso", "100", "--channel", "1", "--volume", v].map(String::from);
    let (disk_args, url_args) = (args(disk.to_str().unwrap()), args(&url));
    let (code, err, from_disk) = render(&disk_args.each_ref().map(String::as_str), &dir.join("a.png"), &[]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err, from_url) = render(&url_args.each_ref().map(String::as_str), &dir.join("b.png"), &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(from_disk, from_url);
    // Every file of the store, once: the bound on what a frame may fetch.
    fn bytes_under(p: &Path) -> u64 {
        std::fs::read_dir(p)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                if e.file_type().unwrap().is_dir() {
                    bytes_under(&e.path())
                } else {
                    e.metadata().unwrap().len()
                }
            })
            .sum()
    }
    let fetched = sent.load(Ordering::Relaxed);
    assert!(
        fetched > 0 && fetched <= bytes_under(&disk),
        "fetched {fetched} bytes of a {}-byte store",
        bytes_under(&disk)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_store_and_a_stalled_server_are_one_line_and_exit_2() {
    let dir = temp("bad");
    let (_server, base) = python_server(&dir);
    let (code, err, _) = render(&["--volume", &format!("{base}/nothing.zarr")], &dir.join("a.png"), &[]);
    assert!(one_error_line(code, &err, "nothing.zarr"), "exit {code:?}: {err}");
    // A server that accepts and never answers.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let held = std::thread::spawn(move || {
        let mut open = Vec::new();
        for s in listener.incoming().take(8) {
            open.push(s);
        }
    });
    let started = Instant::now();
    let url = format!("http://127.0.0.1:{port}/stalled.zarr");
    let (code, err, _) = render(&["--volume", &url], &dir.join("b.png"), &[("BOXFORGE_HTTP_TIMEOUT_S", "1")]);
    assert!(one_error_line(code, &err, "stalled.zarr"), "exit {code:?}: {err}");
    assert!(started.elapsed() < Duration::from_secs(30), "took {:?}", started.elapsed());
    drop(held);
    let (code, err, _) = render(&["--volume", "https://127.0.0.1:1/x.zarr"], &dir.join("c.png"), &[]);
    assert!(one_error_line(code, &err, "http://"), "exit {code:?}: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}
