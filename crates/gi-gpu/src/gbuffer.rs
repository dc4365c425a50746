//! The ray-cast G-buffer: pass `gbuffer/primary` (`shaders/gbuffer/primary.wgsl`) traces one
//! closest-hit ray per pixel through the pixel center and stores what the path tier sees at
//! that first hit.
//!
//! Why ray casting rather than rasterization: the rays are the reference's
//! (`CameraView::ray_direction` through pixel centers) and the hits come from the same CWBVH
//! traversal and the same surface rules (shading normal, textured material, front-face
//! emission) as the path tier, so the G-buffer agrees exactly with the CPU reference's and the
//! path tier's primary hits. It is one code path over the [`GpuScene`] and [`GpuBvh`] already
//! uploaded: no vertex pipeline and no second copy of the geometry. The cost is one
//! closest-hit ray per pixel.
//!
//! Outputs, one storage buffer each, `size` = width x height entries in row-major order, all
//! counted by the context under `gbuffer.*`:
//!
//! | label | per pixel | sky |
//! |---|---|---|
//! | `gbuffer.depth` | `f32` distance `t` along the unit camera ray | `+inf` |
//! | `gbuffer.normal` | `u32` octahedral world shading normal facing the camera (`gi::packing`) | 0 |
//! | `gbuffer.base_color` | `[f32; 4]` textured linear base color, w = 1 | 0 |
//! | `gbuffer.metallic_roughness` | `[f32; 2]` textured metallic, perceptual roughness | 0 |
//! | `gbuffer.emissive` | `[f32; 4]` radiance toward the camera (0 behind single-sided emitters), w = the material's occlusion factor (`occlusionTexture`, 1 without) | 0 |
//! | `gbuffer.triangle` | `u32` frame triangle index | [`GBUFFER_MISS`] |
//! | `gbuffer.motion` | `[f32; 2]` previous pixel position minus this pixel's center, pixels, +y down | camera rotation only |
//! | `gbuffer.blend_layer` | `[f32; 4]` the nearest alpha-`BLEND` surface in front: distance (0: none), normal (packed), albedo towards the camera (packed), alpha; only for scenes with `BLEND` materials | 0 |
//!
//! Alpha `BLEND`: the rays of every tier pass a blended surface with probability 1 - alpha (a
//! hash of the hit), which averages to alpha blending over many rays per pixel, but one ray
//! through each pixel center would show a fixed dither. In scenes with `BLEND` materials the
//! G-buffer's ray therefore passes blended surfaces (the G-buffer describes the surface behind
//! them) and a second ray, which stops at them, finds the nearest blended layer in front; the
//! real-time tiers composite their GI over the layer's (its albedo times the brick cache's
//! irradiance there) with its alpha. Their direct light already is the blend: it averages
//! jittered rays that follow the hash.
//!
//! Motion is 0 where the surface point was behind the previous camera.

use bytemuck::{Pod, Zeroable};
use gi_scene::SceneFrame;

use crate::binding::{buffer_entries, storage_entry, uniform_entry};
use crate::bvh::{BVH_MISS, GpuBvh};
use crate::technique::{Recorder, Technique};
use crate::{GpuCamera, GpuContext, GpuError, GpuScene, ShaderLibrary};

/// Triangle id of a sky pixel in `gbuffer.triangle` (the BVH's miss value).
pub const GBUFFER_MISS: u32 = BVH_MISS;

/// Pixels per side of a `gbuffer/primary` workgroup (`@workgroup_size(8, 8)`).
const TILE: u32 = 8;

/// The camera of the G-buffer: the shared [`GpuCamera`] (`Camera` of `gi::camera`).
pub type GBufferCamera = GpuCamera;

/// Most ranges of moving triangles copied one by one into `gbuffer.previous_triangles`; a
/// scene with more copies everything in one command.
const MAX_RANGE_COPIES: usize = 256;

