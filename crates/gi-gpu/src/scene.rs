//! A scene frame in GPU storage buffers for the path tracer: per-triangle shading attributes,
//! materials, textures, the emitter power table, punctual lights and the BVH.
//!
//! Everything is indexed like the frame's ORIGINAL triangle list, which is what BVH hits
//! return, so a hit finds its attributes and its emitter selection probability in O(1).
//! The WGSL side of these layouts is declared in `shaders/path/scene.wgsl` (`gi::scene`);
//! a test checks every struct's size and member offsets against these Rust mirrors.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use gi_scene::{AlphaMode, EmitterDistribution, LightKind, Scene, SceneFrame};
use rayon::prelude::*;

use crate::bvh::{BvhError, GpuBvh};
use crate::skin::GpuSkinning;
use crate::textures::{SceneTextures, TextureError, TextureOptions};
use crate::{GpuContext, GpuTimer};

/// Texture and emitter index meaning "none" in the GPU tables.
pub const NO_TEXTURE: u32 = u32::MAX;

/// Geometry and shading attributes of one triangle, 112 bytes (`TriangleShading` in WGSL).
/// Vertices are repeated here because the BVH stores them in leaf order.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleShading {
    /// Vertex positions (xyz). `pa.w` is the index of the scene node the triangle belongs to,
    /// as an f32 (exact below 2^24 nodes), for per-node data such as motion; `pb.w` and `pc.w`
    /// are unused.
    pub pa: [f32; 4],
    pub pb: [f32; 4],
    pub pc: [f32; 4],
    /// Vertex normals (xyz), with the vertex's u coordinate in w.
    pub na: [f32; 4],
    pub nb: [f32; 4],
    pub nc: [f32; 4],
    /// v coordinates of the three vertices.
    pub v: [f32; 3],
    /// Material index (out of range: the default material).
    pub material: u32,
}

/// glTF metallic-roughness material with `KHR_materials_specular`, `KHR_materials_ior`, a
/// normal map, an occlusion map and an alpha mode, 112 bytes (`Material` in WGSL). Texture fields index the
/// reference table ([`crate::GpuTextureRef`]), [`NO_TEXTURE`] when absent or empty, which
/// samples as white as the reference does.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear RGBA factor (alpha unused, as in the reference).
    pub base_color: [f32; 4],
    /// Linear emitted radiance factor.
    pub emissive: [f32; 3],
    /// Factor of the metallic-roughness texture's blue channel.
    pub metallic: f32,
    /// Perceptual roughness; factor of the texture's green channel.
    pub roughness: f32,
    /// Index into `scene.textures`, or [`NO_TEXTURE`].
    pub base_color_texture: u32,
    /// Index into `scene.textures`, or [`NO_TEXTURE`].
    pub metallic_roughness_texture: u32,
    /// Index into `scene.textures`, or [`NO_TEXTURE`].
    pub emissive_texture: u32,
    /// 1 when both faces emit.
    pub double_sided: u32,
    /// Weight of the dielectric's specular layer; factor of the specular texture's alpha.
    pub specular: f32,
    /// Index of refraction of the dielectric.
    pub ior: f32,
    /// Index into `scene.textures`, or [`NO_TEXTURE`].
    pub specular_texture: u32,
    /// Linear specular color; factor of the specular color texture's rgb.
    pub specular_color: [f32; 3],
    /// Index into `scene.textures`, or [`NO_TEXTURE`].
    pub specular_color_texture: u32,
    /// Index into `scene.textures`, or [`NO_TEXTURE`].
    pub normal_texture: u32,
    /// Scale of the normal map's x and y.
    pub normal_scale: f32,
    /// [`ALPHA_OPAQUE`], [`ALPHA_MASK`] or [`ALPHA_BLEND`].
    pub alpha_mode: u32,
    /// `alphaCutoff` of [`ALPHA_MASK`].
    pub alpha_cutoff: f32,
    /// Index into `scene.textures`, or [`NO_TEXTURE`]: the ambient occlusion map (red).
    pub occlusion_texture: u32,
    /// `occlusionTexture.strength`: the factor is `1 + strength * (texel - 1)`.
    pub occlusion_strength: f32,
    pub pad: [u32; 2],
}

