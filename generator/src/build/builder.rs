//! The build-script API: generate WGSL modules into `OUT_DIR` from a
//! `build.rs`, the way `prost-build` and `bindgen` generate Rust.
//!
//! A by-value [`Builder`] collects catalog filters and spec files, then
//! [`Builder::generate`] derives every filter, emits its module, validates it
//! with naga (and, for the fast variant, proves `<f>_eval`, `<f>_eval_grad`, `<f>_eval_hessian`
//! branch-free and table-free), and only then writes
//! `<filter>.<layout>.wgsl` (or `<filter>.<layout>.naive.wgsl`) atomically.
//! A module that does not validate is an [`Error::InvalidWgsl`]; it is never
//! written.
//!
//! `build.rs` (not run here: it needs the spec file and Cargo's `OUT_DIR`):
//!
//! ```no_run
//! use boxforge::Builder;
//!
//! fn main() {
//!     Builder::new().filter("bcc7").spec_file("filters/my_filter.toml").generate().unwrap();
//! }
//! ```
//!
//! and in the crate, the module as a string for `wgpu::ShaderSource::Wgsl`,
//! embedded at compile time with
//! `include_str!(concat!(env!("OUT_DIR"), "/bcc7.embedded.wgsl"))`. That line
//! only compiles in a crate whose build script ran, so the example below does
//! the same at run time, into a directory of its own:
//!
//! ```
//! let dir = std::env::temp_dir().join(format!("boxforge-doc-module-{}", std::process::id()));
//! let generated = boxforge::Builder::new().filter("zp").out_dir(&dir).generate()?;
//! assert_eq!(generated.files, vec![dir.join("zp.embedded.wgsl")]);
//! let zp_wgsl = std::fs::read_to_string(&generated.files[0])?;
//! assert!(zp_wgsl.contains("fn zp_eval(p: vec2<f32>) -> f32"));
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The header of every generated file names `boxforge::Builder (build.rs)`
//! as the command that made it.

use crate::back::{translate, Target, TranslateOptions};
use crate::build::output::write_atomic;
use crate::derive::Derivation;
use crate::emit::{emit, Bounds, EmitOptions, EmitStats, EvalForm, FetchMode, Layout, Variant};
use crate::error::{Error, Result};
use crate::spec::{catalog, Caps, Filter};
use crate::validate::{check_branch_free, validate_wgsl};
use std::path::{Path, PathBuf};

/// The command named in the header of every file the [`Builder`] writes.
pub const BUILDER_COMMAND: &str = "boxforge::Builder (build.rs)";

/// Generates WGSL modules for box-spline filters from a build script.
///
/// Configure by value and finish with [`generate`](Builder::generate):
///
/// ```no_run
/// // build.rs (not run here: it needs the spec file and Cargo's `OUT_DIR`)
/// use boxforge::Builder;
///
/// fn main() {
///     Builder::new().filter("bcc7").spec_file("filters/my_filter.toml").generate().unwrap();
/// }
/// ```
///
/// In the crate, `include_str!(concat!(env!("OUT_DIR"), "/bcc7.embedded.wgsl"))`
/// then embeds the module (see the [module docs](crate::build::builder)). Options change the
/// file and its bindings, e.g. the packed layout in bind group 1:
///
/// ```
/// use boxforge::emit::Layout;
/// let dir = std::env::temp_dir().join(format!("boxforge-doc-builder-{}", std::process::id()));
/// let generated =
///     boxforge::Builder::new().filter("zp").layout(Layout::Packed).bind_group(1).out_dir(&dir).generate()?;
/// assert_eq!(generated.files, vec![dir.join("zp.packed.wgsl")]);
/// let wgsl = std::fs::read_to_string(&generated.files[0])?;
/// assert!(wgsl.contains("@group(1) @binding(0) var zp_cosets: texture_2d<f32>;"));
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// Defaults: [`Layout::Embedded`], [`Variant::Fast`], bind group 0, first
/// binding 0, prefilter and min/max kernels included, output in `$OUT_DIR`,
/// and `cargo:rerun-if-changed=<spec path>` printed for every spec file when
/// running as a build script (`OUT_DIR` set).
#[derive(Clone, Debug)]
#[must_use = "a Builder does nothing until .generate() is called"]
pub struct Builder {
    filters: Vec<String>,
    spec_files: Vec<PathBuf>,
    layout: Layout,
    variant: Variant,
    out_dir: Option<PathBuf>,
    group: u32,
    binding: u32,
    kernels: bool,
    form: Option<EvalForm>,
    bounds: Bounds,
    fetch: FetchMode,
    texels: crate::emit::Texels,
    caps: Option<Caps>,
    target: Target,
    emit_rerun_if_changed: bool,
}

