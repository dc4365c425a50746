//! A scene evaluated at one time: world-space triangles, lights and camera.
//!
//! Renderers never walk the hierarchy themselves; they ask [`Scene::evaluate`] for a
//! [`SceneFrame`] and trace against its flat triangle list.

use glam::{Mat4, Quat, Vec2, Vec3, Vec3A, Vec4};
use obvhs::triangle::Triangle;

use rayon::prelude::*;

use crate::model::{
    Animation, CameraPath, Channel, ChannelValues, Interpolation, LightKind, Primitive, Scene, Sky,
};
use crate::morph::morph;
use crate::skin::{skin_positions, skin_primitive};

/// Shading attributes of one world-space triangle (index-aligned with
/// [`SceneFrame::triangles`]).
#[derive(Clone, Copy, Debug)]
pub struct TriangleAttributes {
    /// World-space vertex normals (unit length).
    pub normals: [Vec3; 3],
    /// `TEXCOORD_0` of the vertices (zero where the primitive has none).
    pub uvs: [Vec2; 3],
    /// `TEXCOORD_1` of the vertices (zero where the primitive has none).
    pub uvs1: [Vec2; 3],
    /// World-space unit tangents with the bitangent sign in w (zero where the primitive has
    /// none).
    pub tangents: [Vec4; 3],
    pub material: u32,
    /// Node that instanced this triangle's mesh.
    pub node: u32,
}

/// A punctual light in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldLight {
    pub kind: LightKind,
    pub position: Vec3,
    /// Unit direction the light shines along (the node's -Z axis).
    pub direction: Vec3,
    /// `color * intensity`: W/sr for point and spot, W/m^2 for directional.
    pub intensity: Vec3,
    pub range: Option<f32>,
}

impl WorldLight {
    /// Radiance-like contribution arriving at `point`, without visibility or cosine: returns
    /// the unit direction from `point` towards the light, the distance (infinite for
    /// directional lights) and the irradiance on a surface facing the light.
    /// Falloff and spot cone follow the glTF KHR_lights_punctual recommendations.
    pub fn incident(&self, point: Vec3) -> (Vec3, f32, Vec3) {
        match self.kind {
            LightKind::Directional => (-self.direction, f32::INFINITY, self.intensity),
            LightKind::Point | LightKind::Spot { .. } => {
                let to_light = self.position - point;
                let distance_sq = to_light.length_squared().max(1e-8);
                let distance = distance_sq.sqrt();
                let wi = to_light / distance;
                let mut falloff = 1.0 / distance_sq;
                if let Some(range) = self.range {
                    let ratio = distance / range;
                    falloff *= (1.0 - ratio.powi(4)).clamp(0.0, 1.0).powi(2);
                }
                if let LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } = self.kind
                {
                    let cos_outer = outer_cone_angle.cos();
                    let scale = 1.0 / (inner_cone_angle.cos() - cos_outer).max(1e-3);
                    let cd = self.direction.dot(-wi);
                    falloff *= ((cd - cos_outer) * scale).clamp(0.0, 1.0).powi(2);
                }
                (wi, distance, self.intensity * falloff)
            }
        }
    }
}

/// A pinhole camera in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraView {
    pub position: Vec3,
    /// Unit view axes in world space: right (+X), up (+Y), forward (-Z of the camera).
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
}

