//! Helpers shared by the subcommands: the failure type, `outln!`, filter
//! names, derivation with a progress bar, `--view`, the value enums of
//! several subcommands and the Markdown-section writer of `bench`.

use crate::request;
use boxforge::derive::Derivation;
use boxforge::emit::{EvalForm, FetchMode, Layout, Variant};
use boxforge::spec;
use boxforge_runtime::progress;
use std::path::Path;

/// `println!` that ends the process quietly when stdout is closed (e.g.
/// `boxforge inspect --all | head`) instead of panicking on a broken pipe.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        if let Err(e) = writeln!(out, $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
            eprintln!("error: cannot write to stdout: {e}");
            std::process::exit(2);
        }
    }};
}

/// A user-facing failure: one line on stderr, exit code 2.
pub struct Failure(pub String);

impl From<boxforge::Error> for Failure {
    fn from(e: boxforge::Error) -> Failure {
        Failure(with_flags(&e.to_string()))
    }
}

/// The generator names its options as a spec or a `Builder` spells them
/// (`fetch = exact`, `layout = packed`); on the command line they are flags,
/// so its messages are told in the flags' words (`--fetch exact`).
pub fn with_flags(message: &str) -> String {
    let mut out = message.to_string();
    for option in ["fetch", "layout", "variant", "form", "bounds", "target"] {
        let (spec, flag) = (format!("{option} = "), format!("--{option} "));
        let mut rest = out.as_str();
        let mut told = String::with_capacity(out.len());
        while let Some(at) = rest.find(&spec) {
            let word_before = rest[..at].chars().last().is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '-');
            told.push_str(&rest[..at]);
            told.push_str(if word_before { &spec } else { &flag });
            rest = &rest[at + spec.len()..];
        }
        told.push_str(rest);
        out = told;
    }
    out
}

impl From<String> for Failure {
    fn from(e: String) -> Failure {
        Failure(e)
    }
}

/// `--layout`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LayoutArg {
    Embedded,
    Packed,
    /// Bricks of --brick texels with halos in a pool texture, one page-table
    /// lookup per evaluation (volumes past the 3D texture limit).
    Bricked,
    /// The same bricks with each slot coset-packed (one texel per sample).
    BrickedPacked,
}

impl From<LayoutArg> for Layout {
    fn from(l: LayoutArg) -> Layout {
        match l {
            LayoutArg::Embedded => Layout::Embedded,
            LayoutArg::Packed => Layout::Packed,
            LayoutArg::Bricked => Layout::Bricked,
            LayoutArg::BrickedPacked => Layout::BrickedPacked,
        }
    }
}

/// `--format`: how samples are stored on the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    /// 32-bit float (exact).
    F32,
    /// 16-bit float (11 significant bits).
    F16,
    /// 16-bit normalized over the data range (65536 levels).
    U16,
    /// 8-bit normalized over the data range (256 levels).
    U8,
}

impl From<FormatArg> for boxforge_runtime::volume::SampleFormat {
    fn from(f: FormatArg) -> Self {
        use boxforge_runtime::volume::SampleFormat;
        match f {
            FormatArg::F32 => SampleFormat::F32,
            FormatArg::F16 => SampleFormat::F16,
            FormatArg::U16 => SampleFormat::U16,
            FormatArg::U8 => SampleFormat::U8,
        }
    }
}

/// `--variant`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum VariantArg {
    Fast,
    Naive,
}

impl From<VariantArg> for Variant {
    fn from(v: VariantArg) -> Variant {
        match v {
            VariantArg::Fast => Variant::Fast,
            VariantArg::Naive => Variant::Naive,
        }
    }
}

/// `--form`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FormArg {
    Auto,
    Factored,
    Power,
    Ridge,
    Bb,
    Dense,
}

impl From<FormArg> for EvalForm {
    fn from(f: FormArg) -> EvalForm {
        match f {
            FormArg::Auto => EvalForm::Auto,
            FormArg::Factored => EvalForm::Factored,
            FormArg::Power => EvalForm::Power,
            FormArg::Ridge => EvalForm::Ridge,
            FormArg::Bb => EvalForm::Bb,
            FormArg::Dense => EvalForm::Dense,
        }
    }
}

/// `--fetch`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FetchArg {
    Exact,
    Linear,
}

impl From<FetchArg> for FetchMode {
    fn from(f: FetchArg) -> FetchMode {
        match f {
            FetchArg::Exact => FetchMode::Exact,
            FetchArg::Linear => FetchMode::Linear,
        }
    }
}

/// `--target`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TargetArg {
    Wgsl,
    Spirv,
    Glsl,
    GlslEs,
    Hlsl,
    Msl,
}

