//! The resource bindings a WGSL module declares, read from the validated naga
//! module rather than written down by hand: the reports list them, and a
//! host builds its bind group layouts from the same table, so the numbers
//! cannot drift from the shader.

use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};
use naga::{AddressSpace, ImageClass, ImageDimension, Module, ScalarKind, StorageAccess, TypeInner};
use std::collections::BTreeSet;

/// One `@group(g) @binding(b)` variable of a module.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Binding {
    /// Bind group index.
    pub group: u32,
    /// Binding index within the group.
    pub binding: u32,
    /// The variable's name in the WGSL source.
    pub name: String,
    /// What the host binds, in WGSL-like words: `texture_3d<f32>`,
    /// `texture_storage_3d<r32uint, write>`, `storage buffer read`,
    /// `storage buffer read_write`, `uniform buffer`, `sampler` or
    /// `sampler_comparison`.
    pub kind: String,
    /// The contents' type where it says more than the kind: the storage
    /// format of a storage texture (`r32uint`), the WGSL type of a buffer
    /// (`array<f32>`, a struct name); `None` for sampled textures and samplers.
    pub format: Option<String>,
    /// Entry points whose call tree uses the variable (naga's global-use
    /// analysis, which follows calls), in module order.
    pub entry_points: Vec<String>,
    /// Functions no other function calls (the module's API, e.g. `<f>_eval`)
    /// whose call tree uses the variable, in module order.
    pub functions: Vec<String>,
    /// What the host must put there, in one sentence; `None` unless the
    /// caller knows the module (see [`binding_purpose`]).
    pub purpose: Option<String>,
}

/// What the host must bind to the variable `name` of a module emitted for
/// filter `filter`, in one sentence; `None` for a name the emitter does not
/// write. Hand-written because the meaning of the bytes is not in the WGSL;
/// the numbers (group, binding, type) are read from the module itself
/// ([`bindings_of_wgsl`]). Kept here, beside [`Binding::purpose`], rather
/// than in the emitter, so that the back ends (below the emitter in the
/// generator's stages) can fill it in without importing `emit`.
pub fn binding_purpose(filter: &str, name: &str) -> Option<&'static str> {
    Some(match name.strip_prefix(filter)?.strip_prefix('_')? {
        "samples" => "The 4D samples as a read-only storage buffer: a vec4<i32> header (the stored extent, embedded; one coset's grid size, packed), then the f32 samples x fastest, then y, z and w (packed: the coset grids tiled as in the packed texture layout).",
        "volume" => "The samples as an r32float texture (r16float, r16unorm, r8unorm read the same; u8x4 modules: r32uint, four u8 samples a texel along x): lattice point j at texel j (the other texels are unused).",
        "cosets" => "The samples packed per coset of 2Z^s as one r32float texture (filterable with fetch = linear): lattice point j at texel (j >> 1) + (j & p) * grid.size, p = 1 on the pivot axes of the coset id, so each coset's grid is one tile.",
        "grid" => "The coset grid: its size (x, y, z or x, y) and, in w, the words per coset.",
        "pool" => "The brick pool as an r32float (or compact-format; u8x4 modules: r32uint, four u8 samples a texel along x) texture: slot s holds brick k's texels k * B - h .. (k + 1) * B + h (clamped to the volume), as they are (bricked) or coset-packed in a tile per coset (bricked-packed).",
        "bricks" => "The brick geometry: the volume's size in lattice texels (bricked) or its coset grid size (bricked-packed) with the brick edge B in w, and the bricks per axis with the halo h in w.",
        "pages" => "The page table as an r32uint texture, one texel per brick: its slot (10 bits per axis in 3D, 16 in 2D).",
        "linear" => "A linear, clamp-to-edge sampler for the hardware-filtered fetches.",
        "out" => "The kernels' output buffer: one prefiltered value per point of the job's box (row-major), or a (min, max) pair per block for minmax.",
        "job" => "The kernel's job: the box's lattice-coordinate origin and extent, and the block edge B in extent.w for minmax.",
        _ => return None,
    })
}

/// The bindings of any WGSL source, sorted by (group, binding).
///
/// The module is parsed and validated (all checks, default capabilities)
/// first: the uses come from the validator's analysis, which only exists for
/// a valid module.
///
/// # Errors
///
/// naga's parse or validation error, rendered as text.
///
/// Remembered per source text (up to [`MEMO_SOURCE_BYTES`] of it): the
/// reports read every generated module's bindings and the web viewer reads
/// the same modules' again, and naga's front end is the costliest part of
/// both on shaders of ten thousand lines.
pub fn bindings_of_wgsl(source: &str) -> Result<Vec<Binding>, String> {
    if let Some(known) = memo().lock().unwrap_or_else(|e| e.into_inner()).get(source) {
        return known.clone();
    }
    let read = read_bindings(source);
    memo().lock().unwrap_or_else(|e| e.into_inner()).insert(source, &read);
    read
}