/// What [`Builder::generate`] wrote: one entry per filter, catalog filters
/// first (in the order given), then spec files (in the order given).
/// For WGSL `files[i]` and `stats[i]` belong to the same module; other
/// targets write several files per module, in module order.
#[derive(Clone, Debug)]
pub struct Generated {
    /// Paths of the written files: `<out_dir>/<filter>.<layout>[.naive].wgsl`,
    /// or with [`Builder::target`] every file of each translation.
    pub files: Vec<PathBuf>,
    /// The emitter's counts for each module (fetches per eval, operations, ...).
    pub stats: Vec<EmitStats>,
}

impl Default for Builder {
    fn default() -> Self {
        Builder::new()
    }
}

impl Builder {
    /// A builder with no filters and the defaults listed on [`Builder`].
    pub fn new() -> Self {
        Builder {
            filters: Vec::new(),
            spec_files: Vec::new(),
            layout: Layout::Embedded,
            variant: Variant::Fast,
            out_dir: None,
            group: 0,
            binding: 0,
            kernels: true,
            form: None,
            bounds: Bounds::Clamp,
            fetch: FetchMode::Exact,
            texels: crate::emit::Texels::Float,
            caps: None,
            target: Target::Wgsl,
            emit_rerun_if_changed: std::env::var_os("OUT_DIR").is_some(),
        }
    }

    /// Adds a catalog filter by name (`boxforge list` shows them).
    pub fn filter(mut self, name: &str) -> Self {
        self.filters.push(name.to_string());
        self
    }

    /// Adds a filter from a TOML spec file (same format as the catalog). A
    /// relative path is relative to the working directory, which in a build
    /// script is the package's root.
    pub fn spec_file(mut self, path: impl AsRef<Path>) -> Self {
        self.spec_files.push(path.as_ref().to_path_buf());
        self
    }

    /// Storage layout of the samples (default [`Layout::Embedded`]).
    pub fn layout(mut self, l: Layout) -> Self {
        self.layout = l;
        self
    }

    /// Code shape (default [`Variant::Fast`], branch-free).
    pub fn variant(mut self, v: Variant) -> Self {
        self.variant = v;
        self
    }

    /// Bind group of the samples (default 0).
    pub fn bind_group(mut self, g: u32) -> Self {
        self.group = g;
        self
    }

    /// First binding of the samples within the bind group (default 0).
    pub fn binding(mut self, b: u32) -> Self {
        self.binding = b;
        self
    }

    /// Whether to include the prefilter and min/max compute kernels (default true).
    pub fn kernels(mut self, yes: bool) -> Self {
        self.kernels = yes;
        self
    }

    /// Forces an evaluation form for every filter (default: each spec's
    /// `form`, itself `auto` by default: the cheapest by static op count).
    /// Forcing [`EvalForm::Factored`] on a filter that is not a tensor
    /// product makes [`Builder::generate`] fail with [`Error::Spec`].
    pub fn form(mut self, f: EvalForm) -> Self {
        self.form = Some(f);
        self
    }