impl From<TargetArg> for boxforge::back::Target {
    fn from(t: TargetArg) -> boxforge::back::Target {
        use boxforge::back::Target;
        match t {
            TargetArg::Wgsl => Target::Wgsl,
            TargetArg::Spirv => Target::Spirv,
            TargetArg::Glsl => Target::Glsl,
            TargetArg::GlslEs => Target::GlslEs,
            TargetArg::Hlsl => Target::Hlsl,
            TargetArg::Msl => Target::Msl,
        }
    }
}

/// The filters named on the command line, or the catalog with --all.
pub fn filter_names(filters: Vec<String>, all: bool) -> Result<Vec<String>, Failure> {
    if all {
        if !filters.is_empty() {
            return Err(Failure("give either --all or filter names, not both".into()));
        }
        Ok(spec::catalog::names().into_iter().map(String::from).collect())
    } else if filters.is_empty() {
        Err(Failure(format!(
            "name a filter (one of {}) or a spec file, or pass --all",
            spec::catalog::names().join(", ")
        )))
    } else {
        Ok(filters)
    }
}

/// Derives filters one after another, each one's reference pieces in
/// parallel on every core, with a progress bar on a terminal for
/// derivations of more than a few thousand polynomials; maps each result
/// with the seconds it took.
pub fn derive_all<T>(filters: &[boxforge::Filter], map: impl Fn(Derivation, f64) -> T) -> Result<Vec<T>, Failure> {
    let mut out = Vec::with_capacity(filters.len());
    for f in filters {
        let started = std::time::Instant::now();
        let d = Derivation::new(f)?;
        let bar = progress::derivation_bar(&d);
        d.derive_all_forms(&|done, _| bar.set_position(done as u64));
        bar.finish_and_clear();
        out.push(map(d, started.elapsed().as_secs_f64()));
    }
    Ok(out)
}

/// `--view AZ,EL` in degrees.
pub fn parse_view(v: &str) -> Result<(f32, f32), Failure> {
    let parts: Vec<&str> = v.split(',').collect();
    match parts.as_slice() {
        [a, e] => match (a.trim().parse(), e.trim().parse()) {
            (Ok(a), Ok(e)) => Ok((a, e)),
            _ => Err(Failure(format!("--view {v}: expected AZ,EL in degrees, e.g. --view 30,25"))),
        },
        _ => Err(Failure(format!("--view {v}: expected AZ,EL in degrees, e.g. --view 30,25"))),
    }
}

/// A `bench` mode that owns one section of the Markdown file (`--derive`,
/// `--literature`, `--perm`): the command line written into the section,
/// the output file checked before the run, the section spliced into the
/// file after it, and the report printed.
pub struct Section<'a> {
    /// How the file's section is called in the message (e.g. `PERM`).
    what: &'static str,
    command: String,
    markdown: Option<&'a Path>,
}

impl<'a> Section<'a> {
    /// `flags`: the mode's flags after `boxforge bench` (`--markdown` is added here).
    pub fn new(what: &'static str, flags: &str, markdown: Option<&'a Path>) -> Result<Section<'a>, Failure> {
        let mut command = format!("boxforge bench {flags}");
        if let Some(m) = markdown {
            request::check_output_file(m, "--markdown")?;
            command.push_str(&format!(" --markdown {}", m.display()));
        }
        Ok(Section { what, command, markdown })
    }

    /// The command line the section says it was generated by.
    pub fn command(&self) -> &str {
        &self.command
    }

    /// Splices `section` (the report as Markdown) into the file with
    /// `splice`, then prints the report as JSON with `json`, or the
    /// section when there is no file.
    pub fn finish<R: serde::Serialize>(
        &self,
        report: &R,
        section: &str,
        splice: fn(&str, &str) -> String,
        json: bool,
    ) -> Result<(), Failure> {
        if let Some(m) = self.markdown {
            let old = std::fs::read_to_string(m).unwrap_or_default();
            boxforge::build::output::write_atomic(m, splice(&old, section).as_bytes())?;
            eprintln!("wrote the {} section of {}", self.what, m.display());
        }
        if json {
            outln!("{}", serde_json::to_string(report).expect("the report serialises"));
        } else if self.markdown.is_none() {
            outln!("{section}");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::with_flags;

    #[test]
    fn generator_options_are_told_as_flags() {
        assert_eq!(
            with_flags("use exact fetches (fetch = exact) for hlsl, or layout = packed"),
            "use exact fetches (--fetch exact) for hlsl, or --layout packed"
        );
        assert_eq!(with_flags("prefetch = 2 stays"), "prefetch = 2 stays");
    }
}
