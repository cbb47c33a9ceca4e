//! `boxforge web`: the generated WGSL in a WebGPU viewer that runs in any
//! browser with WebGPU, as a static site (plain HTML, one ES module, the
//! shaders and a small volume file; no bundler, nothing downloaded).
//!
//! The site holds, per 3D filter and layout, the same shader sources the
//! native renderer compiles ([`crate::render::iso::raycast_shader`]: the emitted
//! module plus `templates/raycast.wgsl.j2`), every catalog module of every
//! layout and variant (for the compile check in Chrome's WGSL compiler),
//! `catalog.json` (what the page needs to sample, pack and ray cast: lattice
//! Hermite basis and cosets, support radius, shader paths) and the MNI head
//! in the `.bfv` format of [`volume_file`]. [`serve`] serves a folder on
//! 127.0.0.1 (WebGPU needs a secure context; localhost is one).

mod serve;

pub use serve::{serve, Server};

use crate::render::iso::{raycast_shader, HitMode};
use crate::volume::Volume;
use boxforge::build::output::{generated_files, write_atomic, ALL_VARIANTS};

/// The layouts the browser viewer binds (bricks and paging stay native).
const WEB_LAYOUTS: [Layout; 2] = [Layout::Embedded, Layout::Packed];
use boxforge::derive::Derivation;
use boxforge::emit::{coset_pivots, Layout};
use boxforge::Filter;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Why a site could not be written or served, or a `.bfv` file read.
#[derive(Debug, thiserror::Error)]
pub enum WebError {
    /// The bytes do not start with the `.bfv` header.
    #[error("not a .bfv volume (it must start with BFVOL, version 1)")]
    NotBfv,
    /// The header's dims overflow a sample count.
    #[error("dims overflow")]
    DimsOverflow,
    /// The file's length does not match its dims.
    #[error("a {}x{}x{} .bfv needs {expected} bytes, the file has {actual}", dims[0], dims[1], dims[2])]
    BfvSize { dims: [usize; 3], expected: usize, actual: usize },
    /// A volume could not be read or built.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    /// A filter could not be derived or its modules emitted or written.
    #[error(transparent)]
    Generator(#[from] boxforge::Error),
    /// A shader of the site could not be assembled.
    #[error(transparent)]
    Shader(#[from] crate::gpu::GpuError),
    /// A renderer's module could not be assembled.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// A transfer-function preset did not load.
    #[error(transparent)]
    TransferFunction(#[from] crate::render::dvr::transfer::TfError),
    /// The catalog did not serialize.
    #[error("cannot write catalog.json: {0}")]
    Catalog(#[from] serde_json::Error),
    /// A folder of the site could not be created.
    #[error("cannot create {}: {error}", dir.display())]
    CreateDir { dir: PathBuf, error: std::io::Error },
    /// The MNI head is not in the repository's data folder.
    #[error(
        "the MNI head data/mni152_t1_1mm.nii.gz is missing: run from the repository root, or build the site without it"
    )]
    MissingMni,
    /// [`serve`] was given a folder without a site.
    #[error("{} holds no index.html: build the site there first", root.display())]
    NoSite { root: PathBuf },
    /// [`serve`] could not bind its port.
    #[error("cannot listen on 127.0.0.1:{port}: {error} (pick another port, or port 0 for any free one)")]
    Listen { port: u16, error: String },
}

/// The page, its script and style sheet (in `runtime/web/`), written as they are.
const ASSETS: &[(&str, &str)] = &[
    ("index.html", include_str!("../../web/index.html")),
    ("viewer.js", include_str!("../../web/viewer.js")),
    ("style.css", include_str!("../../web/style.css")),
];

/// The command named in the headers of the site's shaders.
pub const WEB_COMMAND: &str = "boxforge web";

/// What goes into the site besides the filters.
#[derive(Clone, Debug)]
pub struct SiteOptions {
    /// A Cartesian volume to ship as `volumes/<name>.bfv`, with its name,
    /// a description and a sensible iso-value: the MNI head by default.
    pub volumes: Vec<SiteVolume>,
}

/// A volume shipped with the site.
#[derive(Clone, Debug)]
pub struct SiteVolume {
    pub name: String,
    pub description: String,
    pub iso: f32,
    /// The transfer-function preset the page starts DVR with.
    pub transfer_function: String,
    pub volume: Volume,
}

/// What [`write_site`] wrote.
#[derive(Clone, Debug)]
pub struct Site {
    /// Every file written, relative to the site folder.
    pub files: Vec<String>,
    /// Filters in the viewer (3D ones; others are only compile-checked).
    pub filters: Vec<String>,
    /// Catalog modules shipped for the compile check.
    pub modules: usize,
    /// Total bytes written.
    pub bytes: u64,
}

/// The magic bytes that open a `.bfv` file.
pub const BFV_MAGIC: &[u8; 8] = b"BFVOL\0\x01\0";

/// A Cartesian volume as a `.bfv` file (all little-endian): the 8 bytes
/// [`BFV_MAGIC`] ("BFVOL", 0, format version 1, 0), then `nx`, `ny`, `nz`
/// as u32, then nx * ny * nz f32 samples, x fastest (value(i,j,k) at
/// index i + nx (j + ny k)). The viewer reads the same layout (`viewer.js`,
/// `parseBfv`).
pub fn volume_file(v: &Volume) -> Vec<u8> {
    let mut out = Vec::with_capacity(20 + v.data.len() * 4);
    out.extend_from_slice(BFV_MAGIC);
    for n in v.dims {
        out.extend_from_slice(&(n as u32).to_le_bytes());
    }
    for x in &v.data {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out
}

/// Reads a `.bfv` file back (the inverse of [`volume_file`]).
pub fn parse_volume_file(bytes: &[u8]) -> Result<Volume, WebError> {
    if bytes.len() < 20 || &bytes[..8] != BFV_MAGIC {
        return Err(WebError::NotBfv);
    }
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes")) as usize;
    let dims = [word(8), word(12), word(16)];
    let count = dims.iter().try_fold(1usize, |a, &n| a.checked_mul(n)).ok_or(WebError::DimsOverflow)?;
    if bytes.len() != 20 + count * 4 {
        return Err(WebError::BfvSize { dims, expected: 20 + count * 4, actual: bytes.len() });
    }
    let data = bytes[20..].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect();
    Ok(Volume::new(dims, data)?)
}

/// The viewer's view of a filter: lattice, support, shaders (paths in the site).
fn filter_entry(d: &Derivation, layouts: &[Layout]) -> Value {
    let f = &d.filter;
    let lat = &f.lattice;
    // Cosets of the packed layout: the parity vector r of each coset, in the
    // coset order of the emitted fetch (as `LatticeVolume::packed`).
    let cosets: Option<Vec<Vec<i64>>> = coset_pivots(lat).ok().map(|pivots| {
        let mut parity: Vec<Option<Vec<i64>>> = vec![None; 1 << pivots.len()];
        for bits in 0..8i64 {
            let r = vec![bits & 1, (bits >> 1) & 1, (bits >> 2) & 1];
            if lat.contains(&r) {
                parity[boxforge::emit::coset_of(&pivots, &r)].get_or_insert(r);
            }
        }
        parity.into_iter().map(|r| r.unwrap_or_default()).collect()
    });
    let shaders: serde_json::Map<String, Value> = layouts
        .iter()
        .map(|l| {
            let base = format!("shaders/{}.{}", f.name, l.name());
            (
                l.name().to_string(),
                json!({
                    "step": format!("{base}.iso-step.wgsl"),
                    "exact": format!("{base}.iso-exact.wgsl"),
                    "dvr": format!("{base}.dvr.wgsl"),
                }),
            )
        })
        .collect();
    json!({
        "name": f.name,
        "description": f.description,
        "lattice": {
            "name": lat.name,
            "det": lat.det(),
            "hermite": lat.hermite_basis(),
            "cosets": cosets,
        },
        "degree": d.facts.degree,
        "support_radius": crate::volume::support_radius(d),
        "view_dependent": f.view_dependent,
        "shaders": shaders,
    })
}

/// A transfer-function preset as the page needs it, `tf/<name>.bin`: the
/// sampled table ([`crate::render::dvr::transfer::TransferFunction::table`], (r, g, b,
/// extinction) per entry) then the pre-integration table for segments of
/// `step` cells ([`crate::render::dvr::transfer::Tf1d::preintegrate`], row = front
/// value), all f32 little-endian; and its catalog entry.
fn transfer_file(name: &str, step: f32) -> Result<(Value, Vec<u8>), WebError> {
    let tf = crate::render::dvr::transfer::TransferFunction::load(name)?;
    let table = tf.table();
    let pi = table.preintegrate(step as f64);
    let data: Vec<u8> = table.entries.iter().chain(&pi.entries).flatten().flat_map(|x| x.to_le_bytes()).collect();
    let entry = json!({
        "name": name,
        "file": format!("tf/{name}.bin"),
        "range": [table.lo, table.hi],
        "table_size": table.entries.len(),
        "preint_size": pi.size,
        "step": step,
    });
    Ok((entry, data))
}

/// Writes the site into `out` (created if missing; files replaced
/// atomically). `progress(i, n, name)` is called before each filter.
pub fn write_site(
    out: &Path,
    filters: &[Filter],
    o: &SiteOptions,
    mut progress: impl FnMut(usize, usize, &str),
) -> Result<Site, WebError> {
    let mut files: Vec<(String, Vec<u8>)> =
        ASSETS.iter().map(|(n, s)| (n.to_string(), s.as_bytes().to_vec())).collect();
    let mut entries = Vec::new();
    let mut modules = Vec::new();
    let mut names = Vec::new();
    for (i, f) in filters.iter().enumerate() {
        progress(i, filters.len(), &f.name);
        let d = Derivation::new(f)?;
        for (name, source) in generated_files(&d, WEB_COMMAND, &WEB_LAYOUTS, &ALL_VARIANTS)? {
            if name.ends_with(".wgsl") {
                modules.push(format!("modules/{name}"));
                files.push((format!("modules/{name}"), source.into_bytes()));
            }
        }
        if d.facts.dim != 3 {
            continue;
        }
        let layouts: Vec<Layout> = WEB_LAYOUTS
            .iter()
            .copied()
            .filter(|&l| l == Layout::Embedded || coset_pivots(&f.lattice).is_ok())
            .collect();
        for &layout in &layouts {
            for hit in [HitMode::Step, HitMode::Exact] {
                let source = raycast_shader(&d, layout, hit, (1, [1, 1, 1]), WEB_COMMAND)?;
                let path = format!("shaders/{}.{}.iso-{}.wgsl", f.name, layout.name(), hit.as_str());
                files.push((path, source.into_bytes()));
            }
            let source = crate::render::dvr::shader_source(&d, layout)?;
            files.push((format!("shaders/{}.{}.dvr.wgsl", f.name, layout.name()), source.into_bytes()));
        }
        entries.push(filter_entry(&d, &layouts));
        names.push(f.name.clone());
    }
    let mut volumes = Vec::new();
    for v in &o.volumes {
        let path = format!("volumes/{}.bfv", v.name);
        volumes.push(json!({
            "name": v.name,
            "description": v.description,
            "iso": v.iso,
            "transfer_function": v.transfer_function,
            "dims": v.volume.dims,
            "file": path,
        }));
        files.push((path, volume_file(&v.volume)));
    }
    let dvr = crate::render::dvr::DvrOptions::default();
    let mut tfs = Vec::new();
    for (name, _) in crate::render::dvr::transfer::PRESETS {
        let (entry, data) = transfer_file(name, dvr.step)?;
        files.push((entry["file"].as_str().expect("a path").to_string(), data));
        tfs.push(entry);
    }
    // Every viewer shader's bindings, read from the shader as the reports
    // read the modules' (the page binds group 1 by these numbers).
    let mut bindings = serde_json::Map::new();
    for (path, data) in files.iter().filter(|(p, _)| p.starts_with("shaders/")) {
        let source = std::str::from_utf8(data).expect("generated WGSL is UTF-8");
        let table = boxforge::validate::bindings_of_wgsl(source)
            .map_err(|message| crate::gpu::GpuError::Shader { label: path.clone(), message })?;
        bindings.insert(path.clone(), serde_json::to_value(table)?);
    }
    let catalog = json!({
        "generator": format!("{WEB_COMMAND} {}", env!("CARGO_PKG_VERSION")),
        "schema_version": boxforge::build::report::REPORT_SCHEMA_VERSION,
        "bindings": bindings,
        "filters": entries,
        "modules": modules,
        "volumes": volumes,
        "transfer_functions": tfs,
        "dvr": {
            "step": dvr.step,
            "block": dvr.block,
            "termination": dvr.termination,
            "light": crate::render::dvr::LIGHT,
            "g0_of_range": crate::render::dvr::G0_OF_RANGE,
        },
        "defaults": {
            "block": crate::render::iso::RenderOptions::default().block,
            "step": crate::render::iso::RenderOptions::default().step,
        },
    });
    let text = serde_json::to_string_pretty(&catalog)? + "\n";
    files.push(("catalog.json".into(), text.into_bytes()));
    let mut written = Vec::new();
    let mut bytes = 0u64;
    for (rel, data) in &files {
        let path: PathBuf = out.join(rel);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|error| WebError::CreateDir { dir: dir.to_path_buf(), error })?;
        }
        write_atomic(&path, data)?;
        bytes += data.len() as u64;
        written.push(rel.clone());
    }
    Ok(Site { files: written, filters: names, modules: modules.len(), bytes })
}

/// The MNI head of the repository's data folder, box-averaged `downsample`
/// times per axis (the 1 mm volume is 182x218x182, 29 MB as f32), for the site.
pub fn mni_volume(downsample: usize) -> Result<SiteVolume, WebError> {
    let path = crate::scene::data_file("mni152_t1_1mm.nii.gz").ok_or(WebError::MissingMni)?;
    let v = Volume::load_nifti(&path)?;
    let v = v.downsample(downsample);
    Ok(SiteVolume {
        name: "mni".into(),
        description: format!(
            "MNI152 T1 head (1 mm, box-averaged {downsample}x per axis to {}x{}x{}); the lattice subset is taken in the page",
            v.dims[0], v.dims[1], v.dims[2]
        ),
        iso: 90.0,
        transfer_function: "mni-tissue".into(),
        volume: v,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_files_round_trip_and_bad_ones_are_refused() {
        let v = Volume::new([3, 2, 2], (0..12).map(|i| i as f32 * 0.5 - 1.0).collect()).unwrap();
        let bytes = volume_file(&v);
        assert_eq!(bytes.len(), 20 + 12 * 4);
        assert_eq!(parse_volume_file(&bytes).unwrap(), v);
        assert!(parse_volume_file(&bytes[..bytes.len() - 1]).unwrap_err().to_string().contains("needs 68 bytes"));
        let mut bad = bytes.clone();
        bad[0] = b'X';
        assert!(parse_volume_file(&bad).unwrap_err().to_string().contains("BFVOL"));
    }

    #[test]
    fn the_site_has_the_viewer_shaders_and_every_module() {
        let dir = std::env::temp_dir().join(format!("boxforge-web-unit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let filters = vec![boxforge::spec::catalog::get("bcc_linear").unwrap()];
        let site = write_site(&dir, &filters, &SiteOptions { volumes: vec![] }, |_, _, _| {}).unwrap();
        assert_eq!(site.filters, ["bcc_linear"]);
        assert_eq!(site.modules, 4, "2 layouts x 2 variants");
        let catalog: Value = serde_json::from_slice(&std::fs::read(dir.join("catalog.json")).unwrap()).unwrap();
        let f = &catalog["filters"][0];
        // BCC as a sublattice of Z^3 (all-even or all-odd points): index 4.
        assert_eq!(f["lattice"]["det"], 4);
        // The BCC cosets: all even and all odd coordinates.
        assert_eq!(f["lattice"]["cosets"], json!([[0, 0, 0], [1, 1, 1]]));
        for layout in ["embedded", "packed"] {
            for hit in ["step", "exact"] {
                let path = f["shaders"][layout][hit].as_str().unwrap();
                let source = std::fs::read_to_string(dir.join(path)).unwrap();
                assert!(source.contains("fn bcc_linear_raycast_main"), "{path}");
                assert_eq!(hit == "exact", source.contains("override bcc_linear_FINE_EDGE"), "{path}");
            }
            let path = f["shaders"][layout]["dvr"].as_str().unwrap();
            assert!(std::fs::read_to_string(dir.join(path)).unwrap().contains("fn bcc_linear_dvr_main"), "{path}");
        }
        // The bindings the page must provide, per shader, read from the shader:
        // group 1 of the step walk has no fine grid (binding 4), the exact walk has.
        assert_eq!(catalog["schema_version"], boxforge::build::report::REPORT_SCHEMA_VERSION);
        let group1 = |path: &str| -> Vec<(u64, String)> {
            let table = catalog["bindings"][path].as_array().unwrap_or_else(|| panic!("no bindings for {path}"));
            table
                .iter()
                .filter(|b| b["group"] == 1)
                .map(|b| (b["binding"].as_u64().unwrap(), b["kind"].as_str().unwrap().to_string()))
                .collect()
        };
        let kinds = |k: &[&str]| -> Vec<(u64, String)> {
            k.iter().enumerate().map(|(i, k)| (i as u64, k.to_string())).collect()
        };
        let step =
            kinds(&["uniform buffer", "storage buffer read_write", "storage buffer read", "storage buffer read_write"]);
        assert_eq!(group1(f["shaders"]["embedded"]["step"].as_str().unwrap()), step);
        let mut exact = step.clone();
        exact.push((4, "storage buffer read".into()));
        assert_eq!(group1(f["shaders"]["embedded"]["exact"].as_str().unwrap()), exact);
        let dvr = kinds(&[
            "uniform buffer",
            "storage buffer read_write",
            "storage buffer read",
            "storage buffer read",
            "storage buffer read",
        ]);
        assert_eq!(group1(f["shaders"]["packed"]["dvr"].as_str().unwrap()), dvr);
        // Each preset's tables: the 1D table then the pre-integration table, as the native renderer builds them.
        for t in catalog["transfer_functions"].as_array().unwrap() {
            let name = t["name"].as_str().unwrap();
            let bytes = std::fs::read(dir.join(t["file"].as_str().unwrap())).unwrap();
            let floats: Vec<f32> = bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
            let table = crate::render::dvr::transfer::TransferFunction::load(name).unwrap().table();
            let (n, m) = (t["table_size"].as_u64().unwrap() as usize, t["preint_size"].as_u64().unwrap() as usize);
            assert_eq!((n, floats.len()), (table.entries.len(), 4 * (n + m * m)), "{name}");
            assert_eq!(floats[4 * (n - 1)..4 * n], table.entries[n - 1], "{name}: last 1D entry");
            let pi = table.preintegrate(t["step"].as_f64().unwrap());
            assert_eq!(floats[4 * n + 4 * (m * m - 2)..4 * n + 4 * (m * m - 1)], pi.entries[m * m - 2], "{name}");
        }
        for (name, _) in ASSETS {
            assert!(dir.join(name).is_file(), "{name}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