/// The shader definition that makes a pass's rays honor alpha-tested materials
/// (`gi::bvh` then calls `gi::scene::alpha_covers`, so the pass must bind the scene and its
/// textures).
pub const ALPHA_TEST: (&str, crate::ShaderDefValue) =
    ("ALPHA_TEST", crate::ShaderDefValue::Bool(true));

/// [`GpuMaterial::alpha_mode`] values.
pub const ALPHA_OPAQUE: u32 = 0;
pub const ALPHA_MASK: u32 = 1;
pub const ALPHA_BLEND: u32 = 2;

/// The second texture coordinate set and the tangents of one triangle's vertices, 80 bytes
/// (`TriangleExtras` in WGSL); read only for materials with a normal map or a texture on
/// `TEXCOORD_1`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleExtras {
    /// World-space unit tangents (xyz) with the bitangent sign in w.
    pub ta: [f32; 4],
    pub tb: [f32; 4],
    pub tc: [f32; 4],
    /// `TEXCOORD_1` of vertices a and b.
    pub uv_ab: [f32; 4],
    /// `TEXCOORD_1` of vertex c.
    pub uv_c: [f32; 2],
    pub pad: [f32; 2],
}

/// One entry of the emitter power table, 8 bytes.
///
/// The reference picks entry `partition_point(cdf <= u)` with `u = k / 2^24`. Since
/// `cdf <= k / 2^24` exactly when `k >= ceil(cdf * 2^24)`, storing that integer threshold lets
/// the GPU reproduce every pick of the f64 table bit for bit with integer comparisons.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuEmitter {
    /// Frame triangle index.
    pub triangle: u32,
    /// `ceil(cdf * 2^24)` of this entry's inclusive cumulative probability.
    pub threshold: u32,
}

/// A punctual light in world space, 64 bytes (`PunctualLight` in WGSL). Spot cone values are
/// precomputed on the CPU exactly as `WorldLight::incident` computes them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// World position (point and spot lights).
    pub position: [f32; 3],
    /// 0 directional, 1 point, 2 spot.
    pub kind: u32,
    /// Unit direction the light shines along.
    pub direction: [f32; 3],
    /// Distance where the glTF range window reaches zero (when `has_range` is 1).
    pub range: f32,
    /// `color * intensity`: W/sr for point and spot lights, W/m^2 for directional ones.
    pub intensity: [f32; 3],
    /// 1 when `range` applies.
    pub has_range: u32,
    /// Cosine of the spot's outer cone angle.
    pub cos_outer: f32,
    /// `1 / max(cos_inner - cos_outer, 1e-3)`.
    pub spot_scale: f32,
    pub pad: [u32; 2],
}

/// The emitter table and per-triangle selection probabilities: the reference's
/// [`EmitterDistribution`], with each cdf entry stored as the integer `ceil(cdf * 2^24)` so the
/// GPU's pick equals the CPU's f64 search bit for bit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmitterTable {
    /// The table in the reference's order (frame triangle order).
    pub entries: Vec<GpuEmitter>,
    /// Probability of picking each frame triangle (0 for non-emitters).
    pub selection: Vec<f32>,
}

impl EmitterTable {
    /// Builds the table of `frame` (an evaluation of `scene`).
    pub fn build(scene: &Scene, frame: &SceneFrame) -> Self {
        let distribution = EmitterDistribution::build(frame, &scene.materials, &scene.textures);
        let entries = distribution
            .triangles
            .iter()
            .zip(&distribution.cdf)
            .map(|(&triangle, &cdf)| GpuEmitter {
                triangle,
                threshold: (cdf * 16_777_216.0).ceil() as u32,
            })
            .collect();
        Self {
            entries,
            selection: distribution.selection,
        }
    }
}

/// Why a scene cannot go to the GPU.
#[derive(Debug, thiserror::Error)]
pub enum SceneUploadError {
    #[error(transparent)]
    Bvh(#[from] BvhError),
    #[error(transparent)]
    Textures(#[from] TextureError),
    /// A scene buffer would exceed the device's largest storage binding or buffer.
    #[error(
        "{label} needs {bytes} bytes, over the device's limit of {limit} \
         (`max_storage_buffer_binding_size` / `max_buffer_size`): the scene is too large for \
         this adapter"
    )]
    TooLarge {
        label: &'static str,
        bytes: u64,
        limit: u64,
    },
    /// The frame left out the normals and tangents of a node that is not skinned on the GPU
    /// (`gi_scene::Evaluation::positions_only` beyond [`crate::gpu_skinned_nodes`]).
    #[error(
        "the frame has no normals for node {node}, which is not skinned on the GPU: evaluate \
         it with `Scene::evaluate`, or leave out only `gpu_skinned_nodes`"
    )]
    PositionsOnly { node: usize },
    /// A shader of the upload's passes (the GPU skinning) failed to compile.
    #[error("a scene shader failed to compile: {message}")]
    Shader { message: String },
}