impl CameraView {
    /// A camera at `position` looking at `target` with world +Y as up (falls back to +Z when
    /// looking straight up or down).
    pub fn look_at(position: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - position).normalize_or(Vec3::NEG_Z);
        let up_hint = if forward.cross(Vec3::Y).length_squared() < 1e-8 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        Self {
            position,
            right,
            up,
            forward,
            yfov,
        }
    }

    /// From a node's world transform (camera looks down its -Z axis).
    pub fn from_world_transform(world_from_camera: &Mat4, yfov: f32) -> Self {
        let (_, rotation, position) = world_from_camera.to_scale_rotation_translation();
        Self {
            position,
            right: (rotation * Vec3::X).normalize(),
            up: (rotation * Vec3::Y).normalize(),
            forward: (rotation * Vec3::NEG_Z).normalize(),
            yfov,
        }
    }

    /// The camera of an engine's view and projection matrices, right-handed (the view looks
    /// down -Z of its view space, as `glam::camera::rh` makes them), with the projection of
    /// any graphics API's convention (clip y up or down, depth in [0, 1] or [-1, 1]): the
    /// position and axes from the inverse of `view`, the vertical field of view from the
    /// magnitude of `projection`'s y scale (`1 / tan(yfov / 2)`). `None` when `view` is not
    /// invertible or `projection` is not a perspective one (an orthographic projection has no
    /// field of view). The aspect ratio is the image's, as for every camera here.
    pub fn from_view_projection(view: &Mat4, projection: &Mat4) -> Option<Self> {
        let determinant = view.determinant();
        if !determinant.is_finite() || determinant.abs() < 1e-12 {
            return None;
        }
        let y_scale = projection.y_axis.y.abs();
        let perspective = projection.z_axis.w.abs() > 0.5 && projection.w_axis.w.abs() < 1e-6;
        if !perspective || !y_scale.is_finite() || y_scale <= 0.0 {
            return None;
        }
        let yfov = 2.0 * (1.0 / y_scale).atan();
        let world = view.inverse();
        let view = Self::from_world_transform(&world, yfov);
        let finite = view.position.is_finite() && view.forward.is_finite() && view.up.is_finite();
        finite.then_some(view)
    }

    /// Unit world direction through the film point `(u, v)` in \[0,1\]^2, u to the right and
    /// v downwards (pixel (x, y) center is `((x + 0.5) / w, (y + 0.5) / h)`).
    pub fn ray_direction(&self, u: f32, v: f32, aspect: f32) -> Vec3 {
        let tan_half = (self.yfov * 0.5).tan();
        let x = (2.0 * u - 1.0) * tan_half * aspect;
        let y = (1.0 - 2.0 * v) * tan_half;
        (self.forward + x * self.right + y * self.up).normalize()
    }
}

/// The scene at one instant, flattened to world space.
#[derive(Clone, Debug)]
pub struct SceneFrame {
    pub time_s: f32,
    /// World-space triangles (the BVH primitives).
    pub triangles: Vec<Triangle>,
    pub attributes: Vec<TriangleAttributes>,
    pub lights: Vec<WorldLight>,
    pub camera: CameraView,
    pub sky: Sky,
    pub exposure: f32,
    /// World transform of every node at this time.
    pub world_from_node: Vec<Mat4>,
    /// Morph target weights of every node at this time ([`Scene::morph_weights`]; empty for
    /// nodes whose mesh has no targets).
    pub morph_weights: Vec<Vec<f32>>,
    /// Names the geometry (`triangles`, `attributes`, `world_from_node`, `morph_weights`) of
    /// one evaluation: every [`Scene::evaluate`] draws a new one and clones keep it; 0 means
    /// unknown. State derived from the triangles (the brick cache's triangle index) is kept
    /// without looking at them while the revision stays the same, so code that edits a frame's
    /// geometry in place calls [`SceneFrame::geometry_changed`].
    pub geometry_revision: u64,
    /// Per node, whether [`Scene::evaluate_with`] left its triangles' normals and tangents out
    /// (zero in `attributes`; positions, texture coordinates, material and node are there).
    /// Empty when the frame is complete, as [`Scene::evaluate`] makes it.
    pub positions_only: Vec<bool>,
    /// Which edit of the scene's materials the frame shows: 0 as loaded, raised by every
    /// material edit a renderer makes between frames (`Renderer::set_material` in gi-tiers), so
    /// that what a tier prepared from the materials (the GPU's material table and emitter
    /// table, the brick cache's voxels) is made again. [`Scene::evaluate`] leaves it 0.
    pub material_revision: u64,
}

/// What [`Scene::evaluate_with`] evaluates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evaluation {
    /// Per node (missing entries false): evaluate only where its triangles are, leaving their
    /// normals and tangents zero, for a renderer that places their shading itself (the GPU
    /// tiers skin moving skinned meshes on the GPU: `gi_gpu::gpu_skinned_nodes`). A skinned
    /// node's vertices are still blended, so its positions and winding are exact; the normal
    /// and tangent transforms and their normalization, about half the work, are skipped.
    pub positions_only: Vec<bool>,
}

