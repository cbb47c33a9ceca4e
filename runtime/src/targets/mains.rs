//! The entry points boxforge writes by hand around a translated library to
//! run it: a compute shader that includes the emitted text as it is and
//! calls `<f>_eval` and `<f>_eval_grad` by their public names at every point
//! of a buffer, as a user's shader would. Nothing here edits the library:
//! the text between the version line and the entry point is the emitted
//! file, byte for byte.

/// Invocations per workgroup of every entry point here (x only).
pub const WORKGROUP_SIZE: u32 = 64;

/// Where a GLSL entry point's own buffers go: Vulkan has descriptor sets
/// (set 1, bindings 0..2, beside the library's set 0); OpenGL has one
/// binding space per kind, so its buffers take binding points the
/// libraries do not use (8, 9, 10).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlslApi {
    Vulkan,
    OpenGl,
}

/// The first GL shader-storage binding point of the entry point's buffers.
pub const GL_FIRST_BINDING: u32 = 8;

/// A complete GLSL 4.50 compute shader: `library`, then the points (vec4,
/// xyz used), gradients (vec4: value, gradient) and values buffers.
pub fn glsl(library: &str, filter: &str, api: GlslApi) -> String {
    let slot = |k: u32| match api {
        GlslApi::Vulkan => format!("set = 1, binding = {k}"),
        GlslApi::OpenGl => format!("binding = {}", GL_FIRST_BINDING + k),
    };
    format!(
        "#version 450 core\n{library}\n\
// The entry point (boxforge, by hand): {filter}_eval and {filter}_eval_grad at every point.\n\
layout(local_size_x = {WORKGROUP_SIZE}) in;\n\
layout(std430, {p}) readonly buffer BoxforgePoints {{ vec4 boxforge_points[]; }};\n\
layout(std430, {g}) writeonly buffer BoxforgeGradients {{ vec4 boxforge_gradients[]; }};\n\
layout(std430, {v}) writeonly buffer BoxforgeValues {{ float boxforge_values[]; }};\n\
void main() {{\n\
    uint i = gl_GlobalInvocationID.x;\n\
    if (i >= uint(boxforge_points.length())) {{\n\
        return;\n\
    }}\n\
    vec3 p = boxforge_points[i].xyz;\n\
    boxforge_gradients[i] = {filter}_eval_grad(p);\n\
    boxforge_values[i] = {filter}_eval(p);\n\
}}\n",
        p = slot(0),
        g = slot(1),
        v = slot(2),
    )
}

/// The HLSL entry point's name.
pub const HLSL_ENTRY: &str = "boxforge_main";

/// A complete HLSL compute shader: `library`, then the same three buffers
/// in register space 1 (descriptor set 1 under glslang's mapping).
pub fn hlsl(library: &str, filter: &str) -> String {
    format!(
        "{library}\n\
// The entry point (boxforge, by hand): {filter}_eval and {filter}_eval_grad at every point.\n\
StructuredBuffer<float4> boxforge_points : register(t0, space1);\n\
RWStructuredBuffer<float4> boxforge_gradients : register(u1, space1);\n\
RWStructuredBuffer<float> boxforge_values : register(u2, space1);\n\
[numthreads({WORKGROUP_SIZE}, 1, 1)]\n\
void {HLSL_ENTRY}(uint3 gid : SV_DispatchThreadID) {{\n\
    uint count, stride;\n\
    boxforge_points.GetDimensions(count, stride);\n\
    if (gid.x >= count) {{\n\
        return;\n\
    }}\n\
    float3 p = boxforge_points[gid.x].xyz;\n\
    boxforge_gradients[gid.x] = {filter}_eval_grad(p);\n\
    boxforge_values[gid.x] = {filter}_eval(p);\n\
}}\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_library_is_included_verbatim_and_called_by_name() {
        let lib =
            "float f_eval(vec3 p) { return p.x; }\nvec4 f_eval_grad(vec3 p) { return vec4(p.x, 1.0, 0.0, 0.0); }\n";
        for api in [GlslApi::Vulkan, GlslApi::OpenGl] {
            let s = glsl(lib, "f", api);
            assert!(s.starts_with(&format!("#version 450 core\n{lib}")));
            assert!(s.contains("f_eval_grad(p)") && s.contains("f_eval(p)"));
        }
        assert!(glsl(lib, "f", GlslApi::Vulkan).contains("set = 1, binding = 2"));
        assert!(glsl(lib, "f", GlslApi::OpenGl).contains("binding = 10)"));
        assert!(hlsl("// lib\n", "f").contains("register(u2, space1)"));
    }
}
