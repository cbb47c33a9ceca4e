//! The shader compilers of a Linux machine, run on translated units:
//! glslang (`glslangValidator`, Debian `glslang-tools`) for GLSL and GLSL
//! ES, and its HLSL front end for HLSL ("accepted by glslang": DXC is not
//! there), `spirv-val` (Debian `spirv-tools`) for SPIR-V. Metal has no
//! compiler on Linux: MSL is emitted and left uncompiled, and says so.
//!
//! A library unit cannot be compiled alone (it has no entry point), so it
//! is compiled inside a harness: the language's version line, the library
//! as written, and an entry point that calls `<f>_fetch`, `<f>_eval` and
//! `<f>_eval_grad` by their public names, as a user's shader would.

use super::{Code, Role, Target, Translated, Unit};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

/// What compiling one unit gave.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The compiler accepted it; `by` names the compiler, version and mode
    /// (for HLSL: "accepted by glslang", not more).
    Compiled {
        /// E.g. `glslangValidator 12.0.0 (GLSL)`.
        by: String,
    },
    /// The compiler rejected it (a boxforge or naga bug).
    Failed {
        /// The compiler.
        by: String,
        /// Its output.
        message: String,
    },
    /// The compiler is not installed; `install` is the command that installs it.
    Missing {
        /// The program that was not found.
        tool: &'static str,
        /// The Debian command that installs it.
        install: &'static str,
    },
    /// No compiler for this language exists on this kind of machine (MSL on Linux).
    NotCompilable {
        /// Why.
        why: &'static str,
    },
}

/// The Debian command that installs both compilers.
pub const INSTALL: &str = "apt-get install -y glslang-tools spirv-tools";

fn version_of(tool: &str) -> Option<String> {
    let out = Command::new(tool).arg("--version").output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let first = text.lines().next()?.trim().to_string();
    // `Glslang Version: 11:12.0.0` -> `12.0.0`; `SPIRV-Tools v2023.1 ...` -> `v2023.1`.
    Some(match first.rsplit_once(':') {
        Some((_, v)) if tool == "glslangValidator" => v.trim().to_string(),
        _ => first.split_whitespace().nth(1).unwrap_or(&first).to_string(),
    })
}

/// `glslangValidator`'s version, or None when it is not installed.
pub fn glslang_version() -> Option<&'static str> {
    static V: OnceLock<Option<String>> = OnceLock::new();
    V.get_or_init(|| version_of("glslangValidator")).as_deref()
}

/// `spirv-val`'s version, or None when it is not installed.
pub fn spirv_val_version() -> Option<&'static str> {
    static V: OnceLock<Option<String>> = OnceLock::new();
    V.get_or_init(|| version_of("spirv-val")).as_deref()
}

/// A private scratch directory per call (tests compile in parallel threads).
fn scratch() -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "boxforge-compile-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::create_dir_all(&d);
    d
}

fn run(by: String, cmd: &mut Command, dir: &Path) -> Outcome {
    let outcome = match cmd.output() {
        Ok(o) if o.status.success() => Outcome::Compiled { by },
        Ok(o) => Outcome::Failed {
            by,
            message: format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
                .trim()
                .to_string(),
        },
        Err(e) => Outcome::Failed { by, message: e.to_string() },
    };
    let _ = std::fs::remove_dir_all(dir);
    outcome
}

/// Runs `cmd`: Ok when it succeeds, else its output.
fn cmd_output(cmd: &mut Command) -> Result<(), String> {
    match cmd.output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
            .trim()
            .to_string()),
        Err(e) => Err(e.to_string()),
    }
}

/// `spirv-dis --raw-id` of a binary (numeric ids: the parse below needs no names).
fn disassemble(spv: &Path) -> Result<String, String> {
    let o = Command::new("spirv-dis")
        .arg("--raw-id")
        .arg(spv)
        .output()
        .map_err(|e| format!("spirv-dis ({INSTALL}): {e}"))?;
    if !o.status.success() {
        return Err(format!("spirv-dis: {}", String::from_utf8_lossy(&o.stderr).trim()));
    }
    Ok(String::from_utf8_lossy(&o.stdout).into_owned())
}

/// What an opaque (UniformConstant) descriptor of a SPIR-V module is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DescriptorKind {
    /// `OpTypeImage` with Sampled = 1 (a WGSL `texture_*`).
    SampledImage,
    /// `OpTypeImage` with Sampled = 2 (a WGSL `texture_storage_*`).
    StorageImage,
    /// `OpTypeSampler`.
    Sampler,
    /// `OpTypeSampledImage`: a combined image sampler, which no WGSL binding is.
    CombinedImageSampler,
}

