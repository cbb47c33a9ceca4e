//! A SPIR-V evaluation program run on the wgpu device through passthrough
//! (`Gpu::spirv_passthrough`): the volume bound as [`DeviceVolume`] binds it
//! for the emitted WGSL (same groups and bindings, which the translations
//! keep), plus the points, gradients and values buffers where the program
//! declares them.
//!
//! wgpu's Vulkan backend numbers a group's descriptors by their rank in
//! the group (binding 4 of a group holding bindings 0 and 4 becomes Vulkan
//! binding 1) and renumbers the SPIR-V that naga writes for it to match;
//! SPIR-V passed through keeps the WGSL numbers. So the layout here has no
//! holes: every binding below the highest one exists, the unused ones as a
//! small uniform buffer ([`hole_entries`]), and rank equals number.

use super::TargetError;
use crate::gpu::binding::{storage_entry, uniform_entry};
use crate::gpu::Gpu;
use crate::volume::DeviceVolume;

/// Where a program's own three buffers are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Io {
    /// The generated `<f>_eval_main`: in the volume's group 0, at bindings
    /// `first` (points), `first + 1` (values), `first + 2` (gradients).
    EvalKernel { first: u32 },
    /// boxforge's hand-written entry points: group 1, bindings 0 (points),
    /// 1 (gradients), 2 (values).
    Set1,
}

/// Points per dispatch (well under 65535 workgroups of 64 in x).
pub const POINTS_PER_DISPATCH: usize = 1 << 20;

/// A compiled program over one device volume.
pub struct Program {
    pipeline: wgpu::ComputePipeline,
    group0: wgpu::BindGroupLayout,
    group1: Option<wgpu::BindGroupLayout>,
    io: Io,
    label: String,
    /// Bindings of group 0 that only fill a hole (see the module docs).
    holes: Vec<u32>,
}

/// The bindings missing below the highest of `entries`, as uniform-buffer
/// entries, so that wgpu's rank numbering equals the binding numbers.
pub fn hole_entries(entries: &[wgpu::BindGroupLayoutEntry]) -> Vec<wgpu::BindGroupLayoutEntry> {
    let max = entries.iter().map(|e| e.binding).max().unwrap_or(0);
    (0..max).filter(|b| !entries.iter().any(|e| e.binding == *b)).map(uniform_entry).collect()
}

impl Program {
    pub fn new(
        gpu: &Gpu,
        words: &[u32],
        entry: &str,
        label: &str,
        dv: &DeviceVolume,
        io: Io,
    ) -> Result<Program, TargetError> {
        let shader = gpu.spirv_passthrough(label, words, entry, (super::mains::WORKGROUP_SIZE, 1, 1))?;
        let dev = &gpu.device;
        let mut entries = dv.layout_entries(0, wgpu::ShaderStages::COMPUTE);
        if let Io::EvalKernel { first } = io {
            entries.extend([
                storage_entry(first, true),
                storage_entry(first + 1, false),
                storage_entry(first + 2, false),
            ]);
        }
        let holes_entries = hole_entries(&entries);
        let holes: Vec<u32> = holes_entries.iter().map(|e| e.binding).collect();
        entries.extend(holes_entries);
        let group0 = dev
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("samples"), entries: &entries });
        let group1 = (io == Io::Set1).then(|| {
            dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("points"),
                entries: &[storage_entry(0, true), storage_entry(1, false), storage_entry(2, false)],
            })
        });
        let mut layouts = vec![&group0];
        layouts.extend(group1.as_ref());
        let pipeline = gpu.pipeline(label, &shader, &layouts, entry)?;
        Ok(Program { pipeline, group0, group1, io, label: label.to_string(), holes })
    }

    /// (values, value + gradient) at every point.
    pub fn eval(
        &self,
        gpu: &Gpu,
        dv: &DeviceVolume,
        points: &[[f32; 4]],
    ) -> Result<(Vec<f32>, Vec<[f32; 4]>), TargetError> {
        let mut values = Vec::with_capacity(points.len());
        let mut grads = Vec::with_capacity(points.len());
        for chunk in points.chunks(POINTS_PER_DISPATCH) {
            let n = chunk.len();
            let pts = gpu.storage_buffer("points", bytemuck::cast_slice(chunk), false);
            let grad = gpu.storage_buffer("gradients", &vec![0u8; n * 16], true);
            let value = gpu.storage_buffer("values", &vec![0u8; n * 4], true);
            let dev = &gpu.device;
            let bind = |layout: &wgpu::BindGroupLayout, entries: &[wgpu::BindGroupEntry]| {
                gpu.checked("bind the samples and points", || {
                    dev.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(&self.label), layout, entries })
                })
            };
            let filler = gpu.uniform_buffer("binding hole", &[0u8; 16]);
            let mut e0 = dv.bind_entries(0);
            e0.extend(
                self.holes.iter().map(|&b| wgpu::BindGroupEntry { binding: b, resource: filler.as_entire_binding() }),
            );
            let groups = match (self.io, &self.group1) {
                (Io::EvalKernel { first }, _) => {
                    e0.push(wgpu::BindGroupEntry { binding: first, resource: pts.as_entire_binding() });
                    e0.push(wgpu::BindGroupEntry { binding: first + 1, resource: value.as_entire_binding() });
                    e0.push(wgpu::BindGroupEntry { binding: first + 2, resource: grad.as_entire_binding() });
                    vec![bind(&self.group0, &e0)?]
                }
                (Io::Set1, Some(g1)) => {
                    let e1 = [
                        wgpu::BindGroupEntry { binding: 0, resource: pts.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: grad.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 2, resource: value.as_entire_binding() },
                    ];
                    vec![bind(&self.group0, &e0)?, bind(g1, &e1)?]
                }
                (Io::Set1, None) => unreachable!("Program::new makes group 1 for Io::Set1"),
            };
            let refs: Vec<&wgpu::BindGroup> = groups.iter().collect();
            let x = n.div_ceil(super::mains::WORKGROUP_SIZE as usize) as u32;
            gpu.dispatch(&self.label, &self.pipeline, &refs, (x, 1, 1))?;
            grads.extend_from_slice(bytemuck::cast_slice::<u8, [f32; 4]>(&gpu.read_buffer(&grad)?));
            values.extend_from_slice(bytemuck::cast_slice::<u8, f32>(&gpu.read_buffer(&value)?));
        }
        Ok((values, grads))
    }
}