/// One scene frame on the GPU. Buffers are labeled `scene.*` and counted by the context until
/// [`GpuScene::release`].
pub struct GpuScene {
    /// `scene.triangles`: [`GpuTriangleShading`] per frame triangle.
    pub triangles: wgpu::Buffer,
    /// `scene.materials`: [`GpuMaterial`]s (at least one: the default material follows them).
    pub materials: wgpu::Buffer,
    /// `scene.texture_refs`: the [`crate::GpuTextureRef`] table the materials index.
    pub texture_refs: wgpu::Buffer,
    /// `scene.triangle_extras`: [`GpuTriangleExtras`] per frame triangle, or one zeroed entry
    /// when no primitive has tangents or a second texture coordinate set.
    pub triangle_extras: wgpu::Buffer,
    /// `scene.emitters`: the [`GpuEmitter`] table.
    pub emitters: wgpu::Buffer,
    /// `scene.selection`: per frame triangle, its emitter selection probability.
    pub selection: wgpu::Buffer,
    /// `scene.lights`: [`GpuLight`]s.
    pub lights: wgpu::Buffer,
    /// The texture arrays (bind group [`crate::TEXTURE_BIND_GROUP`]).
    pub textures: SceneTextures,
    /// The BVH (bind group [`crate::bvh::BVH_BIND_GROUP`]).
    pub bvh: GpuBvh,
    /// Entries in the emitter table.
    pub emitter_count: u32,
    /// Punctual lights.
    pub light_count: u32,
    /// Index of the default material in `scene.materials`.
    pub default_material: u32,
    /// Wall time of the BVH's bottom-level builds on the CPU, in seconds.
    pub bvh_build_seconds: f64,
    /// Whether `scene.triangle_extras` holds every triangle.
    has_extras: bool,
    /// The frame triangles whose shading data can change between frames (those of moving and
    /// deforming nodes), as sorted, disjoint ranges; [`GpuScene::update`] rewrites only these.
    changing: Vec<Range<usize>>,
    /// The part of `changing` the CPU writes: all of it but the triangles skinned on the GPU.
    cpu_changing: Vec<Range<usize>>,
    /// The skinning of skinned meshes whose joints move, on the GPU (`None`: no such mesh).
    skinning: Option<GpuSkinning>,
    /// Per node, whether it is skinned on the GPU ([`crate::gpu_skinned_nodes`] at the upload):
    /// the nodes whose shading a frame may leave out.
    gpu_skinned: Vec<bool>,
    /// Whether a changing triangle emits light: then the emitter table changes with the
    /// frame.
    changing_emitters: bool,
    /// The [`SceneFrame::material_revision`] whose materials the material and emitter tables
    /// hold.
    material_revision: u64,
    /// Whether a material is alpha `BLEND` (the real-time tiers then composite a blended
    /// layer over the surface behind it: `gi_gpu::gbuffer`).
    pub has_blend: bool,
    /// Whether some node's triangles change shape from frame to frame
    /// ([`Scene::deforming_nodes`]: skins, morph targets), so their motion does not follow
    /// a node transform.
    pub has_deforming: bool,
}

/// Per-triangle shading data of `frame`'s triangles `range`, in frame order, as the CPU writes
/// them (all triangles but those skinned on the GPU).
pub fn triangle_shading(frame: &SceneFrame, range: Range<usize>) -> Vec<GpuTriangleShading> {
    (frame.triangles[range.clone()].par_iter())
        .zip(&frame.attributes[range])
        .map(|(tri, a)| {
            let p = |v: glam::Vec3A, w: f32| [v.x, v.y, v.z, w];
            let n = |i: usize| {
                let n = a.normals[i];
                [n.x, n.y, n.z, a.uvs[i].x]
            };
            GpuTriangleShading {
                pa: p(tri.v0, a.node as f32),
                pb: p(tri.v1, 0.0),
                pc: p(tri.v2, 0.0),
                na: n(0),
                nb: n(1),
                nc: n(2),
                v: [a.uvs[0].y, a.uvs[1].y, a.uvs[2].y],
                material: a.material,
            }
        })
        .collect()
}

