//! Pass `cache/screen_inject` (`shaders/cache/screen_inject.wgsl`): corrects resident bricks
//! from the G-buffer (HSGI, GDC 2023, "Injection": screen injection with tile-based culling).
//!
//! Voxelization is exact but only runs where the CPU queued bricks (entering slabs, moved
//! dynamic nodes); everything else keeps what it was voxelized with. What the camera sees is
//! current, so each update with [`crate::CacheInputs::gbuffer`] set checks the visible
//! resident bricks against it, one thread per voxel:
//! - voxels the view sees through (every pixel over the voxel shows something farther, by a
//!   voxel diagonal plus a pixel footprint) are **cleared** from the occupancy mask;
//! - voxels the visible surface crosses, with agreeing normals, get the G-buffer's diffuse
//!   albedo and normal (**update**);
//! - everything else is left alone (**skip**): occluded, off screen, normals disagreeing.
//!
//! Only occupancy is removed, never added: new geometry arrives through voxelization.
//!
//! Bricks are chosen on the CPU: resident bricks whose box intersects the view frustum, not
//! voxelized in this update (they are exact already), finer levels first and nearer bricks
//! first within a level, at most [`crate::CacheConfig::screen_inject_bricks_per_frame`].
//! The finest levels cover the near field, so the budget amortizes by distance as HSGI's tiles
//! do: what falls beyond it waits for a frame with fewer visible fine bricks.
//!
//! **What clearing leaves behind.** A brick whose mask ends empty stays allocated and linked,
//! with its group-mask bit still set: the CPU does not read brick masks back, so it cannot keep
//! its mirror consistent if the GPU unlinked bricks, and a set group bit over an empty brick
//! only costs the tracer one brick-mask fetch. The brick is freed when its slab leaves the
//! window, or voxelized again when a dynamic node moves through it.
//!
//! Group 0: binding 0 the pass uniforms, 1 the jobs, 2..=5 the G-buffer's depth, normal, base
//! color and metallic/roughness, 6 three counters (voxels cleared, voxels updated, bricks left
//! empty). Group 2: the cache ([`CacheBuffers`]). Memory: `cache.screen_inject_*`, 32 bytes per
//! job, grown on demand.

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::{GBufferOutputs, GpuCamera, GpuContext, GpuError, GpuTimer, ShaderLibrary, wgpu};
use gi_scene::CameraView;
use glam::{IVec3, Vec3, Vec4};

use crate::buffers::CacheBuffers;
use crate::cache::ResidentBrick;
use crate::clipmap::ClipmapWindows;
use crate::config::CacheConfig;
use crate::layout::{GROUP_BRICKS, group_of_brick, mask_cell};
use crate::residency::{IdSet, bits};
use crate::structure::CacheStructure;

/// Least `|cos|` between the G-buffer normal and a voxel's normal for an update: a voxel whose
/// surface turns (an edge or a corner of the geometry) keeps its own normal.
pub const NORMAL_AGREEMENT: f32 = 0.9;
/// Grazing views count as this steep (`|cos|` of the view and the surface) in the clear
/// margin, which grows as one pixel footprint over it: at most ten footprints.
pub const MIN_COS_VIEW: f32 = 0.1;

/// The G-buffer a cache update reads for screen injection: its buffers and the camera that
/// cast it (see `gi_gpu::gbuffer` for each buffer's contents).
#[derive(Clone, Copy)]
pub struct ScreenInputs<'a> {
    /// `gbuffer.depth`: distance along the unit camera ray, `+inf` for sky.
    pub depth: &'a wgpu::Buffer,
    /// `gbuffer.normal`: octahedral world shading normal facing the camera.
    pub normal: &'a wgpu::Buffer,
    /// `gbuffer.base_color`: textured linear base color.
    pub base_color: &'a wgpu::Buffer,
    /// `gbuffer.metallic_roughness`: textured metallic (x), perceptual roughness (y).
    pub metallic_roughness: &'a wgpu::Buffer,
    /// The camera the G-buffer's rays were cast from.
    pub camera: GpuCamera,
    /// Image size in pixels.
    pub size_px: (u32, u32),
}

impl<'a> ScreenInputs<'a> {
    /// The buffers of a G-buffer frame, cast from `camera`.
    pub fn new(gbuffer: &GBufferOutputs<'a>, camera: &CameraView) -> Self {
        Self {
            depth: gbuffer.depth,
            normal: gbuffer.normal,
            base_color: gbuffer.base_color,
            metallic_roughness: gbuffer.metallic_roughness,
            camera: GpuCamera::new(camera, gbuffer.size),
            size_px: gbuffer.size,
        }
    }
}