    /// Fetch bounds policy (default [`Bounds::Clamp`]); [`Bounds::Unchecked`]
    /// drops the clamp for callers that pad their volumes.
    pub fn bounds(mut self, b: Bounds) -> Self {
        self.bounds = b;
        self
    }

    /// Fetch mode of `eval` (default [`FetchMode::Exact`]);
    /// [`FetchMode::Linear`] uses hardware linear filtering: on the packed
    /// layout for any filter, on the embedded layout for one-coset tensor
    /// products (see [`FetchMode`]); [`Builder::generate`] fails otherwise.
    /// The module is written as `<filter>.<layout>.linear.wgsl`.
    pub fn fetch(mut self, f: FetchMode) -> Self {
        self.fetch = f;
        self
    }

    /// What a sample texel holds (default [`crate::emit::Texels::Float`]:
    /// one sample per texel in any float-readable format). With
    /// [`crate::emit::Texels::U8x4`] the module reads four u8 samples per
    /// r32uint texel, and the host builds its sample map with a scale of
    /// (range) / 255.
    pub fn texels(mut self, t: crate::emit::Texels) -> Self {
        self.texels = t;
        self
    }

    /// The language of the output (default [`Target::Wgsl`]). Any other
    /// target translates each validated module with naga's backends
    /// ([`crate::back::translate`]) and writes its files instead of the
    /// WGSL: a library to include plus the kernels as compute shaders
    /// (SPIR-V: one binary per kernel and `<stem>.spirv.txt`); see the
    /// table in [`crate::back`].
    pub fn target(mut self, t: Target) -> Self {
        self.target = t;
        self
    }

    /// Output directory (default: `$OUT_DIR`; created if missing).
    pub fn out_dir(mut self, dir: impl AsRef<Path>) -> Self {
        self.out_dir = Some(dir.as_ref().to_path_buf());
        self
    }

    /// Whether to print `cargo:rerun-if-changed=<spec path>` for every spec
    /// file (default: true when `OUT_DIR` is set, i.e. in a build script).
    pub fn emit_rerun_if_changed(mut self, yes: bool) -> Self {
        self.emit_rerun_if_changed = yes;
        self
    }

    /// Limits for every filter, replacing each spec's `[caps]` (default:
    /// the spec's caps, else [`Caps::default`]). Raise them for a filter the
    /// default caps refuse; the refusal names the cap and its estimate.
    pub fn caps(mut self, caps: Caps) -> Self {
        self.caps = Some(caps);
        self
    }

