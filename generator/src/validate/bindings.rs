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
    /// caller knows the module (see `boxforge::emit::binding_purpose`).
    pub purpose: Option<String>,
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
pub fn bindings_of_wgsl(source: &str) -> Result<Vec<Binding>, String> {
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
