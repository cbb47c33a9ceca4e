//! Frame timing: what every renderer's CLI path and the bench measure a
//! frame with (submit, then wait for the device).

use crate::gpu::{Gpu, GpuError};
use std::time::Instant;

/// Times a row-banded image kernel (8x8 workgroups, bind groups 0 and 1):
/// one warm-up frame (with a progress bar when asked), then `frames` timed
/// frames of submit + wait. The uniform `params` is written to its buffer
/// once per band with the band's first row set by `set_row`. `shape` is
/// (width, height, rows per band); `what` is (label, progress bar text,
/// progress). Returns the frame times in ms, sorted.
pub fn timed_banded_frames<P: bytemuck::Pod>(
    gpu: &Gpu,
    pipeline: &wgpu::ComputePipeline,
    groups: [&wgpu::BindGroup; 2],
    (params_buf, params, set_row): (&wgpu::Buffer, P, impl Fn(&mut P, u32)),
    (width, height, band): (u32, u32, u32),
    (label, bar_text, progress): (&str, &str, bool),
    frames: usize,
) -> Result<Vec<f64>, GpuError> {
    let band = band.max(1);
    let frame = |report: bool| -> Result<f64, GpuError> {
        let start = Instant::now();
        let bar =
            if report { crate::progress::bar(height as u64, bar_text) } else { crate::progress::ProgressBar::hidden() };
        let mut y0 = 0u32;
        while y0 < height {
            let rows = band.min(height - y0);
            let mut p = params;
            set_row(&mut p, y0);
            gpu.queue.write_buffer(params_buf, 0, bytemuck::bytes_of(&p));
            let mut enc = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
            {
                let mut pass =
                    enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, groups[0], &[]);
                pass.set_bind_group(1, groups[1], &[]);
                pass.dispatch_workgroups(width.div_ceil(8), rows.div_ceil(8), 1);
            }
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            y0 += rows;
            bar.set_position(y0 as u64);
        }
        bar.finish_and_clear();
        Ok(start.elapsed().as_secs_f64() * 1e3)
    };
    gpu.checked(&format!("{label} warm-up"), || frame(progress))??;
    let mut times: Vec<f64> = (0..frames).map(|_| frame(false)).collect::<Result<_, _>>()?;
    times.sort_by(|a, b| a.total_cmp(b));
    Ok(times)
}
