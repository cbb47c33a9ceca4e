//! 1D transfer functions for direct volume rendering: the JSON file format,
//! the built-in presets (runtime/presets/), the sampled table both renderers
//! use, the pre-integration table (Engel, Kraus and Ertl 2001) and the
//! per-interval opacity test behind TF-aware empty-space skipping.
//!
//! File format (JSON):
//!
//! ```json
//! { "range": [0, 255],
//!   "points": [ { "value": 0,   "color": [0, 0, 0], "opacity": 0 },
//!               { "value": 210, "color": [1, 0.95, 0.85], "opacity": 0.25 } ] }
//! ```
//!
//! `range` is the data interval the tables span; `points` are control points
//! with strictly increasing `value`s inside `range`, a `color` (RGB in
//! [0, 1], the emitted colour) and an `opacity` in [0, 1]. Between points
//! the colour and opacity are linear; outside the first and last point they
//! keep the end points' values, and outside `range` the table is clamped.
//! `opacity` is the opacity of a slab one cell thick ([`REF_STEP`]); the
//! renderers turn it into an extinction tau = -ln(1 - opacity) (opacity
//! capped at [`MAX_OPACITY`]), so a step of length s gets
//! alpha' = 1 - exp(-tau s) = 1 - (1 - opacity)^(s / REF_STEP), the usual
//! opacity correction. A `description` string is allowed and ignored.
//!
//! Instead of `points`, `"colormap": "file.png"` (relative to the JSON file)
//! takes the control points from the first row of an RGBA PNG spread evenly
//! over `range`: RGB the colour, alpha the opacity.
//!
//! Empty-space skipping treats a block as transparent only when the sampled
//! table is zero one entry beyond the block's [min, max] on both sides
//! ([`Tf1d::transparent`]): give the values to be skipped a zero-opacity
//! stretch (two zero points), not a single zero point where a ramp starts.

/// Reference step (cells) of the `opacity` of a control point.
pub const REF_STEP: f64 = 1.0;
/// Opacities are capped here, so the extinction stays finite.
pub const MAX_OPACITY: f64 = 0.9999;
/// Entries of the sampled 1D table (over `range`, both ends included).
pub const TABLE_SIZE: usize = 256;
/// Entries per axis of the pre-integration table (front x back value).
pub const PREINT_SIZE: usize = 128;

/// Built-in presets: (name, JSON text).
pub const PRESETS: &[(&str, &str)] = &[
    ("mni-tissue", include_str!("../../../presets/mni-tissue.json")),
    ("mni-opaque", include_str!("../../../presets/mni-opaque.json")),
    ("marschner-lobb", include_str!("../../../presets/marschner-lobb.json")),
];

/// One control point of a transfer function.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "files", derive(serde::Deserialize), serde(deny_unknown_fields))]
pub struct ControlPoint {
    /// Data value.
    pub value: f64,
    /// Emitted RGB in [0, 1].
    pub color: [f64; 3],
    /// Opacity of a slab [`REF_STEP`] thick, in [0, 1].
    pub opacity: f64,
}

// The JSON form (feature `files`): without it a host builds its
// [`TransferFunction`] from points in code.
#[cfg(feature = "files")]
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct TfFile {
    range: [f64; 2],
    #[serde(default)]
    points: Option<Vec<ControlPoint>>,
    #[serde(default)]
    colormap: Option<String>,
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
}

#[cfg(feature = "files")]
struct TfFileChecked {
    range: [f64; 2],
    points: Vec<ControlPoint>,
}

