//! A static file server on 127.0.0.1 for the viewer (`boxforge web --serve`):
//! GET and HEAD of the files under one folder, nothing else.

use super::WebError;
use std::path::{Component, Path, PathBuf};

/// A bound server: [`Server::url`] to open, [`Server::run`] to answer requests.
pub struct Server {
    http: tiny_http::Server,
    root: PathBuf,
    url: String,
}

/// Binds 127.0.0.1:`port` (0: any free port) for the files under `root`.
pub fn serve(root: &Path, port: u16) -> Result<Server, WebError> {
    if !root.join("index.html").is_file() {
        return Err(WebError::NoSite { root: root.to_path_buf() });
    }
    let http =
        tiny_http::Server::http(("127.0.0.1", port)).map_err(|e| WebError::Listen { port, error: e.to_string() })?;
    let port = http.server_addr().to_ip().map(|a| a.port()).unwrap_or(port);
    Ok(Server { http, root: root.to_path_buf(), url: format!("http://127.0.0.1:{port}/") })
}

/// The content type of a file of the site, by extension.
fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" => "application/json",
        "wgsl" | "md" | "txt" => "text/plain; charset=utf-8",
        "png" => "image/png",
        _ => "application/octet-stream",
    }
}

/// The file under `root` that a request path names (`/` is index.html);
/// None for paths that leave the folder.
fn resolve(root: &Path, url: &str) -> Option<PathBuf> {
    let path = url.split(['?', '#']).next().unwrap_or("/");
    let mut out = root.to_path_buf();
    for c in Path::new(path.trim_start_matches('/')).components() {
        match c {
            Component::Normal(part) => out.push(part),
            Component::CurDir => {}
            _ => return None,
        }
    }
    if out.is_dir() {
        out.push("index.html");
    }
    Some(out)
}

impl Server {
    /// `http://127.0.0.1:PORT/`.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Answers requests until the process ends.
    pub fn run(self) {
        for request in self.http.incoming_requests() {
            let method = request.method().clone();
            let file = match method {
                tiny_http::Method::Get | tiny_http::Method::Head => resolve(&self.root, request.url()),
                _ => {
                    let _ = request.respond(tiny_http::Response::from_string("only GET").with_status_code(405));
                    continue;
                }
            };
            let response = match file.as_ref().and_then(|p| std::fs::read(p).ok().map(|b| (p, b))) {
                Some((path, bytes)) => {
                    let header =
                        |k: &str, v: &str| tiny_http::Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("header");
                    tiny_http::Response::from_data(bytes)
                        .with_header(header("Content-Type", content_type(path)))
                        .with_header(header("Cache-Control", "no-store"))
                }
                None => tiny_http::Response::from_data(b"not found".to_vec()).with_status_code(404),
            };
            let _ = request.respond(response);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_stay_in_the_folder() {
        let root = Path::new("/site");
        assert_eq!(resolve(root, "/viewer.js?x=1"), Some(PathBuf::from("/site/viewer.js")));
        assert_eq!(resolve(root, "/shaders/a.wgsl"), Some(PathBuf::from("/site/shaders/a.wgsl")));
        assert_eq!(resolve(root, "/../etc/passwd"), None);
        assert_eq!(resolve(root, "/a/../../b"), None);
        assert_eq!(content_type(Path::new("x.wgsl")), "text/plain; charset=utf-8");
    }
}
