//! The text targets: GLSL (core and ES), HLSL and MSL, each a library file
//! and the kernels as complete compute shaders (see the table in
//! [`super`]). Slots follow the WGSL numbers so that one host layout fits
//! every language: GL `binding` = WGSL binding (GL has no groups), HLSL
//! `register(<class><binding>, space<group>)`, Metal `[[texture|buffer|sampler(binding)]]`.

use super::header::header;
use super::modules::{Prepared, Validated};
use super::{BackError, Code, Role, Target, TargetBinding, TargetSlot, Unit};
use crate::validate::Binding;
use naga::back::{glsl, hlsl, msl};
use naga::{Handle, ResourceBinding, ShaderStage};

/// Metal buffer slot of the array sizes naga passes to kernels that call
/// `arrayLength` (the last of Metal's 31 buffer slots).
pub const METAL_SIZES_BUFFER: u8 = 30;

/// GLSL, HLSL or MSL: the library unit, then the kernels.
///
/// # Errors
///
/// [`BackError::Backend`] when naga's backend refuses;
/// [`BackError::Unsupported`] for a binding beyond GL's or Metal's slots.
pub fn translate(p: &Prepared, target: Target) -> Result<Vec<Unit>, BackError> {
    match target {
        Target::Glsl | Target::GlslEs => glsl_units(p, target),
        Target::Hlsl => hlsl_units(p),
        Target::Msl => msl_units(p),
        Target::Wgsl | Target::Spirv => unreachable!("text::translate is for GLSL, HLSL and MSL"),
    }
}

fn backend(file: &str, target: Target, e: impl std::fmt::Display) -> BackError {
    BackError::Backend { file: file.to_string(), target, message: e.to_string() }
}

fn global_of(v: &Validated, b: &Binding) -> Option<Handle<naga::GlobalVariable>> {
    v.module.global_variables.iter().find_map(|(h, g)| {
        let rb = g.binding.as_ref()?;
        (rb.group == b.group && rb.binding == b.binding).then_some(h)
    })
}

fn small_slot(file: &str, b: &Binding, what: &str) -> Result<u8, BackError> {
    u8::try_from(b.binding).ok().filter(|&s| what != "Metal" || s < METAL_SIZES_BUFFER).ok_or_else(|| {
        BackError::Unsupported {
            file: file.to_string(),
            message: format!(
                "binding {} of `{}` is beyond {what}'s slots; give the Builder (or generate) a lower first binding, or use the wgsl or spirv target",
                b.binding, b.name
            ),
        }
    })
}