/// How many bytes of WGSL the memo of [`bindings_of_wgsl`] keeps before it
/// starts over.
pub const MEMO_SOURCE_BYTES: usize = 64 << 20;

/// Bindings already read, by source text.
#[derive(Default)]
struct Memo {
    read: std::collections::HashMap<String, Result<Vec<Binding>, String>>,
    bytes: usize,
}

impl Memo {
    fn get(&self, source: &str) -> Option<&Result<Vec<Binding>, String>> {
        self.read.get(source)
    }

    fn insert(&mut self, source: &str, read: &Result<Vec<Binding>, String>) {
        if source.len() > MEMO_SOURCE_BYTES {
            return;
        }
        if self.bytes + source.len() > MEMO_SOURCE_BYTES {
            self.read.clear();
            self.bytes = 0;
        }
        if self.read.insert(source.to_string(), read.clone()).is_none() {
            self.bytes += source.len();
        }
    }
}

fn memo() -> &'static std::sync::Mutex<Memo> {
    static MEMO: std::sync::OnceLock<std::sync::Mutex<Memo>> = std::sync::OnceLock::new();
    MEMO.get_or_init(Default::default)
}

/// [`bindings_of_wgsl`] without the memo.
fn read_bindings(source: &str) -> Result<Vec<Binding>, String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let info = Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .map_err(|e| e.emit_to_string(source))?;
    Ok(bindings(&module, &info))
}

/// The bindings of a validated module (`info` from validating `module`),
/// sorted by (group, binding).
pub fn bindings(module: &Module, info: &ModuleInfo) -> Vec<Binding> {
    // Functions some other function calls are helpers, not the module's API.
    let called: BTreeSet<String> = module
        .functions
        .iter()
        .flat_map(|(_, f)| f.body.iter())
        .chain(module.entry_points.iter().flat_map(|ep| ep.function.body.iter()))
        .flat_map(callees)
        .filter_map(|h| module.functions[h].name.clone())
        .collect();
    let mut out: Vec<Binding> = module
        .global_variables
        .iter()
        .filter_map(|(handle, var)| {
            let rb = var.binding.as_ref()?;
            let (kind, format) = kind_and_format(module, var);
            let entry_points = module
                .entry_points
                .iter()
                .enumerate()
                .filter(|(i, _)| !info.get_entry_point(*i)[handle].is_empty())
                .map(|(_, ep)| ep.name.clone())
                .collect();
            let functions = module
                .functions
                .iter()
                .filter(|(fh, _)| !info[*fh][handle].is_empty())
                .filter_map(|(_, f)| f.name.clone())
                .filter(|n| !called.contains(n))
                .collect();
            Some(Binding {
                group: rb.group,
                binding: rb.binding,
                name: var.name.clone().unwrap_or_default(),
                kind,
                format,
                entry_points,
                functions,
                purpose: None,
            })
        })
        .collect();
    out.sort_by_key(|b| (b.group, b.binding));
    out
}

/// The functions called by `stmt` and the blocks nested in it.
fn callees(stmt: &naga::Statement) -> Vec<naga::Handle<naga::Function>> {
    use naga::Statement as S;
    let blocks: Vec<&naga::Block> = match stmt {
        S::Call { function, .. } => return vec![*function],
        S::Block(b) => vec![b],
        S::If { accept, reject, .. } => vec![accept, reject],
        S::Switch { cases, .. } => cases.iter().map(|c| &c.body).collect(),
        S::Loop { body, continuing, .. } => vec![body, continuing],
        _ => vec![],
    };
    blocks.into_iter().flat_map(|b| b.iter()).flat_map(callees).collect()
}