/// Uniforms of `gbuffer/primary`, 160 bytes (`GBufferUniforms` in WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GBufferUniforms {
    /// This frame's camera, which casts the rays.
    pub camera: GBufferCamera,
    /// The previous frame's camera, which motion vectors project with.
    pub previous_camera: GBufferCamera,
    /// Image size in pixels.
    pub size_px: [u32; 2],
    /// Index of the default material, used for out-of-range material indices.
    pub default_material: u32,
    /// 1 when `gbuffer.previous_from_current` holds the previous frame's node motion.
    pub has_previous_transforms: u32,
    /// 1 when the scene has alpha-`BLEND` materials and `gbuffer.blend_layer` holds one entry
    /// per pixel.
    pub blend_layer_on: u32,
    /// 1 when `gbuffer.previous_triangles` holds the previous frame's triangles (scenes with
    /// deforming meshes).
    pub has_previous_triangles: u32,
    pub pad: [u32; 2],
}

/// The inputs of one G-buffer frame.
pub struct GBufferInputs<'a> {
    /// This frame (its camera casts the rays).
    pub frame: &'a SceneFrame,
    /// This frame uploaded: attributes, materials and the BVH.
    pub scene: &'a GpuScene,
    /// The scene evaluated at the previous frame's time, with the previous camera. Only its
    /// camera and node transforms are read. A frame with a different node count has no usable
    /// history: motion then comes from the camera alone, as if the geometry had not moved.
    pub previous: &'a SceneFrame,
}

/// The G-buffer's output buffers, one entry per pixel in row-major order (see the module
/// docs for each one's format and sky value).
#[derive(Clone, Copy, Debug)]
pub struct GBufferOutputs<'a> {
    /// `gbuffer.depth`.
    pub depth: &'a wgpu::Buffer,
    /// `gbuffer.normal`.
    pub normal: &'a wgpu::Buffer,
    /// `gbuffer.base_color`.
    pub base_color: &'a wgpu::Buffer,
    /// `gbuffer.metallic_roughness`.
    pub metallic_roughness: &'a wgpu::Buffer,
    /// `gbuffer.emissive`.
    pub emissive: &'a wgpu::Buffer,
    /// `gbuffer.triangle`.
    pub triangle: &'a wgpu::Buffer,
    /// `gbuffer.motion`.
    pub motion: &'a wgpu::Buffer,
    /// `gbuffer.blend_layer`: one entry per pixel for scenes with alpha-`BLEND` materials,
    /// one placeholder entry otherwise.
    pub blend_layer: &'a wgpu::Buffer,
    /// Image size in pixels.
    pub size: (u32, u32),
}

/// The G-buffer read back to the CPU, one entry per pixel in row-major order (see the module
/// docs for each field's meaning and sky value).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GBufferData {
    /// `gbuffer.depth`: distance along the unit camera ray; `+inf` for sky.
    pub depth: Vec<f32>,
    /// `gbuffer.normal`: octahedral-packed world shading normal (`gi::packing`).
    pub normal: Vec<u32>,
    /// `gbuffer.base_color`: textured linear base color (rgb; w 1 on hits).
    pub base_color: Vec<[f32; 4]>,
    /// `gbuffer.metallic_roughness`: textured metallic and perceptual roughness.
    pub metallic_roughness: Vec<[f32; 2]>,
    /// `gbuffer.emissive`: radiance emitted toward the camera (rgb) and the material's
    /// occlusion factor (w).
    pub emissive: Vec<[f32; 4]>,
    /// `gbuffer.triangle`: frame triangle index, [`GBUFFER_MISS`] for sky.
    pub triangle: Vec<u32>,
    /// `gbuffer.motion`: previous pixel position minus this pixel's center, in pixels.
    pub motion: Vec<[f32; 2]>,
}

