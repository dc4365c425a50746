//! Skinning on the GPU (`shaders/skin/skin.wgsl`): the triangles of skinned meshes whose
//! joints move are placed by their joints on the GPU each frame and written straight into
//! `scene.triangles` and `scene.triangle_extras`, so [`crate::GpuScene::update`] uploads only
//! the joints' matrices for them (64 bytes per joint) instead of 112 to 192 bytes per triangle.
//!
//! The rest vertices (morphed at the node's weights, which must be constant) go up once, 80
//! bytes each, with their weights cleaned as the CPU evaluation cleans them; each triangle's
//! vertex indices, texture coordinates, material and node go up once too, 80 bytes each. A
//! frame then runs two dispatches: one invocation per vertex blends its matrix and places
//! position, normal and tangent (48 bytes of scratch per vertex), one per triangle assembles
//! the shading record. The arithmetic is the CPU's (`gi_scene`'s `skin` module), so the
//! buffers hold what an upload of [`gi_scene::Scene::evaluate`]'s triangles would, up to
//! rounding; a test compares them.
//!
//! Nodes whose morph target weights are animated stay on the CPU: their rest vertices change
//! every frame. The BVH keeps taking the CPU's skinned positions (its refit decisions and the
//! radiance cache's binning read them on the CPU).

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use gi_scene::{Scene, SceneFrame};
use glam::{Mat4, Vec2};

use crate::binding::{storage_entry, uniform_entry};
use crate::scene::SceneUploadError;
use crate::{GpuContext, GpuTimer, ShaderLibrary};

/// Invocations per workgroup (`WORKGROUP_SIZE` in the shader).
const WORKGROUP_SIZE: u32 = 64;

/// `SkinVertex` in the shader: a rest vertex, 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct SkinVertex {
    /// w: the bits of the index of the matrix used when no weight is usable.
    position: [f32; 4],
    /// w: 1 when the vertex has a tangent.
    normal: [f32; 4],
    tangent: [f32; 4],
    weights: [f32; 4],
    /// Indices into the frame's matrices.
    joints: [u32; 4],
}

/// `SkinTriangle` in the shader, 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct SkinTriangle {
    /// Indices into the vertices, then the frame triangle index.
    vertices: [u32; 4],
    uv_ab: [f32; 4],
    uv_c_uv1_a: [f32; 4],
    uv1_bc: [f32; 4],
    /// Material, node, unused, unused.
    material_node: [u32; 4],
}

/// `Counts` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct Counts {
    vertices: u32,
    triangles: u32,
    has_extras: u32,
    row: u32,
}

/// Bytes of the per-vertex scratch (`SkinnedVertex` in the shader).
const SKINNED_VERTEX_BYTES: u64 = 48;

/// A node skinned on the GPU and where its matrices go.
struct SkinnedNode {
    node: usize,
    skin: usize,
    /// Its joints' matrices start here; its own world transform (the fallback) follows them.
    matrix_base: usize,
}

/// `skinned[node]`: node `node` is skinned on the GPU (pass `skin`): its mesh is skinned,
/// one of its joints or itself moves ([`Scene::deforming_nodes`]), and its morph target
/// weights are not animated.
pub fn gpu_skinned_nodes(scene: &Scene) -> Vec<bool> {
    let deforming = scene.deforming_nodes();
    let morph_animated = scene.morph_animated_nodes();
    (0..scene.nodes.len())
        .map(|node| deforming[node] && !morph_animated[node] && scene.node_skin(node).is_some())
        .collect()
}

/// The skinning pass of one scene: its pipelines and buffers.
pub(crate) struct GpuSkinning {
    vertices_pipeline: wgpu::ComputePipeline,
    triangles_pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    counts: wgpu::Buffer,
    vertices: wgpu::Buffer,
    matrices: wgpu::Buffer,
    skinned: wgpu::Buffer,
    triangles: wgpu::Buffer,
    nodes: Vec<SkinnedNode>,
    matrix_count: usize,
    vertex_count: u32,
    triangle_count: u32,
    /// Dispatch grids (x, y) of the two entry points.
    vertex_grid: (u32, u32),
    triangle_grid: (u32, u32),
    /// The frame triangles it writes, sorted and disjoint.
    ranges: Vec<Range<usize>>,
}

