//! One eye's sample buffers on the device: the record that the sample-space passes (trace and
//! shade, temporal accumulation, denoising, AA) write and read, and that the reconstruction
//! maps to the screen, without a round trip through the CPU.
//!
//! Layout (WGSL `array<vec4<f32>>`, one storage buffer): every layer of the mapping's
//! `buffers()` in order, each row-major (row `j`, column `i` at `offset + j * width + i`),
//! each texel linear RGB in `xyz` and depth in `w` — metres along the view axis, `+inf` for a
//! miss, as [`SampleBuffers`] holds it on the CPU. A layer's texels not shaded by the mapping
//! hold whatever was written last (as on the CPU).
//!
//! The CPU side of a frame never reads this buffer on the frame path; [`DeviceSamples::read`]
//! (a blocking readback, counted in [`crate::traffic`]) is for tests and for an image asked
//! for, [`DeviceSamples::upload`] for a frame whose earlier stages ran on the CPU.

use bytemuck::{Pod, Zeroable};
use fovea_core::mapping::{BufferSize, FoveationMapping};
use fovea_core::Image;
use fovea_post::inverse_map::SampleBuffers;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::transfer::read_back;

/// Bytes of one texel: `vec4<f32>`.
pub const TEXEL_BYTES: u64 = 16;

/// Where one layer lies in the buffer, in texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleLayer {
    /// Index of the layer's first texel (row 0, column 0).
    pub offset: u32,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
}

/// [`SampleLayer`] as a shader reads it (`struct SampleLayer { offset, width, height, pad }`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct SampleLayerGpu {
    /// Index of the layer's first texel.
    pub offset: u32,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

impl From<SampleLayer> for SampleLayerGpu {
    fn from(l: SampleLayer) -> Self {
        Self {
            offset: l.offset,
            width: l.width,
            height: l.height,
            pad: 0,
        }
    }
}

/// One eye's sample buffers on the device (see the module's layout).
#[derive(Debug)]
pub struct DeviceSamples {
    buffer: wgpu::Buffer,
    layers: Vec<SampleLayer>,
    texels: u64,
}

impl DeviceSamples {
    /// The layers of `sizes` one after another, in texels; `None` when they exceed `u32`
    /// indexing.
    pub fn layout(sizes: &[BufferSize]) -> Option<(Vec<SampleLayer>, u64)> {
        let mut offset = 0u64;
        let mut layers = Vec::with_capacity(sizes.len());
        for s in sizes {
            layers.push(SampleLayer {
                offset: u32::try_from(offset).ok()?,
                width: s.width,
                height: s.height,
            });
            offset += s.pixels();
        }
        u32::try_from(offset).ok()?;
        Some((layers, offset))
    }

    /// Device buffers for layers of `sizes` (contents undefined until a pass writes them).
    /// [`GpuError::AdapterTooSmall`] when they exceed one storage binding, before anything is
    /// allocated.
    pub fn new(ctx: &GpuContext, sizes: &[BufferSize]) -> Result<Self> {
        Self::with_capacity(ctx, sizes, 0)
    }