/// Writes `bytes` at `offset` of `buffer`, or makes `buffer` again holding `bytes` alone when
/// they do not fit (returns true then: bind groups over it must be made again).
fn write_at(
    ctx: &GpuContext,
    buffer: &mut wgpu::Buffer,
    label: &str,
    offset: u64,
    bytes: &[u8],
) -> bool {
    if bytes.is_empty() {
        return false;
    }
    if offset + bytes.len() as u64 > buffer.size() {
        let usage = buffer.usage();
        ctx.release_buffer(buffer);
        *buffer = ctx.create_buffer_init(label, bytes, usage);
        return true;
    }
    ctx.queue.write_buffer(buffer, offset, bytes);
    false
}

/// The triangles of `frame` (an evaluation of `scene`) whose nodes move or deform, as sorted,
/// disjoint ranges: a node's triangles are contiguous in a frame, and the others are the same
/// in every evaluation.
fn changing_ranges(scene: &Scene, frame: &SceneFrame) -> Vec<Range<usize>> {
    let (moving, deforming) = scene.moving_and_deforming_nodes();
    let changes = |node: u32| {
        let node = node as usize;
        moving.get(node).copied().unwrap_or(true) || deforming.get(node).copied().unwrap_or(true)
    };
    let mut ranges: Vec<Range<usize>> = Vec::new();
    for (index, attributes) in frame.attributes.iter().enumerate() {
        if !changes(attributes.node) {
            continue;
        }
        match ranges.last_mut() {
            Some(last) if last.end == index => last.end = index + 1,
            _ => ranges.push(index..index + 1),
        }
    }
    ranges
}

/// A node whose shading `frame` left out (`SceneFrame::positions_only`) must be one the GPU
/// skins (`skinned`, from [`crate::gpu_skinned_nodes`]), or its triangles would get zero
/// normals.
fn check_positions_only(skinned: &[bool], frame: &SceneFrame) -> Result<(), SceneUploadError> {
    match (frame.positions_only.iter().enumerate())
        .position(|(node, &only)| only && !skinned.get(node).copied().unwrap_or(false))
    {
        Some(node) => Err(SceneUploadError::PositionsOnly { node }),
        None => Ok(()),
    }
}

/// The parts of the sorted, disjoint `ranges` outside the sorted, disjoint `removed`.
fn subtract_ranges(ranges: &[Range<usize>], removed: &[Range<usize>]) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    for range in ranges {
        let mut start = range.start;
        for cut in removed
            .iter()
            .filter(|c| c.end > range.start && c.start < range.end)
        {
            if cut.start > start {
                out.push(start..cut.start);
            }
            start = start.max(cut.end);
        }
        if start < range.end {
            out.push(start..range.end);
        }
    }
    out
}

/// Whether a triangle of `ranges` of `frame` (an evaluation of `scene`) has an emissive
/// material.
fn emits(scene: &Scene, frame: &SceneFrame, ranges: &[Range<usize>]) -> bool {
    let exitance = EmitterDistribution::exitance(&scene.materials, &scene.textures);
    ranges.iter().any(|range| {
        frame.attributes[range.clone()]
            .iter()
            .any(|a| exitance.get(a.material as usize).is_some_and(|&e| e > 0.0))
    })
}

/// Whether some primitive of `scene` has tangents or a second texture coordinate set: then
/// the triangles have extras ([`triangle_extras`]).
fn has_extras(scene: &Scene) -> bool {
    scene
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .any(|p| !p.tangents.is_empty() || !p.uvs1.is_empty())
}

/// Tangents and second texture coordinates of `frame`'s triangles `range`, in frame order, as
/// the CPU writes them.
pub fn triangle_extras(frame: &SceneFrame, range: Range<usize>) -> Vec<GpuTriangleExtras> {
    frame.attributes[range]
        .par_iter()
        .map(|a| {
            let [u0, u1, u2] = a.uvs1;
            GpuTriangleExtras {
                ta: a.tangents[0].to_array(),
                tb: a.tangents[1].to_array(),
                tc: a.tangents[2].to_array(),
                uv_ab: [u0.x, u0.y, u1.x, u1.y],
                uv_c: u2.to_array(),
                pad: [0.0; 2],
            }
        })
        .collect()
}