/// Source of [`SceneFrame::geometry_revision`]s, unique within the process.
static NEXT_GEOMETRY_REVISION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl SceneFrame {
    /// Everything of the frame but its geometry (no triangles, no attributes, revision 0):
    /// what a renderer keeps of the last frame for the next one (its camera, lights and node
    /// transforms), without copying megabytes of triangles per frame.
    pub fn without_geometry(&self) -> SceneFrame {
        SceneFrame {
            time_s: self.time_s,
            triangles: Vec::new(),
            attributes: Vec::new(),
            lights: self.lights.clone(),
            camera: self.camera,
            sky: self.sky,
            exposure: self.exposure,
            world_from_node: self.world_from_node.clone(),
            morph_weights: self.morph_weights.clone(),
            geometry_revision: 0,
            positions_only: Vec::new(),
            material_revision: self.material_revision,
        }
    }

    /// Whether the scene's content differs from `previous` (a frame of the same scene, whole or
    /// [`SceneFrame::without_geometry`]): a node moved (by its animation or by the caller), a
    /// morph weight, a light, the sky or a material changed. The camera and the time are not
    /// compared: a renderer that accumulates restarts on those itself.
    pub fn content_changed_from(&self, previous: &SceneFrame) -> bool {
        self.material_revision != previous.material_revision
            || self.world_from_node != previous.world_from_node
            || self.morph_weights != previous.morph_weights
            || self.lights != previous.lights
            || self.sky != previous.sky
            || self.exposure != previous.exposure
    }

    /// Gives the frame a new [`SceneFrame::geometry_revision`], after its geometry was edited
    /// in place.
    pub fn geometry_changed(&mut self) {
        self.geometry_revision = next_geometry_revision();
    }
}

