//! The host-depth input the iso and DVR ray casters share
//! (`@group(1) @binding(6)` uniform, `@binding(7)` `texture_depth_2d` in
//! the templates' `host_depth` variant): its uniform, the 1x1 dummy bound
//! when a frame has no host depth (one pipeline layout either way: the
//! uniform's mode is 0 and the shader never reads the dummy), and the
//! caster's bind group over both.

use crate::gpu::Gpu;
use crate::render::camera::HostDepth;
use glam::Mat4;

/// The uniform block `<f>_HostDepth` of the templates.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct HostUniform {
    inv_view_proj: [f32; 16],
    mode: [f32; 4],
}

/// A renderer's host-depth state: built once, written only when it changes.
pub(crate) struct HostInput {
    uniform: wgpu::Buffer,
    dummy: wgpu::TextureView,
    last: Option<HostUniform>,
}

impl HostInput {
    pub(crate) fn new(gpu: &Gpu) -> HostInput {
        let dummy = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("no host depth"),
            size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Depth32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        HostInput {
            uniform: gpu.uniform_buffer("host depth", bytemuck::bytes_of(&HostUniform::zeroed())),
            dummy: dummy.create_view(&Default::default()),
            last: None,
        }
    }

    /// Writes the uniform for a frame with (`on`) or without a host depth
    /// converted with `view_proj`, when it differs from the last frame's.
    pub(crate) fn write(&mut self, gpu: &Gpu, view_proj: Mat4, on: bool) {
        let u = if on {
            HostUniform { inv_view_proj: view_proj.inverse().to_cols_array(), mode: [1.0, 0.0, 0.0, 0.0] }
        } else {
            HostUniform::zeroed()
        };
        if self.last != Some(u) {
            gpu.queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&u));
            self.last = Some(u);
        }
    }

    /// The view a frame binds: the host's depth, or the dummy.
    pub(crate) fn view<'a>(&'a self, depth: Option<&HostDepth<'a>>) -> &'a wgpu::TextureView {
        depth.map_or(&self.dummy, |d| d.view)
    }

    /// The caster's group-1 bind group: `buffers` (binding, buffer) and the
    /// host uniform and `depth` view, each where the shader's `bindings`
    /// declare it.
    pub(crate) fn bind_group(
        &self,
        gpu: &Gpu,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        bindings: &[boxforge::validate::Binding],
        buffers: &[(u32, &wgpu::Buffer)],
        depth: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        let mut resources: Vec<(u32, &wgpu::Buffer)> = buffers.to_vec();
        resources.push((6, &self.uniform));
        let mut entries = crate::gpu::binding::entries_for(bindings, 1, &resources);
        if bindings.iter().any(|b| b.group == 1 && b.binding == 7) {
            entries.push(wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(depth) });
        }
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
    }
}

use bytemuck::Zeroable as _;

#[cfg(test)]
mod tests {
    use crate::render::iso::{raycast_shader_with, HitMode};
    use boxforge::derive::Derivation;
    use boxforge::emit::Layout;

    /// (group, binding, kind) of a shader's bindings.
    fn table(source: &str) -> Vec<(u32, u32, String)> {
        boxforge::validate::bindings_of_wgsl(source)
            .unwrap()
            .into_iter()
            .map(|b| (b.group, b.binding, b.kind))
            .collect()
    }

    #[test]
    fn only_the_native_variant_declares_the_host_depth_and_its_uniform_matches() {
        let d = Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
        let module = crate::render::dvr::filter_module(&d, Layout::Embedded).unwrap();
        let host = [(1, 6, "uniform buffer".to_string()), (1, 7, "texture_depth_2d".to_string())];
        for hit in [HitMode::Step, HitMode::Exact] {
            let opts = boxforge::emit::EmitOptions { command: "t".into(), ..Default::default() };
            let plain = raycast_shader_with(&d, &opts, hit, (1, [1, 1, 1]), false, &Default::default()).unwrap();
            let native = raycast_shader_with(&d, &opts, hit, (1, [1, 1, 1]), true, &Default::default()).unwrap();
            let (p, n) = (table(&plain), table(&native));
            assert!(host.iter().all(|h| n.contains(h) && !p.contains(h)), "{hit:?}: {n:?}");
            assert_eq!(n.len(), p.len() + 2);
        }
        let dvr =
            |host_depth| format!("{module}\n{}", crate::render::dvr::dvr_template_with("bcc7", false, host_depth));
        let (p, n) = (table(&dvr(false)), table(&dvr(true)));
        assert!(host.iter().all(|h| n.contains(h) && !p.contains(h)), "dvr: {n:?}");
        // The uniform block: a mat4x4<f32> and a vec4<f32>, 80 bytes.
        let source = dvr(true);
        let body = source.split("struct bcc7_HostDepth {").nth(1).unwrap().split('}').next().unwrap();
        let fields: Vec<&str> = body.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")).collect();
        assert_eq!(fields, ["inv_view_proj: mat4x4<f32>,", "mode: vec4<f32>,"]);
        assert_eq!(std::mem::size_of::<super::HostUniform>(), 64 + 16);
    }
}
