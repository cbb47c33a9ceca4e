//! A compiled throughput kernel with its buffers, and interleaved timing.

use super::stats::round_order;
use super::BenchError;
use crate::gpu::binding::storage_entry;
use crate::gpu::{Gpu, GpuError};
use crate::references;
use crate::verify::kernel::{dispatch_size, points_kernel, Output};
use crate::volume::DeviceVolume;
use boxforge::emit::Layout;
use std::time::Instant;

/// A throughput program: the generated `module`, `extra` WGSL (a
/// reference), and a `bench_main` kernel writing `call` (a vec4 expression
/// of `p`) at every point, for [`Job::new`]. The kernel's buffers go to
/// group 2 when the extra code declares the `ref_linear` sampler (group 1).
pub fn program(module: &str, extra: &str, call: &str) -> String {
    let group = if references::uses_sampler(extra) { 2 } else { 1 };
    let kernel = points_kernel("bench_main", group, "bx", &[Output { name: "out", ty: "vec4<f32>", expr: call }]);
    format!("{module}\n{extra}\n{kernel}")
}

/// [`program`] for a 4D module: `p` is the whole `vec4` point.
pub fn program4(module: &str, call: &str) -> String {
    let kernel = crate::verify::kernel::points_kernel_in(
        4,
        "bench_main",
        1,
        "bx",
        &[Output { name: "out", ty: "vec4<f32>", expr: call }],
    );
    format!("{module}\n{kernel}")
}

/// Central differences from 6 extra evaluations (h = 1e-2 cell).
pub(super) fn central_call(name: &str) -> String {
    format!(
        "vec4<f32>({n}_eval(p), ({n}_eval(p + vec3<f32>(0.01, 0.0, 0.0)) - {n}_eval(p - vec3<f32>(0.01, 0.0, 0.0))) * 50.0, ({n}_eval(p + vec3<f32>(0.0, 0.01, 0.0)) - {n}_eval(p - vec3<f32>(0.0, 0.01, 0.0))) * 50.0, ({n}_eval(p + vec3<f32>(0.0, 0.0, 0.01)) - {n}_eval(p - vec3<f32>(0.0, 0.0, 0.01))) * 50.0)",
        n = name
    )
}

/// Does this device filter R32Float textures (wgpu::Features::FLOAT32_FILTERABLE)?
pub fn can_filter_f32(gpu: &Gpu) -> bool {
    gpu.device.features().contains(wgpu::Features::FLOAT32_FILTERABLE)
}

/// A compiled throughput kernel with its buffers, ready to dispatch.
pub struct Job {
    pipeline: wgpu::ComputePipeline,
    groups: Vec<wgpu::BindGroup>,
    out: wgpu::Buffer,
    n: usize,
    dispatch: (u32, u32),
    queries: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

impl Job {
    /// Compiles `source` (which has `bench_main`) over the points. A source
    /// declaring `ref_linear` gets a linear clamp-to-edge sampler in group 1
    /// and the volume bound as a filterable texture.
    pub fn new(
        gpu: &Gpu,
        source: &str,
        label: &str,
        dv: &DeviceVolume,
        points: &[[f32; 4]],
    ) -> Result<Job, BenchError> {
        let sampled = references::uses_sampler(source);
        if sampled && !can_filter_f32(gpu) {
            return Err(GpuError::MissingFeature {
                feature: "FLOAT32_FILTERABLE",
                needed_for: format!("{label} (it filters an R32Float texture)"),
                fix: "run it on an adapter that filters f32 textures",
            }
            .into());
        }
        if sampled && dv.layout != Layout::Embedded {
            return Err(BenchError::FilterLayout { label: label.to_string(), layout: dv.layout });
        }
        let shader = gpu.compile(label, source)?;
        let samples = (dv.layout_entries(0, wgpu::ShaderStages::COMPUTE), dv.bind_entries(0));
        Ok(Job::with_shader(gpu, &shader, ("bench_main", label), sampled, samples, points)?)
    }

    /// [`Job::new`] over 4D samples (one storage buffer; a source made by
    /// `program4`).
    pub fn new4(
        gpu: &Gpu,
        source: &str,
        label: &str,
        dv: &crate::volume::DeviceVolume4,
        points: &[[f32; 4]],
    ) -> Result<Job, GpuError> {
        let shader = gpu.compile(label, source)?;
        let samples = (vec![dv.layout_entry(0)], vec![dv.bind_entry(0)]);
        Job::with_shader(gpu, &shader, ("bench_main", label), false, samples, points)
    }

    /// A SPIR-V program run as it is (wgpu's passthrough): the volume in
    /// set 0 as [`DeviceVolume`] binds it, the points (`vec4`, read) and the
    /// outputs (`vec4`, one per point) at set 1, bindings 0 and 1, a
    /// workgroup of [`crate::verify::kernel::WORKGROUP_SIZE`] in x and the
    /// index `gid.x + gid.y * 65535 * 64`, as [`program`]'s kernel has them.
    pub fn from_spirv(
        gpu: &Gpu,
        words: &[u32],
        entry: &str,
        label: &str,
        dv: &DeviceVolume,
        points: &[[f32; 4]],
    ) -> Result<Job, GpuError> {
        let size = crate::verify::kernel::WORKGROUP_SIZE;
        let shader = gpu.spirv_passthrough(label, words, entry, (size, 1, 1))?;
        let samples = (dv.layout_entries(0, wgpu::ShaderStages::COMPUTE), dv.bind_entries(0));
        Job::with_shader(gpu, &shader, (entry, label), false, samples, points)
    }