fn next_geometry_revision() -> u64 {
    NEXT_GEOMETRY_REVISION.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Scene {
    /// Time of frame `index` when a render advances time.
    pub fn frame_time(&self, index: u32) -> f32 {
        index as f32 * self.frame_time_s
    }

    /// Calls `apply(channel, t)` for every animation channel, `t` being `time_s` in its
    /// animation's time (each animation loops over its own duration).
    fn for_each_channel_at(&self, time_s: f32, mut apply: impl FnMut(&Channel, f32)) {
        for animation in &self.animations {
            let duration = animation_duration(animation);
            let t = if duration > 0.0 {
                time_s.rem_euclid(duration)
            } else {
                0.0
            };
            for channel in &animation.channels {
                apply(channel, t);
            }
        }
    }

    /// Local transforms of every node at `time_s`, with animations applied (each animation
    /// loops over its own duration).
    pub fn local_transforms(&self, time_s: f32) -> Vec<(Vec3, Quat, Vec3)> {
        let mut trs: Vec<_> = self
            .nodes
            .iter()
            .map(|n| (n.translation, n.rotation, n.scale))
            .collect();
        self.for_each_channel_at(time_s, |channel, t| {
            if let Some(slot) = trs.get_mut(channel.node) {
                apply_channel(channel, t, slot);
            }
        });
        trs
    }

    /// Morph target weights of every node at `time_s`: one per target of the node's mesh, from
    /// its weights channel where one animates it, else [`Scene::rest_morph_weights`]. Empty
    /// for nodes whose mesh has no targets.
    pub fn morph_weights(&self, time_s: f32) -> Vec<Vec<f32>> {
        let mut weights: Vec<Vec<f32>> = (0..self.nodes.len())
            .map(|node| self.rest_morph_weights(node))
            .collect();
        self.for_each_channel_at(time_s, |channel, t| {
            if let Some(slot) = weights.get_mut(channel.node) {
                apply_weights_channel(channel, t, slot);
            }
        });
        weights
    }

    /// World transform of every node at `time_s`.
    pub fn world_transforms(&self, time_s: f32) -> Vec<Mat4> {
        let local = self.local_transforms(time_s);
        let mut world: Vec<Option<Mat4>> = vec![None; self.nodes.len()];
        for index in 0..self.nodes.len() {
            resolve_world(self, &local, &mut world, index, 0);
        }
        world
            .into_iter()
            .map(|m| m.unwrap_or(Mat4::IDENTITY))
            .collect()
    }

    /// True when anything in the scene moves over time (node transforms, and with them skinned
    /// meshes whose joints they animate, and morph target weights), or the caller may move a
    /// node between frames ([`Node::movable`](crate::Node::movable)).
    pub fn is_animated(&self) -> bool {
        self.nodes.iter().any(|node| node.movable)
            || self
                .animations
                .iter()
                .flat_map(|a| &a.channels)
                .any(|c| !c.is_constant())
    }

    /// The default camera at `time_s`: the default camera node if any, else a view of the
    /// whole scene's bounds from the +Z side.
    pub fn default_view(&self, time_s: f32) -> CameraView {
        let world = self.world_transforms(time_s);
        self.default_view_with(&world)
    }

    fn default_view_with(&self, world: &[Mat4]) -> CameraView {
        if let Some(node) = self.default_camera_node
            && let Some(camera) = self.nodes.get(node).and_then(|n| n.camera)
            && let Some(camera) = self.cameras.get(camera)
        {
            return CameraView::from_world_transform(&world[node], camera.yfov);
        }
        self.fallback_view(world)
    }

    /// A view framing the scene's bounding box, used when the scene has no camera.
    pub fn fallback_view(&self, world: &[Mat4]) -> CameraView {
        let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for (index, (node, world_from_node)) in self.nodes.iter().zip(world).enumerate() {
            let Some(mesh) = node.mesh.and_then(|m| self.meshes.get(m)) else {
                continue;
            };
            let joint_matrices = self.node_skin(index).map(|skin| skin.joint_matrices(world));
            let weights = self.rest_morph_weights(index);
            for primitive in &mesh.primitives {
                let morphed = morph(primitive, &weights);
                let points = match &joint_matrices {
                    Some(joints) if primitive.is_skinned() => {
                        skin_positions(primitive, &morphed.positions, joints, *world_from_node)
                    }
                    _ => (morphed.positions.iter())
                        .map(|p| world_from_node.transform_point3(*p))
                        .collect(),
                };
                for wp in points {
                    min = min.min(wp);
                    max = max.max(wp);
                }
            }
        }
        if min.x > max.x {
            return CameraView::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 0.8);
        }
        let center = (min + max) * 0.5;
        let radius = ((max - min).length() * 0.5).max(1e-3);
        let yfov = 0.8f32;
        let distance = radius / (yfov * 0.5).sin();
        CameraView::look_at(center + Vec3::new(0.0, 0.0, distance), center, yfov)
    }

    /// The camera of the scene's camera path at `time_s`, or the default view if it has none.
    pub fn path_view(&self, time_s: f32) -> CameraView {
        match &self.camera_path {
            Some(path) if !path.keys.is_empty() => path.view(time_s),
            _ => self.default_view(time_s),
        }
    }

    /// Flatten the scene at `time_s` into world space, viewed through `camera`
    /// (`None`: the default camera). Meshes with morph targets are morphed by their weights at
    /// `time_s` (see the `morph` module), then skinned meshes are deformed by their joints
    /// (linear blend skinning; see the `skin` module for normals, tangents and fallbacks), all
    /// on the CPU.
    pub fn evaluate(&self, time_s: f32, camera: Option<CameraView>) -> SceneFrame {
        self.evaluate_with(time_s, camera, &Evaluation::default())
    }

    /// [`Scene::evaluate`], with the parts `evaluation` leaves out left out (see
    /// [`Evaluation`]; [`SceneFrame::positions_only`] records them).
    pub fn evaluate_with(
        &self,
        time_s: f32,
        camera: Option<CameraView>,
        evaluation: &Evaluation,
    ) -> SceneFrame {
        let world_from_node = self.world_transforms(time_s);
        let morph_weights = self.morph_weights(time_s);
        let positions_only = self.positions_only(evaluation);
        let (triangles, attributes) =
            self.flatten(&world_from_node, &morph_weights, &positions_only);
        let lights = self.world_lights(&world_from_node);
        let camera = camera.unwrap_or_else(|| self.default_view_with(&world_from_node));
        SceneFrame {
            time_s,
            triangles,
            attributes,
            lights,
            camera,
            sky: self.sky,
            exposure: self.exposure,
            world_from_node,
            morph_weights,
            geometry_revision: next_geometry_revision(),
            positions_only,
            material_revision: 0,
        }
    }
}

