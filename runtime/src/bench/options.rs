//! What a run measures, and the check of its inputs before it starts.

use super::BenchError;
use boxforge::derive::Derivation;

#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub filters: Vec<String>,
    /// Points per throughput dispatch.
    pub points: usize,
    /// Interleaved timing rounds per comparison (after one warm-up each).
    pub runs: usize,
    pub naive: bool,
    /// Filters whose naive variant is measured (its shaders compile slowly
    /// on lavapipe: minutes for the large stencils).
    pub naive_filters: Vec<String>,
    pub render_sizes: Vec<u32>,
    pub mni: Option<String>,
    pub quality: bool,
    /// Time the built-in hand-written references (runtime/references/).
    pub references: bool,
    pub external: Option<External>,
}

#[derive(Clone, Debug)]
pub struct External {
    pub wgsl: String,
    pub entry: String,
    pub like: String,
}

impl BenchOptions {
    /// Only the external shader against its generated module (what
    /// `bench --wgsl F --entry E --like L` times unless asked for more).
    pub fn external_only(external: External) -> BenchOptions {
        BenchOptions {
            filters: vec![],
            naive: false,
            naive_filters: vec![],
            render_sizes: vec![],
            mni: None,
            quality: false,
            references: false,
            external: Some(external),
            ..BenchOptions::full()
        }
    }

    pub fn full() -> BenchOptions {
        BenchOptions {
            filters: ["cc_trilinear", "cc_tricubic", "bcc_linear", "bcc7", "bcc8", "bcc12", "fcc6"]
                .map(String::from)
                .to_vec(),
            points: 1 << 18,
            runs: 7,
            naive: true,
            naive_filters: ["bcc_linear", "bcc7", "fcc6"].map(String::from).to_vec(),
            render_sizes: vec![256, 512],
            mni: crate::scene::data_file("mni152_t1_1mm.nii.gz").map(|p| p.display().to_string()),
            quality: true,
            references: true,
            external: None,
        }
    }
    /// Seconds-long version for CI (numbers are not meaningful).
    pub fn smoke() -> BenchOptions {
        BenchOptions {
            filters: vec!["bcc_linear".into()],
            points: 4096,
            runs: 3,
            naive: true,
            naive_filters: vec!["bcc_linear".into()],
            render_sizes: vec![32],
            mni: None,
            quality: true,
            // Minutes of cache builds and DVR frames: not in a smoke run.
            references: false,
            external: None,
        }
    }
}

/// The derivation of a filter by name (a catalog name or a spec).
pub(super) fn derive_filter(name: &str) -> Result<Derivation, BenchError> {
    let f = boxforge::spec::resolve(name)?;
    Ok(Derivation::new(&f)?)
}

/// Checks every input of a run (filters, the MNI file, an external shader)
/// before the first measurement, so a bad one fails in a second instead of
/// after minutes of timing. [`run`](fn@super::run) calls it; the CLI calls it before it
/// even opens a device.
pub fn check_inputs(o: &BenchOptions) -> Result<(), BenchError> {
    for name in &o.filters {
        derive_filter(name)?;
    }
    if let Some(path) = &o.mni {
        if !std::path::Path::new(path).is_file() {
            return Err(BenchError::MissingMni { path: path.clone() });
        }
    }
    if let Some(ext) = &o.external {
        std::fs::read_to_string(&ext.wgsl)
            .map_err(|x| BenchError::ExternalShader { path: ext.wgsl.clone(), reason: x.to_string() })?;
        derive_filter(&ext.like)?;
    }
    Ok(())
}