fn kind_and_format(module: &Module, var: &naga::GlobalVariable) -> (String, Option<String>) {
    use naga::common::wgsl::TypeContext;
    let ctx = module.to_ctx();
    let ty = ctx.type_to_string(var.ty);
    match (&var.space, &module.types[var.ty].inner) {
        (AddressSpace::Storage { access }, _) => {
            let rw = if access.contains(StorageAccess::STORE) { "read_write" } else { "read" };
            (format!("storage buffer {rw}"), Some(ty))
        }
        (AddressSpace::Uniform, _) => ("uniform buffer".into(), Some(ty)),
        (_, TypeInner::Sampler { comparison }) => {
            ((if *comparison { "sampler_comparison" } else { "sampler" }).into(), None)
        }
        // Textures are spelled out as in WGSL source (naga's type printer
        // writes `texture_storage_2d<r32uint,write>` without the space).
        (_, TypeInner::Image { dim, arrayed, class: ImageClass::Storage { format, access } }) => {
            use naga::common::wgsl::ToWgsl;
            let access = match (access.contains(StorageAccess::LOAD), access.contains(StorageAccess::STORE)) {
                (true, true) => "read_write",
                (true, false) => "read",
                _ => "write",
            };
            let format = format.to_wgsl();
            (format!("texture_storage_{}<{format}, {access}>", dim_name(*dim, *arrayed)), Some(format.to_string()))
        }
        (_, TypeInner::Image { dim, arrayed, class: ImageClass::Sampled { kind, multi } }) => {
            let sample = match kind {
                ScalarKind::Sint => "i32",
                ScalarKind::Uint => "u32",
                _ => "f32",
            };
            let ms = if *multi { "multisampled_" } else { "" };
            (format!("texture_{ms}{}<{sample}>", dim_name(*dim, *arrayed)), None)
        }
        _ => (ty, None),
    }
}

/// `1d`, `2d`, `2d_array`, `3d`, `cube`, `cube_array`.
fn dim_name(dim: ImageDimension, arrayed: bool) -> String {
    let d = match dim {
        ImageDimension::D1 => "1d",
        ImageDimension::D2 => "2d",
        ImageDimension::D3 => "3d",
        ImageDimension::Cube => "cube",
    };
    format!("{d}{}", if arrayed { "_array" } else { "" })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOURCE: &str = "
@group(0) @binding(3) var<uniform> u: vec4<f32>;
@group(1) @binding(0) var<storage, read> a: array<f32>;
@group(0) @binding(0) var t: texture_3d<f32>;
@group(0) @binding(1) var<storage, read_write> o: array<u32>;
@group(0) @binding(2) var s: sampler;
@group(2) @binding(0) var w: texture_storage_2d<r32uint, write>;
fn helper(i: i32) -> f32 { return a[i]; }
fn api(i: i32) -> f32 { return helper(i) + textureLoad(t, vec3<i32>(i), 0).x; }
@compute @workgroup_size(1)
fn k(@builtin(global_invocation_id) g: vec3<u32>) {
    o[g.x] = u32(helper(i32(g.x)) + u.x);
    textureStore(w, vec2<i32>(0), vec4<u32>(1u));
}
@compute @workgroup_size(1)
fn unused(@builtin(global_invocation_id) g: vec3<u32>) {}
";

    #[test]
    fn bindings_come_sorted_with_kinds_formats_and_uses() {
        let b = bindings_of_wgsl(SOURCE).unwrap();
        // (group, binding, name, kind, format, entry points, functions)
        type Row<'a> = (u32, u32, &'a str, &'a str, Option<&'a str>, Vec<&'a str>, Vec<&'a str>);
        let rows: Vec<Row> = b
            .iter()
            .map(|b| {
                (
                    b.group,
                    b.binding,
                    b.name.as_str(),
                    b.kind.as_str(),
                    b.format.as_deref(),
                    b.entry_points.iter().map(String::as_str).collect(),
                    b.functions.iter().map(String::as_str).collect(),
                )
            })
            .collect();
        assert_eq!(
            rows,
            vec![
                (0, 0, "t", "texture_3d<f32>", None, vec![], vec!["api"]),
                (0, 1, "o", "storage buffer read_write", Some("array<u32>"), vec!["k"], vec![]),
                (0, 2, "s", "sampler", None, vec![], vec![]),
                (0, 3, "u", "uniform buffer", Some("vec4<f32>"), vec!["k"], vec![]),
                (1, 0, "a", "storage buffer read", Some("array<f32>"), vec!["k"], vec!["api"]),
                (2, 0, "w", "texture_storage_2d<r32uint, write>", Some("r32uint"), vec!["k"], vec![]),
            ]
        );
        assert!(b.iter().all(|b| b.purpose.is_none()));
    }

    #[test]
    fn invalid_wgsl_is_an_error() {
        assert!(bindings_of_wgsl("fn f() -> f32 { return x; }").is_err());
    }
}