/// The G-buffer technique: its pipeline, its output buffers and the per-node motion since the
/// previous frame. Memory: 60 bytes per pixel (76 for scenes with alpha-`BLEND` materials)
/// plus 48 bytes per scene node, and for scenes with deforming meshes a copy of the scene's
/// triangles (112 bytes each).
pub struct GBuffer {
    /// Image size in pixels.
    pub size: (u32, u32),
    /// Entry point `primary` of `gbuffer/primary.wgsl`.
    primary: wgpu::ComputePipeline,
    frame_layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    /// `gbuffer.previous_from_current`: per scene node, the rows of the affine map taking this
    /// frame's world position of a point on the node to the previous frame's; grows with the
    /// scene.
    previous_from_current: wgpu::Buffer,
    /// The outputs in binding order (bindings 9..=15).
    outputs: [wgpu::Buffer; 7],
    /// `gbuffer.blend_layer` (binding 16): per pixel, the nearest alpha-`BLEND` surface in front
    /// of the pixel's surface, for scenes with such materials ([`GBuffer::prepare_layers`]);
    /// one placeholder entry otherwise.
    blend_layer: wgpu::Buffer,
    blend_layer_on: bool,
    /// `gbuffer.previous_triangles` (binding 17): for scenes with deforming meshes
    /// ([`GpuScene::has_deforming`]), a copy of the last recorded frame's `scene.triangles`
    /// made after its pass, so the next frame finds where a point of a skinned or morphed
    /// triangle was; one placeholder entry otherwise.
    previous_triangles: wgpu::Buffer,
    /// The time and triangle count of the frame `previous_triangles` holds.
    previous_triangles_of: Option<(f32, usize)>,
}

/// Bytes of a `scene.triangles` entry.
const TRIANGLE_BYTES: u64 = size_of::<crate::scene::GpuTriangleShading>() as u64;

/// Output labels and bytes per pixel, in binding order from binding 9.
const OUTPUTS: [(&str, u64); 7] = [
    ("gbuffer.depth", 4),
    ("gbuffer.normal", 4),
    ("gbuffer.base_color", 16),
    ("gbuffer.metallic_roughness", 8),
    ("gbuffer.emissive", 16),
    ("gbuffer.triangle", 4),
    ("gbuffer.motion", 8),
];

