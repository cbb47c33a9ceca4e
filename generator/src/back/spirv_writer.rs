//! SPIR-V: one binary per compute entry point (Vulkan takes no function
//! library without an entry point), named by the WGSL names (`OpName`, so
//! the checks and a debugger find `<f>_eval`). Built with the `targets`
//! feature (naga's SPIR-V back end).

use super::header::header;
use super::modules::Prepared;
use super::spirv::read;
use super::{BackError, Code, Role, Target, TargetBinding, TargetSlot, Unit};
use naga::back::spv;
use naga::ShaderStage;

/// The binaries and their manifest (`<stem>.spirv.txt`, the header that a
/// binary cannot carry).
///
/// # Errors
///
/// [`BackError::Backend`] when naga's SPIR-V backend refuses.
pub fn translate(p: &Prepared) -> Result<Vec<Unit>, BackError> {
    let options = spv::Options { lang_version: (1, 3), flags: spv::WriterFlags::DEBUG, ..Default::default() };
    let mut units = Vec::new();
    for ep in p.kernel_entry_points() {
        let file = format!("{}.{}.spv", p.stem, p.kernel_short_name(&ep));
        let pipeline = spv::PipelineOptions { shader_stage: ShaderStage::Compute, entry_point: ep.clone() };
        let words = spv::write_vec(&p.kernels.module, &p.kernels.info, &options, Some(&pipeline))
            .map_err(|e| BackError::Backend { file: file.clone(), target: Target::Spirv, message: e.to_string() })?;
        let bindings = p
            .bindings_of(&ep)
            .into_iter()
            .map(|b| TargetBinding {
                name_in_target: b.name.clone(),
                slot: TargetSlot::DescriptorSet { set: b.group, binding: b.binding },
                wgsl: b,
            })
            .collect();
        let functions = read(&words)
            .map(|m| {
                p.public_functions
                    .iter()
                    .filter(|f| m.functions.iter().any(|g| g.name.as_deref() == Some(f)))
                    .cloned()
                    .collect()
            })
            .unwrap_or_default();
        units.push(Unit {
            file_name: file,
            role: Role::Kernels,
            code: Code::Words(words),
            functions,
            entry_points: vec![ep],
            bindings,
        });
    }
    let mut manifest = header(p, Target::Spirv, &Role::Manifest, &[], &[], &[]);
    for u in &units {
        manifest.push_str(&header_lines_of(u));
    }
    units.insert(
        0,
        Unit {
            file_name: format!("{}.spirv.txt", p.stem),
            role: Role::Manifest,
            code: Code::Text(manifest),
            functions: vec![],
            entry_points: vec![],
            bindings: vec![],
        },
    );
    Ok(units)
}

/// One binary's section of the manifest.
fn header_lines_of(u: &Unit) -> String {
    use std::fmt::Write;
    let mut s = format!(
        "// {}: entry point {} (GLCompute); functions: {}.\n",
        u.file_name,
        u.entry_points.join(", "),
        if u.functions.is_empty() { "-".to_string() } else { u.functions.join(", ") }
    );
    for b in &u.bindings {
        let w = &b.wgsl;
        let format = w.format.as_deref().map(|f| format!(", {f}")).unwrap_or_default();
        let _ = writeln!(s, "//   {}: {} ({}{format})", b.slot, b.name_in_target, w.kind);
    }
    s
}