impl Scene {
    /// [`Evaluation::positions_only`] with one entry per node, or empty when it leaves
    /// nothing out (the form [`SceneFrame::positions_only`] records).
    fn positions_only(&self, evaluation: &Evaluation) -> Vec<bool> {
        if evaluation.positions_only.contains(&true) {
            (0..self.nodes.len())
                .map(|node| evaluation.positions_only.get(node) == Some(&true))
                .collect()
        } else {
            Vec::new()
        }
    }

    /// The punctual lights of the nodes placed by `world_from_node`.
    /// The scene's lights placed by `world_from_node` (a frame's node transforms).
    pub fn world_lights(&self, world_from_node: &[Mat4]) -> Vec<WorldLight> {
        self.nodes
            .iter()
            .enumerate()
            .filter_map(|(i, node)| {
                let light = self.lights.get(node.light?)?;
                let world = world_from_node[i];
                Some(WorldLight {
                    kind: light.kind,
                    position: world.transform_point3(Vec3::ZERO),
                    direction: world
                        .transform_vector3(Vec3::NEG_Z)
                        .normalize_or(Vec3::NEG_Y),
                    intensity: light.color * light.intensity,
                    range: light.range,
                })
            })
            .collect()
    }
}

impl CameraPath {
    /// The interpolated view at `time_s` (held at the first and last key).
    pub fn view(&self, time_s: f32) -> CameraView {
        let keys = &self.keys;
        let index = keys.partition_point(|k| k.time_s <= time_s);
        let (position, target) = if index == 0 {
            (keys[0].position, keys[0].target)
        } else if index >= keys.len() {
            let last = keys[keys.len() - 1];
            (last.position, last.target)
        } else {
            let (a, b) = (keys[index - 1], keys[index]);
            let f = ((time_s - a.time_s) / (b.time_s - a.time_s).max(1e-6)).clamp(0.0, 1.0);
            (a.position.lerp(b.position, f), a.target.lerp(b.target, f))
        };
        CameraView::look_at(position, target, self.yfov)
    }
}

fn animation_duration(animation: &Animation) -> f32 {
    animation
        .channels
        .iter()
        .filter_map(|c| c.times.last().copied())
        .fold(0.0, f32::max)
}

/// The keys `i` and `j` around time `t` of `channel` and the blend factor `f` between them
/// (`i == j` and `f == 0` before the first key and after the last), or `None` without keys.
fn key_interval(channel: &Channel, t: f32) -> Option<(usize, usize, f32)> {
    let times = &channel.times;
    if times.is_empty() {
        return None;
    }
    let next = times.partition_point(|&k| k <= t);
    Some(if next == 0 {
        (0, 0, 0.0)
    } else if next >= times.len() {
        (times.len() - 1, times.len() - 1, 0.0)
    } else {
        let (a, b) = (times[next - 1], times[next]);
        let f = match channel.interpolation {
            Interpolation::Step => 0.0,
            Interpolation::Linear => ((t - a) / (b - a).max(1e-9)).clamp(0.0, 1.0),
        };
        (next - 1, next, f)
    })
}

/// Sets the transform part that `channel` animates to its value at `t` (weights channels
/// leave the transform alone; see [`apply_weights_channel`]).
fn apply_channel(channel: &Channel, t: f32, slot: &mut (Vec3, Quat, Vec3)) {
    let Some((i, j, f)) = key_interval(channel, t) else {
        return;
    };
    match &channel.values {
        ChannelValues::Translation(v) if j < v.len() => slot.0 = v[i].lerp(v[j], f),
        ChannelValues::Rotation(v) if j < v.len() => slot.1 = v[i].slerp(v[j], f).normalize(),
        ChannelValues::Scale(v) if j < v.len() => slot.2 = v[i].lerp(v[j], f),
        _ => {}
    }
}

/// Sets `weights` (one per morph target of the node's mesh) to a weights channel's values at
/// `t`; a key with fewer weights than targets leaves the rest as they were.
fn apply_weights_channel(channel: &Channel, t: f32, weights: &mut [f32]) {
    let ChannelValues::Weights(keys) = &channel.values else {
        return;
    };
    let Some((i, j, f)) = key_interval(channel, t) else {
        return;
    };
    let (Some(a), Some(b)) = (keys.get(i), keys.get(j)) else {
        return;
    };
    for ((weight, a), b) in weights.iter_mut().zip(a).zip(b) {
        *weight = a + (b - a) * f;
    }
}