    /// [`Self::new`] with room for at least `capacity_texels` texels, so that a later frame's
    /// layers of another size may take the buffer over ([`Self::relayout`]) without
    /// allocating (a polar buffer's size follows the gaze).
    pub fn with_capacity(
        ctx: &GpuContext,
        sizes: &[BufferSize],
        capacity_texels: u64,
    ) -> Result<Self> {
        let (layers, texels, bytes) = Self::sized(sizes, capacity_texels, "sample buffers")?;
        ctx.check_storage_binding("the frame's sample buffers", bytes)?;
        let buffer = ctx.scoped("allocating the frame's sample buffers", || {
            ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("sample buffers"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        Ok(Self {
            buffer,
            layers,
            texels,
        })
    }

    /// Texels the buffer holds room for.
    pub fn capacity(&self) -> u64 {
        self.buffer.size() / TEXEL_BYTES
    }

    /// Takes the layers of `sizes` in the same buffer (contents undefined until a pass writes
    /// them) when they fit its [`capacity`](Self::capacity); `false`, and nothing changed,
    /// otherwise.
    pub fn relayout(&mut self, sizes: &[BufferSize]) -> bool {
        Self::relayout_within(sizes, self.capacity(), &mut self.layers, &mut self.texels)
    }

    /// The layers of `sizes`, their texels, and the bytes of a buffer of vec4 texels with
    /// room for at least `capacity_texels` (shared with the denoiser's guides, which follow
    /// the samples' layout); `what` names the buffers in the error.
    pub(crate) fn sized(
        sizes: &[BufferSize],
        capacity_texels: u64,
        what: &str,
    ) -> Result<(Vec<SampleLayer>, u64, u64)> {
        let (layers, texels) = Self::layout(sizes).ok_or_else(|| {
            GpuError::Unsupported(format!("{what} of more than {} texels", u32::MAX))
        })?;
        Ok((
            layers,
            texels,
            texels.max(capacity_texels).max(1) * TEXEL_BYTES,
        ))
    }

    /// Sets `layers` and `texels` to those of `sizes` when they fit `capacity` texels;
    /// `false`, and nothing changed, otherwise.
    pub(crate) fn relayout_within(
        sizes: &[BufferSize],
        capacity: u64,
        layers: &mut Vec<SampleLayer>,
        texels: &mut u64,
    ) -> bool {
        match Self::layout(sizes) {
            Some((l, t)) if t <= capacity => {
                *layers = l;
                *texels = t;
                true
            }
            _ => false,
        }
    }

    /// [`Self::new`] for the buffers of `mapping`.
    pub fn for_mapping(ctx: &GpuContext, mapping: &dyn FoveationMapping) -> Result<Self> {
        Self::new(ctx, &mapping.buffers())
    }

    /// Whether these buffers have exactly the layers of `sizes` (a frame context reuses them
    /// then instead of allocating).
    pub fn fits(&self, sizes: &[BufferSize]) -> bool {
        self.layers.len() == sizes.len()
            && self
                .layers
                .iter()
                .zip(sizes)
                .all(|(l, s)| l.width == s.width && l.height == s.height)
    }

    /// The storage buffer.
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// The layers, in the mapping's order.
    pub fn layers(&self) -> &[SampleLayer] {
        &self.layers
    }

    /// The layers as a shader reads them.
    pub fn layers_gpu(&self) -> Vec<SampleLayerGpu> {
        self.layers.iter().map(|&l| l.into()).collect()
    }

    /// Texels in all layers.
    pub fn texels(&self) -> u64 {
        self.texels
    }

    /// Writes `buffers` (same layers) into the device buffer: one counted upload.
    pub fn upload(&self, ctx: &GpuContext, buffers: &SampleBuffers) -> Result<()> {
        self.check_layers(buffers)?;
        let mut words = Vec::with_capacity(self.texels as usize);
        for (color, depth) in buffers.color.iter().zip(&buffers.depth) {
            words.extend(
                color
                    .data()
                    .iter()
                    .zip(depth.data())
                    .map(|(c, &d)| [c[0], c[1], c[2], d]),
            );
        }
        ctx.scoped("uploading the frame's sample buffers", || {
            ctx.write_buffer(&self.buffer, 0, bytemuck::cast_slice(&words))
        })
    }

    /// The buffers read back (blocking, counted): for tests and for an image asked for, never
    /// on the frame path.
    pub fn read(&self, ctx: &GpuContext) -> Result<SampleBuffers> {
        let bytes = self.texels.max(1) * TEXEL_BYTES;
        let mut texels: Vec<[f32; 4]> = Vec::new();
        read_back(
            ctx,
            &[(&self.buffer, bytes)],
            "the frame's sample buffers",
            |_, b| {
                texels = bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(b);
            },
        )?;
        let image_err = |e: fovea_core::FoveaError| GpuError::Input(e.to_string());
        let (mut color, mut depth) = (Vec::new(), Vec::new());
        for l in &self.layers {
            let n = l.width as usize * l.height as usize;
            let slice = texels
                .get(l.offset as usize..l.offset as usize + n)
                .ok_or_else(|| GpuError::Input("sample buffers read back short".to_string()))?;
            let c = slice.iter().map(|t| [t[0], t[1], t[2]]).collect();
            let d = slice.iter().map(|t| t[3]).collect();
            color.push(Image::from_vec(l.width, l.height, c).map_err(image_err)?);
            depth.push(Image::from_vec(l.width, l.height, d).map_err(image_err)?);
        }
        Ok(SampleBuffers { color, depth })
    }

    fn check_layers(&self, buffers: &SampleBuffers) -> Result<()> {
        let same = buffers.color.len() == self.layers.len()
            && buffers.depth.len() == self.layers.len()
            && self.layers.iter().enumerate().all(|(k, l)| {
                let (c, d) = (&buffers.color[k], &buffers.depth[k]);
                (c.width(), c.height()) == (l.width, l.height)
                    && (d.width(), d.height()) == (l.width, l.height)
            });
        if same {
            Ok(())
        } else {
            Err(GpuError::Input(format!(
                "sample buffers of {} layers do not match the device's {:?}",
                buffers.color.len(),
                self.layers
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_follow_each_other() {
        let sizes = [
            BufferSize {
                width: 3,
                height: 2,
            },
            BufferSize {
                width: 5,
                height: 4,
            },
        ];
        let (layers, texels) = DeviceSamples::layout(&sizes).unwrap();
        assert_eq!(
            layers,
            vec![
                SampleLayer {
                    offset: 0,
                    width: 3,
                    height: 2
                },
                SampleLayer {
                    offset: 6,
                    width: 5,
                    height: 4
                }
            ]
        );
        assert_eq!(texels, 26);
        let huge = [BufferSize {
            width: 1 << 16,
            height: 1 << 16,
        }];
        assert!(DeviceSamples::layout(&huge).is_none());
    }
}