impl GpuSkinning {
    /// The skinning of `scene`'s nodes flagged in `skinned_nodes` ([`gpu_skinned_nodes`]) at
    /// `frame` (an evaluation of it, which gives the nodes' triangle ranges and morph weights),
    /// writing into `buffers`, the scene's triangles and extras (`has_extras`: the latter holds
    /// every triangle). `None` when no node is skinned on the GPU. Every buffer and dispatch size is
    /// checked against the device's limits first.
    pub(crate) fn new(
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
        skinned_nodes: &[bool],
        buffers: (&wgpu::Buffer, &wgpu::Buffer),
        has_extras: bool,
    ) -> Result<Option<Self>, SceneUploadError> {
        let (scene_triangles, scene_extras) = buffers;
        if !skinned_nodes.contains(&true) {
            return Ok(None);
        }
        let firsts = first_triangles(frame, scene.nodes.len());
        let mut nodes = Vec::new();
        let mut vertices: Vec<SkinVertex> = Vec::new();
        let mut triangles: Vec<SkinTriangle> = Vec::new();
        let mut ranges: Vec<Range<usize>> = Vec::new();
        let mut matrix_count = 0;
        for (node, _) in skinned_nodes.iter().enumerate().filter(|(_, s)| **s) {
            let (Some(skin_index), Some(mesh), Some(first)) = (
                scene.nodes[node].skin,
                scene.nodes[node].mesh.and_then(|m| scene.meshes.get(m)),
                firsts[node],
            ) else {
                continue;
            };
            let skin = &scene.skins[skin_index];
            let matrix_base = matrix_count;
            let fallback = (matrix_base + skin.joints.len()) as u32;
            matrix_count += skin.joints.len() + 1;
            let weights = frame.morph_weights.get(node).map_or(&[][..], Vec::as_slice);
            let mut triangle = first;
            for primitive in &mesh.primitives {
                let base = vertices.len() as u32;
                let morphed = primitive.morphed(weights);
                let skinned = primitive.is_skinned();
                for (i, position) in morphed.positions.iter().enumerate() {
                    let (joints, weights) = if skinned {
                        usable_weights(scene, skin, primitive.joints[i], primitive.weights[i])
                    } else {
                        ([0; 4], [0.0; 4])
                    };
                    let normal = morphed.normals.get(i).copied().unwrap_or_default();
                    let tangent = morphed.tangents.get(i).copied();
                    vertices.push(SkinVertex {
                        position: [position.x, position.y, position.z, f32::from_bits(fallback)],
                        normal: [normal.x, normal.y, normal.z, f32::from(tangent.is_some())],
                        tangent: tangent.unwrap_or_default().to_array(),
                        weights,
                        joints: joints.map(|j| (matrix_base + j as usize) as u32),
                    });
                }
                let uv = |i: u32| primitive.uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO);
                let uv1 = |i: u32| {
                    primitive
                        .uvs1
                        .get(i as usize)
                        .copied()
                        .unwrap_or(Vec2::ZERO)
                };
                let start = triangle;
                for corners in primitive.indices.chunks_exact(3) {
                    let [a, b, c] = [corners[0], corners[1], corners[2]];
                    triangles.push(SkinTriangle {
                        vertices: [base + a, base + b, base + c, triangle as u32],
                        uv_ab: [uv(a).x, uv(a).y, uv(b).x, uv(b).y],
                        uv_c_uv1_a: [uv(c).x, uv(c).y, uv1(a).x, uv1(a).y],
                        uv1_bc: [uv1(b).x, uv1(b).y, uv1(c).x, uv1(c).y],
                        material_node: [primitive.material as u32, node as u32, 0, 0],
                    });
                    triangle += 1;
                }
                match ranges.last_mut() {
                    Some(last) if last.end == start => last.end = triangle,
                    _ if triangle > start => ranges.push(start..triangle),
                    _ => {}
                }
            }
            nodes.push(SkinnedNode {
                node,
                skin: skin_index,
                matrix_base,
            });
        }
        if triangles.is_empty() {
            return Ok(None);
        }
        // A triangle index past the frame's (a frame of another scene) would write out of
        // the shading buffers' range: such a scene is not skinned here.
        if ranges.last().is_some_and(|r| r.end > frame.triangles.len()) {
            return Ok(None);
        }
        let limits = &ctx.limits;
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let vertex_count = vertices.len() as u64;
        for (label, bytes) in [
            (
                "skin.vertices",
                vertex_count * size_of::<SkinVertex>() as u64,
            ),
            ("skin.skinned", vertex_count * SKINNED_VERTEX_BYTES),
            (
                "skin.triangles",
                triangles.len() as u64 * size_of::<SkinTriangle>() as u64,
            ),
            ("skin.matrices", matrix_count as u64 * 64),
        ] {
            if bytes > limit {
                return Err(SceneUploadError::TooLarge {
                    label,
                    bytes,
                    limit,
                });
            }
        }
        let most_groups = limits.max_compute_workgroups_per_dimension;
        let vertex_grid = grid(vertices.len() as u32, most_groups);
        let triangle_grid = grid(triangles.len() as u32, most_groups);
        let row = vertex_grid.0.max(triangle_grid.0);
        let (vertex_grid, triangle_grid) = (
            (
                row,
                vertices.len().div_ceil((row * WORKGROUP_SIZE) as usize) as u32,
            ),
            (
                row,
                triangles.len().div_ceil((row * WORKGROUP_SIZE) as usize) as u32,
            ),
        );
        if vertex_grid.1.max(triangle_grid.1) > most_groups {
            return Err(SceneUploadError::TooLarge {
                label: "skin dispatch (workgroups)",
                bytes: u64::from(vertex_grid.1.max(triangle_grid.1)) * u64::from(row),
                limit: u64::from(most_groups) * u64::from(most_groups),
            });
        }