#[cfg(feature = "files")]
/// Control points from a colormap PNG: the first row's pixels, evenly over
/// `range` (first pixel at lo, last at hi), RGB the colour and alpha the
/// opacity (8 or 16 bits, grey or RGB, with an alpha channel).
fn colormap_points(path: &std::path::Path, range: [f64; 2]) -> Result<Vec<ControlPoint>, String> {
    let bytes =
        std::fs::read(path).map_err(|e| format!("cannot read it: {e}; check the path (relative to the JSON file)"))?;
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(|e| format!("not a readable PNG ({e})"))?;
    let mut buf = vec![0u8; reader.output_buffer_size().ok_or("the PNG is too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| format!("not a readable PNG ({e})"))?;
    let channels = match info.color_type {
        png::ColorType::Rgba => 4,
        png::ColorType::GrayscaleAlpha => 2,
        _ => return Err("has no alpha channel: save it as RGBA (alpha = opacity)".into()),
    };
    let w = info.width as usize;
    if w < 2 {
        return Err(format!("is {w} pixel(s) wide: a colormap needs at least 2 (one row, lo to hi)"));
    }
    let row = &buf[..w * channels];
    Ok((0..w)
        .map(|i| {
            let px = &row[i * channels..(i + 1) * channels];
            let c = |k: usize| px[if channels == 4 { k } else { 0 }] as f64 / 255.0;
            ControlPoint {
                value: range[0] + (range[1] - range[0]) * i as f64 / (w - 1) as f64,
                color: [c(0), c(1), c(2)],
                opacity: px[channels - 1] as f64 / 255.0,
            }
        })
        .collect())
}

/// A piecewise-linear 1D transfer function.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    /// Where it came from (a preset name or a file path), for messages.
    pub name: String,
    /// The data interval its tables span.
    pub range: [f64; 2],
    /// Control points, values strictly increasing.
    pub points: Vec<ControlPoint>,
}

/// Why a transfer function was refused: the preset name or file it came
/// from, and the problem (with its fix). One line.
#[cfg(feature = "files")]
#[derive(Debug, thiserror::Error)]
#[error("{name}: {problem}")]
pub struct TfError {
    /// The argument or source name the transfer function was asked by.
    pub name: String,
    pub problem: TfProblem,
}

/// What is wrong with a transfer function.
#[cfg(feature = "files")]
#[derive(Debug, thiserror::Error)]
pub enum TfProblem {
    #[error("cannot read the transfer function file: {error}; check the path, or {}", usage())]
    Unreadable { error: std::io::Error },
    #[error("no such preset or file; {}", usage())]
    Unknown,
    #[error("not a valid transfer function ({error}); {}", usage())]
    Json { error: serde_json::Error },
    #[error("\"range\" [{lo}, {hi}] must be two finite numbers with lo < hi, e.g. [0, 255]")]
    Range { lo: f64, hi: f64 },
    #[error("colormap {}: {problem}", path.display())]
    Colormap { path: std::path::PathBuf, problem: String },
    #[error("give either \"points\" or \"colormap\", not both")]
    PointsAndColormap,
    #[error("no \"points\" (or \"colormap\": a PNG whose first row spans \"range\"); {}", usage())]
    NoPoints,
    #[error("{count} control point(s): give at least two in \"points\" (values increasing inside \"range\")")]
    TooFewPoints { count: usize },
    #[error("point {index}: value {value} is outside \"range\" [{lo}, {hi}]; widen the range or move the point")]
    Outside { index: usize, value: f64, lo: f64, hi: f64 },
    #[error(
        "point {index}: value {value} is not above the previous point's {previous}; list points by increasing value"
    )]
    NotIncreasing { index: usize, value: f64, previous: f64 },
    #[error("point {index}: color {color:?} must have three components in [0, 1], e.g. [1, 0.5, 0]")]
    Color { index: usize, color: [f64; 3] },
    #[error("point {index}: opacity {opacity} must be in [0, 1]")]
    Opacity { index: usize, opacity: f64 },
}

/// How to name a transfer function, for error messages.
#[cfg(feature = "files")]
fn usage() -> String {
    let names: Vec<&str> = PRESETS.iter().map(|p| p.0).collect();
    format!(
        "give a preset ({}) or a JSON file like {{\"range\": [0, 1], \"points\": [{{\"value\": 0, \"color\": [0, 0, 0], \"opacity\": 0}}, ...]}}",
        names.join(", ")
    )
}

