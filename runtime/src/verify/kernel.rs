//! The one point-evaluation compute kernel: a storage array of points
//! (`vec4<f32>`, xyz used), one storage array per output, and an entry point
//! that writes each output's expression of `p` at every point. `verify`
//! ([`super::PointEvaluator`]) and `bench` ([`crate::bench::program`]) both
//! append it to a module.

/// Invocations per workgroup of the kernel.
pub const WORKGROUP_SIZE: u32 = 64;

/// The most workgroups along x: larger point counts spill into y (the
/// kernel's index is `gid.x + gid.y * 65535 * 64`).
pub const MAX_GROUPS_X: u32 = 65535;

/// One output array of a [`points_kernel`]: `<prefix>_<name>`, of element
/// type `ty` (e.g. `vec4<f32>`, `f32`), written with `expr` (WGSL in `p`).
#[derive(Clone, Copy, Debug)]
pub struct Output<'a> {
    pub name: &'a str,
    pub ty: &'a str,
    pub expr: &'a str,
}

/// The kernel text: entry point `entry`, its arrays in bind group `group`,
/// the points `<prefix>_points` at binding 0 (read-only), then the outputs
/// at bindings 1, 2, ... in order (read-write).
pub fn points_kernel(entry: &str, group: u32, prefix: &str, outputs: &[Output]) -> String {
    points_kernel_in(3, entry, group, prefix, outputs)
}

/// [`points_kernel`] for `dim`-dimensional points: `p` is the first `dim`
/// components of each `vec4<f32>` point (all four in 4D).
pub fn points_kernel_in(dim: usize, entry: &str, group: u32, prefix: &str, outputs: &[Output]) -> String {
    use std::fmt::Write;
    let swizzle = &"xyzw"[..dim.clamp(1, 4)];
    let mut s = format!("\n@group({group}) @binding(0) var<storage, read> {prefix}_points: array<vec4<f32>>;\n");
    for (k, o) in outputs.iter().enumerate() {
        let _ = writeln!(
            s,
            "@group({group}) @binding({}) var<storage, read_write> {prefix}_{}: array<{}>;",
            k + 1,
            o.name,
            o.ty
        );
    }
    let _ = write!(
        s,
        "
@compute @workgroup_size({WORKGROUP_SIZE})
fn {entry}(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x + gid.y * {MAX_GROUPS_X}u * {WORKGROUP_SIZE}u;
    if (i >= arrayLength(&{prefix}_points)) {{
        return;
    }}
    let p = {prefix}_points[i].{swizzle};
"
    );
    for o in outputs {
        let _ = writeln!(s, "    {prefix}_{}[i] = {};", o.name, o.expr);
    }
    s.push_str("}\n");
    s
}

/// Workgroups (x, y) that cover `points` invocations of the kernel.
pub fn dispatch_size(points: usize) -> (u32, u32) {
    let groups = points.div_ceil(WORKGROUP_SIZE as usize) as u32;
    (groups.min(MAX_GROUPS_X), groups.div_ceil(MAX_GROUPS_X))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel is valid WGSL beside a module that defines the called functions.
    #[test]
    fn points_kernel_validates_with_two_outputs() {
        let module = "fn f_eval(p: vec3<f32>) -> f32 { return p.x; }\n";
        let k = points_kernel(
            "main",
            1,
            "t",
            &[
                Output { name: "grad", ty: "vec4<f32>", expr: "vec4<f32>(f_eval(p), p)" },
                Output { name: "value", ty: "f32", expr: "f_eval(p)" },
            ],
        );
        assert!(k.contains("@group(1) @binding(2) var<storage, read_write> t_value: array<f32>;"), "{k}");
        let r = boxforge::validate::validate_wgsl(&format!("{module}{k}"), "kernel");
        assert!(r.valid, "{:?}\n{k}", r.error);
    }

    #[test]
    fn dispatch_spills_into_y() {
        assert_eq!(dispatch_size(0), (0, 0));
        assert_eq!(dispatch_size(65), (2, 1));
        assert_eq!(dispatch_size(64 * 65535 + 1), (65535, 2));
    }
}