fn glsl_units(p: &Prepared, target: Target) -> Result<Vec<Unit>, BackError> {
    let es = target == Target::GlslEs;
    let ext = if es { "es.glsl" } else { "glsl" };
    let version = if es { glsl::Version::new_gles(310) } else { glsl::Version::Desktop(450) };
    let write = |v: &Validated, entry: &str, file: &str| -> Result<(String, glsl::ReflectionInfo), BackError> {
        let mut options = glsl::Options { version, writer_flags: glsl::WriterFlags::empty(), ..Default::default() };
        for (_, g) in v.module.global_variables.iter() {
            if let Some(rb) = &g.binding {
                let b = u8::try_from(rb.binding).map_err(|_| BackError::Unsupported {
                    file: file.to_string(),
                    message: format!("binding {} is beyond GL's binding points; use a lower first binding", rb.binding),
                })?;
                options.binding_map.insert(*rb, b);
            }
        }
        let pipeline = glsl::PipelineOptions {
            shader_stage: ShaderStage::Compute,
            entry_point: entry.to_string(),
            multiview: None,
        };
        let mut out = String::new();
        let mut w = glsl::Writer::new(&mut out, &v.module, &v.info, &options, &pipeline, Default::default())
            .map_err(|e| backend(file, target, e))?;
        let reflection = w.write().map_err(|e| backend(file, target, e))?;
        Ok((out, reflection))
    };
    let target_bindings = |v: &Validated, list: &[Binding], r: &glsl::ReflectionInfo| -> Vec<TargetBinding> {
        list.iter()
            .map(|b| {
                let name = format!("_group_{}_binding_{}_cs", b.group, b.binding);
                let slot = if b.kind.starts_with("sampler") {
                    let h = global_of(v, b);
                    let texture = r
                        .texture_mapping
                        .iter()
                        .filter(|(_, m)| m.sampler.is_some() && m.sampler == h)
                        .map(|(k, _)| k.clone())
                        .min()
                        .unwrap_or_default();
                    TargetSlot::CombinedWith { texture }
                } else {
                    TargetSlot::GlBinding { binding: b.binding }
                };
                TargetBinding { wgsl: b.clone(), name_in_target: name, slot }
            })
            .collect()
    };
    let mut units = Vec::new();
    let file = format!("{}.{ext}", p.stem);
    let (text, reflection) = write(&p.library, &p.stub, &file)?;
    let text = vulkan_declarations(&text, &p.library, &reflection, &file, target)?;
    let bindings = target_bindings(&p.library, &p.library_bindings, &reflection);
    let body = glsl_library_body(&text, &file, target)?;
    let functions = p.public_functions.clone();
    let head = header(p, target, &Role::Library, &functions, &[], &bindings);
    units.push(Unit {
        file_name: file,
        role: Role::Library,
        code: Code::Text(format!("{head}{body}")),
        functions,
        entry_points: vec![],
        bindings,
    });
    for ep in p.kernel_entry_points() {
        let file = format!("{}.{}.{}", p.stem, p.kernel_short_name(&ep), if es { "es.comp" } else { "comp" });
        let (text, reflection) = write(&p.kernels, &ep, &file)?;
        let text = vulkan_declarations(&text, &p.kernels, &reflection, &file, target)?;
        let bindings = target_bindings(&p.kernels, &p.bindings_of(&ep), &reflection);
        let entry_points = vec![ep];
        let head = header(p, target, &Role::Kernels, &[], &entry_points, &bindings);
        // `#version` comes first (GLSL ES allows nothing before it, not even comments).
        let (version, rest) = text.split_once('\n').unwrap_or((&text, ""));
        units.push(Unit {
            file_name: file,
            role: Role::Kernels,
            code: Code::Text(format!("{version}\n{head}{rest}")),
            functions: vec![],
            entry_points,
            bindings,
        });
    }
    Ok(units)
}

/// The extension that lets Vulkan GLSL `texelFetch` from a `texture3D`
/// without a sampler.
pub const SAMPLERLESS_EXTENSION: &str = "GL_EXT_samplerless_texture_functions";