/// Uniforms of `cache/screen_inject` (`ScreenInjectUniforms` in WGSL), 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ScreenInjectUniforms {
    pub camera: GpuCamera,
    pub size_px: [u32; 2],
    /// Jobs in this dispatch.
    pub job_count: u32,
    pub pad: u32,
}

/// One brick to correct (`ScreenJob` in WGSL), 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuScreenJob {
    /// World brick coordinate.
    pub brick: [i32; 3],
    pub level: u32,
    /// Pool ID.
    pub brick_id: u32,
    pub pad_a: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

/// What the pass did, read back from its counters ([`ScreenInjector::read_counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScreenInjectCounts {
    /// Voxels whose occupancy was cleared.
    pub cleared_voxels: u32,
    /// Voxels whose albedo and normal were refreshed.
    pub updated_voxels: u32,
    /// Bricks whose mask became empty (they stay allocated).
    pub emptied_bricks: u32,
}

/// True when the box `[lo, hi]` intersects the view frustum of `camera` (the four side
/// planes and the plane through the camera facing forward; no far plane).
pub fn box_in_frustum(camera: &GpuCamera, lo: Vec3, hi: Vec3) -> bool {
    Frustum::new(camera).touches(lo, hi)
}

/// The planes of [`box_in_frustum`], made once for many boxes.
struct Frustum {
    position: Vec3,
    /// Inward normals.
    planes: [Vec3; 5],
}

impl Frustum {
    fn new(camera: &GpuCamera) -> Self {
        let (right, up, forward) = (
            Vec3::from(camera.right),
            Vec3::from(camera.up),
            Vec3::from(camera.forward),
        );
        let tx = camera.tan_half_fov * camera.aspect;
        let ty = camera.tan_half_fov;
        Self {
            position: Vec3::from(camera.position),
            planes: [
                forward,
                forward * tx - right,
                forward * tx + right,
                forward * ty - up,
                forward * ty + up,
            ],
        }
    }

    #[inline]
    fn touches(&self, lo: Vec3, hi: Vec3) -> bool {
        self.planes.iter().all(|n| {
            // The box corner farthest along the plane's inward normal.
            let corner = Vec3::select(n.cmpge(Vec3::ZERO), hi, lo);
            (corner - self.position).dot(*n) >= 0.0
        })
    }

    /// The test of [`Frustum::touches`] for the bricks of edge `size` (brick `b` spans
    /// `[b, b + 1] * size`), with the four side planes side by side and the same arithmetic,
    /// so it agrees with [`box_in_frustum`] to the bit.
    fn for_bricks(&self, size: f32) -> BrickFrustum {
        // The farthest corner along `n` is `lo + size` on the axes where `n >= 0`, else `lo`.
        let step = |n: f32| if n >= 0.0 { size } else { 0.0 };
        let [front, sides @ ..] = self.planes;
        BrickFrustum {
            size,
            position: self.position,
            x: Vec4::from_array(sides.map(|n| n.x)),
            y: Vec4::from_array(sides.map(|n| n.y)),
            z: Vec4::from_array(sides.map(|n| n.z)),
            step_x: Vec4::from_array(sides.map(|n| step(n.x))),
            step_y: Vec4::from_array(sides.map(|n| step(n.y))),
            step_z: Vec4::from_array(sides.map(|n| step(n.z))),
            front,
        }
    }
}

/// [`Frustum`] for the bricks of one level: whether a brick touches it, from its integer
/// coordinates.
struct BrickFrustum {
    size: f32,
    position: Vec3,
    /// The side planes' inward normals, a plane per lane.
    x: Vec4,
    y: Vec4,
    z: Vec4,
    /// Per side plane, what its farthest corner adds to the brick's low corner.
    step_x: Vec4,
    step_y: Vec4,
    step_z: Vec4,
    front: Vec3,
}