/// The GPU form of `scene`'s materials, the glTF default material appended; texture
/// references are added to `textures`' table.
fn gpu_materials(scene: &Scene, textures: &mut SceneTextures) -> Vec<GpuMaterial> {
    scene
        .materials
        .iter()
        .chain(std::iter::once(&gi_scene::Material::default()))
        .map(|m| {
            let (alpha_mode, alpha_cutoff) = match m.alpha_mode {
                AlphaMode::Opaque => (ALPHA_OPAQUE, 0.0),
                AlphaMode::Mask { cutoff } => (ALPHA_MASK, cutoff),
                AlphaMode::Blend => (ALPHA_BLEND, 0.0),
            };
            GpuMaterial {
                base_color: m.base_color.to_array(),
                emissive: m.emissive.to_array(),
                metallic: m.metallic,
                roughness: m.roughness,
                base_color_texture: textures.reference(m.base_color_texture),
                metallic_roughness_texture: textures.reference(m.metallic_roughness_texture),
                emissive_texture: textures.reference(m.emissive_texture),
                double_sided: u32::from(m.double_sided),
                specular: m.specular,
                ior: m.ior,
                specular_texture: textures.reference(m.specular_texture),
                specular_color: m.specular_color.to_array(),
                specular_color_texture: textures.reference(m.specular_color_texture),
                normal_texture: textures.reference(m.normal_texture),
                normal_scale: m.normal_scale,
                alpha_mode,
                alpha_cutoff,
                occlusion_texture: textures.reference(m.occlusion_texture),
                occlusion_strength: m.occlusion_strength,
                pad: [0; 2],
            }
        })
        .collect()
}

impl GpuScene {
    /// [`GpuScene::upload_with`] the default texture options.
    pub fn upload(
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
    ) -> Result<Self, SceneUploadError> {
        Self::upload_with(ctx, scene, frame, &TextureOptions::default())
    }

