//! A minimal Chrome DevTools protocol client for the browser tests: starts
//! Debian's Chromium headless with WebGPU on SwiftShader (the flags of
//! docs/TESTING.md), opens one page and evaluates
//! JavaScript in it over the page's WebSocket.

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The Chromium binary: `BOXFORGE_CHROMIUM` (scripts/ensure-chromium.sh sets
/// it), else Debian's real binary (the /usr/bin/chromium wrapper script
/// misbehaves headless).
pub fn chromium() -> String {
    std::env::var("BOXFORGE_CHROMIUM")
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "/usr/lib/chromium/chromium".into())
}

pub struct Browser {
    child: Child,
    socket: tungstenite::WebSocket<TcpStream>,
    next_id: u64,
    _profile: std::path::PathBuf,
    /// Console messages and uncaught exceptions of the page so far.
    pub log: Vec<String>,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self._profile);
    }
}

/// GET of a small JSON document over HTTP/1.1 (Chromium answers HTTP/1.0
/// with an empty reply, and keeps the connection open after its reply, so
/// the body is read by its Content-Length).
fn http_json(port: u16, path: &str) -> Result<Value, String> {
    let s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10))).map_err(|e| e.to_string())?;
    let mut w = &s;
    write!(w, "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n")
        .map_err(|e| e.to_string())?;
    let mut r = BufReader::new(&s);
    let mut length = None;
    loop {
        let mut line = String::new();
        r.read_line(&mut line).map_err(|e| format!("GET {path}: {e}"))?;
        let line = line.trim_end();
        if line.is_empty() {
            break;
        }
        if let Some((k, v)) = line.split_once(':') {
            if k.eq_ignore_ascii_case("content-length") {
                length = v.trim().parse::<usize>().ok();
            }
        }
    }
    let mut body = vec![0; length.ok_or(format!("GET {path}: no Content-Length"))?];
    r.read_exact(&mut body).map_err(|e| format!("GET {path}: {e}"))?;
    serde_json::from_slice(&body).map_err(|e| format!("{e}: {}", String::from_utf8_lossy(&body)))
}

impl Browser {
    /// Starts Chromium on `url` and connects to its page.
    pub fn open(url: &str, window: u32) -> Result<Browser, String> {
        let profile = std::env::temp_dir().join(format!("boxforge-chromium-{}-{}", std::process::id(), window));
        let _ = std::fs::remove_dir_all(&profile);
        let chromium = chromium();
        let mut child = Command::new(&chromium)
            .args([
                "--headless=new",
                "--no-sandbox",
                "--hide-scrollbars",
                &format!("--window-size={window},{window}"),
                "--enable-unsafe-webgpu",
                "--enable-features=Vulkan",
                "--use-vulkan=swiftshader",
                "--use-angle=swiftshader",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
                "--disable-quic",
                &format!("--user-data-dir={}", profile.display()),
                "--remote-debugging-port=0",
                url,
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot start {chromium}: {e} (install it: sudo apt-get install -y chromium, or run scripts/test.sh as root)"))?;
        // "DevTools listening on ws://127.0.0.1:PORT/devtools/browser/..." on stderr.
        let stderr = child.stderr.take().expect("piped");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(rest) = line.split("ws://127.0.0.1:").nth(1) {
                    let port: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
                    let _ = tx.send(port);
                }
            }
        });
        let port: u16 = rx
            .recv_timeout(Duration::from_secs(30))
            .map_err(|_| "chromium printed no DevTools port within 30 s".to_string())?
            .parse()
            .map_err(|e| format!("bad DevTools port: {e}"))?;
        let started = Instant::now();
        let ws_url = loop {
            let list = http_json(port, "/json/list")?;
            if let Some(u) = list.as_array().and_then(|a| {
                a.iter()
                    .find(|t| t["type"] == "page")
                    .and_then(|t| t["webSocketDebuggerUrl"].as_str().map(String::from))
            }) {
                break u;
            }
            if started.elapsed() > Duration::from_secs(20) {
                return Err("chromium opened no page".into());
            }
            std::thread::sleep(Duration::from_millis(100));
        };
        let stream = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
        // A page that stops answering fails the test instead of hanging it.
        stream.set_read_timeout(Some(Duration::from_secs(360))).map_err(|e| e.to_string())?;
        let (socket, _) = tungstenite::client(ws_url.as_str(), stream).map_err(|e| format!("websocket: {e}"))?;
        let mut b = Browser { child, socket, next_id: 1, _profile: profile, log: Vec::new() };
        b.call("Runtime.enable", json!({}))?;
        Ok(b)
    }

    /// One DevTools command; waits for its reply (console and exception
    /// events in between go to [`Browser::log`], others are dropped).
    pub fn call(&mut self, method: &str, params: Value) -> Result<Value, String> {
        let id = self.next_id;
        self.next_id += 1;
        let msg = json!({ "id": id, "method": method, "params": params }).to_string();
        self.socket.send(tungstenite::Message::text(msg)).map_err(|e| e.to_string())?;
        loop {
            let m = self.socket.read().map_err(|e| format!("{method}: {e}; page log:\n{}", self.log.join("\n")))?;
            if let tungstenite::Message::Text(t) = m {
                let v: Value = serde_json::from_str(t.as_str()).map_err(|e| e.to_string())?;
                match v["method"].as_str() {
                    Some("Runtime.consoleAPICalled") => {
                        let args: Vec<String> = v["params"]["args"]
                            .as_array()
                            .map(|a| {
                                a.iter()
                                    .map(|x| {
                                        x["value"]
                                            .as_str()
                                            .map(String::from)
                                            .unwrap_or_else(|| x["description"].to_string())
                                    })
                                    .collect()
                            })
                            .unwrap_or_default();
                        self.log.push(format!(
                            "console.{}: {}",
                            v["params"]["type"].as_str().unwrap_or("log"),
                            args.join(" ")
                        ));
                    }
                    Some("Runtime.exceptionThrown") => {
                        let d = &v["params"]["exceptionDetails"];
                        self.log.push(format!(
                            "exception: {}",
                            d["exception"]["description"].as_str().unwrap_or(d["text"].as_str().unwrap_or(""))
                        ));
                    }
                    _ => {}
                }
                if v["id"] == id {
                    if let Some(err) = v.get("error") {
                        return Err(format!("{method}: {err}"));
                    }
                    return Ok(v["result"].clone());
                }
            }
        }
    }

    /// Evaluates `expression` in the page (awaiting a promise) and returns its JSON value;
    /// a thrown exception comes back as Err with its text.
    pub fn eval(&mut self, expression: &str) -> Result<Value, String> {
        let r = self.call(
            "Runtime.evaluate",
            json!({ "expression": expression, "awaitPromise": true, "returnByValue": true, "timeout": 300000 }),
        )?;
        if let Some(ex) = r.get("exceptionDetails") {
            let text = ex["exception"]["description"].as_str().or(ex["text"].as_str()).unwrap_or("exception");
            return Err(format!("{text}; page log:\n{}", self.log.join("\n")));
        }
        Ok(r["result"]["value"].clone())
    }

    /// A PNG screenshot of the page.
    pub fn screenshot(&mut self) -> Result<Vec<u8>, String> {
        use base64::Engine as _;
        let r = self.call("Page.captureScreenshot", json!({ "format": "png" }))?;
        base64::engine::general_purpose::STANDARD.decode(r["data"].as_str().unwrap_or("")).map_err(|e| e.to_string())
    }
}