        let module = ShaderLibrary::new()
            .create_module(ctx, "skin/skin.wgsl", &[])
            .map_err(|err| SceneUploadError::Shader {
                message: err.to_string(),
            })?;
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("skin.layout"),
                entries: &[
                    uniform_entry(0),
                    storage_entry(1, true),
                    storage_entry(2, true),
                    storage_entry(3, false),
                    storage_entry(4, true),
                    storage_entry(5, false),
                    storage_entry(6, false),
                ],
            });
        let pipeline = |entry: &str| {
            ctx.create_compute_pipeline_with_layouts(
                &format!("skin/{entry}"),
                &module,
                entry,
                &[Some(&layout)],
            )
        };
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let counts = Counts {
            vertices: vertices.len() as u32,
            triangles: triangles.len() as u32,
            has_extras: u32::from(has_extras),
            row: row * WORKGROUP_SIZE,
        };
        let counts = ctx.create_buffer_init(
            "skin.counts",
            bytemuck::bytes_of(&counts),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let vertices_buffer =
            ctx.create_buffer_init("skin.vertices", bytemuck::cast_slice(&vertices), storage);
        let triangles_buffer =
            ctx.create_buffer_init("skin.triangles", bytemuck::cast_slice(&triangles), storage);
        let matrices = ctx.create_buffer("skin.matrices", matrix_count as u64 * 64, storage);
        let skinned = ctx.create_buffer(
            "skin.skinned",
            vertex_count * SKINNED_VERTEX_BYTES,
            wgpu::BufferUsages::STORAGE,
        );
        let bind_group = bind_group(
            ctx,
            &layout,
            [
                &counts,
                &vertices_buffer,
                &matrices,
                &skinned,
                &triangles_buffer,
                scene_triangles,
                scene_extras,
            ],
        );
        Ok(Some(Self {
            vertices_pipeline: pipeline("skin_vertices"),
            triangles_pipeline: pipeline("skin_triangles"),
            bind_group,
            counts,
            vertices: vertices_buffer,
            matrices,
            skinned,
            triangles: triangles_buffer,
            nodes,
            matrix_count,
            vertex_count: vertices.len() as u32,
            triangle_count: triangles.len() as u32,
            vertex_grid,
            triangle_grid,
            ranges,
        }))
    }

    /// The frame triangles the pass writes, sorted and disjoint.
    pub(crate) fn ranges(&self) -> &[Range<usize>] {
        &self.ranges
    }

    /// Uploads the joints' matrices at `frame` (an evaluation of `scene`) and submits the two
    /// dispatches that write the skinned triangles, as pass `skin` of `timer`'s frame when
    /// given.
    pub(crate) fn run(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
        timer: Option<&mut GpuTimer>,
    ) {
        let mut matrices = vec![Mat4::IDENTITY; self.matrix_count];
        for node in &self.nodes {
            let skin = &scene.skins[node.skin];
            let joints = skin.joint_matrices(&frame.world_from_node);
            for (k, matrix) in joints.into_iter().enumerate() {
                matrices[node.matrix_base + k] = matrix.unwrap_or(Mat4::IDENTITY);
            }
            matrices[node.matrix_base + skin.joints.len()] = frame
                .world_from_node
                .get(node.node)
                .copied()
                .unwrap_or(Mat4::IDENTITY);
        }
        ctx.queue
            .write_buffer(&self.matrices, 0, bytemuck::cast_slice(&matrices));
        let mut encoder = ctx.create_encoder("skin");
        let record = |pass: &mut wgpu::ComputePass<'_>| {
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_pipeline(&self.vertices_pipeline);
            pass.dispatch_workgroups(self.vertex_grid.0, self.vertex_grid.1, 1);
            pass.set_pipeline(&self.triangles_pipeline);
            pass.dispatch_workgroups(self.triangle_grid.0, self.triangle_grid.1, 1);
        };
        match timer {
            Some(timer) => {
                timer.compute_pass(ctx, &mut encoder, "skin", record);
                timer.submit(ctx, encoder);
            }
            None => {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("skin"),
                    timestamp_writes: None,
                });
                record(&mut pass);
                drop(pass);
                ctx.queue.submit([encoder.finish()]);
            }
        }
    }

    /// Vertices and triangles skinned per frame.
    pub(crate) fn counts(&self) -> (u32, u32) {
        (self.vertex_count, self.triangle_count)
    }

    /// The pass's own buffers.
    fn buffers(&self) -> [&wgpu::Buffer; 5] {
        [
            &self.counts,
            &self.vertices,
            &self.matrices,
            &self.skinned,
            &self.triangles,
        ]
    }

    /// Bytes of the pass's buffers.
    pub(crate) fn bytes(&self) -> u64 {
        self.buffers().iter().map(|b| b.size()).sum()
    }

    /// Stops counting and destroys the pass's buffers.
    pub(crate) fn release(&self, ctx: &GpuContext) {
        for buffer in self.buffers() {
            ctx.release_buffer(buffer);
        }
    }
}

