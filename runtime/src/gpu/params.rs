//! Where the runtime's parameter blocks live: the uniform blocks of its own
//! templates (the ray caster's `_rc`, DVR's `_dv`, the host depth's
//! `_host`, PERM's `_pm` and `_pb`) and the emitted kernels' job (`_job`,
//! which the runtime binds itself; the module's other bindings, its API,
//! stay as emitted) are uniform buffers, except on a CPU adapter, where
//! they are read-only storage buffers.
//!
//! Why: lavapipe (llvmpipe) inlines the values of small uniform blocks that
//! steer loops and branches into a new shader variant, compiled at a
//! dispatch and kept: measured here, every frame of an isosurface added
//! about 3 MB (bcc7, cc_tricubic; 0.6 MB for cc_trilinear) to the
//! process's resident memory without end, and a 64x64 cc_tricubic frame
//! took 22 ms against 11 ms with the same block in a storage buffer. A
//! storage buffer is never inlined. The kernels' job steers their bounds
//! check: each slab of the bricked bounds (`render::paged::bounds`) kept
//! about 1.5 MB the same way (16 slabs of a 2304x256x256 volume: 24 MB,
//! measured with BOXFORGE_MEMORY_TRACE). On a GPU a uniform block is the fast
//! path for parameters every invocation reads, so it stays there.

/// The parameter blocks of the runtime's templates, by the suffix of their
/// variable names (`<filter>_rc`, ...).
pub const PARAM_BLOCKS: [&str; 6] = ["_rc", "_dv", "_host", "_pm", "_pb", "_job"];

/// `source` with the declarations of the parameter blocks moved from the
/// uniform to the read-only storage address space (the struct layout is the
/// same in both); every other line as it was.
pub fn in_storage(source: &str) -> String {
    let mut out = String::with_capacity(source.len() + 64);
    for line in source.split_inclusive('\n') {
        out.push_str(&rewrite_line(line).unwrap_or_else(|| line.to_string()));
    }
    out
}

/// The line declaring a parameter block, rewritten; None for any other line.
fn rewrite_line(line: &str) -> Option<String> {
    const UNIFORM: &str = "var<uniform> ";
    let at = line.find(UNIFORM)?;
    let rest = &line[at + UNIFORM.len()..];
    let name_end = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))?;
    let name = &rest[..name_end];
    PARAM_BLOCKS.iter().any(|s| name.ends_with(s)).then(|| format!("{}var<storage, read> {rest}", &line[..at]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_parameter_blocks_move_to_storage() {
        let src = "@group(1) @binding(0) var<uniform> bcc7_rc: bcc7_RayParams;\n\
                   @group(0) @binding(1) var<uniform> bcc7_grid: bcc7_Grid;\n\
                   @group(1) @binding(6) var<uniform> bcc7_host: bcc7_HostDepth;\n\
                   @group(0) @binding(2) var<uniform> bcc7_job: bcc7_Job;\n\
                   // var<uniform> bcc7_dv is in a comment\n";
        let out = in_storage(src);
        assert!(out.contains("var<storage, read> bcc7_rc: bcc7_RayParams;"), "{out}");
        assert!(out.contains("var<storage, read> bcc7_host: bcc7_HostDepth;"), "{out}");
        assert!(out.contains("var<uniform> bcc7_grid: bcc7_Grid;"), "the module's own binding stays: {out}");
        assert!(out.contains("var<storage, read> bcc7_job: bcc7_Job;"), "the kernels' job moves: {out}");
        assert_eq!(out.lines().count(), src.lines().count());
    }

    #[test]
    fn every_runtime_template_keeps_valid_wgsl_with_its_blocks_in_storage() {
        let d = boxforge::derive::Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
        let sources = [
            crate::render::iso::raycast_shader(
                &d,
                boxforge::emit::Layout::Embedded,
                Default::default(),
                (4, [8, 8, 8]),
                "t",
            )
            .unwrap(),
            crate::render::dvr::shader_source(&d, boxforge::emit::Layout::Packed).unwrap(),
        ];
        for s in sources {
            let moved = in_storage(&s);
            assert_ne!(moved, s, "a parameter block moved");
            assert!(!moved.contains("var<uniform> bcc7_rc") && !moved.contains("var<uniform> bcc7_dv"));
            crate::gpu::naga_check(&moved, "moved").unwrap();
        }
    }
}
