//! A GPU tier's frame as textures on its device ([`OutputTextures`]), for an engine that
//! samples the GI instead of reading an image back: the composited image and the GI term, each
//! `rgba16float`, made once per image size and written by one pass (`output/textures`) when
//! the caller asks ([`crate::Renderer::output_textures`]).

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, uniform_entry};
use gi_gpu::{GpuContext, GpuError, ShaderLibrary, wgpu};
use gi_image::Image;
use glam::Vec3;

/// The format of both textures: linear radiance in half floats, filterable and writable from a
/// compute pass on every WebGPU device.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Pixels per side of the pass's workgroups (`@workgroup_size(8, 8)`).
const TILE: u32 = 8;

/// Where a GPU tier's last frame lies on its device ([`crate::Tier::gpu_output`]).
pub struct GpuOutput<'a> {
    /// The device the buffers live on.
    pub ctx: &'a GpuContext,
    /// The composited image, `array<vec4<f32>>`, one texel per pixel, row-major.
    pub image: &'a wgpu::Buffer,
    /// The direct light in the same layout, for tiers that compose GI over it (`mobile`,
    /// `pc`); `None` where the image is one estimate of all light (`path`, `direct`).
    pub direct: Option<&'a wgpu::Buffer>,
    /// Image width and height in pixels.
    pub size: (u32, u32),
}

/// Rust mirror of `OutputParams` in `shaders/output/textures.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct OutputParams {
    size: [u32; 2],
    has_direct: u32,
    pad: u32,
}

/// The textures of one image size on one device, and the pass that fills them.
pub struct OutputTextures {
    /// The composited image: what [`crate::Renderer::render`] reads back, as a texture.
    pub image: wgpu::Texture,
    /// The GI term: the composited image minus the tier's direct light (black for tiers
    /// without a separate direct light). Unclamped: a noisy estimate may dip below zero.
    pub gi: wgpu::Texture,
    size: (u32, u32),
    params: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    /// A one-texel stand-in for `direct` when the tier has none.
    no_direct: wgpu::Buffer,
    /// Views of `image` and `gi`, made once: the pass writes through them every frame.
    views: [wgpu::TextureView; 2],
}

impl OutputTextures {
    /// Textures of `size` on `ctx`. Fails when a side exceeds the device's 2D texture limit
    /// or the pass does not compile.
    pub fn new(ctx: &GpuContext, size: (u32, u32)) -> Result<Self, GpuError> {
        let limit = ctx.limits.max_texture_dimension_2d;
        let side = size.0.max(size.1).max(1);
        if side > limit {
            return Err(GpuError::LimitTooSmall {
                limit: "max_texture_dimension_2d",
                needed: side.into(),
                available: limit.into(),
            });
        }
        let size = (size.0.max(1), size.1.max(1));
        let texture = |label: &str| {
            ctx.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: size.0,
                    height: size.1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: OUTPUT_FORMAT,
                usage: wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let storage = |binding: u32| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: OUTPUT_FORMAT,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            count: None,
        };
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("output/textures.layout0"),
                entries: &[
                    uniform_entry(0),
                    gi_gpu::binding::storage_entry(1, true),
                    gi_gpu::binding::storage_entry(2, true),
                    storage(3),
                    storage(4),
                ],
            });
        let module = ShaderLibrary::new().create_module(ctx, "output/textures.wgsl", &[])?;
        let pipeline = ctx.create_compute_pipeline_with_layouts(
            "output/textures",
            &module,
            "main",
            &[Some(&layout)],
        );
        let (image, gi) = (texture("output.image"), texture("output.gi"));
        let views = [&image, &gi].map(|t| t.create_view(&Default::default()));
        Ok(Self {
            image,
            gi,
            views,
            size,
            params: ctx.create_buffer(
                "output.params",
                size_of::<OutputParams>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            layout,
            pipeline,
            no_direct: ctx.create_buffer("output.no_direct", 16, wgpu::BufferUsages::STORAGE),
        })
    }

    /// Width and height of both textures.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Writes `output`'s frame into the textures (one pass, submitted now; the queue orders
    /// it after the frame and before the caller's later work).
    pub fn write(&self, output: &GpuOutput) {
        let ctx = output.ctx;
        let params = OutputParams {
            size: [output.size.0, output.size.1],
            has_direct: u32::from(output.direct.is_some()),
            pad: 0,
        };
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let [image_view, gi_view] = &self.views;
        let mut entries = buffer_entries(
            0,
            [
                &self.params,
                output.image,
                output.direct.unwrap_or(&self.no_direct),
            ],
        );
        entries.push(wgpu::BindGroupEntry {
            binding: 3,
            resource: wgpu::BindingResource::TextureView(image_view),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: 4,
            resource: wgpu::BindingResource::TextureView(gi_view),
        });
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("output/textures.group0"),
            layout: &self.layout,
            entries: &entries,
        });
        let mut encoder = ctx.create_encoder("output/textures");
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("output/textures"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(self.size.0.div_ceil(TILE), self.size.1.div_ceil(TILE), 1);
        }
        ctx.queue.submit([encoder.finish()]);
    }

    /// The composited image read back from [`OutputTextures::image`] (stalls the GPU): for
    /// tools and tests; an engine samples the texture.
    pub fn read_image(&self, ctx: &GpuContext) -> Result<Image, GpuError> {
        read_texture(ctx, &self.image, self.size)
    }

    /// The GI term read back from [`OutputTextures::gi`] (stalls the GPU).
    pub fn read_gi(&self, ctx: &GpuContext) -> Result<Image, GpuError> {
        read_texture(ctx, &self.gi, self.size)
    }

    /// Stops counting the buffers and destroys them and the textures.
    pub fn release(&self, ctx: &GpuContext) {
        ctx.release_buffer(&self.params);
        ctx.release_buffer(&self.no_direct);
        ctx.release_texture(&self.image);
        ctx.release_texture(&self.gi);
    }
}

/// The rgb of an [`OUTPUT_FORMAT`] texture of `size`, through a buffer whose rows are padded to
/// `wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`.
fn read_texture(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    size: (u32, u32),
) -> Result<Image, GpuError> {
    let texel = 8u32;
    let row = (size.0 * texel).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("output.readback"),
        size: u64::from(row) * u64::from(size.1),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.create_encoder("output.readback");
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(size.1),
            },
        },
        wgpu::Extent3d {
            width: size.0,
            height: size.1,
            depth_or_array_layers: 1,
        },
    );
    ctx.queue.submit([encoder.finish()]);
    let halves: Vec<u16> = ctx.try_read_buffer(&buffer)?;
    buffer.destroy();
    let per_row = (row / 2) as usize;
    let pixels = (0..size.1 as usize)
        .flat_map(|y| (0..size.0 as usize).map(move |x| y * per_row + x * 4))
        .map(|at| {
            let channel = |c: usize| half::f16::from_bits(halves[at + c]).to_f32();
            Vec3::new(channel(0), channel(1), channel(2))
        })
        .collect();
    Ok(Image {
        width: size.0,
        height: size.1,
        pixels,
    })
}
