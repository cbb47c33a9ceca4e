//! The header of every translated file: the WGSL module's header (which
//! names the generating command, the filter, layout and form), the language
//! version, what the file is for, and every binding as the backend emitted
//! it, so a host author needs nothing but the file.

use super::{modules::Prepared, Role, Target, TargetBinding};
use std::fmt::Write;

/// The header as `//` comment lines (every target's comment syntax),
/// ending in a blank line.
pub fn header(
    prepared: &Prepared,
    target: Target,
    role: &Role,
    functions: &[String],
    entry_points: &[String],
    bindings: &[TargetBinding],
) -> String {
    let mut h = prepared.wgsl_header.clone();
    let _ = writeln!(
        h,
        "// Translated by naga {} from the validated WGSL module into {}.",
        NAGA_VERSION,
        target.language()
    );
    let use_line = match (role, target) {
        (Role::Library, Target::Glsl | Target::GlslEs) => {
            "Library: paste or #include it right after your #version line (and, for ES, before your precision-dependent code). For OpenGL or Vulkan: compiled with VULKAN defined (glslangValidator -V), textures are texture3D at set = WGSL group, binding = WGSL binding, and samplers separate, as a host of the WGSL layout binds them."
        }
        (Role::Library, Target::Msl) => {
            "Library: #include it; Metal has no global resources, so each function that reads the samples takes them as trailing arguments (see its signature)."
        }
        (Role::Library, _) => "Library: #include it.",
        (Role::Kernels, Target::Glsl | Target::GlslEs) => {
            "A complete compute shader; its entry point is main. For OpenGL or Vulkan (with VULKAN defined, textures and samplers are separate descriptors at set = WGSL group)."
        }
        (Role::Kernels, _) => "Complete compute shaders.",
        (Role::Manifest, _) => {
            "The SPIR-V binaries beside this file, one compute entry point each (a library of functions alone would need the Linkage capability, which Vulkan does not take)."
        }
    };
    let _ = writeln!(h, "// {use_line}");
    if !functions.is_empty() {
        let _ = writeln!(h, "// Functions (the WGSL names): {}.", functions.join(", "));
    }
    if !entry_points.is_empty() {
        let _ = writeln!(h, "// Compute entry points: {}.", entry_points.join(", "));
    }
    if let Some((group, first)) =
        prepared.eval_kernel_slots.filter(|_| entry_points.iter().any(|e| e.ends_with("_eval_main")))
    {
        let _ = writeln!(
            h,
            "// {f}_eval_main (added by boxforge) writes {f}_eval and {f}_eval_grad at every point of group {group} binding {first} into bindings {} and {}; {} invocations per workgroup, one point each.",
            first + 1,
            first + 2,
            super::modules::EVAL_WORKGROUP_SIZE,
            f = prepared.filter,
        );
    }
    if *role == Role::Manifest {
        // Each binary's bindings follow, in its own section.
    } else if bindings.is_empty() {
        let _ = writeln!(h, "// Bindings: none.");
    } else {
        let _ = writeln!(h, "// Bindings the host must provide:");
        for b in bindings {
            let w = &b.wgsl;
            let format = w.format.as_deref().map(|f| format!(", {f}")).unwrap_or_default();
            let _ = writeln!(
                h,
                "//   {}: {} (WGSL @group({}) @binding({}) {}: {}{format}){}",
                b.slot,
                b.name_in_target,
                w.group,
                w.binding,
                w.name,
                w.kind,
                w.purpose.as_deref().map(|p| format!(" {p}")).unwrap_or_default()
            );
        }
    }
    h.push('\n');
    h
}

/// The naga version the backends come from (named in every header).
pub const NAGA_VERSION: &str = "30";