impl TransferFunction {
    #[cfg(feature = "files")]
    /// A preset by name, or a JSON file. Errors are one line naming the
    /// argument, the problem and the fix.
    pub fn load(arg: &str) -> Result<TransferFunction, TfError> {
        if let Some((name, text)) = PRESETS.iter().find(|p| p.0 == arg) {
            return TransferFunction::parse(text, name);
        }
        let path = std::path::Path::new(arg);
        let is_file_like = arg.ends_with(".json") || arg.contains('/') || arg.contains('\\');
        match std::fs::read_to_string(path) {
            Ok(text) => TransferFunction::parse_in(&text, arg, path.parent()),
            Err(error) if is_file_like || path.exists() => {
                Err(TfError { name: arg.to_string(), problem: TfProblem::Unreadable { error } })
            }
            Err(_) => Err(TfError { name: arg.to_string(), problem: TfProblem::Unknown }),
        }
    }

    /// The default a viewer starts from when no transfer function is given:
    /// a ramp over the data's range `[lo, hi]`, transparent at `lo`, rising
    /// linearly to opacity 0.25 per unit slab at `hi`, coloured from dark
    /// blue through orange to white, so every value above the lowest shows
    /// and denser data is brighter and more opaque.
    pub fn ramp(lo: f64, hi: f64) -> TransferFunction {
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo, lo + 1.0) };
        let at = |t: f64| lo + t * (hi - lo);
        let point = |t: f64, color: [f64; 3]| ControlPoint { value: at(t), color, opacity: 0.25 * t };
        TransferFunction {
            name: format!("ramp over [{lo}, {hi}]"),
            range: [lo, hi],
            points: vec![point(0.0, [0.1, 0.15, 0.4]), point(0.5, [0.95, 0.55, 0.2]), point(1.0, [1.0, 1.0, 1.0])],
        }
    }

    #[cfg(feature = "files")]
    /// A preset by name (panics on an unknown name: for built-in uses).
    pub fn preset(name: &str) -> TransferFunction {
        let text = PRESETS.iter().find(|p| p.0 == name).unwrap_or_else(|| panic!("no preset {name}")).1;
        TransferFunction::parse(text, name).expect("presets parse")
    }

    #[cfg(feature = "files")]
    /// Parses and checks the JSON text of a transfer function; `source`
    /// names it in the (one-line) error. A `colormap` is read relative to
    /// the working directory.
    pub fn parse(text: &str, source: &str) -> Result<TransferFunction, TfError> {
        TransferFunction::parse_in(text, source, None)
    }

    #[cfg(feature = "files")]
    /// [`TransferFunction::parse`] with a `colormap` path relative to `dir`
    /// (the JSON file's folder).
    pub fn parse_in(text: &str, source: &str, dir: Option<&std::path::Path>) -> Result<TransferFunction, TfError> {
        let bad = |problem: TfProblem| TfError { name: source.to_string(), problem };
        let file: TfFile = serde_json::from_str(text).map_err(|error| bad(TfProblem::Json { error }))?;
        let [lo, hi] = file.range;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad(TfProblem::Range { lo, hi }));
        }
        let points = match (file.points, &file.colormap) {
            (Some(p), None) => p,
            (None, Some(c)) => {
                let path = dir.map_or_else(|| std::path::PathBuf::from(c), |d| d.join(c));
                colormap_points(&path, [lo, hi])
                    .map_err(|problem| bad(TfProblem::Colormap { path: path.clone(), problem }))?
            }
            (Some(_), Some(_)) => {
                return Err(bad(TfProblem::PointsAndColormap));
            }
            (None, None) => {
                return Err(bad(TfProblem::NoPoints));
            }
        };
        let file = TfFileChecked { range: file.range, points };
        if file.points.len() < 2 {
            return Err(bad(TfProblem::TooFewPoints { count: file.points.len() }));
        }
        for (i, p) in file.points.iter().enumerate() {
            if !p.value.is_finite() || p.value < lo || p.value > hi {
                return Err(bad(TfProblem::Outside { index: i, value: p.value, lo, hi }));
            }
            if i > 0 && p.value <= file.points[i - 1].value {
                return Err(bad(TfProblem::NotIncreasing {
                    index: i,
                    value: p.value,
                    previous: file.points[i - 1].value,
                }));
            }
            if p.color.iter().any(|c| !c.is_finite() || !(0.0..=1.0).contains(c)) {
                return Err(bad(TfProblem::Color { index: i, color: p.color }));
            }
            if !p.opacity.is_finite() || !(0.0..=1.0).contains(&p.opacity) {
                return Err(bad(TfProblem::Opacity { index: i, opacity: p.opacity }));
            }
        }
        Ok(TransferFunction { name: source.to_string(), range: file.range, points: file.points })
    }

    /// Colour and opacity at `v` (piecewise linear, constant past the ends).
    pub fn eval(&self, v: f64) -> ([f64; 3], f64) {
        let pts = &self.points;
        if v <= pts[0].value {
            return (pts[0].color, pts[0].opacity);
        }
        let last = &pts[pts.len() - 1];
        if v >= last.value {
            return (last.color, last.opacity);
        }
        let k = pts.partition_point(|p| p.value <= v).max(1) - 1;
        let (a, b) = (&pts[k], &pts[k + 1]);
        let f = (v - a.value) / (b.value - a.value);
        let c = [0, 1, 2].map(|i| a.color[i] + f * (b.color[i] - a.color[i]));
        (c, a.opacity + f * (b.opacity - a.opacity))
    }

    /// The sampled table: [`TABLE_SIZE`] entries over `range`, each
    /// (r, g, b, tau) with tau = -ln(1 - opacity) the extinction per cell.
    /// Both renderers look it up with linear interpolation (clamped).
    pub fn table(&self) -> Tf1d {
        let [lo, hi] = self.range;
        let n = TABLE_SIZE;
        let entries = (0..n)
            .map(|i| {
                let v = lo + (hi - lo) * i as f64 / (n - 1) as f64;
                let (c, a) = self.eval(v);
                let tau = -(1.0 - a.min(MAX_OPACITY)).ln() / REF_STEP;
                [c[0] as f32, c[1] as f32, c[2] as f32, tau as f32]
            })
            .collect();
        Tf1d { lo: lo as f32, hi: hi as f32, entries }
    }
}