    /// Builds the two-level BVH of `scene` placed at `frame` ([`GpuBvh::from_scene`]) and
    /// uploads it with everything a path needs, the textures within `texture_options`. Cost:
    /// the bottom-level builds, the textures' mip chains, copies of the frame's attributes;
    /// later frames of an animated scene call [`GpuScene::update`]. Texture warnings
    /// (downscaled, resampled) are in `textures.warnings`.
    pub fn upload_with(
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
        texture_options: &TextureOptions,
    ) -> Result<Self, SceneUploadError> {
        let gpu_skinned = crate::gpu_skinned_nodes(scene);
        check_positions_only(&gpu_skinned, frame)?;
        // Every buffer is checked against the device's limits before anything is created.
        let triangle_count = frame.triangles.len() as u64;
        let limit = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        for (label, bytes) in [
            (
                "scene.triangles",
                triangle_count * size_of::<GpuTriangleShading>() as u64,
            ),
            (
                "scene.triangle_extras",
                triangle_count * size_of::<GpuTriangleExtras>() as u64,
            ),
            ("scene.selection", triangle_count * 4),
        ] {
            if bytes > limit {
                return Err(SceneUploadError::TooLarge {
                    label,
                    bytes,
                    limit,
                });
            }
        }
        let mut textures = SceneTextures::upload(ctx, scene, texture_options)?;
        for warning in &textures.warnings {
            tracing::warn!("{warning}");
        }
        let bvh = GpuBvh::from_scene(ctx, scene, frame)?;
        let all = 0..frame.triangles.len();
        let triangles = triangle_shading(frame, all.clone());
        let extras = if has_extras(scene) {
            triangle_extras(frame, all)
        } else {
            Vec::new()
        };
        let materials = gpu_materials(scene, &mut textures);
        let default_material = materials.len() as u32 - 1;
        let table = EmitterTable::build(scene, frame);
        let lights: Vec<GpuLight> = frame.lights.iter().map(gpu_light).collect();
        // Copyable: the G-buffer keeps a copy of the triangles of scenes with deforming meshes.
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        // Storage bindings may not be empty: empty tables get one zeroed element that the
        // counts keep unread.
        let upload = |label: &str, bytes: &[u8], element: usize| {
            let zero = vec![0u8; element];
            let bytes = if bytes.is_empty() { &zero[..] } else { bytes };
            ctx.create_buffer_init(label, bytes, usage)
        };
        let changing = changing_ranges(scene, frame);
        let triangles = upload("scene.triangles", bytemuck::cast_slice(&triangles), 112);
        let triangle_extras = upload("scene.triangle_extras", bytemuck::cast_slice(&extras), 80);
        let skinning = GpuSkinning::new(
            ctx,
            scene,
            frame,
            &gpu_skinned,
            (&triangles, &triangle_extras),
            !extras.is_empty(),
        )?;
        let cpu_changing = match &skinning {
            Some(skinning) => {
                // The frame's normals and tangents of these nodes may have been left out
                // (`Evaluation::positions_only`): the GPU writes their shading now.
                skinning.run(ctx, scene, frame, None);
                subtract_ranges(&changing, skinning.ranges())
            }
            None => changing.clone(),
        };
        Ok(Self {
            triangles,
            materials: upload("scene.materials", bytemuck::cast_slice(&materials), 112),
            texture_refs: upload(
                "scene.texture_refs",
                bytemuck::cast_slice(&textures.refs),
                48,
            ),
            triangle_extras,
            emitters: upload("scene.emitters", bytemuck::cast_slice(&table.entries), 8),
            selection: upload("scene.selection", bytemuck::cast_slice(&table.selection), 4),
            lights: upload("scene.lights", bytemuck::cast_slice(&lights), 64),
            emitter_count: table.entries.len() as u32,
            light_count: lights.len() as u32,
            default_material,
            bvh_build_seconds: bvh.build_seconds,
            has_extras: !extras.is_empty(),
            has_blend: scene
                .materials
                .iter()
                .any(|m| m.alpha_mode == AlphaMode::Blend),
            has_deforming: scene.deforming_nodes().contains(&true),
            changing_emitters: emits(scene, frame, &changing),
            material_revision: frame.material_revision,
            changing,
            cpu_changing,
            skinning,
            gpu_skinned,
            textures,
            bvh,
        })
    }

