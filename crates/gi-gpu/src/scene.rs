//! A scene frame in GPU storage buffers for the path tracer: per-triangle shading attributes,
//! materials, textures, the emitter power table, punctual lights and the BVH.
//!
//! Everything is indexed like the frame's ORIGINAL triangle list, which is what BVH hits
//! return, so a hit finds its attributes and its emitter selection probability in O(1).
//! The WGSL side of these layouts is declared in `shaders/path/scene.wgsl` (`gi::scene`);
//! a test checks every struct's size and member offsets against these Rust mirrors.

use bytemuck::{Pod, Zeroable};
use gi_scene::{EmitterDistribution, LightKind, Scene, SceneFrame};

use crate::GpuContext;
use crate::bvh::{BvhError, GpuBvh};

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

/// glTF metallic-roughness material with `KHR_materials_specular` and `KHR_materials_ior`,
/// 80 bytes (`Material` in WGSL). Texture indices are [`NO_TEXTURE`] when absent or empty,
/// which samples as white as the reference does.
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
}

/// Where one texture's texels start in `scene.texels` and its size, 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTextureInfo {
    /// Index of the texture's first texel (top-left) in `scene.texels`.
    pub offset: u32,
    /// Size in texels.
    pub width: u32,
    pub height: u32,
    pub pad: u32,
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

/// One scene frame on the GPU. Buffers are labeled `scene.*` and counted by the context until
/// [`GpuScene::release`].
pub struct GpuScene {
    /// `scene.triangles`: [`GpuTriangleShading`] per frame triangle.
    pub triangles: wgpu::Buffer,
    /// `scene.materials`: [`GpuMaterial`]s (at least one: the default material follows them).
    pub materials: wgpu::Buffer,
    /// `scene.textures`: [`GpuTextureInfo`] per texture.
    pub textures: wgpu::Buffer,
    /// `scene.texels`: every texture's linear RGBA texels, row-major, one after another.
    pub texels: wgpu::Buffer,
    /// `scene.emitters`: the [`GpuEmitter`] table.
    pub emitters: wgpu::Buffer,
    /// `scene.selection`: per frame triangle, its emitter selection probability.
    pub selection: wgpu::Buffer,
    /// `scene.lights`: [`GpuLight`]s.
    pub lights: wgpu::Buffer,
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
}