/// A transfer function sampled at `entries.len()` values from `lo` to `hi`.
#[derive(Clone, Debug)]
pub struct Tf1d {
    /// The value of the first entry.
    pub lo: f32,
    /// The value of the last entry.
    pub hi: f32,
    /// (r, g, b, extinction per cell).
    pub entries: Vec<[f32; 4]>,
}

impl Tf1d {
    /// Table coordinate of value `v`: clamped to [0, n - 1].
    pub fn coord(&self, v: f64) -> f64 {
        let n = self.entries.len() as f64;
        ((v - self.lo as f64) * ((n - 1.0) / (self.hi as f64 - self.lo as f64))).clamp(0.0, n - 1.0)
    }

    /// Linear lookup (as the shader does): (r, g, b, tau).
    pub fn at(&self, v: f64) -> [f64; 4] {
        let u = self.coord(v);
        let n = self.entries.len();
        let i = (u.floor() as usize).min(n - 2);
        let f = u - i as f64;
        let (a, b) = (self.entries[i], self.entries[i + 1]);
        [0, 1, 2, 3].map(|k| a[k] as f64 + f * (b[k] as f64 - a[k] as f64))
    }

    /// Whether every value in [vmin, vmax] maps to zero opacity, judged on
    /// the table entries around the interval widened by one entry on each
    /// side (so f32 rounding of evaluations and the pre-integration table's
    /// bilinear lookups never reach a non-zero entry from inside).
    pub fn transparent(&self, vmin: f64, vmax: f64) -> bool {
        // NaN bounds (or an inverted interval) prove nothing.
        if vmin.is_nan() || vmax.is_nan() || vmin > vmax {
            return false;
        }
        let n = self.entries.len();
        let a = (self.coord(vmin).floor() as usize).saturating_sub(1);
        let b = (self.coord(vmax).ceil() as usize + 1).min(n - 1);
        self.entries[a..=b].iter().all(|e| e[3] == 0.0)
    }