    /// Moves the scene to `frame`, a later evaluation of the same scene: the BVH's top level
    /// and instance transforms ([`GpuBvh::update`], bottom levels untouched), the lights and
    /// the emitter table. The per-triangle shading buffers hold world-space vertices, normals
    /// and tangents, so the triangles of moving and deforming nodes are written again: those
    /// of moving skinned meshes by the GPU skinning pass (`skin`, [`crate::gpu_skinned_nodes`];
    /// 64 bytes per joint go up), the others from `frame` (112 bytes per triangle, 80 more with
    /// tangents or a second texture coordinate set). Static triangles are the same in every
    /// evaluation and stay as uploaded (a frame of a scene with more triangles is uploaded
    /// whole, from `frame`). The emitter table is built again only when a
    /// moving or deforming triangle emits light or the materials were edited
    /// ([`SceneFrame::material_revision`]; the material table is then uploaded again). A camera
    /// move alone needs no update at all.
    ///
    /// Returns true when a buffer had to be replaced (an emitter table that grew), so bind
    /// groups made over [`GpuScene::buffers`] must be made again. A frame that leaves out the
    /// normals of a node the GPU does not skin is refused
    /// ([`SceneUploadError::PositionsOnly`]), as at the upload.
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
    ) -> Result<bool, SceneUploadError> {
        self.update_with_timer(ctx, scene, frame, None)
    }

    /// [`GpuScene::update`] with its GPU passes timed in `timer`'s current frame: `skin` and
    /// the BVH's `bvh/refit` (submitted through [`GpuTimer::submit`]; the caller's
    /// [`GpuTimer::finish`] reports them).
    pub fn update_timed(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
        timer: &mut GpuTimer,
    ) -> Result<bool, SceneUploadError> {
        self.update_with_timer(ctx, scene, frame, Some(timer))
    }

    fn update_with_timer(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
        mut timer: Option<&mut GpuTimer>,
    ) -> Result<bool, SceneUploadError> {
        check_positions_only(&self.gpu_skinned, frame)?;
        match timer.as_deref_mut() {
            Some(timer) => self.bvh.update_timed(ctx, frame, timer)?,
            None => self.bvh.update(ctx, frame)?,
        }
        let mut replaced = false;
        let shading = size_of::<GpuTriangleShading>() as u64;
        let extra = size_of::<GpuTriangleExtras>() as u64;
        let fits = frame.triangles.len() as u64 * shading <= self.triangles.size()
            && (!self.has_extras
                || frame.triangles.len() as u64 * extra <= self.triangle_extras.size());
        // Another scene's frame (more triangles than the buffers hold) is uploaded whole.
        let whole = 0..frame.triangles.len();
        let ranges = if fits {
            &self.cpu_changing[..]
        } else {
            std::slice::from_ref(&whole)
        };
        for range in ranges {
            let range =
                range.start.min(frame.triangles.len())..range.end.min(frame.triangles.len());
            let triangles = triangle_shading(frame, range.clone());
            let offset = range.start as u64;
            replaced |= write_at(
                ctx,
                &mut self.triangles,
                "scene.triangles",
                offset * shading,
                bytemuck::cast_slice(&triangles),
            );
            if self.has_extras {
                let extras = triangle_extras(frame, range);
                replaced |= write_at(
                    ctx,
                    &mut self.triangle_extras,
                    "scene.triangle_extras",
                    offset * extra,
                    bytemuck::cast_slice(&extras),
                );
            }
        }
        match &self.skinning {
            Some(skinning) if fits => skinning.run(ctx, scene, frame, timer),
            // Another scene's frame was uploaded whole: the skinning is not its.
            Some(_) => {
                if let Some(skinning) = self.skinning.take() {
                    skinning.release(ctx);
                }
                self.cpu_changing = self.changing.clone();
            }
            None => {}
        }
        let mut write = |buffer: &mut wgpu::Buffer, label: &str, bytes: &[u8]| {
            replaced |= write_at(ctx, buffer, label, 0, bytes);
        };
        // An edited material: the table of materials again (the texture references are the
        // same, `Material::check_edit`, so the reference table stays), and the emitters'
        // power with it.
        let materials_edited = frame.material_revision != self.material_revision;
        if materials_edited {
            let materials = gpu_materials(scene, &mut self.textures);
            write(
                &mut self.materials,
                "scene.materials",
                bytemuck::cast_slice(&materials),
            );
            self.changing_emitters = emits(scene, frame, &self.changing);
            self.material_revision = frame.material_revision;
        }
        // Static emitters keep their power: the table changes only when an emitter moves or
        // a material is edited.
        if self.changing_emitters || !fits || materials_edited {
            let table = EmitterTable::build(scene, frame);
            write(
                &mut self.emitters,
                "scene.emitters",
                bytemuck::cast_slice(&table.entries),
            );
            write(
                &mut self.selection,
                "scene.selection",
                bytemuck::cast_slice(&table.selection),
            );
            self.emitter_count = table.entries.len() as u32;
        }
        let lights: Vec<GpuLight> = frame.lights.iter().map(gpu_light).collect();
        write(
            &mut self.lights,
            "scene.lights",
            bytemuck::cast_slice(&lights),
        );
        self.light_count = lights.len() as u32;
        Ok(replaced)
    }

    /// The frame triangles that [`GpuScene::update`] rewrites (those of moving and deforming
    /// nodes), as sorted, disjoint ranges; the others hold the same data in every frame.
    pub fn changing_ranges(&self) -> &[Range<usize>] {
        &self.changing
    }

    /// The [`SceneFrame::material_revision`] whose materials the material and emitter tables
    /// hold (the last update's frame's).
    pub fn material_revision(&self) -> u64 {
        self.material_revision
    }

    /// Vertices and triangles skinned on the GPU at each update (skinned meshes whose joints
    /// move and whose morph weights are constant: [`crate::gpu_skinned_nodes`]); `None` when
    /// there are none.
    pub fn gpu_skinned(&self) -> Option<(u32, u32)> {
        self.skinning.as_ref().map(GpuSkinning::counts)
    }

    /// Bytes of every buffer and texture array, BVH included.
    pub fn bytes(&self) -> u64 {
        self.buffers().iter().map(|b| b.size()).sum::<u64>()
            + self.bvh.bytes()
            + self.textures.bytes
            + self.skinning.as_ref().map_or(0, GpuSkinning::bytes)
    }

    /// The binding of `scene.triangles`, the first of `gi::scene`'s seven in group 0.
    pub const FIRST_BINDING: u32 = 1;

    /// The layout entries of `gi::scene`: read-only storage buffers at bindings 1..=7 of a
    /// pass's group 0, visible to compute stages. All seven are listed, also for passes that
    /// read fewer, so the bind group of [`GpuScene::bind_group_entries`] always fits. Passes
    /// that shade also bind [`SceneTextures::bind_group_layout`] as group
    /// [`crate::TEXTURE_BIND_GROUP`].
    pub fn layout_entries() -> [wgpu::BindGroupLayoutEntry; 7] {
        std::array::from_fn(|i| crate::binding::storage_entry(Self::FIRST_BINDING + i as u32, true))
    }

    /// [`GpuScene::buffers`] bound whole at bindings 1..=7, matching
    /// [`GpuScene::layout_entries`].
    pub fn bind_group_entries(&self) -> [wgpu::BindGroupEntry<'_>; 7] {
        let buffers = self.buffers();
        std::array::from_fn(|i| wgpu::BindGroupEntry {
            binding: Self::FIRST_BINDING + i as u32,
            resource: buffers[i].as_entire_binding(),
        })
    }

    /// The layout of bind group [`crate::TEXTURE_BIND_GROUP`], the texture arrays, for every
    /// pass that samples textures (directly or through alpha-tested rays).
    pub fn texture_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        SceneTextures::bind_group_layout(ctx)
    }

    /// Binds the texture arrays at group [`crate::TEXTURE_BIND_GROUP`] of `pass`.
    pub fn set_texture_bind_group(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_bind_group(crate::TEXTURE_BIND_GROUP, &self.textures.bind_group, &[]);
    }

    /// The scene buffers in the binding order of `gi::scene` (bindings 1..=7 of group 0).
    pub fn buffers(&self) -> [&wgpu::Buffer; 7] {
        [
            &self.triangles,
            &self.materials,
            &self.texture_refs,
            &self.triangle_extras,
            &self.emitters,
            &self.selection,
            &self.lights,
        ]
    }

    /// Stops counting and destroys every buffer and texture (for a scene replaced by a new
    /// frame's).
    pub fn release(self, ctx: &GpuContext) {
        for buffer in self.buffers() {
            ctx.release_buffer(buffer);
        }
        self.textures.release(ctx);
        self.bvh.release(ctx);
        if let Some(skinning) = &self.skinning {
            skinning.release(ctx);
        }
    }
}

