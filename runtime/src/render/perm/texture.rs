//! The cache's densities and gradients in 3D textures of words.

use super::PermError;
use crate::gpu::{Gpu, GpuError};

/// One part of the cache: words in an r32uint 3D texture, word i at texel
/// (i % W, (i / W) % H, i / (W H)). A texture, not a storage buffer,
/// because storage bindings are limited (128 MiB on lavapipe and many
/// GPUs) and the densities of N = 10 exceed that on ordinary volumes.
pub(super) struct CacheWords {
    texture: wgpu::Texture,
    pub(super) view: wgpu::TextureView,
    pub(super) extent: [u32; 3],
}

impl CacheWords {
    pub(super) fn new(gpu: &Gpu, label: &str, words: u64) -> Result<CacheWords, PermError> {
        let max = gpu.limits().max_texture_dimension_3d;
        let extent =
            texel_extent(words, max).ok_or_else(|| PermError::Texture { label: label.to_string(), words, max })?;
        let texture = gpu.checked(&format!("allocate {label}"), || {
            gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: extent[0], height: extent[1], depth_or_array_layers: extent[2] },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R32Uint,
                usage: wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        })?;
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        Ok(CacheWords { texture, view, extent })
    }

    /// Bytes allocated.
    pub(super) fn bytes(&self) -> u64 {
        self.extent.iter().map(|&e| u64::from(e)).product::<u64>() * 4
    }

    /// All words, in order (texels past the last word included).
    pub(super) fn read(&self, gpu: &Gpu) -> Result<Vec<u32>, GpuError> {
        let [w, h, d] = self.extent;
        let row = u64::from(w) * 4;
        let padded = row.div_ceil(256) * 256;
        let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("perm readback"),
            size: padded * u64::from(h) * u64::from(d),
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("perm readback") });
        enc.copy_texture_to_buffer(
            self.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: d },
        );
        gpu.queue.submit([enc.finish()]);
        let bytes = gpu.read_buffer(&staging)?;
        Ok(bytes
            .chunks(padded as usize)
            .flat_map(|r| bytemuck::cast_slice::<u8, u32>(&r[..row as usize]).to_vec())
            .collect())
    }
}

/// The extent (W, H, D) of a 3D texture of at least `words` texels, no
/// side over `max`, wasting as few texels as the search finds (at most W
/// per slice; often none): the reported memory is what is allocated.
pub fn texel_extent(words: u64, max: u32) -> Option<[u32; 3]> {
    let words = words.max(1);
    let m = u64::from(max);
    let mut best: Option<(u64, [u32; 3])> = None;
    for w in (1..=m.min(words)).rev() {
        let rows = words.div_ceil(w);
        let d = rows.div_ceil(m);
        if d > m {
            break;
        }
        let h = rows.div_ceil(d);
        let total = w * h * d;
        if best.is_none_or(|(t, _)| total < t) {
            best = Some((total, [w as u32, h as u32, d as u32]));
            if total == words {
                break;
            }
        }
    }
    best.map(|(_, e)| e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_extents_hold_every_word_and_waste_little() {
        for (words, max) in
            [(1u64, 2048u32), (5, 2048), (2049, 2048), (4096 * 4097, 2048), (1 << 29, 2048), (99_991, 64), (4093, 16)]
        {
            let e = texel_extent(words, max).unwrap();
            let total: u64 = e.iter().map(|&v| u64::from(v)).product();
            assert!(e.iter().all(|&v| v >= 1 && v <= max), "{words}: {e:?}");
            assert!(total >= words, "{words}: {e:?} holds {total}");
            // At most one row per slice is partly empty.
            assert!(total - words < u64::from(e[0]) * u64::from(e[2]), "{words}: {e:?} wastes {}", total - words);
        }
        // 2^29 words fill 2048 x 2048 x 128 exactly; a prime count fits exactly in one row when it can.
        assert_eq!(texel_extent(1 << 29, 2048), Some([2048, 2048, 128]));
        assert_eq!(texel_extent(2039, 2048), Some([2039, 1, 1]));
        // Too many words for the largest texture.
        assert_eq!(texel_extent(16 * 16 * 16 + 1, 16), None);
    }
}