/// The pass's bind group over `buffers` at bindings 0..=6.
fn bind_group(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    buffers: [&wgpu::Buffer; 7],
) -> wgpu::BindGroup {
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("skin.bind_group"),
        layout,
        entries: &crate::binding::buffer_entries(0, buffers),
    })
}

/// The first frame triangle of each node (`None` for nodes without triangles): a node's
/// triangles are consecutive in the frame, its primitives in order.
fn first_triangles(frame: &SceneFrame, nodes: usize) -> Vec<Option<usize>> {
    let mut first = vec![None; nodes];
    for (index, attributes) in frame.attributes.iter().enumerate() {
        if let Some(slot @ None) = first.get_mut(attributes.node as usize) {
            *slot = Some(index);
        }
    }
    first
}

/// A vertex's joints and weights with the weights the CPU evaluation ignores set to zero:
/// negative or non-finite ones, and those of a joint outside the skin or not a node.
fn usable_weights(
    scene: &Scene,
    skin: &gi_scene::Skin,
    joints: [u16; 4],
    weights: glam::Vec4,
) -> ([u16; 4], [f32; 4]) {
    let mut usable = weights.to_array();
    let mut joints_out = joints;
    for k in 0..4 {
        let joint_is_node =
            (skin.joints.get(joints[k] as usize)).is_some_and(|&j| j < scene.nodes.len());
        if !(usable[k].is_finite() && usable[k] > 0.0 && joint_is_node) {
            usable[k] = 0.0;
            joints_out[k] = 0;
        }
    }
    (joints_out, usable)
}

/// A dispatch grid for `count` invocations: as few rows as the largest row allows.
fn grid(count: u32, most_groups: u32) -> (u32, u32) {
    let groups = count.div_ceil(WORKGROUP_SIZE).max(1);
    let x = groups.min(most_groups.max(1));
    (x, groups.div_ceil(x))
}