/// The (set, binding, kind) of every opaque descriptor in a `spirv-dis
/// --raw-id` listing.
pub fn opaque_descriptors(dis: &str) -> Vec<(u32, u32, DescriptorKind)> {
    use std::collections::HashMap;
    let mut types: HashMap<&str, DescriptorKind> = HashMap::new();
    let mut pointers: HashMap<&str, &str> = HashMap::new();
    let mut variables: Vec<(&str, &str)> = Vec::new();
    let mut sets: HashMap<&str, u32> = HashMap::new();
    let mut bindings: HashMap<&str, u32> = HashMap::new();
    for line in dis.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["OpDecorate", id, "DescriptorSet", n, ..] => {
                sets.insert(id, n.parse().unwrap_or(u32::MAX));
            }
            ["OpDecorate", id, "Binding", n, ..] => {
                bindings.insert(id, n.parse().unwrap_or(u32::MAX));
            }
            [id, "=", "OpTypeImage", _ty, _dim, _depth, _arrayed, _ms, sampled, ..] => {
                let kind = if *sampled == "2" { DescriptorKind::StorageImage } else { DescriptorKind::SampledImage };
                types.insert(id, kind);
            }
            [id, "=", "OpTypeSampler", ..] => {
                types.insert(id, DescriptorKind::Sampler);
            }
            [id, "=", "OpTypeSampledImage", ..] => {
                types.insert(id, DescriptorKind::CombinedImageSampler);
            }
            [id, "=", "OpTypePointer", "UniformConstant", pointee, ..] => {
                pointers.insert(id, pointee);
            }
            [id, "=", "OpVariable", ptr, "UniformConstant", ..] => variables.push((id, ptr)),
            _ => {}
        }
    }
    let mut out: Vec<(u32, u32, DescriptorKind)> = variables
        .into_iter()
        .filter_map(|(id, ptr)| {
            let kind = *types.get(pointers.get(ptr)?)?;
            Some((sets.get(id).copied().unwrap_or(0), *bindings.get(id)?, kind))
        })
        .collect();
    out.sort_by_key(|&(s, b, _)| (s, b));
    out
}

/// Every opaque descriptor of the Vulkan compile is the kind that the WGSL
/// binding at its set and binding is, so that a host binding the WGSL
/// layout (a sampled image, a separate sampler) matches the shader.
pub fn check_vulkan_descriptors(dis: &str, expected: &[super::TargetBinding]) -> Result<(), String> {
    for (set, binding, kind) in opaque_descriptors(dis) {
        let Some(b) = expected.iter().find(|b| b.wgsl.group == set && b.wgsl.binding == binding) else {
            return Err(format!(
                "the Vulkan compile declares a {kind:?} at set {set} binding {binding}, which the header does not list"
            ));
        };
        let want = if b.wgsl.kind.starts_with("texture_storage") {
            DescriptorKind::StorageImage
        } else if b.wgsl.kind.starts_with("texture") {
            DescriptorKind::SampledImage
        } else if b.wgsl.kind.starts_with("sampler") {
            DescriptorKind::Sampler
        } else {
            return Err(format!(
                "set {set} binding {binding} is a {kind:?} in the Vulkan compile but `{}` ({}) in WGSL",
                b.wgsl.name, b.wgsl.kind
            ));
        };
        if kind != want {
            return Err(format!(
                "set {set} binding {binding} (`{}`, {}) is a {kind:?} in the Vulkan compile; a host of the WGSL layout binds a {want:?}",
                b.wgsl.name, b.wgsl.kind
            ));
        }
    }
    Ok(())
}

/// The harness entry point that calls the library's functions by name.
fn harness(t: &Translated, target: Target) -> String {
    let f = &t.filter;
    let d = t.dim;
    let (point, ipoint) = match (target, d) {
        (Target::Hlsl, 2) => ("float2(0.5, 0.25)", "int2(0, 0)"),
        (Target::Hlsl, 4) => ("float4(0.5, 0.25, 0.125, 0.0625)", "int4(0, 0, 0, 0)"),
        (_, 4) => ("vec4(0.5, 0.25, 0.125, 0.0625)", "ivec4(0)"),
        (Target::Hlsl, _) => ("float3(0.5, 0.25, 0.125)", "int3(0, 0, 0)"),
        (_, 2) => ("vec2(0.5, 0.25)", "ivec2(0)"),
        _ => ("vec3(0.5, 0.25, 0.125)", "ivec3(0)"),
    };
    // 4D: eval_grad returns the module's `<f>_Gradient` struct (no vec5).
    let gradient_struct = format!("{f}_Gradient");
    let grad = match (target, d) {
        (_, 4) => gradient_struct.as_str(),
        (Target::Hlsl, 2) => "float3",
        (Target::Hlsl, _) => "float4",
        (_, 2) => "vec3",
        _ => "vec4",
    };
    let body = format!(
        "    float v = {f}_eval({point});\n    {grad} g = {f}_eval_grad({point});\n    float s = {f}_fetch({ipoint});\n"
    );
    if target == Target::Hlsl {
        format!("\n[numthreads(1, 1, 1)]\nvoid boxforge_harness()\n{{\n{body}}}\n")
    } else {
        format!("\nlayout(local_size_x = 1) in;\nvoid main() {{\n{body}}}\n")
    }
}

