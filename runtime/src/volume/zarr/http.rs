//! A read-only zarrs store over plain HTTP (`ureq`, no TLS): a key is a GET of `base/key` (404: absent), a
//! byte range a GET with a `Range` header, which must come back as 206
//! Partial Content. A server that ignores `Range` (Python's `http.server`)
//! answers 200 with the whole object: the range is then cut out of it here
//! (codecs such as blosc read parts of a chunk), and a sharded store, whose
//! point is fetching parts of a shard, is refused at open on such a server. Each request has a timeout and is
//! retried on connection errors and 5xx answers, with backoff.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use zarrs::storage::byte_range::{ByteRange, ByteRangeIterator};
use zarrs::storage::{Bytes, MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey};

/// How an [`HttpStore`] talks to its server.
#[derive(Clone, Debug)]
pub struct HttpOptions {
    /// The longest one request may take, connect to last byte.
    pub timeout: Duration,
    /// Further tries after a connection error or a 5xx answer.
    pub retries: u32,
}

impl Default for HttpOptions {
    /// 30 s per request and 2 retries; `BOXFORGE_HTTP_TIMEOUT_S` (seconds)
    /// overrides the timeout.
    fn default() -> Self {
        let timeout = std::env::var("BOXFORGE_HTTP_TIMEOUT_S")
            .ok()
            .and_then(|s| s.trim().parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s > 0.0)
            .map_or(Duration::from_secs(30), Duration::from_secs_f64);
        HttpOptions { timeout, retries: 2 }
    }
}

/// A Zarr store at an `http://` (or, with the `https` feature, `https://`) URL.
pub struct HttpStore {
    base: String,
    agent: ureq::Agent,
    options: HttpOptions,
    fetched: AtomicU64,
}

/// A request's answer: status, body and the declared length.
struct Answer {
    status: u16,
    body: Vec<u8>,
    length: Option<u64>,
}

/// Why a request failed, for the store error's text.
fn other(message: String) -> StorageError {
    StorageError::Other(message)
}

impl HttpStore {
    /// A store whose keys live under `base` (no trailing slash needed).
    pub fn new(base: &str, options: HttpOptions) -> HttpStore {
        let config =
            ureq::Agent::config_builder().timeout_global(Some(options.timeout)).http_status_as_error(false).build();
        HttpStore {
            base: base.trim_end_matches('/').to_string(),
            agent: config.into(),
            options,
            fetched: AtomicU64::new(0),
        }
    }

    /// Body bytes received so far (all requests).
    pub fn bytes_fetched(&self) -> u64 {
        self.fetched.load(Ordering::Relaxed)
    }

    /// Whether the server answers a Range request for `key` with 206
    /// Partial Content (Python's `http.server` answers 200 and everything).
    pub fn honours_range(&self, key: &StoreKey) -> Result<bool, StorageError> {
        Ok(matches!(self.request(key, Some("bytes=0-0"), false)?, Some(Answer { status: 206, .. })))
    }

    fn url(&self, key: &StoreKey) -> String {
        format!("{}/{}", self.base, key.as_str())
    }

    /// One request, retried; None for an absent key (404).
    fn request(&self, key: &StoreKey, range: Option<&str>, head: bool) -> Result<Option<Answer>, StorageError> {
        let url = self.url(key);
        let mut last = String::new();
        for attempt in 0..=self.options.retries {
            if attempt > 0 {
                std::thread::sleep(Duration::from_millis(200 << (attempt - 1)));
            }
            let result = if head {
                self.agent.head(&url).call()
            } else {
                let mut r = self.agent.get(&url);
                if let Some(range) = range {
                    r = r.header("Range", range);
                }
                r.call()
            };
            let response = match result {
                Ok(r) => r,
                Err(e) => {
                    last = format!("GET {url}: {e}");
                    continue;
                }
            };
            let status = response.status().as_u16();
            // 403: what a bucket without list rights answers for an absent key.
            if status == 404 || status == 403 {
                return Ok(None);
            }
            if status >= 500 {
                last = format!("GET {url}: the server answered {status}");
                continue;
            }
            if !(200..300).contains(&status) {
                return Err(other(format!("GET {url}: the server answered {status}")));
            }
            let length = response.headers().get("content-length").and_then(|v| v.to_str().ok()?.parse::<u64>().ok());
            if head {
                return Ok(Some(Answer { status, body: Vec::new(), length }));
            }
            match response.into_body().with_config().limit(u64::MAX).read_to_vec() {
                Ok(body) => {
                    self.fetched.fetch_add(body.len() as u64, Ordering::Relaxed);
                    return Ok(Some(Answer { status, body, length }));
                }
                Err(e) => last = format!("GET {url}: reading the answer failed: {e}"),
            }
        }
        Err(other(format!(
            "{last} (after {} tries; check the URL and that the server is up)",
            self.options.retries + 1
        )))
    }
}

fn range_header(r: &ByteRange) -> String {
    match r {
        ByteRange::FromStart(start, None) => format!("bytes={start}-"),
        ByteRange::FromStart(start, Some(len)) => format!("bytes={start}-{}", start + len.saturating_sub(1)),
        ByteRange::Suffix(len) => format!("bytes=-{len}"),
    }
}

impl ReadableStorageTraits for HttpStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        Ok(self.request(key, None, false)?.map(|a| Bytes::from(a.body)))
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let mut parts = Vec::new();
        for r in byte_ranges {
            if let ByteRange::FromStart(_, Some(0)) = r {
                parts.push(Ok(Bytes::new()));
                continue;
            }
            match self.request(key, Some(&range_header(&r)), false)? {
                None => return Ok(None),
                Some(Answer { status: 206, body, .. }) => parts.push(Ok(Bytes::from(body))),
                // The whole object (a server that ignores Range): the range
                // cut out of it here. Correct, if wasteful; a sharded store
                // is refused at open on such a server (`honours_range`).
                Some(Answer { body, .. }) => {
                    let len = body.len() as u64;
                    if r.end(len) > len || r.start(len) > r.end(len) {
                        return Err(other(format!("GET {}: {r} is past the object's {len} bytes", self.url(key))));
                    }
                    parts.push(Ok(Bytes::from(body).slice(r.to_range_usize(len))));
                }
            }
        }
        Ok(Some(Box::new(parts.into_iter())))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        match self.request(key, None, true)? {
            None => Ok(None),
            Some(Answer { length: Some(len), .. }) => Ok(Some(len)),
            Some(Answer { length: None, .. }) => Ok(self.get(key)?.map(|b| b.len() as u64)),
        }
    }

    fn supports_get_partial(&self) -> bool {
        true
    }
}