fn gpu_light(light: &gi_scene::WorldLight) -> GpuLight {
    let (kind, cos_outer, spot_scale) = match light.kind {
        LightKind::Directional => (0, 0.0, 0.0),
        LightKind::Point => (1, 0.0, 0.0),
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let cos_outer = outer_cone_angle.cos();
            (
                2,
                cos_outer,
                1.0 / (inner_cone_angle.cos() - cos_outer).max(1e-3),
            )
        }
    };
    GpuLight {
        position: light.position.to_array(),
        kind,
        direction: light.direction.to_array(),
        range: light.range.unwrap_or(0.0),
        intensity: light.intensity.to_array(),
        has_range: u32::from(light.range.is_some()),
        cos_outer,
        spot_scale,
        pad: [0; 2],
    }
}

#[cfg(test)]
mod tests {
    use super::subtract_ranges;

    /// The CPU writes the changing triangles outside the GPU-skinned ranges: cuts at the start,
    /// inside, at the end, across two ranges, covering a range whole, and none.
    #[test]
    fn subtracted_ranges_are_what_is_left_outside_the_cuts() {
        let ranges = [0..10, 20..30, 40..50];
        assert_eq!(subtract_ranges(&ranges, &[]), ranges.to_vec());
        assert_eq!(
            subtract_ranges(&ranges, &[0..3, 5..7, 9..22, 40..50]),
            vec![3..5, 7..9, 22..30]
        );
        assert_eq!(
            subtract_ranges(&ranges, std::slice::from_ref(&(25..45))),
            vec![0..10, 20..25, 45..50]
        );
        assert_eq!(
            subtract_ranges(&ranges, std::slice::from_ref(&(0..50))),
            Vec::<std::ops::Range<usize>>::new()
        );
    }
}
