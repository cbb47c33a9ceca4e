//! `boxforge convert IN OUT.zarr`: a volume (NIfTI, raw, OME-Zarr or
//! Marschner-Lobb) written as an OME-Zarr 0.5 pyramid, streaming, with a
//! progress bar (the writer is `volume::zarr::write_pyramid`).

use crate::common::Failure;
use boxforge::spec::lattice::Lattice;
use boxforge_runtime::volume::zarr::{
    self, LatticeOptions, OmeZarr, PyramidOptions, Reduction, Selection, ZarrType, ZarrVolume,
};
use boxforge_runtime::volume::{BrickSource, MappedVolume};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct ConvertArgs {
    /// The volume to convert: a .nii/.nii.gz file, a raw file with --raw, an OME-Zarr image
    /// (level --lod, channel --channel, time point --time), or ml:N (Marschner-Lobb, N^3 samples in [0, 1], float32).
    input: String,
    /// The OME-Zarr store to write (a new or empty folder; by convention named *.zarr).
    output: PathBuf,
    /// Raw input format: nx,ny,nz,type (type u8, u16 or f32).
    #[arg(long)]
    raw: Option<String>,
    /// OME-Zarr input: the level to read (default 0).
    #[arg(long)]
    lod: Option<usize>,
    /// OME-Zarr input: the channel to read (default 0).
    #[arg(long)]
    channel: Option<usize>,
    /// OME-Zarr input: the time point to read (default 0).
    #[arg(long)]
    time: Option<usize>,
    /// Chunk edge in samples.
    #[arg(long, default_value_t = 64)]
    chunk: usize,
    /// Shard edge in samples (a multiple of --chunk); default: unsharded.
    #[arg(long)]
    shard: Option<usize>,
    /// Pyramid levels; default: until the largest edge fits one chunk.
    #[arg(long)]
    levels: Option<usize>,
    /// How coarser levels are made: box (2x2x2 mean; the least loss among the low-passes, measured
    /// by bench --pyramid), tent ((1,2,1)/4), binomial ((1,4,6,4,1)/16) or subsample (every second
    /// sample, no low-pass: aliases).
    #[arg(long, value_enum, default_value = "box")]
    reduction: ReductionArg,
    /// Stored sample type; default: the input's (float32 for scaled NIfTI and other types,
    /// and for lattice samples).
    #[arg(long, value_enum)]
    dtype: Option<DtypeArg>,
    /// Store lattice samples instead of the grid: bcc or fcc (each level resampled at a
    /// matched sample count, stored as its Cartesian cosets; docs/OME_ZARR.md), or cc.
    /// Default: the --prefilter filter's lattice, else the grid as it is.
    #[arg(long)]
    lattice: Option<String>,
    /// Store the samples prefiltered for this filter (its spline coefficients, float32):
    /// a catalog name or a spec file, on the --lattice lattice.
    #[arg(long)]
    prefilter: Option<String>,
}

/// `--reduction`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ReductionArg {
    Binomial,
    Box,
    Subsample,
    Tent,
}

/// `--dtype`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum DtypeArg {
    U8,
    U16,
    I16,
    F32,
}

impl From<DtypeArg> for ZarrType {
    fn from(d: DtypeArg) -> ZarrType {
        match d {
            DtypeArg::U8 => ZarrType::U8,
            DtypeArg::U16 => ZarrType::U16,
            DtypeArg::I16 => ZarrType::I16,
            DtypeArg::F32 => ZarrType::F32,
        }
    }
}

/// The input opened: its samples, stored type, voxel size (x, y, z) and its unit.
struct Input {
    source: Box<dyn BrickSource>,
    ty: ZarrType,
    spacing: [f64; 3],
    unit: Option<String>,
}