/// Per-triangle shading data of `frame`, in frame order.
fn triangle_shading(frame: &SceneFrame) -> Vec<GpuTriangleShading> {
    frame
        .triangles
        .iter()
        .zip(&frame.attributes)
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

impl GpuScene {
    /// Builds the two-level BVH of `scene` placed at `frame` ([`GpuBvh::from_scene`]) and
    /// uploads it with everything a path needs. Cost: the bottom-level builds and copies of the
    /// frame's attributes and the scene's textures; later frames of an animated scene call
    /// [`GpuScene::update`].
    pub fn upload(ctx: &GpuContext, scene: &Scene, frame: &SceneFrame) -> Result<Self, BvhError> {
        let bvh = GpuBvh::from_scene(ctx, scene, frame)?;
        let triangles = triangle_shading(frame);
        let texture_ok = |texture: Option<gi_scene::TextureRef>| {
            texture
                .map(|r| r.texture)
                .filter(|&i| scene.textures.get(i).is_some_and(|t| t.is_valid()))
                .map_or(NO_TEXTURE, |i| i as u32)
        };
        let materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .chain(std::iter::once(&gi_scene::Material::default()))
            .map(|m| GpuMaterial {
                base_color: m.base_color.to_array(),
                emissive: m.emissive.to_array(),
                metallic: m.metallic,
                roughness: m.roughness,
                base_color_texture: texture_ok(m.base_color_texture),
                metallic_roughness_texture: texture_ok(m.metallic_roughness_texture),
                emissive_texture: texture_ok(m.emissive_texture),
                double_sided: u32::from(m.double_sided),
                specular: m.specular,
                ior: m.ior,
                specular_texture: texture_ok(m.specular_texture),
                specular_color: m.specular_color.to_array(),
                specular_color_texture: texture_ok(m.specular_color_texture),
            })
            .collect();
        let default_material = materials.len() as u32 - 1;
        let mut texels = Vec::new();
        let mut infos = Vec::new();
        for t in &scene.textures {
            infos.push(GpuTextureInfo {
                offset: texels.len() as u32,
                width: t.width,
                height: t.height,
                pad: 0,
            });
            texels.extend(t.texels.iter().map(|&v| t.decode(v).to_array()));
        }
        let table = EmitterTable::build(scene, frame);
        let lights: Vec<GpuLight> = frame.lights.iter().map(gpu_light).collect();
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        // Storage bindings may not be empty: empty tables get one zeroed element that the
        // counts keep unread.
        let upload = |label: &str, bytes: &[u8], element: usize| {
            let zero = vec![0u8; element];
            let bytes = if bytes.is_empty() { &zero[..] } else { bytes };
            ctx.create_buffer_init(label, bytes, usage)
        };
        Ok(Self {
            triangles: upload("scene.triangles", bytemuck::cast_slice(&triangles), 112),
            materials: upload("scene.materials", bytemuck::cast_slice(&materials), 64),
            textures: upload("scene.textures", bytemuck::cast_slice(&infos), 16),
            texels: upload("scene.texels", bytemuck::cast_slice(&texels), 16),
            emitters: upload("scene.emitters", bytemuck::cast_slice(&table.entries), 8),
            selection: upload("scene.selection", bytemuck::cast_slice(&table.selection), 4),
            lights: upload("scene.lights", bytemuck::cast_slice(&lights), 64),
            emitter_count: table.entries.len() as u32,
            light_count: lights.len() as u32,
            default_material,
            bvh_build_seconds: bvh.build_seconds,
            bvh,
        })
    }

    /// Moves the scene to `frame`, a later evaluation of the same scene: the BVH's top level
    /// and instance transforms ([`GpuBvh::update`], bottom levels untouched), the lights and
    /// the emitter table. The per-triangle shading buffer holds world-space vertices and
    /// normals, so it is re-uploaded whole (112 bytes per triangle) when the scene is animated;
    /// a camera move alone needs no update at all.
    ///
    /// Returns true when a buffer had to be replaced (an emitter table that grew), so bind
    /// groups made over [`GpuScene::buffers`] must be made again.
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
    ) -> Result<bool, BvhError> {
        self.bvh.update(ctx, frame)?;
        let triangles = triangle_shading(frame);
        let triangle_bytes: &[u8] = bytemuck::cast_slice(&triangles);
        let mut replaced = false;
        let mut write = |buffer: &mut wgpu::Buffer, label: &str, bytes: &[u8]| {
            if bytes.is_empty() {
                return;
            }
            if bytes.len() as u64 > buffer.size() {
                ctx.release_buffer(buffer);
                *buffer = ctx.create_buffer_init(
                    label,
                    bytes,
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                );
                replaced = true;
            } else {
                ctx.queue.write_buffer(buffer, 0, bytes);
            }
        };
        write(&mut self.triangles, "scene.triangles", triangle_bytes);
        let table = EmitterTable::build(scene, frame);
        let lights: Vec<GpuLight> = frame.lights.iter().map(gpu_light).collect();
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
        write(
            &mut self.lights,
            "scene.lights",
            bytemuck::cast_slice(&lights),
        );
        self.emitter_count = table.entries.len() as u32;
        self.light_count = lights.len() as u32;
        Ok(replaced)
    }

    /// Bytes of every buffer, BVH included.
    pub fn bytes(&self) -> u64 {
        self.buffers().iter().map(|b| b.size()).sum::<u64>() + self.bvh.bytes()
    }

    /// The binding of `scene.triangles`, the first of `gi::scene`'s seven in group 0.
    pub const FIRST_BINDING: u32 = 1;

    /// The layout entries of `gi::scene`: read-only storage buffers at bindings 1..=7 of a
    /// pass's group 0, visible to compute stages. All seven are listed, also for passes that
    /// read fewer, so the bind group of [`GpuScene::bind_group_entries`] always fits.
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

    /// The scene buffers in the binding order of `gi::scene` (bindings 1..=7 of group 0).
    pub fn buffers(&self) -> [&wgpu::Buffer; 7] {
        [
            &self.triangles,
            &self.materials,
            &self.textures,
            &self.texels,
            &self.emitters,
            &self.selection,
            &self.lights,
        ]
    }

    /// Stops counting and destroys every buffer (for a scene replaced by a new frame's).
    pub fn release(self, ctx: &GpuContext) {
        for buffer in self.buffers() {
            ctx.release_buffer(buffer);
        }
        self.bvh.release(ctx);
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