impl BrickFrustum {
    #[inline]
    fn touches(&self, brick: IVec3) -> bool {
        let lo = brick.as_vec3() * self.size;
        let hi = lo + Vec3::splat(self.size);
        let corner = Vec3::select(self.front.cmpge(Vec3::ZERO), hi, lo);
        if (corner - self.position).dot(self.front) < 0.0 {
            return false;
        }
        let p = self.position;
        let dx = (Vec4::splat(lo.x) + self.step_x) - Vec4::splat(p.x);
        let dy = (Vec4::splat(lo.y) + self.step_y) - Vec4::splat(p.y);
        let dz = (Vec4::splat(lo.z) + self.step_z) - Vec4::splat(p.z);
        (dx * self.x + dy * self.y + dz * self.z)
            .cmpge(Vec4::ZERO)
            .all()
    }
}

/// The bricks `cache/screen_inject` corrects this update: the resident bricks (linked in
/// `structure`, inside `windows`) inside the frustum of `camera` and not in `skip`, finer
/// levels first, then nearer, at most `budget`.
///
/// A level's bricks are found through its groups of 4 x 4 x 4 bricks: a group whose box (grown
/// by a thousandth of its edge against rounding) misses the frustum is skipped whole, and the
/// bricks of the others come from their group masks and are tested one by one, so the choice
/// costs a test per group of the window (256 a level by default) and per brick of the visible
/// groups, rather than one per resident brick.
pub fn select_bricks(
    config: &CacheConfig,
    structure: &CacheStructure,
    windows: &ClipmapWindows,
    camera: &GpuCamera,
    skip: &[ResidentBrick],
    budget: u32,
) -> Vec<ResidentBrick> {
    let position = Vec3::from(camera.position);
    let frustum = Frustum::new(camera);
    let mut skipped = IdSet::default();
    for b in skip {
        skipped.insert(b.brick_id);
    }
    // Finer levels first, then nearer, then by pool ID: levels are taken whole in order
    // until the budget is reached, so coarser levels are not even tested; the last level's
    // share is selected in linear time before its bricks are sorted.
    let budget = budget as usize;
    let mut selected = Vec::with_capacity(budget);
    let mut visible: Vec<(u64, ResidentBrick)> = Vec::new();
    let group_bricks = GROUP_BRICKS as i32;
    for level in 0..config.levels {
        if selected.len() >= budget {
            break;
        }
        let size = config.brick_size_at(level);
        let group_size = size * GROUP_BRICKS as f32;
        let margin = Vec3::splat(group_size * 1e-3);
        let bricks = frustum.for_bricks(size);
        let window = windows.window(level);
        // Distance bits order like the distances (non-negative floats), then the pool ID.
        visible.clear();
        let (first, last) = (
            group_of_brick(window.min),
            group_of_brick(window.max - IVec3::ONE),
        );
        for z in first.z..=last.z {
            for y in first.y..=last.y {
                for x in first.x..=last.x {
                    let group = IVec3::new(x, y, z);
                    let lo = group.as_vec3() * group_size;
                    if !frustum.touches(lo - margin, lo + Vec3::splat(group_size) + margin) {
                        continue;
                    }
                    let origin = group * group_bricks;
                    let mask = structure.group_mask(level, origin);
                    for bit in bits(mask, 0) {
                        let brick = origin + mask_cell(bit).as_ivec3();
                        let id = structure.brick_id(level, brick);
                        if skipped.contains(id) || !bricks.touches(brick) {
                            continue;
                        }
                        let center = (brick.as_vec3() + 0.5) * size;
                        let distance = (center - position).length();
                        visible.push((
                            (u64::from(distance.to_bits()) << 32) | u64::from(id),
                            ResidentBrick {
                                level,
                                brick,
                                brick_id: id,
                            },
                        ));
                    }
                }
            }
        }
        let take = (budget - selected.len()).min(visible.len());
        if take < visible.len() {
            visible.select_nth_unstable_by_key(take, |(key, _)| *key);
            visible.truncate(take);
        }
        visible.sort_unstable_by_key(|(key, _)| *key);
        selected.extend(visible.iter().map(|(_, b)| *b));
    }
    selected
}

/// The screen injection pass: its pipeline, job buffer and counters.
pub struct ScreenInjector {
    /// Entry point `screen_inject` of `cache/screen_inject.wgsl`.
    screen_inject: wgpu::ComputePipeline,
    frame_layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    jobs: wgpu::Buffer,
    counts: wgpu::Buffer,
}