    /// The pre-integration table for segments of length `step` cells (Engel
    /// et al. 2001): entry (i, j) holds the premultiplied colour and opacity
    /// of a segment whose value runs linearly from front value s_i to back
    /// value s_j (s_k = lo + k (hi - lo) / (n - 1), n = [`PREINT_SIZE`]),
    /// row i = front, column j = back, as (r, g, b, alpha).
    ///
    /// Integration: a Riemann sum with self-attenuation kept. The segment is
    /// cut into M sub-segments (M = max(8, 2 x the number of 1D table cells
    /// the segment's values cross), so every table cell is sampled twice),
    /// each with the 1D table's colour c_k and extinction tau_k at its
    /// midpoint value, composited front to back: alpha_k = 1 - exp(-tau_k
    /// step / M), C += T c_k alpha_k, T *= 1 - alpha_k; alpha = 1 - T. This
    /// converges to the emission-absorption integral
    /// C = int c(s(x)) tau(s(x)) exp(-int_0^x tau) dx as M grows.
    pub fn preintegrate(&self, step: f64) -> Preint {
        let n = PREINT_SIZE;
        let (lo, hi) = (self.lo as f64, self.hi as f64);
        let value = |k: usize| lo + (hi - lo) * k as f64 / (n - 1) as f64;
        let cells_per_value = (self.entries.len() - 1) as f64 / (hi - lo);
        let row = |i: usize| -> Vec<[f32; 4]> {
            (0..n)
                .map(|j| {
                    let (sf, sb) = (value(i), value(j));
                    let m = ((2.0 * (sb - sf).abs() * cells_per_value).ceil() as usize).max(8);
                    let dx = step / m as f64;
                    let (mut c, mut t) = ([0.0f64; 3], 1.0f64);
                    for k in 0..m {
                        let s = sf + (sb - sf) * (k as f64 + 0.5) / m as f64;
                        let e = self.at(s);
                        let a = 1.0 - (-e[3] * dx).exp();
                        for q in 0..3 {
                            c[q] += t * e[q] * a;
                        }
                        t *= 1.0 - a;
                    }
                    [c[0] as f32, c[1] as f32, c[2] as f32, (1.0 - t) as f32]
                })
                .collect()
        };
        let threads = std::thread::available_parallelism().map(|t| t.get()).unwrap_or(1);
        let rows: Vec<usize> = (0..n).collect();
        let mut entries = vec![[0f32; 4]; n * n];
        std::thread::scope(|s| {
            let handles: Vec<_> = rows
                .chunks(n.div_ceil(threads))
                .map(|chunk| {
                    let row = &row;
                    s.spawn(move || chunk.iter().map(|&i| (i, row(i))).collect::<Vec<_>>())
                })
                .collect();
            for h in handles {
                for (i, r) in h.join().expect("pre-integration") {
                    entries[i * n..(i + 1) * n].copy_from_slice(&r);
                }
            }
        });
        Preint { lo: self.lo, hi: self.hi, size: n, step: step as f32, entries }
    }
}

/// A pre-integration table (see [`Tf1d::preintegrate`]).
#[derive(Clone, Debug)]
pub struct Preint {
    /// The value of the first row and column.
    pub lo: f32,
    /// The value of the last row and column.
    pub hi: f32,
    /// Entries per axis.
    pub size: usize,
    /// The segment length it was integrated for (cells).
    pub step: f32,
    /// Row-major, row = front value: (r, g, b, alpha), colour premultiplied.
    pub entries: Vec<[f32; 4]>,
}