/// Declarations that hold under both GLSL APIs. naga writes OpenGL GLSL, in
/// which every texture is a combined `sampler3D`; a Vulkan host (wgpu, or
/// any host binding the WGSL layout) binds a sampled image and a separate
/// sampler, and a combined image sampler in the shader would not match that
/// descriptor type (lavapipe tolerates it, other drivers need not). So each
/// combined declaration gets a `#ifdef VULKAN` twin (glslang defines
/// `VULKAN` when it compiles for Vulkan, `-V`): the texture as a `texture3D`
/// at the WGSL set and binding, and where naga combined it with a sampler,
/// the `sampler` at its own binding and a `#define` that rebuilds the
/// combined name with `sampler3D(texture, sampler)`, so the function bodies
/// stay as naga wrote them. Samplerless `texelFetch` needs
/// [`SAMPLERLESS_EXTENSION`], declared under the same `#ifdef`.
fn vulkan_declarations(
    text: &str,
    v: &Validated,
    r: &glsl::ReflectionInfo,
    file: &str,
    target: Target,
) -> Result<String, BackError> {
    let binding_of = |h: Handle<naga::GlobalVariable>| {
        v.module.global_variables[h].binding.ok_or_else(|| BackError::Check {
            file: file.to_string(),
            target,
            message: format!("a texture or sampler of the combined samplers has no binding ({h:?})"),
        })
    };
    let mut lines: Vec<String> = Vec::new();
    let mut needs_samplerless = false;
    for line in text.lines() {
        let Some(decl) = combined_sampler_declaration(line) else {
            lines.push(line.to_string());
            continue;
        };
        let Some(mapping) = r.texture_mapping.get(decl.name) else {
            return Err(BackError::Check {
                file: file.to_string(),
                target,
                message: format!("naga declared `{}` but its reflection does not map it to a texture", decl.name),
            });
        };
        let t = binding_of(mapping.texture)?;
        let image = format!("{}texture{}", decl.prefix, decl.shape);
        let p = decl.precision;
        lines.push("#ifdef VULKAN".into());
        match mapping.sampler {
            None => {
                needs_samplerless = true;
                lines.push(format!(
                    "layout(set = {}, binding = {}) uniform {p}{image} {};",
                    t.group, t.binding, decl.name
                ));
            }
            Some(sh) => {
                let s = binding_of(sh)?;
                let n = decl.name;
                lines.push(format!("layout(set = {}, binding = {}) uniform {p}{image} {n}_image;", t.group, t.binding));
                lines.push(format!(
                    "layout(set = {}, binding = {}) uniform {p}sampler {n}_sampler;",
                    s.group, s.binding
                ));
                lines.push(format!("#define {n} {}sampler{}({n}_image, {n}_sampler)", decl.prefix, decl.shape));
            }
        }
        lines.push("#else".into());
        lines.push(line.to_string());
        lines.push("#endif".into());
    }
    if needs_samplerless {
        // After #version and naga's own #extension lines, before any declaration.
        let at =
            lines.iter().rposition(|l| l.starts_with("#extension") || l.starts_with("#version")).map_or(0, |i| i + 1);
        let block =
            ["#ifdef VULKAN".to_string(), format!("#extension {SAMPLERLESS_EXTENSION} : require"), "#endif".into()];
        lines.splice(at..at, block);
    }
    let mut out = lines.join("\n");
    if text.ends_with('\n') {
        out.push('\n');
    }
    Ok(out)
}

/// One `layout(binding = N) uniform [precision ]<i|u>sampler<shape> NAME;` line of naga's GLSL.
struct CombinedDeclaration<'a> {
    precision: &'a str,
    prefix: &'a str,
    shape: &'a str,
    name: &'a str,
}

fn combined_sampler_declaration(line: &str) -> Option<CombinedDeclaration<'_>> {
    let rest = line.strip_prefix("layout(binding = ")?;
    let (_, rest) = rest.split_once(") uniform ")?;
    let rest = rest.strip_suffix(';')?;
    let mut words: Vec<&str> = rest.split_whitespace().collect();
    let name = words.pop()?;
    let ty = words.pop()?;
    let precision = match words.as_slice() {
        [] => "",
        [p] if ["lowp", "mediump", "highp"].contains(p) => &rest[..p.len() + 1],
        _ => return None,
    };
    let at = ty.find("sampler")?;
    let (prefix, shape) = (&ty[..at], &ty[at + "sampler".len()..]);
    if !["", "i", "u"].contains(&prefix) || shape.is_empty() || shape.contains("Shadow") {
        return None;
    }
    Some(CombinedDeclaration { precision, prefix, shape, name })
}