    /// Derives, emits and validates every filter, then writes the modules.
    ///
    /// Nothing is written unless every module validates, so a failing build
    /// never leaves a mix of old and new files behind. Returns the written
    /// paths and the emitter's counts (see [`Generated`]); with no filters
    /// it writes nothing and returns empty lists.
    ///
    /// # Errors
    ///
    /// [`Error::OutDir`] without an output directory; [`Error::UnknownFilter`]
    /// for an unknown catalog name; an unreadable or invalid spec file
    /// ([`Error::Io`], [`Error::Spec`] and the validation errors of
    /// [`Filter::from_file`], also when [`Builder::caps`] re-validates);
    /// [`Error::Spec`] for two filters with the same name; the cap and
    /// prefilter errors of [`Derivation::new`]; the errors of [`emit`];
    /// [`Error::InvalidWgsl`] for a module naga rejects or that is not
    /// branch-free in the fast variant; [`Error::Translate`] when a
    /// [`Builder::target`] backend refuses a module or its check fails;
    /// [`Error::Io`] when writing fails.
    pub fn generate(self) -> Result<Generated> {
        let out_dir = match &self.out_dir {
            Some(d) => d.clone(),
            None => std::env::var_os("OUT_DIR").map(PathBuf::from).ok_or(Error::OutDir)?,
        };
        if self.emit_rerun_if_changed {
            for p in &self.spec_files {
                // Absolute, so Cargo watches the right file whatever it takes as the base.
                let shown = std::path::absolute(p).unwrap_or_else(|_| p.clone());
                println!("cargo:rerun-if-changed={}", shown.display());
            }
        }
        let mut filters: Vec<Filter> = Vec::new();
        for name in &self.filters {
            filters.push(catalog::get(name)?);
        }
        for p in &self.spec_files {
            filters.push(Filter::from_file(p)?);
        }
        if let Some(caps) = &self.caps {
            for f in &mut filters {
                let form = f.form;
                *f = Filter::new(&f.name, &f.description, f.lattice.clone(), f.directions.clone(), caps.clone())?;
                f.form = form;
            }
        }
        for (i, f) in filters.iter().enumerate() {
            if filters[..i].iter().any(|g| g.name == f.name) {
                return Err(Error::Spec {
                    origin: format!("filter '{}'", f.name),
                    message: "two filters given to boxforge::Builder share this name and would write the same \
                              file; rename one spec"
                        .into(),
                });
            }
        }
        let opts = EmitOptions {
            layout: self.layout,
            variant: self.variant,
            group: self.group,
            binding: self.binding,
            kernels: self.kernels,
            command: BUILDER_COMMAND.to_string(),
            form: self.form,
            bounds: self.bounds,
            fetch: self.fetch,
            samples: crate::emit::SampleMap::IDENTITY,
            texels: self.texels,
        };
        let mut modules = Vec::new();
        for f in &filters {
            let started = std::time::Instant::now();
            let d = Derivation::new(f)?;
            d.derive_all_forms(&|_, _| {});
            let derived = started.elapsed().as_secs_f64();
            let e = emit(&d, &opts)?;
            let total = started.elapsed().as_secs_f64();
            if self.emit_rerun_if_changed && total > SLOW_BUILD_SECONDS {
                // Cargo shows these lines from build scripts; a slow build should say why.
                println!(
                    "cargo:warning=boxforge: '{}' took {total:.1} s ({derived:.1} s to derive {} polynomials, the rest to emit); \
                     fewer or shorter directions build faster",
                    f.name,
                    d.polynomials()
                );
            }
            let path = out_dir.join(&e.file_name);
            check_module(&f.name, &e.source, &path, self.variant)?;
            let files: Vec<(PathBuf, Vec<u8>)> = if self.target == Target::Wgsl {
                vec![(path, e.source.clone().into_bytes())]
            } else {
                let stem = e.file_name.strip_suffix(".wgsl").unwrap_or(&e.file_name);
                let t = translate(&e.source, stem, self.target, &TranslateOptions::default())?;
                t.units.into_iter().map(|u| (out_dir.join(&u.file_name), u.code.bytes())).collect()
            };
            modules.push((files, e.stats));
        }
        let mut generated = Generated { files: Vec::new(), stats: Vec::new() };
        for (files, stats) in modules {
            for (path, bytes) in files {
                // Leave an identical file alone (keeps its mtime for anything watching it).
                if std::fs::read(&path).ok().as_deref() != Some(bytes.as_slice()) {
                    write_atomic(&path, &bytes)?;
                }
                generated.files.push(path);
            }
            generated.stats.push(stats);
        }
        Ok(generated)
    }
}

/// A build-time filter slower than this prints a `cargo:warning`.
pub const SLOW_BUILD_SECONDS: f64 = 3.0;