/// Computes node `index`'s world transform; `depth` guards against parent cycles, which the
/// importer rejects but hand-built scenes could contain.
fn resolve_world(
    scene: &Scene,
    local: &[(Vec3, Quat, Vec3)],
    world: &mut [Option<Mat4>],
    index: usize,
    depth: usize,
) -> Mat4 {
    if let Some(m) = world[index] {
        return m;
    }
    let (t, r, s) = local[index];
    let local_matrix = Mat4::from_scale_rotation_translation(s, r, t);
    let matrix = match scene.nodes[index].parent {
        Some(parent) if parent < scene.nodes.len() && depth < scene.nodes.len() => {
            resolve_world(scene, local, world, parent, depth + 1) * local_matrix
        }
        _ => local_matrix,
    };
    world[index] = Some(matrix);
    matrix
}

/// Triangles of one primitive and more are evaluated on several threads; below it the
/// thread pool's overhead outweighs the work.
const PARALLEL_TRIANGLES: usize = 4096;

/// One mesh primitive placed by a node, with what its evaluation needs.
struct PrimitiveJob<'a> {
    node_index: usize,
    primitive: &'a Primitive,
    world: Mat4,
    normal_matrix: Mat4,
    /// The node's transform mirrors (negative determinant).
    flips: bool,
    /// The node's skin's joint matrices, for a skinned node.
    joints: Option<&'a [Option<Mat4>]>,
    weights: &'a [f32],
    /// Normals and tangents are left out ([`Evaluation::positions_only`]).
    positions_only: bool,
}