pub fn run(a: ConvertArgs) -> Result<(), Failure> {
    let fail = |e: &dyn std::fmt::Display| Failure(e.to_string());
    if a.output.exists() && std::fs::read_dir(&a.output).map(|mut d| d.next().is_some()).unwrap_or(true) {
        return Err(Failure(format!("{} exists: remove it first or give a new output path", a.output.display())));
    }
    let input = open(&a)?;
    let prefilter = match &a.prefilter {
        Some(name) => {
            let filter = boxforge::spec::resolve(name).map_err(|e| fail(&e))?;
            if filter.dim() != 3 {
                return Err(Failure(format!(
                    "--prefilter {name}: {} is {}D; a volume is prefiltered with a 3D filter",
                    filter.name,
                    filter.dim()
                )));
            }
            Some(boxforge::derive::Derivation::new(&filter).map_err(|e| fail(&e))?)
        }
        None => None,
    };
    let lattice = match (&a.lattice, &prefilter) {
        (Some(name), _) => Some(Lattice::builtin(name).map_err(|e| fail(&e))?),
        (None, Some(d)) => Some(d.filter.lattice.clone()),
        (None, None) => None,
    };
    if let (Some(l), Some(d)) = (&lattice, &prefilter) {
        if d.filter.lattice.name != l.name {
            return Err(Failure(format!(
                "--prefilter {} is a filter on {}, not on --lattice {}: pick a filter on {} or drop --lattice",
                d.filter.name, d.filter.lattice.name, l.name, l.name
            )));
        }
    }
    let default_ty = if lattice.is_some() { ZarrType::F32 } else { input.ty };
    let options = PyramidOptions {
        chunk: a.chunk,
        shard: a.shard,
        levels: a.levels,
        reduction: match a.reduction {
            ReductionArg::Binomial => Reduction::Binomial,
            ReductionArg::Box => Reduction::Box,
            ReductionArg::Subsample => Reduction::Subsample,
            ReductionArg::Tent => Reduction::Tent,
        },
        ty: a.dtype.map_or(default_ty, ZarrType::from),
        spacing: input.spacing,
        unit: input.unit.clone(),
        ..PyramidOptions::default()
    };
    let bar = boxforge_runtime::progress::bar(1, &format!("writing {}", a.output.display()));
    let progress = |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let report = match &lattice {
        Some(l) => {
            let l = LatticeOptions { lattice: l, prefilter: prefilter.as_ref() };
            zarr::write_lattice_pyramid(input.source.as_ref(), &a.output, &options, l, &progress)
        }
        None => zarr::write_pyramid(input.source.as_ref(), &a.output, &options, &progress),
    }
    .map_err(|e| fail(&e))?;
    bar.finish_and_clear();
    let samples = match (&lattice, &prefilter) {
        (None, _) => String::new(),
        (Some(l), None) => format!(" {} samples", l.name),
        (Some(l), Some(p)) => format!(" {} samples prefiltered for {}", l.name, p.filter.name),
    };
    let d = report.levels[0];
    outln!(
        "wrote {} ({}x{}x{}{samples} {}, {} levels, {} reduction, chunks of {}^3{})",
        a.output.display(),
        d[0],
        d[1],
        d[2],
        options.ty.name(),
        report.levels.len(),
        options.reduction.name(),
        options.chunk,
        options.shard.map(|s| format!(" in shards of {s}^3")).unwrap_or_default()
    );
    Ok(())
}

fn open(a: &ConvertArgs) -> Result<Input, Failure> {
    let fail = |e: &dyn std::fmt::Display| Failure(e.to_string());
    let cc = Lattice::builtin("cc").map_err(|e| fail(&e))?;
    let path = Path::new(&a.input);
    let zarr_input = zarr::is_store(path);
    if !zarr_input {
        for (flag, given) in
            [("--lod", a.lod.is_some()), ("--channel", a.channel.is_some()), ("--time", a.time.is_some())]
        {
            if given {
                return Err(Failure(format!(
                    "{flag} picks from an OME-Zarr input; {} is not one: drop {flag}",
                    a.input
                )));
            }
        }
    }
    if zarr_input {
        let image = OmeZarr::open(path).map_err(|e| fail(&e))?;
        let s = Selection { level: a.lod.unwrap_or(0), channel: a.channel.unwrap_or(0), time: a.time.unwrap_or(0) };
        let v = ZarrVolume::new(&image, s, &cc).map_err(|e| fail(&e))?;
        let (ty, spacing, unit) = (v.sample_type(), v.spacing(), v.space_unit().map(str::to_string));
        return Ok(Input { source: Box::new(v), ty, spacing, unit });
    }
    if a.input.starts_with("ml:") {
        let v = boxforge_runtime::scene::load(&a.input, None, &cc, boxforge_runtime::scene::Conversion::Subset)
            .map_err(|e| fail(&e))?;
        return Ok(Input { source: Box::new(v), ty: ZarrType::F32, spacing: [1.0; 3], unit: None });
    }
    let cache = boxforge_runtime::volume::default_cache_dir();
    let m = MappedVolume::open(path, a.raw.as_deref(), &cc, &cache, &|_, _| {}).map_err(|e| fail(&e))?;
    let ty = match (m.stored_type(), m.scaled()) {
        ("uint8", false) => ZarrType::U8,
        ("uint16", false) => ZarrType::U16,
        ("int16", false) => ZarrType::I16,
        _ => ZarrType::F32,
    };
    let (spacing, unit) = (m.voxel_size(), m.space_unit().map(str::to_string));
    Ok(Input { source: Box::new(m), ty, spacing, unit })
}