impl Preint {
    /// Bilinear lookup (as the shader does): premultiplied (r, g, b, alpha).
    pub fn at(&self, sf: f64, sb: f64) -> [f64; 4] {
        let n = self.size;
        let coord = |v: f64| {
            ((v - self.lo as f64) * ((n as f64 - 1.0) / (self.hi as f64 - self.lo as f64))).clamp(0.0, n as f64 - 1.0)
        };
        let (u, w) = (coord(sf), coord(sb));
        let (i, j) = ((u.floor() as usize).min(n - 2), (w.floor() as usize).min(n - 2));
        let (fu, fw) = (u - i as f64, w - j as f64);
        let e = |a: usize, b: usize| self.entries[a * n + b];
        let (e00, e01, e10, e11) = (e(i, j), e(i, j + 1), e(i + 1, j), e(i + 1, j + 1));
        [0, 1, 2, 3].map(|k| {
            let top = e00[k] as f64 + fw * (e01[k] as f64 - e00[k] as f64);
            let bottom = e10[k] as f64 + fw * (e11[k] as f64 - e10[k] as f64);
            top + fu * (bottom - top)
        })
    }
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;

    #[test]
    fn presets_parse_and_are_transparent_at_zero() {
        for (name, _) in PRESETS {
            let tf = TransferFunction::load(name).unwrap();
            assert!(tf.eval(tf.range[0]).1 == 0.0, "{name}");
            assert!(!tf.table().transparent(tf.range[0], tf.range[1]), "{name}");
        }
        let mni = TransferFunction::preset("mni-tissue").table();
        assert!(mni.transparent(0.0, 40.0) && !mni.transparent(0.0, 80.0), "air is clear, skin is not");
    }