impl GBuffer {
    /// Compiles `gbuffer/primary` and allocates the outputs for `width` x `height` pixels.
    pub fn new(
        ctx: &GpuContext,
        shaders: &ShaderLibrary,
        width: u32,
        height: u32,
    ) -> Result<Self, GpuError> {
        let module = shaders.create_module(ctx, "gbuffer/primary.wgsl", &[crate::ALPHA_TEST])?;
        // An explicit layout: the BVH's bind group is made with `GpuBvh::bind_group_layout`,
        // and the pass leaves some scene bindings unused, which an automatic layout would drop.
        let mut entries = vec![uniform_entry(0)];
        entries.extend(GpuScene::layout_entries());
        entries.push(storage_entry(8, true));
        entries.extend((9..=16).map(|binding| storage_entry(binding, false)));
        entries.push(storage_entry(17, true));
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("gbuffer/primary.frame_layout"),
                entries: &entries,
            });
        let bvh_layout = GpuBvh::bind_group_layout(ctx);
        let texture_layout = GpuScene::texture_layout(ctx);
        let primary = ctx.create_compute_pipeline_with_layouts(
            "gbuffer/primary",
            &module,
            "primary",
            &[
                Some(&frame_layout),
                Some(&bvh_layout),
                None,
                Some(&texture_layout),
            ],
        );
        let pixels = u64::from(width) * u64::from(height);
        let outputs = OUTPUTS.map(|(label, bytes)| {
            ctx.create_buffer(
                label,
                (pixels * bytes).max(bytes),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            )
        });
        Ok(Self {
            size: (width, height),
            primary,
            frame_layout,
            uniforms: ctx.create_buffer(
                "gbuffer.uniforms",
                size_of::<GBufferUniforms>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            previous_from_current: Self::motion_buffer(ctx, 1),
            outputs,
            blend_layer: Self::blend_layer_buffer(ctx, 1),
            blend_layer_on: false,
            previous_triangles: Self::previous_triangles_buffer(ctx, 1),
            previous_triangles_of: None,
        })
    }

    fn previous_triangles_buffer(ctx: &GpuContext, triangles: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            "gbuffer.previous_triangles",
            triangles.max(1) * TRIANGLE_BYTES,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    fn blend_layer_buffer(ctx: &GpuContext, pixels: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            "gbuffer.blend_layer",
            pixels.max(1) * 16,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        )
    }

    /// Sizes the outputs that only some scenes need for `scene`: `gbuffer.blend_layer` holds
    /// one 16-byte entry per pixel when the scene has alpha-`BLEND` materials, one entry
    /// otherwise. Call it when a scene is uploaded, before making bind groups over
    /// [`GBuffer::outputs`]: the buffer may be replaced.
    pub fn prepare_layers(&mut self, ctx: &GpuContext, scene: &GpuScene) {
        let pixels = u64::from(self.size.0) * u64::from(self.size.1);
        let wanted = if scene.has_blend { pixels } else { 1 };
        if self.blend_layer.size() != wanted * 16 {
            ctx.release_buffer(&self.blend_layer);
            self.blend_layer = Self::blend_layer_buffer(ctx, wanted);
        }
        self.blend_layer_on = scene.has_blend;
    }

    /// Whether `gbuffer.blend_layer` holds a layer per pixel (the scene prepared last has
    /// alpha-`BLEND` materials).
    pub fn has_blend_layer(&self) -> bool {
        self.blend_layer_on
    }

    fn motion_buffer(ctx: &GpuContext, nodes: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            "gbuffer.previous_from_current",
            nodes.max(1) * 48,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    /// Reads every output back (stalls the GPU; for tests and tools).
    pub fn read(&self, ctx: &GpuContext) -> GBufferData {
        let pixels = (self.size.0 * self.size.1) as usize;
        let o = self.outputs();
        let read = |buffer| {
            let mut values: Vec<u32> = ctx.read_buffer(buffer);
            values.truncate(pixels);
            values
        };
        let floats =
            |buffer| -> Vec<f32> { read(buffer).into_iter().map(f32::from_bits).collect() };
        let vec2 = |buffer: &wgpu::Buffer| -> Vec<[f32; 2]> {
            let mut values: Vec<[f32; 2]> = ctx.read_buffer(buffer);
            values.truncate(pixels);
            values
        };
        let vec4 = |buffer: &wgpu::Buffer| -> Vec<[f32; 4]> {
            let mut values: Vec<[f32; 4]> = ctx.read_buffer(buffer);
            values.truncate(pixels);
            values
        };
        GBufferData {
            depth: floats(o.depth),
            normal: read(o.normal),
            base_color: vec4(o.base_color),
            metallic_roughness: vec2(o.metallic_roughness),
            emissive: vec4(o.emissive),
            triangle: read(o.triangle),
            motion: vec2(o.motion),
        }
    }

    /// The output buffers by name, for passes that bind them. They are the same buffers
    /// every frame, except `blend_layer`, which [`GBuffer::prepare_layers`] may replace.
    pub fn outputs(&self) -> GBufferOutputs<'_> {
        let [
            depth,
            normal,
            base_color,
            metallic_roughness,
            emissive,
            triangle,
            motion,
        ] = &self.outputs;
        GBufferOutputs {
            depth,
            normal,
            base_color,
            metallic_roughness,
            emissive,
            triangle,
            motion,
            blend_layer: &self.blend_layer,
            size: self.size,
        }
    }

    /// Stops counting and destroys every buffer.
    pub fn release(self, ctx: &GpuContext) {
        ctx.release_buffer(&self.uniforms);
        ctx.release_buffer(&self.previous_from_current);
        for buffer in &self.outputs {
            ctx.release_buffer(buffer);
        }
        ctx.release_buffer(&self.blend_layer);
        ctx.release_buffer(&self.previous_triangles);
    }
}

impl Technique for GBuffer {
    type Inputs<'i> = GBufferInputs<'i>;
    type Outputs<'o> = GBufferOutputs<'o>;