/// Compiles one unit of `t` with the compiler for its language.
pub fn compile(t: &Translated, u: &Unit) -> Outcome {
    let glslang = |mode: &str| glslang_version().map(|v| format!("glslangValidator {v} ({mode})"));
    let missing_glslang = Outcome::Missing { tool: "glslangValidator", install: INSTALL };
    match (&u.code, t.target) {
        (_, Target::Msl) => Outcome::NotCompilable { why: "no Metal compiler runs on Linux" },
        (Code::Text(_), _) if u.role == Role::Manifest => Outcome::NotCompilable { why: "a list of bindings" },
        (Code::Text(text), Target::Wgsl) => {
            let r = crate::validate::validate_wgsl(text, &u.file_name);
            match r.error {
                None => Outcome::Compiled { by: "naga 30 (WGSL validator)".into() },
                Some(message) => Outcome::Failed { by: "naga 30 (WGSL validator)".into(), message },
            }
        }
        (Code::Words(words), _) => {
            let Some(v) = spirv_val_version() else {
                return Outcome::Missing { tool: "spirv-val", install: INSTALL };
            };
            let dir = scratch();
            let path = dir.join(&u.file_name);
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            if let Err(e) = std::fs::write(&path, bytes) {
                return Outcome::Failed { by: "spirv-val".into(), message: e.to_string() };
            }
            run(
                format!("spirv-val {v} (Vulkan 1.1)"),
                Command::new("spirv-val").arg("--target-env").arg("vulkan1.1").arg(&path),
                &dir,
            )
        }
        (Code::Text(text), Target::Glsl | Target::GlslEs) => {
            let es = t.target == Target::GlslEs;
            let Some(by) = glslang(if es { "GLSL ES" } else { "GLSL" }) else { return missing_glslang };
            let source = if u.role == Role::Library {
                let version = if es { "#version 310 es\n" } else { "#version 450 core\n" };
                format!("{version}{text}{}", harness(t, t.target))
            } else {
                text.clone()
            };
            let dir = scratch();
            let path = dir.join(format!("{}.comp", u.file_name));
            if let Err(e) = std::fs::write(&path, source) {
                return Outcome::Failed { by, message: e.to_string() };
            }
            // For OpenGL first, then for Vulkan (`VULKAN` defined), where the
            // descriptors must be the kinds a host of the WGSL layout binds.
            let by_vulkan = format!("{by}, for Vulkan with -V");
            let spv = dir.join("vulkan.spv");
            match cmd_output(Command::new("glslangValidator").arg(&path)) {
                Ok(()) => {}
                Err(message) => {
                    let _ = std::fs::remove_dir_all(&dir);
                    return Outcome::Failed { by, message };
                }
            }
            let checked = cmd_output(Command::new("glslangValidator").arg("-V").arg(&path).arg("-o").arg(&spv))
                .and_then(|()| disassemble(&spv))
                .and_then(|dis| check_vulkan_descriptors(&dis, &u.bindings));
            let _ = std::fs::remove_dir_all(&dir);
            match checked {
                Ok(()) => Outcome::Compiled { by: by_vulkan },
                Err(message) => Outcome::Failed { by: by_vulkan, message },
            }
        }
        (Code::Text(text), Target::Hlsl | Target::Spirv) => {
            let Some(by) = glslang("HLSL front end; DXC not available") else {
                return missing_glslang;
            };
            let (source, entries) = if u.role == Role::Library {
                (format!("{text}{}", harness(t, Target::Hlsl)), vec!["boxforge_harness".to_string()])
            } else {
                (text.clone(), u.entry_points.clone())
            };
            let dir = scratch();
            let path = dir.join(&u.file_name);
            if let Err(e) = std::fs::write(&path, source) {
                return Outcome::Failed { by, message: e.to_string() };
            }
            for (k, entry) in entries.iter().enumerate() {
                let out = dir.join(format!("{k}.spv"));
                let mut cmd = Command::new("glslangValidator");
                cmd.args(["-D", "-V", "-S", "comp", "-e", entry]).arg(&path).arg("-o").arg(&out);
                match cmd.output() {
                    Ok(o) if o.status.success() => {}
                    Ok(o) => {
                        let _ = std::fs::remove_dir_all(&dir);
                        return Outcome::Failed {
                            by,
                            message: format!("entry {entry}: {}", String::from_utf8_lossy(&o.stdout).trim()),
                        };
                    }
                    Err(e) => return Outcome::Failed { by, message: e.to_string() },
                }
            }
            let _ = std::fs::remove_dir_all(&dir);
            Outcome::Compiled { by }
        }
    }
}