    #[test]
    fn piecewise_linear_and_clamped() {
        let tf = TransferFunction::parse(
            r#"{"range": [0, 10], "points": [{"value": 2, "color": [0, 0, 0], "opacity": 0},
                {"value": 6, "color": [1, 0.5, 0], "opacity": 0.8}]}"#,
            "t",
        )
        .unwrap();
        assert_eq!(tf.eval(0.0), ([0.0; 3], 0.0));
        assert_eq!(tf.eval(4.0), ([0.5, 0.25, 0.0], 0.4));
        assert_eq!(tf.eval(9.0), ([1.0, 0.5, 0.0], 0.8));
        let t = tf.table();
        assert!(t.transparent(0.0, 1.8) && !t.transparent(0.0, 2.5) && !t.transparent(7.0, 9.0));
        // The extinction reproduces the opacity over one reference step.
        assert!((1.0 - (-t.at(10.0)[3]).exp() - 0.8).abs() < 1e-6);
    }

    #[test]
    fn preintegration_of_a_constant_segment_is_the_opacity_corrected_sample() {
        let tf = TransferFunction::preset("marschner-lobb");
        let t = tf.table();
        for step in [0.25, 1.0] {
            let p = t.preintegrate(step);
            for k in [0usize, 40, 64, 100] {
                let v = tf.range[0] + (tf.range[1] - tf.range[0]) * k as f64 / (PREINT_SIZE - 1) as f64;
                let e = t.at(v);
                let alpha = 1.0 - (-e[3] * step).exp();
                let got = p.at(v, v);
                assert!((got[3] - alpha).abs() < 1e-4, "alpha {} vs {alpha} at {v}", got[3]);
                for q in 0..3 {
                    assert!((got[q] - e[q] * alpha).abs() < 1e-4, "colour at {v}");
                }
            }
        }
    }

    #[test]
    fn preintegration_sees_a_thin_peak_between_samples() {
        // Front 0.3, back 0.7: both ends are in the faint haze, but the
        // segment crosses the opaque shell at 0.5, which point samples miss.
        let t = TransferFunction::preset("marschner-lobb").table();
        assert!(t.at(0.5)[3] > 1.0);
        let point = |v: f64| 1.0 - (-t.at(v)[3]).exp();
        let p = t.preintegrate(1.0);
        let a = p.at(0.3, 0.7)[3];
        assert!(a > 3.0 * point(0.3).max(point(0.7)), "the crossed shell is seen: alpha {a}");
        assert!((p.at(0.3, 0.7)[3] - p.at(0.7, 0.3)[3]).abs() < 1e-3, "alpha is symmetric");
    }

    #[test]
    fn a_colormap_png_spans_the_range() {
        let dir = std::env::temp_dir().join(format!("boxforge-tf-cmap-{}", std::process::id()));
        let rgba = [0u8, 0, 0, 0, 255, 0, 0, 51, 0, 255, 0, 102, 0, 0, 255, 255];
        crate::render::iso::write_png(&dir.join("cmap.png"), 4, 1, &rgba).unwrap();
        crate::render::iso::write_png(&dir.join("tall.png"), 1, 4, &rgba).unwrap();
        let json = dir.join("tf.json");
        std::fs::write(&json, r#"{"range": [0, 30], "colormap": "cmap.png"}"#).unwrap();
        let tf = TransferFunction::load(json.to_str().unwrap()).unwrap();
        assert_eq!(tf.points.len(), 4);
        assert_eq!(tf.eval(10.0), ([1.0, 0.0, 0.0], 0.2));
        assert_eq!(tf.eval(30.0), ([0.0, 0.0, 1.0], 1.0));
        let (c, a) = tf.eval(15.0);
        assert!((c[0] - 0.5).abs() < 1e-12 && (c[1] - 0.5).abs() < 1e-12 && (a - 0.3).abs() < 1e-12);
        std::fs::write(&json, r#"{"range": [0, 30], "colormap": "tall.png"}"#).unwrap();
        let e = TransferFunction::load(json.to_str().unwrap()).unwrap_err().to_string();
        assert!(e.contains("at least 2"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn parse_errors_name_the_file_and_the_problem() {
        for (text, fragment) in [
            ("not json", "not a valid transfer function"),
            (r#"{"range": [0, 1]}"#, "points"),
            (r#"{"range": [1, 0], "points": []}"#, "lo < hi"),
            (r#"{"range": [0, 1], "points": [{"value": 0, "color": [0,0,0], "opacity": 0}]}"#, "at least two"),
            (
                r#"{"range": [0, 1], "points": [{"value": 0, "color": [0,0,0], "opacity": 0}, {"value": 2, "color": [0,0,0], "opacity": 0}]}"#,
                "outside",
            ),
            (
                r#"{"range": [0, 1], "points": [{"value": 0.5, "color": [0,0,0], "opacity": 0}, {"value": 0.5, "color": [0,0,0], "opacity": 0}]}"#,
                "not above",
            ),
            (
                r#"{"range": [0, 1], "points": [{"value": 0, "color": [0,2,0], "opacity": 0}, {"value": 1, "color": [0,0,0], "opacity": 0}]}"#,
                "color",
            ),
            (
                r#"{"range": [0, 1], "points": [{"value": 0, "color": [0,0,0], "opacity": 1.5}, {"value": 1, "color": [0,0,0], "opacity": 0}]}"#,
                "opacity 1.5",
            ),
            (r#"{"range": [0, 1], "points": [], "colour": 3}"#, "colour"),
        ] {
            let e = TransferFunction::parse(text, "x.json").unwrap_err().to_string();
            assert!(e.starts_with("x.json: ") && e.contains(fragment) && !e.contains('\n') && !e.contains("--"), "{e}");
        }
        for (text, fragment) in [
            (r#"{"range": [0, 1], "colormap": "missing.png"}"#, "cannot read"),
            (r#"{"range": [0, 1], "points": [], "colormap": "x.png"}"#, "not both"),
        ] {
            let e = TransferFunction::parse(text, "x.json").unwrap_err().to_string();
            assert!(e.starts_with("x.json: ") && e.contains(fragment) && !e.contains('\n') && !e.contains("--"), "{e}");
        }
        let e = TransferFunction::load("no-such-preset").unwrap_err().to_string();
        assert!(e.contains("mni-tissue") && e.contains("no such preset"), "{e}");
    }
}