/// The GLSL library: naga's program for the stub entry point without what
/// belongs to the including shader (`#version`, the compute-only extension,
/// `local_size`) and without the stub's `main`.
fn glsl_library_body(text: &str, file: &str, target: Target) -> Result<String, BackError> {
    let mut out = String::with_capacity(text.len());
    let mut in_main = false;
    let mut found_main = false;
    for line in text.lines() {
        if in_main {
            in_main = line != "}";
            continue;
        }
        if line == "void main() {" {
            in_main = true;
            found_main = true;
            continue;
        }
        if line.starts_with("#version")
            || line.starts_with("#extension GL_ARB_compute_shader")
            || line.starts_with("layout(local_size_x")
        {
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    if !found_main {
        return Err(BackError::Check {
            file: file.to_string(),
            target,
            message: "the stub entry point `void main() {` was not found in naga's GLSL".into(),
        });
    }
    Ok(out.trim_end().to_string() + "\n")
}

/// HLSL register class of a binding: t (SRV), u (UAV), b (constant buffer), s (sampler).
fn hlsl_register_class(kind: &str) -> char {
    if kind.starts_with("sampler") {
        's'
    } else if kind.starts_with("uniform") {
        'b'
    } else if kind.contains("read_write") || kind.starts_with("texture_storage") {
        'u'
    } else {
        't'
    }
}

fn hlsl_units(p: &Prepared) -> Result<Vec<Unit>, BackError> {
    let target = Target::Hlsl;
    if let Some(s) = p.kernel_bindings.iter().find(|b| b.kind.starts_with("sampler")) {
        // naga reaches HLSL samplers through wgpu's DX12 sampler heap and a
        // per-group index buffer, which a plain HLSL host does not have.
        return Err(BackError::Unsupported {
            file: format!("{}.hlsl", p.stem),
            message: format!(
                "the hlsl target cannot express the linear sampler `{}` (naga writes HLSL samplers as wgpu's DX12 sampler heap and index buffer): use exact fetches (fetch = exact) for hlsl, or the wgsl, spirv, glsl, glsl-es or msl target for linear fetches",
                s.name
            ),
        });
    }
    let write = |v: &Validated, file: &str| -> Result<String, BackError> {
        let mut options =
            hlsl::Options { shader_model: hlsl::ShaderModel::V5_1, fake_missing_bindings: false, ..Default::default() };
        for (_, g) in v.module.global_variables.iter() {
            if let Some(rb) = &g.binding {
                let space = u8::try_from(rb.group).map_err(|_| backend(file, target, "group beyond 255"))?;
                options.binding_map.insert(
                    *rb,
                    hlsl::BindTarget {
                        space,
                        register: rb.binding,
                        binding_array_size: None,
                        dynamic_storage_buffer_offsets_index: None,
                        restrict_indexing: false,
                    },
                );
            }
        }
        let pipeline = hlsl::PipelineOptions::default();
        let mut out = String::new();
        let mut w = hlsl::Writer::new(&mut out, &options, &pipeline);
        w.write(&v.module, &v.info, None).map_err(|e| backend(file, target, e))?;
        Ok(out)
    };
    let target_bindings = |list: &[Binding]| -> Vec<TargetBinding> {
        list.iter()
            .map(|b| TargetBinding {
                wgsl: b.clone(),
                name_in_target: b.name.clone(),
                slot: TargetSlot::Register {
                    register: format!("{}{}", hlsl_register_class(&b.kind), b.binding),
                    space: b.group,
                },
            })
            .collect()
    };
    let mut library = Validated { module: p.library.module.clone(), info: p.library.info.clone() };
    library.module.entry_points.clear();
    let file = format!("{}.hlsl", p.stem);
    let library = super::modules::revalidate(library, &file)?;
    let text = write(&library, &file)?;
    let bindings = target_bindings(&p.library_bindings);
    let functions = p.public_functions.clone();
    let head = header(p, target, &Role::Library, &functions, &[], &bindings);
    let mut units = vec![Unit {
        file_name: file,
        role: Role::Library,
        code: Code::Text(format!("{head}{text}")),
        functions,
        entry_points: vec![],
        bindings,
    }];
    let file = format!("{}.kernels.hlsl", p.stem);
    let text = write(&p.kernels, &file)?;
    let bindings = target_bindings(&p.kernel_bindings);
    let entry_points = p.kernel_entry_points();
    let head = header(p, target, &Role::Kernels, &[], &entry_points, &bindings);
    units.push(Unit {
        file_name: file,
        role: Role::Kernels,
        code: Code::Text(format!("{head}{text}")),
        functions: vec![],
        entry_points,
        bindings,
    });
    Ok(units)
}

fn metal_index(b: &Binding, slot: u8) -> String {
    if b.kind.starts_with("sampler") {
        format!("sampler({slot})")
    } else if b.kind.starts_with("texture") {
        format!("texture({slot})")
    } else {
        format!("buffer({slot})")
    }
}

fn msl_units(p: &Prepared) -> Result<Vec<Unit>, BackError> {
    let target = Target::Msl;
    let options = msl::Options { lang_version: (2, 1), fake_missing_bindings: false, ..Default::default() };
    let mut library = Validated { module: p.library.module.clone(), info: p.library.info.clone() };
    library.module.entry_points.clear();
    let file = format!("{}.metal", p.stem);
    let library = super::modules::revalidate(library, &file)?;
    let (text, _) = msl::write_string(&library.module, &library.info, &options, &Default::default())
        .map_err(|e| backend(&file, target, e))?;
    let bindings: Vec<TargetBinding> = p
        .library_bindings
        .iter()
        .map(|b| TargetBinding {
            wgsl: b.clone(),
            name_in_target: b.name.clone(),
            slot: TargetSlot::MetalIndex { index: format!("argument `{}`", b.name) },
        })
        .collect();
    let functions = p.public_functions.clone();
    let head = header(p, target, &Role::Library, &functions, &[], &bindings);
    let mut units = vec![Unit {
        file_name: file,
        role: Role::Library,
        code: Code::Text(format!("{head}{text}")),
        functions,
        entry_points: vec![],
        bindings,
    }];

    let file = format!("{}.kernels.metal", p.stem);
    let mut options = options;
    let mut bindings = Vec::new();
    for b in &p.kernel_bindings {
        let slot = small_slot(&file, b, "Metal")?;
        bindings.push(TargetBinding {
            wgsl: b.clone(),
            name_in_target: b.name.clone(),
            slot: TargetSlot::MetalIndex { index: metal_index(b, slot) },
        });
    }
    for ep in p.kernel_entry_points() {
        let mut resources = msl::EntryPointResources { sizes_buffer: Some(METAL_SIZES_BUFFER), ..Default::default() };
        for b in p.bindings_of(&ep) {
            let slot = small_slot(&file, &b, "Metal")?;
            let mut t = msl::BindTarget { mutable: b.kind.contains("read_write"), ..Default::default() };
            if b.kind.starts_with("sampler") {
                t.sampler = Some(msl::BindSamplerTarget::Resource(slot));
            } else if b.kind.starts_with("texture") {
                t.texture = Some(slot);
            } else {
                t.buffer = Some(slot);
            }
            resources.resources.insert(ResourceBinding { group: b.group, binding: b.binding }, t);
        }
        options.per_entry_point_map.insert(ep, resources);
    }
    let (text, _) = msl::write_string(&p.kernels.module, &p.kernels.info, &options, &Default::default())
        .map_err(|e| backend(&file, target, e))?;
    let entry_points = p.kernel_entry_points();
    let mut head = header(p, target, &Role::Kernels, &[], &entry_points, &bindings);
    if text.contains(&format!("[[buffer({METAL_SIZES_BUFFER})]]")) {
        // naga's stand-in for arrayLength: the host passes the buffers' sizes.
        head.insert_str(
            head.len() - 1,
            &format!(
                "//   [[buffer({METAL_SIZES_BUFFER})]]: _buffer_sizes (naga's struct `_mslBufferSizes`, declared below: the byte size of each runtime-sized buffer), for the kernels that take it.\n"
            ),
        );
    }
    units.push(Unit {
        file_name: file,
        role: Role::Kernels,
        code: Code::Text(format!("{head}{text}")),
        functions: vec![],
        entry_points,
        bindings,
    });
    Ok(units)
}