    fn with_shader(
        gpu: &Gpu,
        shader: &wgpu::ShaderModule,
        (entry, label): (&str, &str),
        sampled: bool,
        (mut entries0, binds0): (Vec<wgpu::BindGroupLayoutEntry>, Vec<wgpu::BindGroupEntry<'_>>),
        points: &[[f32; 4]],
    ) -> Result<Job, GpuError> {
        let dev = &gpu.device;
        if sampled {
            for e in entries0.iter_mut() {
                if let wgpu::BindingType::Texture { sample_type, .. } = &mut e.ty {
                    *sample_type = wgpu::TextureSampleType::Float { filterable: true };
                }
            }
        }
        let bgl0 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: &entries0 });
        let bgl_sampler = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            }],
        });
        let bgl_io = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[storage_entry(0, true), storage_entry(1, false)],
        });
        let layouts: Vec<&wgpu::BindGroupLayout> =
            if sampled { vec![&bgl0, &bgl_sampler, &bgl_io] } else { vec![&bgl0, &bgl_io] };
        let pipeline = gpu.pipeline(label, shader, &layouts, entry)?;
        let n = points.len();
        let pts = gpu.storage_buffer("points", bytemuck::cast_slice(points), false);
        let out = gpu.storage_buffer("out", &vec![0u8; n * 16], true);
        let bg0 = dev.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &bgl0, entries: &binds0 });
        let bg_io = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &bgl_io,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: pts.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            ],
        });
        let groups = if sampled {
            let sampler = crate::gpu::binding::linear_sampler(gpu, "ref_linear");
            let bg_s = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &bgl_sampler,
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::Sampler(&sampler) }],
            });
            vec![bg0, bg_s, bg_io]
        } else {
            vec![bg0, bg_io]
        };
        // GPU time from timestamp queries when the adapter has them and is
        // a GPU ([`timestamps_trusted`]), else wall time around submit + wait.
        let queries = timestamps_trusted(gpu).then(|| {
            let set = dev.create_query_set(&wgpu::QuerySetDescriptor {
                label: None,
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = dev.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        });
        Ok(Job { pipeline, groups, out, n, dispatch: dispatch_size(n), queries })
    }

    /// Seconds for one dispatch.
    pub fn time(&self, gpu: &Gpu) -> Result<f64, GpuError> {
        let dev = &gpu.device;
        let start = Instant::now();
        let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let timestamp_writes = self.queries.as_ref().map(|(set, _)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes });
            pass.set_pipeline(&self.pipeline);
            for (i, g) in self.groups.iter().enumerate() {
                pass.set_bind_group(i as u32, g, &[]);
            }
            pass.dispatch_workgroups(self.dispatch.0, self.dispatch.1, 1);
        }
        if let Some((set, resolve)) = &self.queries {
            enc.resolve_query_set(set, 0..2, resolve, 0);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        let wall = start.elapsed().as_secs_f64();
        if let Some((_, resolve)) = &self.queries {
            let ts: Vec<u64> = bytemuck::cast_slice(&gpu.read_buffer(resolve)?).to_vec();
            let gpu_s = ts[1].saturating_sub(ts[0]) as f64 * gpu.queue.get_timestamp_period() as f64 * 1e-9;
            if gpu_s > 0.0 {
                return Ok(gpu_s);
            }
        }
        Ok(wall)
    }

    /// The outputs of the last dispatch.
    pub fn outputs(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>, GpuError> {
        Ok(bytemuck::cast_slice(&gpu.read_buffer(&self.out)?).to_vec())
    }

    pub fn points(&self) -> usize {
        self.n
    }
}

/// Whether the bench times dispatches with timestamp queries: only on a
/// real GPU. On lavapipe (a CPU device) one full bench read timestamps a
/// few microseconds apart around dispatches that take hundreds of
/// milliseconds (1e10 evals/s, a thousand times the wall-clock rate), while
/// other runs read them right: there the device is the CPU, and wall time
/// around submit + wait is the honest clock.
pub fn timestamps_trusted(gpu: &Gpu) -> bool {
    gpu.timestamps && gpu.info.device_type != wgpu::DeviceType::Cpu
}

/// Interleaved rounds: one warm-up dispatch per job (it includes pipeline
/// compilation on lavapipe), then `rounds` rounds timing every job once, the
/// order rotated each round. A job whose second dispatch takes under 50 ms is
/// timed as the fastest of 3 back-to-back dispatches in its turn (short
/// dispatches are the ones other processes on the machine disturb most).
/// Returns evals/s per job per round.
pub fn timed_rounds(gpu: &Gpu, jobs: &[&Job], rounds: usize) -> Result<Vec<Vec<f64>>, GpuError> {
    let mut reps = Vec::with_capacity(jobs.len());
    for j in jobs {
        j.time(gpu)?;
        reps.push(if j.time(gpu)? < 0.05 { 3 } else { 1 });
    }
    let mut rates = vec![Vec::with_capacity(rounds); jobs.len()];
    for r in 0..rounds.max(1) {
        for k in round_order(jobs.len(), r) {
            let mut s = f64::INFINITY;
            for _ in 0..reps[k] {
                s = s.min(jobs[k].time(gpu)?);
            }
            rates[k].push(jobs[k].n as f64 / s);
        }
    }
    Ok(rates)
}