/// naga validation for every module; the branch-free proof of `<f>_eval`,
/// `<f>_eval_grad` and (degree >= 2) `<f>_eval_hessian` for the fast variant.
fn check_module(name: &str, source: &str, path: &Path, variant: Variant) -> Result<()> {
    let report = validate_wgsl(source, &path.display().to_string());
    if !report.valid {
        return Err(Error::InvalidWgsl {
            file: path.to_path_buf(),
            message: report.error.unwrap_or_else(|| "naga rejected the module".into()),
        });
    }
    if variant == Variant::Fast {
        let hessian = format!("{name}_eval_hessian");
        let mut required = vec![format!("{name}_eval"), format!("{name}_eval_grad")];
        if report.function(&hessian).is_some() {
            required.push(hessian);
        }
        check_branch_free(&report, &required.iter().map(String::as_str).collect::<Vec<_>>())
            .map_err(|message| Error::InvalidWgsl { file: path.to_path_buf(), message })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("boxforge-builder-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    fn assert_branch_free(path: &Path, name: &str) {
        let src = std::fs::read_to_string(path).unwrap();
        assert!(src.starts_with(&format!("// generated by `{BUILDER_COMMAND}`")), "{}", path.display());
        let r = validate_wgsl(&src, &path.display().to_string());
        assert!(r.valid, "{}: {:?}", path.display(), r.error);
        check_branch_free(&r, &[&format!("{name}_eval"), &format!("{name}_eval_grad")]).unwrap();
    }

    #[test]
    fn builder_caps_replace_the_specs_caps() {
        let dir = temp_dir("caps");
        let tight = Caps { max_emitted_polynomials: 10, ..Caps::default() };
        let e = Builder::new().filter("bcc7").caps(tight).out_dir(&dir).generate().expect_err("refused");
        assert!(matches!(e, Error::EmitCap { polynomials: 30, cap: 10, .. }), "{e}");
        assert!(!dir.join("bcc7.embedded.wgsl").exists(), "nothing written on a refusal");
        let degree = Caps { max_degree: 2, ..Caps::default() };
        assert!(matches!(
            Builder::new().filter("bcc7").caps(degree).out_dir(&dir).generate(),
            Err(Error::DegreeCap { degree: 4, cap: 2 })
        ));
        Builder::new().filter("bcc7").caps(Caps::default()).out_dir(&dir).generate().unwrap();
        assert!(dir.join("bcc7.embedded.wgsl").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn builder_writes_validated_branch_free_modules() {
        let dir = temp_dir("ok");
        let spec = dir.join("specs").join("my_zp.toml");
        std::fs::create_dir_all(spec.parent().unwrap()).unwrap();
        std::fs::write(&spec, "name = \"my_zp\"\nlattice = \"quincunx\"\ndirections = [[1,1],[-1,1],[2,0],[0,2]]\n")
            .unwrap();
        let out = dir.join("out");
        let g = Builder::new()
            .filter("courant")
            .spec_file(&spec)
            .out_dir(&out)
            .emit_rerun_if_changed(false)
            .generate()
            .unwrap();
        assert_eq!(g.files, vec![out.join("courant.embedded.wgsl"), out.join("my_zp.embedded.wgsl")]);
        assert_eq!(g.stats.len(), 2);
        assert_branch_free(&g.files[0], "courant");
        assert_branch_free(&g.files[1], "my_zp");
        // Only the modules, no temporary files.
        let mut names: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name()).collect();
        names.sort();
        assert_eq!(names, ["courant.embedded.wgsl", "my_zp.embedded.wgsl"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn builder_options_reach_the_module() {
        let dir = temp_dir("opts");
        let g = Builder::new()
            .filter("zp")
            .layout(Layout::Packed)
            .variant(Variant::Naive)
            .bind_group(2)
            .binding(3)
            .kernels(false)
            .out_dir(&dir)
            .emit_rerun_if_changed(false)
            .generate()
            .unwrap();
        assert_eq!(g.files, vec![dir.join("zp.packed.naive.wgsl")]);
        let src = std::fs::read_to_string(&g.files[0]).unwrap();
        assert!(src.contains("@group(2) @binding(3)"), "{src}");
        assert!(!src.contains("zp_prefilter_main"));
        assert!(validate_wgsl(&src, "zp").valid);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn builder_rejects_unknown_filters_bad_specs_and_duplicates() {
        let dir = temp_dir("err");
        let b = || Builder::new().out_dir(&dir).emit_rerun_if_changed(false);
        assert!(matches!(b().filter("no_such_filter").generate(), Err(Error::UnknownFilter { .. })));
        assert!(matches!(b().spec_file(dir.join("missing.toml")).generate(), Err(Error::Io { .. })));
        assert!(matches!(b().filter("zp").filter("zp").generate(), Err(Error::Spec { .. })));
        assert!(!dir.exists(), "nothing is written when generation fails");
    }

    #[test]
    fn builder_without_out_dir_needs_out_dir_env() {
        let b = Builder::new().filter("courant").emit_rerun_if_changed(false);
        // Under a runner that sets OUT_DIR the default applies instead; explicit paths are tested above.
        if std::env::var_os("OUT_DIR").is_none() {
            assert!(matches!(b.generate(), Err(Error::OutDir)));
        }
        assert!(Error::OutDir.to_string().contains("out_dir"));
    }

    #[cfg(feature = "targets")]
    #[test]
    fn builder_target_writes_the_translation() {
        let dir = temp_dir("target");
        let g = Builder::new()
            .filter("zp")
            .target(Target::Glsl)
            .out_dir(&dir)
            .emit_rerun_if_changed(false)
            .generate()
            .unwrap();
        let names: Vec<String> =
            g.files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(
            names,
            ["zp.embedded.glsl", "zp.embedded.prefilter.comp", "zp.embedded.minmax.comp", "zp.embedded.eval.comp"]
        );
        let lib = std::fs::read_to_string(&g.files[0]).unwrap();
        assert!(lib.starts_with(&format!("// generated by `{BUILDER_COMMAND}`")), "{lib}");
        assert!(lib.contains("float zp_eval(vec2 p)"), "{lib}");
        assert!(!lib.lines().any(|l| l.starts_with("#version")), "the including shader has the version line");
        assert!(!dir.join("zp.embedded.wgsl").exists(), "only the target's files");
        let spv = Builder::new()
            .filter("zp")
            .target(Target::Spirv)
            .out_dir(&dir)
            .emit_rerun_if_changed(false)
            .generate()
            .unwrap();
        let words = std::fs::read(spv.files.iter().find(|p| p.ends_with("zp.embedded.eval.spv")).unwrap()).unwrap();
        assert_eq!(&words[..4], &crate::back::spirv::MAGIC.to_le_bytes());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Without the `targets` feature a translation is refused in one line
    /// that names the feature, and WGSL still works.
    #[cfg(not(feature = "targets"))]
    #[test]
    fn builder_target_without_the_feature_names_it() {
        let dir = temp_dir("no-target");
        let e = Builder::new()
            .filter("zp")
            .target(Target::Glsl)
            .out_dir(&dir)
            .emit_rerun_if_changed(false)
            .generate()
            .unwrap_err();
        let text = e.to_string();
        assert!(text.contains("`targets` feature") && text.contains("glsl"), "{text}");
        assert!(!text.contains('\n'), "one line: {text}");
        Builder::new().filter("zp").out_dir(&dir).emit_rerun_if_changed(false).generate().unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn invalid_wgsl_is_an_error() {
        let e = check_module("x", "fn x_eval( -> f32 {}", Path::new("x.wgsl"), Variant::Fast).unwrap_err();
        assert!(matches!(e, Error::InvalidWgsl { .. }), "{e}");
        let branchy = "fn x_eval(p: f32) -> f32 { if p > 0.0 { return 1.0; } return 0.0; }\n\
                       fn x_eval_grad(p: f32) -> f32 { return p; }\n";
        let e = check_module("x", branchy, Path::new("x.wgsl"), Variant::Fast).unwrap_err();
        assert!(e.to_string().contains("x_eval"), "{e}");
        check_module("x", branchy, Path::new("x.wgsl"), Variant::Naive).unwrap();
    }
}