impl Scene {
    /// Every mesh primitive of every node, in node then primitive order (the frame's triangle
    /// order), with what its evaluation needs and where its triangles start.
    fn primitive_jobs<'a>(
        &'a self,
        world_from_node: &[Mat4],
        morph_weights: &'a [Vec<f32>],
        joint_matrices: &'a [Option<Vec<Option<Mat4>>>],
        positions_only: &[bool],
    ) -> (Vec<PrimitiveJob<'a>>, Vec<usize>) {
        let mut jobs = Vec::new();
        let mut starts = Vec::new();
        let mut total = 0;
        for (node_index, node) in self.nodes.iter().enumerate() {
            let Some(mesh) = node.mesh.and_then(|m| self.meshes.get(m)) else {
                continue;
            };
            let world = world_from_node[node_index];
            for primitive in &mesh.primitives {
                jobs.push(PrimitiveJob {
                    node_index,
                    primitive,
                    world,
                    normal_matrix: world.inverse().transpose(),
                    // A mirroring transform flips the winding; keep geometric normals facing
                    // the same side as the authored ones.
                    flips: world.determinant() < 0.0,
                    joints: joint_matrices[node_index].as_deref(),
                    weights: &morph_weights[node_index],
                    positions_only: positions_only.get(node_index) == Some(&true),
                });
                starts.push(total);
                total += primitive.indices.len() / 3;
            }
        }
        starts.push(total);
        (jobs, starts)
    }

    /// The joint matrices of every skinned node ([`Scene::node_skin`]) at `world_from_node`.
    fn all_joint_matrices(&self, world_from_node: &[Mat4]) -> Vec<Option<Vec<Option<Mat4>>>> {
        // A skinned node is placed by its joints, its own transform ignored (glTF 2.0).
        (0..self.nodes.len())
            .map(|node| {
                self.node_skin(node)
                    .map(|skin| skin.joint_matrices(world_from_node))
            })
            .collect()
    }

    /// Every mesh primitive of every node in world space, in node then primitive order: the
    /// primitives' vertices on all cores (a large one's in parallel too), then the triangles,
    /// written in place on all cores (the first touch of a large frame's memory is a large
    /// part of its cost). Each value is computed by the same operations whatever the split, so
    /// the frame is the same bit for bit on any number of threads.
    fn flatten(
        &self,
        world_from_node: &[Mat4],
        morph_weights: &[Vec<f32>],
        positions_only: &[bool],
    ) -> (Vec<Triangle>, Vec<TriangleAttributes>) {
        let joint_matrices = self.all_joint_matrices(world_from_node);
        let (jobs, starts) = self.primitive_jobs(
            world_from_node,
            morph_weights,
            &joint_matrices,
            positions_only,
        );
        // Each primitive's vertices (morphed, skinned or placed), on all cores.
        let vertices: Vec<PrimitiveVertices> = jobs.par_iter().map(primitive_vertices).collect();
        // Then every triangle, written in place in frame order: job `j`'s start at `starts[j]`.
        let total = starts.last().copied().unwrap_or(0);
        let mut triangles = Vec::with_capacity(total);
        let mut attributes = Vec::with_capacity(total);
        (0..total)
            .into_par_iter()
            .with_min_len(PARALLEL_TRIANGLES)
            .map(|index| {
                let j = starts.partition_point(|&start| start <= index) - 1;
                triangle(&jobs[j], &vertices[j], index - starts[j])
            })
            .unzip_into_vecs(&mut triangles, &mut attributes);
        (triangles, attributes)
    }

    /// Moves `frame`, an earlier evaluation of this scene with the same `evaluation`, to
    /// `time_s` through `camera` (`None`: the default camera): what
    /// [`Scene::evaluate_with`] returns, bit for bit, at the cost of the nodes whose geometry
    /// changed ([`Scene::node_geometry_changed`]: moved, their joints moved, their morph
    /// weights changed). Their triangles are evaluated again in place; the others are kept, so
    /// a frame of a large scene with a few animated objects costs those objects, not the
    /// scene. [`SceneFrame::geometry_revision`] changes only when some triangle did. A frame
    /// of another scene (another triangle or node count) or of another evaluation is
    /// evaluated whole. Edits to the scene's meshes between the two evaluations are not seen:
    /// evaluate afresh after them. Returns the number of triangles evaluated.
    pub fn evaluate_into(
        &self,
        frame: &mut SceneFrame,
        time_s: f32,
        camera: Option<CameraView>,
        evaluation: &Evaluation,
    ) -> usize {
        let positions_only = self.positions_only(evaluation);
        let world_from_node = self.world_transforms(time_s);
        let morph_weights = self.morph_weights(time_s);
        let joint_matrices = self.all_joint_matrices(&world_from_node);
        let (jobs, starts) = self.primitive_jobs(
            &world_from_node,
            &morph_weights,
            &joint_matrices,
            &positions_only,
        );
        let total = starts.last().copied().unwrap_or(0);
        let same_scene = frame.triangles.len() == total
            && frame.attributes.len() == total
            && frame.world_from_node.len() == self.nodes.len()
            && frame.morph_weights.len() == self.nodes.len()
            && frame.positions_only == positions_only;
        if !same_scene {
            *frame = self.evaluate_with(time_s, camera, evaluation);
            return total;
        }
        let next = SceneFrame {
            time_s,
            triangles: Vec::new(),
            attributes: Vec::new(),
            lights: Vec::new(),
            camera: frame.camera,
            sky: self.sky,
            exposure: self.exposure,
            world_from_node,
            morph_weights: morph_weights.clone(),
            geometry_revision: 0,
            positions_only: Vec::new(),
            material_revision: frame.material_revision,
        };
        let changed: Vec<usize> = (0..jobs.len())
            .filter(|&j| self.node_geometry_changed(jobs[j].node_index, frame, &next))
            .collect();
        let vertices: Vec<PrimitiveVertices> = changed
            .par_iter()
            .map(|&j| primitive_vertices(&jobs[j]))
            .collect();
        for (&j, vertices) in changed.iter().zip(&vertices) {
            let range = starts[j]..starts[j + 1];
            (frame.triangles[range.clone()].par_iter_mut())
                .zip(frame.attributes[range].par_iter_mut())
                .with_min_len(PARALLEL_TRIANGLES)
                .enumerate()
                .for_each(|(t, (triangle_out, attributes_out))| {
                    (*triangle_out, *attributes_out) = triangle(&jobs[j], vertices, t);
                });
        }
        let camera = camera.unwrap_or_else(|| self.default_view_with(&next.world_from_node));
        frame.lights = self.world_lights(&next.world_from_node);
        frame.time_s = time_s;
        frame.camera = camera;
        frame.sky = self.sky;
        frame.exposure = self.exposure;
        frame.world_from_node = next.world_from_node;
        frame.morph_weights = next.morph_weights;
        if !changed.is_empty() || frame.geometry_revision == 0 {
            frame.geometry_changed();
        }
        changed.iter().map(|&j| starts[j + 1] - starts[j]).sum()
    }
}