    /// Records `gbuffer/primary`, timed under that name. Uploads the
    /// uniforms and one 48-byte motion transform per scene node through the queue, so record
    /// one G-buffer frame per submission.
    ///
    /// Motion comes from the previous frame's node transforms: a hit on node `n` moved by
    /// `previous_world_from_node[n] * node_from_world[n]`, and nodes whose transform did not
    /// change get the exact identity, so static geometry moves only with the camera. Skinned
    /// and morphed triangles change shape, which no node transform describes: in scenes that
    /// have them ([`GpuScene::has_deforming`]), every pass is followed by a GPU copy of the
    /// scene's triangles, and the next frame, when its `previous` is the copied frame (same
    /// time, same triangle count), takes the hit's barycentric point on the copied triangle
    /// instead, for every triangle.
    fn record<'o>(
        &'o mut self,
        rec: &mut Recorder<'_>,
        inputs: &GBufferInputs<'_>,
    ) -> GBufferOutputs<'o> {
        let ctx = rec.ctx;
        let (width, height) = self.size;
        let (now, then) = (
            &inputs.frame.world_from_node,
            &inputs.previous.world_from_node,
        );
        let has_previous = now.len() == then.len();
        if has_previous && !now.is_empty() {
            let rows: Vec<[[f32; 4]; 3]> = now
                .iter()
                .zip(then)
                .map(|(now, then)| {
                    let previous_from_current = if now == then {
                        glam::Mat4::IDENTITY
                    } else {
                        *then * now.inverse()
                    };
                    let t = previous_from_current.transpose();
                    [t.x_axis, t.y_axis, t.z_axis].map(|r| r.to_array())
                })
                .collect();
            let bytes: &[u8] = bytemuck::cast_slice(&rows);
            if (bytes.len() as u64) > self.previous_from_current.size() {
                ctx.release_buffer(&self.previous_from_current);
                self.previous_from_current = Self::motion_buffer(ctx, rows.len() as u64);
            }
            ctx.queue
                .write_buffer(&self.previous_from_current, 0, bytes);
        }
        // Deforming meshes: the previous frame's own triangles, when the copy made after the
        // last pass is of that frame and of as many triangles.
        let triangle_count = inputs.frame.triangles.len();
        let deforming = inputs.scene.has_deforming && triangle_count > 0;
        let needed = triangle_count as u64 * TRIANGLE_BYTES;
        if deforming && self.previous_triangles.size() < needed {
            ctx.release_buffer(&self.previous_triangles);
            self.previous_triangles = Self::previous_triangles_buffer(ctx, triangle_count as u64);
            self.previous_triangles_of = None;
        }
        let has_previous_triangles = deforming
            && self.previous_triangles_of == Some((inputs.previous.time_s, triangle_count));
        let uniforms = GBufferUniforms {
            camera: GpuCamera::new(&inputs.frame.camera, self.size),
            previous_camera: GpuCamera::new(&inputs.previous.camera, self.size),
            size_px: [width, height],
            default_material: inputs.scene.default_material,
            has_previous_transforms: u32::from(has_previous),
            blend_layer_on: u32::from(self.blend_layer_on && inputs.scene.has_blend),
            has_previous_triangles: u32::from(has_previous_triangles),
            pad: [0; 2],
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));

        let mut entries = buffer_entries(0, [&self.uniforms]);
        entries.extend(inputs.scene.bind_group_entries());
        entries.extend(buffer_entries(
            8,
            std::iter::once(&self.previous_from_current)
                .chain(&self.outputs)
                .chain([&self.blend_layer, &self.previous_triangles]),
        ));
        let frame_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gbuffer/primary.frame"),
            layout: &self.frame_layout,
            entries: &entries,
        });
        rec.compute_pass("gbuffer/primary", |pass| {
            pass.set_pipeline(&self.primary);
            pass.set_bind_group(0, &frame_group, &[]);
            pass.set_bind_group(
                crate::bvh::BVH_BIND_GROUP,
                &inputs.scene.bvh.bind_group,
                &[],
            );
            inputs.scene.set_texture_bind_group(pass);
            pass.dispatch_workgroups(width.div_ceil(TILE), height.div_ceil(TILE), 1);
        });
        if deforming {
            // Holding the previous frame, the copy differs from this one only where triangles
            // move or deform; otherwise it is made whole.
            let ranges = inputs.scene.changing_ranges();
            if has_previous_triangles && ranges.len() <= MAX_RANGE_COPIES {
                for range in ranges {
                    let offset = range.start as u64 * TRIANGLE_BYTES;
                    let size = range.len() as u64 * TRIANGLE_BYTES;
                    let (src, dst) = (&inputs.scene.triangles, &self.previous_triangles);
                    rec.encoder()
                        .copy_buffer_to_buffer(src, offset, dst, offset, size);
                }
            } else {
                rec.encoder().copy_buffer_to_buffer(
                    &inputs.scene.triangles,
                    0,
                    &self.previous_triangles,
                    0,
                    needed,
                );
            }
            self.previous_triangles_of = Some((inputs.frame.time_s, triangle_count));
        }
        self.outputs()
    }
}