impl ScreenInjector {
    /// Compiles `cache/screen_inject`.
    pub fn new(ctx: &GpuContext, shaders: &ShaderLibrary) -> Result<Self, GpuError> {
        let module = shaders.create_module(ctx, "cache/screen_inject.wgsl", &[])?;
        let mut entries = vec![uniform_entry(0)];
        entries.extend((1..=5).map(|binding| storage_entry(binding, true)));
        entries.push(storage_entry(6, false));
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cache/screen_inject.frame_layout"),
                entries: &entries,
            });
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let screen_inject = ctx.create_compute_pipeline_with_layouts(
            "cache/screen_inject",
            &module,
            "screen_inject",
            &[Some(&frame_layout), None, Some(&cache_layout)],
        );
        Ok(Self {
            screen_inject,
            frame_layout,
            uniforms: ctx.create_buffer(
                "cache.screen_inject_uniforms",
                size_of::<ScreenInjectUniforms>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            jobs: Self::jobs_buffer(ctx, 32),
            counts: ctx.create_buffer(
                "cache.screen_inject_counts",
                16,
                wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            ),
        })
    }

    fn jobs_buffer(ctx: &GpuContext, bytes: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            "cache.screen_inject_jobs",
            bytes.max(32),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    /// Records `cache/screen_inject` over `bricks` (at most 65535) into `encoder`, timed by
    /// `timer`, and resets the counters first. Uploads through the queue, so record one per
    /// submission.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut GpuTimer,
        cache: &CacheBuffers,
        screen: &ScreenInputs<'_>,
        bricks: &[ResidentBrick],
    ) {
        ctx.queue.write_buffer(&self.counts, 0, &[0; 16]);
        if bricks.is_empty() {
            return;
        }
        assert!(bricks.len() <= 65_535, "too many bricks in one dispatch");
        let jobs: Vec<GpuScreenJob> = bricks
            .iter()
            .map(|b| GpuScreenJob {
                brick: b.brick.to_array(),
                level: b.level,
                brick_id: b.brick_id,
                ..Default::default()
            })
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&jobs);
        ctx.write_growing(&mut self.jobs, "cache.screen_inject_jobs", bytes);
        let uniforms = ScreenInjectUniforms {
            camera: screen.camera,
            size_px: [screen.size_px.0, screen.size_px.1],
            job_count: jobs.len() as u32,
            pad: 0,
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let entries = buffer_entries(
            0,
            [
                &self.uniforms,
                &self.jobs,
                screen.depth,
                screen.normal,
                screen.base_color,
                screen.metallic_roughness,
                &self.counts,
            ],
        );
        let frame_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache/screen_inject.frame"),
            layout: &self.frame_layout,
            entries: &entries,
        });
        timer.compute_pass(ctx, encoder, "cache/screen_inject", |pass| {
            pass.set_pipeline(&self.screen_inject);
            pass.set_bind_group(0, &frame_group, &[]);
            pass.set_bind_group(CacheBuffers::BIND_GROUP, &cache.bind_group, &[]);
            pass.dispatch_workgroups(jobs.len() as u32, 1, 1);
        });
    }

    /// The counters of the last recorded pass (stalls; for tests and tools).
    pub fn read_counts(&self, ctx: &GpuContext) -> ScreenInjectCounts {
        let counts: Vec<u32> = ctx.read_buffer(&self.counts);
        ScreenInjectCounts {
            cleared_voxels: counts[0],
            updated_voxels: counts[1],
            emptied_bricks: counts[2],
        }
    }

    /// Stops counting and destroys the pass's buffers.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [&self.uniforms, &self.jobs, &self.counts] {
            ctx.release_buffer(buffer);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brick test of each level agrees with the box test on every brick of a grid around
    /// cameras looking along and across the axes.
    #[test]
    fn brick_frustum_agrees_with_the_box_test() {
        let config = CacheConfig::default();
        let mut inside = 0;
        for (eye, target) in [
            (Vec3::new(0.3, 1.1, 0.2), Vec3::new(-0.4, 0.1, -1.0)),
            (Vec3::new(-2.0, 0.5, 3.0), Vec3::new(1.0, 0.7, 0.2)),
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, -1.0, 0.01)),
        ] {
            let view = CameraView::look_at(eye, target, 1.0);
            let camera = GpuCamera::new(&view, (160, 90));
            let frustum = Frustum::new(&camera);
            for level in 0..config.levels {
                let size = config.brick_size_at(level);
                let bricks = frustum.for_bricks(size);
                for z in -12..12 {
                    for y in -12..12 {
                        for x in -12..12 {
                            let b = IVec3::new(x, y, z);
                            let lo = b.as_vec3() * size;
                            let expected = box_in_frustum(&camera, lo, lo + Vec3::splat(size));
                            assert_eq!(bricks.touches(b), expected, "level {level}, brick {b}");
                            inside += usize::from(expected);
                        }
                    }
                }
            }
        }
        assert!(inside > 10_000, "{inside}");
    }

    /// The selection taken level by level equals a sort of every visible, unskipped brick by
    /// level, distance and pool ID, cut at the budget, whichever level the budget ends in.
    #[test]
    fn selection_is_the_finest_nearest_visible_bricks() {
        let config = CacheConfig::default();
        // Near the origin, and far on the negative side of every axis and on the positive
        // side of one (windows whose groups have negative coordinates), looking along +x.
        for origin in [
            Vec3::new(0.3, 1.1, 0.2),
            Vec3::new(-403.7, -51.9, -287.4),
            Vec3::new(517.2, -33.3, 20.8),
        ] {
            let view = CameraView::look_at(origin, origin + Vec3::new(1.0, -0.3, 0.2), 1.0);
            let camera = GpuCamera::new(&view, (160, 90));
            let windows = ClipmapWindows::new(&config, view.position);
            let mut structure = CacheStructure::new(&config);
            let mut resident = Vec::new();
            let mut id = 0;
            for level in 0..config.levels {
                let center = (origin / config.brick_size_at(level)).floor().as_ivec3();
                let window = windows.window(level);
                // Bricks around the camera, and the window's first group along x (behind the
                // camera), whose link slots a group past the window's far end would share.
                let near = (-6..6).map(move |x| center.x + x);
                let edge = window.min.x..window.min.x + 4;
                for x in near.chain(edge) {
                    for y in -2..3 {
                        for z in -6..6 {
                            // Pool IDs in no particular order, some levels sparse.
                            let local = IVec3::new(x - center.x, y, z);
                            if (local.x + 2 * y + 3 * z + level as i32).rem_euclid(3) != 0 {
                                let brick = IVec3::new(x, center.y + y, center.z + z);
                                assert!(windows.window(level).contains(brick));
                                let brick_id = ((id + 1) * 7919) % 100_003;
                                structure.set_brick(level, brick, brick_id);
                                resident.push(ResidentBrick {
                                    level,
                                    brick,
                                    brick_id,
                                });
                                id += 1;
                            }
                        }
                    }
                }
            }
            let skip: Vec<ResidentBrick> = resident.iter().step_by(5).copied().collect();
            let mut expected: Vec<(u32, f32, u32)> = resident
                .iter()
                .filter(|b| !skip.contains(b))
                .filter_map(|b| {
                    let size = config.brick_size_at(b.level);
                    let lo = b.brick.as_vec3() * size;
                    let hi = lo + Vec3::splat(size);
                    let distance = ((lo + hi) * 0.5 - view.position).length();
                    box_in_frustum(&camera, lo, hi).then_some((b.level, distance, b.brick_id))
                })
                .collect();
            expected.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
            let levels_seen: std::collections::HashSet<u32> =
                expected.iter().map(|e| e.0).collect();
            assert!(levels_seen.len() >= 3, "the view sees too few levels");
            for budget in [0, 1, 17, 150, 400, expected.len() as u32, 100_000] {
                let selected: Vec<u32> =
                    select_bricks(&config, &structure, &windows, &camera, &skip, budget)
                        .iter()
                        .map(|b| b.brick_id)
                        .collect();
                let want: Vec<u32> = expected.iter().take(budget as usize).map(|e| e.2).collect();
                assert_eq!(selected, want, "camera at {origin}, budget {budget}");
            }
        }
    }

    #[test]
    fn frustum_keeps_boxes_in_view_and_drops_those_behind_or_beside() {
        let view = CameraView::look_at(Vec3::ZERO, Vec3::NEG_Z, 1.0);
        let camera = GpuCamera::new(&view, (64, 64));
        let unit = |c: Vec3| (c - Vec3::splat(0.5), c + Vec3::splat(0.5));
        for (center, inside) in [
            (Vec3::new(0.0, 0.0, -5.0), true),
            (Vec3::new(0.0, 0.0, 5.0), false),
            (Vec3::new(20.0, 0.0, -5.0), false),
            (Vec3::new(0.0, -20.0, -5.0), false),
            (Vec3::new(3.0, 0.0, -5.0), true),
            (Vec3::ZERO, true),
        ] {
            let (lo, hi) = unit(center);
            assert_eq!(box_in_frustum(&camera, lo, hi), inside, "{center}");
        }
    }
}