/// A primitive's vertices in world space.
struct PrimitiveVertices {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    tangents: Vec<Vec4>,
    /// Per vertex, whether its skinning matrix mirrors (skinned primitives only).
    mirrored: Option<Vec<bool>>,
}

/// `job`'s vertices: morph targets first, then the skin (glTF 2.0), or the node's transform.
fn primitive_vertices(job: &PrimitiveJob) -> PrimitiveVertices {
    let primitive = job.primitive;
    let morphed = morph(primitive, job.weights);
    match job.joints {
        Some(joint_matrices) if primitive.is_skinned() => {
            let skinned = skin_primitive(
                primitive,
                &morphed,
                joint_matrices,
                job.world,
                job.positions_only,
            );
            PrimitiveVertices {
                positions: skinned.positions,
                normals: skinned.normals,
                tangents: skinned.tangents,
                mirrored: Some(skinned.mirrored),
            }
        }
        _ => {
            let (world, normal_matrix) = (job.world, job.normal_matrix);
            // A mirroring transform also flips the bitangent's handedness.
            let handedness = if job.flips { -1.0 } else { 1.0 };
            let positions = par_map(&morphed.positions, |p| world.transform_point3(*p));
            if job.positions_only {
                return PrimitiveVertices {
                    positions,
                    normals: Vec::new(),
                    tangents: Vec::new(),
                    mirrored: None,
                };
            }
            PrimitiveVertices {
                positions,
                normals: par_map(&morphed.normals, |n| {
                    normal_matrix.transform_vector3(*n).normalize_or(Vec3::Y)
                }),
                tangents: par_map(&morphed.tangents, |t| {
                    let xyz = world.transform_vector3(t.truncate()).normalize_or_zero();
                    xyz.extend(if t.w < 0.0 { -handedness } else { handedness })
                }),
                mirrored: None,
            }
        }
    }
}

/// Triangle `t` of `job`'s primitive, from its world-space `vertices`.
fn triangle(
    job: &PrimitiveJob,
    vertices: &PrimitiveVertices,
    t: usize,
) -> (Triangle, TriangleAttributes) {
    let primitive = job.primitive;
    let tri = &primitive.indices[3 * t..3 * t + 3];
    let mut idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
    // A skinned triangle follows the matrix of its first vertex.
    let flips = (vertices.mirrored.as_ref()).map_or(job.flips, |m| m[idx[0]]);
    if flips {
        idx.swap(1, 2);
    }
    let [a, b, c] = idx.map(|i| vertices.positions[i]);
    let uv = |i: usize| primitive.uvs.get(i).copied().unwrap_or(Vec2::ZERO);
    let uv1 = |i: usize| primitive.uvs1.get(i).copied().unwrap_or(Vec2::ZERO);
    let tangent = |i: usize| vertices.tangents.get(i).copied().unwrap_or(Vec4::ZERO);
    (
        Triangle {
            v0: Vec3A::from(a),
            v1: Vec3A::from(b),
            v2: Vec3A::from(c),
        },
        TriangleAttributes {
            // Left out ([`Evaluation::positions_only`]): zero.
            normals: idx.map(|i| vertices.normals.get(i).copied().unwrap_or(Vec3::ZERO)),
            uvs: idx.map(uv),
            uvs1: idx.map(uv1),
            tangents: idx.map(tangent),
            material: primitive.material as u32,
            node: job.node_index as u32,
        },
    )
}

/// `items.map(f)`, on several threads when there are many.
fn par_map<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync + Send) -> Vec<U> {
    par_map_index(items.len(), |i| f(&items[i]))
}

/// `(0..count).map(f)`, on several threads when `count` is large.
pub(crate) fn par_map_index<U: Send>(count: usize, f: impl Fn(usize) -> U + Sync + Send) -> Vec<U> {
    if count < PARALLEL_TRIANGLES {
        (0..count).map(f).collect()
    } else {
        (0..count)
            .into_par_iter()
            .with_min_len(PARALLEL_TRIANGLES)
            .map(f)
            .collect()
    }
}
