//! Lighting the cache (`cache/inject`, `cache/propagate`, `cache/propagate_resolve`): direct
//! injection against the analytic irradiance, a white furnace against its exact irradiance,
//! convergence against the reference's irradiance,
//! bit-identical results from identical inputs, reaction to a changed light, and the passes' GPU
//! times.

use gi_cache::cpu_voxelize::closest_point_barycentrics;
use gi_cache::layout::{
    FACE_DIRECTIONS, SIDE_BACK, SIDE_COUNT, SIDE_FRONT, VoxelSurface, mask_cell, side_normal,
    side_slot, state_change, state_change_frames, voxel_index,
};
use gi_cache::lighting::{
    CONVERGING_FRACTION, GpuLightingUniforms, GpuScheduledBrick, GpuSky, side_point,
};
use gi_cache::packing::{unpack_rgb9e5, unpack_unit_vector};
use gi_cache::{
    CacheBuffers, CacheConfig, CacheInputs, CacheLighting, CacheLightingHook, CacheTracer,
    CpuCache, LightingInputs, RadianceCache, Residency, ResidentBrick, ScheduleCounts,
};
use gi_gpu::{
    GpuContext, GpuScene, GpuTimer, PassTimings, Recorder, ShaderLibrary, Technique,
    rust_field_offsets, wgsl_struct_layout,
};
use gi_reference::Reference;
use gi_scene::{Light, LightKind, Node, Scene, SceneBvh, SceneFrame, Sky, WorldLight};
use glam::{IVec3, Quat, Vec3};
use rand::{RngExt, SeedableRng};

#[test]
fn lighting_structs_match_their_wgsl_layout() {
    let module = ShaderLibrary::new()
        .compose("cache/inject.wgsl", &[])
        .unwrap();
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let wgsl = wgsl_struct_layout(&module, name).unwrap_or_else(|| panic!("{name}"));
        assert_eq!(wgsl.members, rust, "{name}");
        assert_eq!(wgsl.size as usize, size, "{name}");
    };
    check(
        "Sky",
        rust_field_offsets!(GpuSky {
            zenith,
            horizon,
            ground,
            kind,
            pad_a,
            pad_b,
            pad_c
        }),
        size_of::<GpuSky>(),
    );
    check(
        "LightingUniforms",
        rust_field_offsets!(GpuLightingUniforms {
            sky,
            brick_count,
            light_count,
            rays_per_side,
            max_age,
            frame_index,
            seed,
            emitter_count,
            default_material,
            change_gain,
            pad_a,
            pad_b,
            pad_c
        }),
        size_of::<GpuLightingUniforms>(),
    );
    check(
        "ScheduledBrick",
        rust_field_offsets!(GpuScheduledBrick {
            brick,
            level,
            brick_id,
            max_age,
            pad_b,
            pad_c
        }),
        size_of::<GpuScheduledBrick>(),
    );
    for file in ["cache/propagate.wgsl", "cache/propagate_resolve.wgsl"] {
        ShaderLibrary::new().compose(file, &[]).unwrap();
    }
}

// ---------------------------------------------------------------------------------------------
// Scenes and a cache lit on the GPU.
// ---------------------------------------------------------------------------------------------

/// A scene assembled in code: one node per quad or light.
struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    fn new(sky: Sky) -> Self {
        Self {
            scene: Scene {
                name: "lighting-test".into(),
                sky,
                exposure: 1.0,
                ..Default::default()
            },
        }
    }

    /// A parallelogram `center +- u +- v`, front face `u x v`, of diffuse `albedo`.
    fn quad(&mut self, center: Vec3, u: Vec3, v: Vec3, albedo: f32) -> &mut Self {
        self.scene.add_diffuse_quad(center, u, v, albedo);
        self
    }

    fn directional(&mut self, intensity: f32, direction: Vec3) -> &mut Self {
        self.scene.lights.push(Light {
            name: String::new(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity,
            range: None,
        });
        self.scene.nodes.push(Node {
            rotation: Quat::from_rotation_arc(Vec3::NEG_Z, direction.normalize()),
            light: Some(self.scene.lights.len() - 1),
            ..Default::default()
        });
        self
    }
}

/// A cache filled on the CPU, uploaded, with its lighting technique and the scene on the GPU.
struct LitCache {
    cpu: CpuCache,
    buffers: CacheBuffers,
    gpu_scene: GpuScene,
    lighting: CacheLighting,
    timer: GpuTimer,
    bricks: Vec<ResidentBrick>,
    residency: Residency,
    lights: Vec<WorldLight>,
    frames: u32,
}

impl LitCache {
    fn new(ctx: &GpuContext, config: &CacheConfig, scene: &Scene, frame: &SceneFrame) -> Self {
        let cpu = CpuCache::build(config, scene, frame, frame.camera.position).unwrap();
        let buffers = cpu.upload(ctx);
        let gpu_scene = GpuScene::upload(ctx, scene, frame).unwrap();
        let lighting = CacheLighting::new(
            ctx,
            &ShaderLibrary::new(),
            config,
            &CacheBuffers::bind_group_layout(ctx),
        )
        .unwrap();
        let bricks: Vec<ResidentBrick> = cpu
            .bricks
            .iter()
            .map(|b| ResidentBrick {
                level: b.level,
                brick: b.brick,
                brick_id: b.id,
            })
            .collect();
        let residency = Residency::from_bricks(config.levels, &bricks);
        Self {
            cpu,
            buffers,
            gpu_scene,
            lighting,
            timer: GpuTimer::new(ctx, "cache.lighting.test", 8),
            bricks,
            residency,
            lights: frame.lights.clone(),
            frames: 0,
        }
    }

    /// One lighting frame: every brick is new on the first, resident afterwards.
    fn frame(&mut self, ctx: &GpuContext, sky: &Sky) -> (ScheduleCounts, PassTimings) {
        let mut encoder = ctx.create_encoder("cache.lighting.test");
        let new: &[ResidentBrick] = if self.frames == 0 { &self.bricks } else { &[] };
        let inputs = LightingInputs {
            sky,
            lights: &self.lights,
            scene: &self.gpu_scene,
            bvh: &self.gpu_scene.bvh,
            cache_bind_group: &self.buffers.bind_group,
            new_bricks: new,
            resident: &self.residency,
        };
        let counts = self
            .lighting
            .record(ctx, &mut self.timer, &mut encoder, &inputs);
        self.frames += 1;
        (counts, self.timer.finish(ctx, encoder))
    }

    /// Every voxel's measured change (`VoxelSurface::state`'s), by voxel index.
    fn read_changes(&self, ctx: &GpuContext) -> Vec<f32> {
        self.read_states(ctx)
            .iter()
            .map(|&s| state_change(s))
            .collect()
    }

    /// Every voxel's `VoxelSurface::state`, by voxel index.
    fn read_states(&self, ctx: &GpuContext) -> Vec<u32> {
        let voxels: Vec<VoxelSurface> = ctx.read_buffer(&self.buffers.voxels);
        voxels.iter().map(|v| v.state).collect()
    }

    /// `(direct, indirect)` irradiance per voxel side, unpacked.
    fn read_sides(&self, ctx: &GpuContext) -> (Vec<Vec3>, Vec<Vec3>) {
        let direct: Vec<u32> = ctx.read_buffer(&self.buffers.direct);
        let indirect: Vec<u32> = ctx.read_buffer(&self.buffers.indirect);
        (
            direct.into_iter().map(unpack_rgb9e5).collect(),
            indirect.into_iter().map(unpack_rgb9e5).collect(),
        )
    }
}

/// One side of an occupied voxel of the CPU cache.
#[derive(Clone, Copy, Debug)]
struct Side {
    level: u32,
    /// World voxel coordinate.
    voxel: IVec3,
    center: Vec3,
    size: f32,
    /// The voxel's normal.
    normal: Vec3,
    side: u32,
    slot: usize,
}

impl Side {
    /// The side's outward normal: the voxel normal, or its opposite for the back.
    fn side_normal(&self) -> Vec3 {
        side_normal(self.normal, self.side)
    }

    /// The point the side is lit at (as `gi::cache::lighting::side_point`).
    fn point(&self) -> Vec3 {
        side_point(self.center, self.size, self.side_normal())
    }
}

/// Both sides of every occupied voxel of the cache.
fn voxel_sides(cpu: &CpuCache) -> Vec<Side> {
    let mut sides = Vec::new();
    for b in &cpu.bricks {
        let mask = cpu.structure.brick_mask(b.id);
        let size = cpu.config.voxel_size_at(b.level);
        for bit in 0..64 {
            if mask & (1u64 << bit) == 0 {
                continue;
            }
            let voxel = b.brick * 4 + mask_cell(bit).as_ivec3();
            let surface = cpu.voxels[voxel_index(b.id, bit) as usize];
            for side in 0..SIDE_COUNT {
                sides.push(Side {
                    level: b.level,
                    voxel,
                    center: (voxel.as_vec3() + 0.5) * size,
                    size,
                    normal: unpack_unit_vector(surface.normal),
                    side,
                    slot: side_slot(b.id, bit, side) as usize,
                });
            }
        }
    }
    sides
}

fn small_config() -> CacheConfig {
    CacheConfig {
        levels: 1,
        level_bricks: [8, 8, 8],
        pool_bricks: 512,
        near_levels: 1,
        ..Default::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Direct injection.
// ---------------------------------------------------------------------------------------------

#[test]
fn direct_injection_matches_the_analytic_irradiance_and_shadows() {
    let Some(ctx) = GpuContext::new_or_skip("direct_injection_matches_the_analytic_irradiance")
    else {
        return;
    };
    // A floor under a directional light (no zero direction component: see
    // `Reference::irradiance`'s test) with a black roof that shadows part of it.
    let intensity = 3.0;
    let light_dir = Vec3::new(0.3, -1.0, 0.5).normalize();
    let mut builder = SceneBuilder::new(Sky::default());
    builder
        .quad(
            Vec3::new(0.0, 0.03, 0.0),
            Vec3::X * 0.9,
            Vec3::NEG_Z * 0.9,
            0.5,
        )
        .quad(
            Vec3::new(0.3, 0.5, 0.0),
            Vec3::X * 0.2,
            Vec3::NEG_Z * 0.2,
            0.0,
        )
        .directional(intensity, light_dir);
    let scene = builder.scene.clone();
    let mut frame = scene.evaluate(0.0, None);
    frame.camera.position = Vec3::new(0.0, 0.1, 0.0);
    let mut lit = LitCache::new(&ctx, &small_config(), &scene, &frame);
    let (counts, timings) = lit.frame(&ctx, &scene.sky);
    println!("{counts:?}\n{timings}");
    let (direct, _) = lit.read_sides(&ctx);

    let bvh = SceneBvh::build(&frame.triangles);
    let wi = -light_dir;
    let (mut lit_sides, mut shadowed, mut below) = (0, 0, 0);
    let mut worst = 0.0f32;
    for f in voxel_sides(&lit.cpu) {
        let cos = wi.dot(f.side_normal());
        let occluded = bvh.occluded(&frame.triangles, f.point(), wi, 0.0, f32::INFINITY);
        let expected = if cos <= 0.0 || occluded {
            0.0
        } else {
            intensity * cos
        };
        let got = direct[f.slot];
        // RGB9E5 keeps 9 mantissa bits of the largest channel: rounding error <= 2^-9 of it.
        let error = (got - Vec3::splat(expected)).abs().max_element();
        worst = worst.max(error / expected.max(1e-3));
        assert!(
            error <= expected * 2f32.powi(-9) + 1e-6,
            "side {} of voxel {} (level {}): {got} vs {expected}",
            f.side,
            f.voxel,
            f.level
        );
        if f.normal.y > 0.99 && f.side == SIDE_FRONT {
            if expected > 0.0 {
                lit_sides += 1;
            } else {
                shadowed += 1;
            }
        }
        if f.normal.y > 0.99 && f.side == SIDE_BACK {
            below += 1;
        }
    }
    println!(
        "floor top sides lit {lit_sides}, in the roof's shadow {shadowed}, bottom sides {below} \
         (all 0); worst relative error of lit sides {worst:.2e}; E = I cos(theta) = {:.4}",
        intensity * wi.y
    );
    assert!(lit_sides > 500 && shadowed > 20 && below > 500);
}

// ---------------------------------------------------------------------------------------------
// Convergence against the reference.
// ---------------------------------------------------------------------------------------------

/// Runs `frames` lighting frames and returns the per-pass median time of the last half.
fn run_frames(ctx: &GpuContext, lit: &mut LitCache, sky: &Sky, frames: u32) -> PassTimings {
    let mut timings = Vec::new();
    for i in 0..frames {
        let (_, t) = lit.frame(ctx, sky);
        if i >= frames / 2 {
            timings.push(t);
        }
    }
    PassTimings::median(&timings)
}

/// The cache's irradiance (`cache_irradiance`) at each `(point, normal)`.
fn cache_irradiance(ctx: &GpuContext, lit: &LitCache, points: &[(Vec3, Vec3)]) -> Vec<Vec3> {
    let tracer = CacheTracer::new(ctx, &ShaderLibrary::new()).unwrap();
    tracer
        .irradiance(ctx, &lit.buffers, points)
        .into_iter()
        .enumerate()
        .map(|(i, e)| e.unwrap_or_else(|| panic!("no voxel at {:?}", points[i])))
        .collect()
}

/// A grid of `nu` x `nv` points over `origin + s u + t v`, s and t in [0, 1], all with `normal`.
fn grid(origin: Vec3, u: Vec3, v: Vec3, nu: u32, nv: u32, normal: Vec3) -> Vec<(Vec3, Vec3)> {
    let mut points = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let s = (i as f32 + 0.5) / nu as f32;
            let t = (j as f32 + 0.5) / nv as f32;
            points.push((origin + u * s + v * t, normal));
        }
    }
    points
}

fn luminance(v: Vec3) -> f32 {
    v.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

fn mean_luminance(values: &[Vec3]) -> f32 {
    values.iter().map(|&v| luminance(v)).sum::<f32>() / values.len() as f32
}

/// The configuration of the convergence tests: every brick relit every frame and a short
/// accumulation (max_age 8), so a few dozen frames on the software adapter converge; the
/// schedule and the default ages are what the product runs with, tested separately.
fn converging_config(levels: u32) -> CacheConfig {
    CacheConfig {
        levels,
        light_bricks_per_frame: CacheConfig::default().pool_bricks,
        max_age: 8,
        ..Default::default()
    }
}

#[test]
fn thin_wall_interior_stays_dark() {
    let Some(ctx) = GpuContext::new_or_skip("thin_wall_interior_stays_dark") else {
        return;
    };
    // Windows of 16 x 8 x 16 bricks: the room at 6.25 and 12.5 cm voxels (the 5 cm wall is one
    // voxel thick either way), the outdoors up to 32 m, about 2300 bricks.
    let means = thin_wall_means(converged_thin_wall(&ctx));
    check_thin_wall(&means);
    let ratios: Vec<String> = means.iter().map(|m| format!("{:.4}", m.0 / m.1)).collect();
    println!("thin-wall cache / reference: {}", ratios.join(", "));
    for (i, (&(cache, reference, noise), expected)) in
        means.iter().zip(THIN_WALL_RATIOS).enumerate()
    {
        let ratio = cache / reference;
        let margin = expected * noise + 5e-4;
        assert!(
            (ratio - expected).abs() <= margin,
            "group {i}: cache / reference {ratio:.4}, expected {expected:.4} +- {margin:.4}"
        );
    }
}

/// The cache / reference ratios of [`thin_wall_means`]' four groups (inner wall face, outer wall
/// face, interior floor, outdoor ground) at 16 x 8 x 16-brick windows. Propagation is
/// deterministic and the reference seeded, so every run measures the same figures: 0.8604,
/// 0.9756, 0.9515 and 0.9787 on the software adapter (the test prints them). (0.8385, 0.9736, 0.9373 and 0.9774 before the BRDF weighed its Lambert
/// base by what the specular layer does not reflect, the cache's voxels taking that base's
/// albedo at the mean view cosine and the test's walls losing their specular layer; 0.7905,
/// 0.9791, 0.8747 and 0.9935 before rays met only the box around a
/// voxel's geometry and a thin wall standing on the floor kept its own normal: the door's
/// jambs then reached up to a voxel into the opening and blocked 22% of the sky seen through
/// it, and the voxel at the foot of the wall showed the sunlit floor outside to rays from the
/// room, which made up for part of it. Before that 0.7198, 0.9785, 0.7875 and 0.9931 before a
/// fill's updates stopped keeping history and sky seen through unfilled space, then 0.7402,
/// 0.9787, 0.8058 and 0.9933 until each side's rays were spread over four threads with their
/// own random sequences, then 0.7203, 0.9787, 0.8166 and 0.9926 until a brick's first
/// `settle_updates` updates were weighed at least 1/2 (`SETTLE_MAX_AGE`), which brings the
/// room's light nearer in 32 frames.) The test allows each ratio to move by its reference's
/// measured relative noise (a reference estimate moving by that fraction moves the ratio by
/// as much) plus 5e-4 for the rounding of these figures.
const THIN_WALL_RATIOS: [f32; 4] = [0.8604, 0.9756, 0.9515, 0.9787];

/// The same at the default shape (7 levels of 32 x 16 x 32 bricks, 10,805 bricks, which the
/// default pool holds): about 3.5 minutes on the software adapter. Run with `--ignored`.
/// Measured before rays met only the box around a voxel's geometry: inner wall 0.77 and
/// interior floor 0.87 of the reference, outer wall 0.98 and outdoor ground 0.99.
#[test]
#[ignore = "the same check at the default shape: minutes on the software adapter"]
fn thin_wall_interior_stays_dark_at_the_default_shape() {
    let Some(ctx) = GpuContext::new_or_skip("thin_wall_interior_stays_dark_at_the_default_shape")
    else {
        return;
    };
    let config = converging_config(CacheConfig::default().levels);
    check_thin_wall(&thin_wall_means(thin_wall_cache_means(&ctx, &config, 32)));
}

/// The four groups of points thin-wall's tests read: the thin wall's inner face, its outer
/// face, the interior floor and the outdoor ground. The thin wall spans x in [0, 0.05], z in
/// [-3, 3], y in [0, 2.8]; the room is x < 0.
fn thin_wall_groups() -> [(&'static str, Vec<(Vec3, Vec3)>); 4] {
    [
        (
            "thin wall, inner face",
            grid(
                Vec3::new(0.0, 0.3, -2.5),
                Vec3::Y * 2.2,
                Vec3::Z * 5.0,
                6,
                10,
                Vec3::NEG_X,
            ),
        ),
        (
            "thin wall, outer face",
            grid(
                Vec3::new(0.05, 0.3, -2.5),
                Vec3::Y * 2.2,
                Vec3::Z * 5.0,
                6,
                10,
                Vec3::X,
            ),
        ),
        (
            "interior floor",
            grid(
                Vec3::new(-3.5, 0.0, -2.5),
                Vec3::X * 2.7,
                Vec3::Z * 5.0,
                6,
                10,
                Vec3::Y,
            ),
        ),
        (
            "outdoor ground",
            grid(
                Vec3::new(0.6, 0.0, -2.5),
                Vec3::X * 2.4,
                Vec3::Z * 5.0,
                6,
                10,
                Vec3::Y,
            ),
        ),
    ]
}

/// Lights thin-wall's cache with `config` for `frames` frames and returns the mean luminance of
/// its irradiance on each of [`thin_wall_groups`].
fn thin_wall_cache_means(ctx: &GpuContext, config: &CacheConfig, frames: u32) -> [f32; 4] {
    let scene = gi_scene::load("thin-wall").unwrap();
    let frame = scene.evaluate(0.0, None);
    let mut lit = LitCache::new(ctx, config, &scene, &frame);
    let timings = run_frames(ctx, &mut lit, &frame.sky, frames);
    assert_eq!(lit.cpu.dropped_for_pool, 0, "the pool is too small");
    println!(
        "thin-wall: {} bricks, {frames} frames; median of the last {}:\n{timings}",
        lit.bricks.len(),
        frames / 2
    );
    thin_wall_groups().map(|(_, points)| mean_luminance(&cache_irradiance(ctx, &lit, &points)))
}

/// [`thin_wall_cache_means`] of the converging configuration at 16 x 8 x 16-brick windows
/// (about 2300 bricks, every one relit every frame) after 32 frames. Two tests read it, so a
/// test process lights it once: it is the suite's longest lighting run on the software
/// adapter. Lighting is deterministic, so which test's context lights it does not matter.
fn converged_thin_wall(ctx: &GpuContext) -> [f32; 4] {
    static MEANS: std::sync::OnceLock<[f32; 4]> = std::sync::OnceLock::new();
    *MEANS.get_or_init(|| {
        let config = CacheConfig {
            level_bricks: [16, 8, 16],
            ..converging_config(4)
        };
        thin_wall_cache_means(ctx, &config, 32)
    })
}

/// The mean luminance `(cache, reference, reference noise)` of the irradiance on
/// [`thin_wall_groups`], given the cache's means: the reference is the mean of two independent
/// estimates, its noise half their relative difference.
fn thin_wall_means(cache_means: [f32; 4]) -> Vec<(f32, f32, f32)> {
    let scene = gi_scene::load("thin-wall").unwrap();
    let reference = Reference::new(&scene, scene.evaluate(0.0, None));
    let mut means = Vec::new();
    for ((name, points), c) in thin_wall_groups().into_iter().zip(cache_means) {
        // Two independent reference estimates: their mean, and half their relative difference
        // as the reference's noise.
        let estimate = |seed: u64| {
            let truth: Vec<Vec3> = points
                .iter()
                .enumerate()
                .map(|(i, &(p, n))| reference.irradiance(p, n, 256, 2 * i as u64 + seed))
                .collect();
            mean_luminance(&truth)
        };
        let (a, b) = (estimate(0), estimate(1));
        let r = 0.5 * (a + b);
        let noise = (a - b).abs() / (2.0 * r);
        println!(
            "{name:>22}: cache {c:8.4}  reference {r:8.4}  ratio {:.4}  reference noise {noise:.4}",
            c / r
        );
        means.push((c, r, noise));
    }
    means
}

/// Mean luminance of the cache's irradiance over thin-wall's interior floor and the inner face
/// of its wall (the room lit through its door; as many points each) from
/// [`thin_wall_cache_means`].
fn thin_wall_interior(cache_means: [f32; 4]) -> f32 {
    0.5 * (cache_means[0] + cache_means[2])
}

#[test]
fn settling_brings_a_young_cache_nearer_its_converged_light() {
    let Some(ctx) =
        GpuContext::new_or_skip("settling_brings_a_young_cache_nearer_its_converged_light")
    else {
        return;
    };
    // About 2300 bricks at 16 x 8 x 16-brick windows; 128 relit per frame by the round-robin
    // (a brick every 18 frames), and 384 more for young bricks when settling.
    let shape = CacheConfig {
        levels: 4,
        level_bricks: [16, 8, 16],
        ..Default::default()
    };
    // Every brick relit every frame for 32 frames: the round-robin takes all of them, so the
    // settling budget has none left to add.
    let converged = thin_wall_interior(converged_thin_wall(&ctx));
    let young = |settle_bricks_per_frame| {
        let config = CacheConfig {
            light_bricks_per_frame: 128,
            settle_bricks_per_frame,
            settle_updates: 8,
            ..shape.clone()
        };
        thin_wall_interior(thin_wall_cache_means(&ctx, &config, 24))
    };
    let (round_robin, settling) = (young(0), young(384));
    println!(
        "interior irradiance after 24 frames: round-robin {round_robin:.4}, settling \
         {settling:.4}; every brick every frame for 32 frames {converged:.4}"
    );
    // Lighting is deterministic, so these figures repeat to the digit; what is asserted is the
    // mechanism. Both start dark and rise towards the converged light with every update a
    // brick gets; four times the updates, weighed at least 1/2 while young, must close at least
    // half the gap the round-robin leaves, and must not overshoot. Measured on the software
    // adapter: round-robin 0.0562, settling 0.0904, converged 0.1135 (gaps 50% and 20%). Until
    // the fill order broke distance ties by position, the round-robin's figure changed from run
    // to run (0.0541 and 0.0562 seen): which bricks it had reached depended on their pool IDs.
    // An earlier build, whose young bricks' updates were averaged like settled ones', read a
    // gap of 49% for settling.
    let gap = |e: f32| (converged - e) / converged;
    assert!(
        gap(round_robin) > 0.1,
        "the round-robin alone converged: {round_robin} of {converged}"
    );
    assert!(
        gap(settling) < 0.5 * gap(round_robin),
        "settling {settling}, round-robin {round_robin}, converged {converged}"
    );
    assert!(
        settling < 1.05 * converged,
        "{settling} overshoots {converged}"
    );
}

/// No leak through thin-wall's 5 cm wall, and the outdoors right: `means` from
/// [`thin_wall_means`].
fn check_thin_wall(means: &[(f32, f32, f32)]) {
    let inner_outer_cache = means[0].0 / means[1].0;
    let inner_outer_reference = means[0].1 / means[1].1;
    let floor_ground_cache = means[2].0 / means[3].0;
    let floor_ground_reference = means[2].1 / means[3].1;
    println!(
        "inner / outer wall: cache {inner_outer_cache:.4}, reference {inner_outer_reference:.4}; \
         interior floor / outdoor ground: cache {floor_ground_cache:.4}, reference \
         {floor_ground_reference:.4}"
    );
    // No leak: light through the 5 cm wall would put the inner sides near the outer ones (about
    // 70 times the reference's inner irradiance). Measured with 16 x 8 x 16-brick windows: the
    // cache's inner wall and interior floor are darker than the reference's (ratios 0.84 and
    // 0.94 after 32 frames, still converging: one bounce per update; 0.79 and 0.87 while the
    // door's jamb voxels narrowed the opening, 0.50 and 0.67 when lighting was stored per axis
    // face, whose hidden faces darkened the room's edges), its outer wall and the outdoor
    // ground within 3% of it. These checks hold at every window shape; `THIN_WALL_RATIOS`
    // pins the 16 x 8 x 16 figures.
    assert!(means[0].0 < 1.5 * means[0].1 && means[2].0 < 1.5 * means[2].1);
    assert!(inner_outer_cache < 2.0 * inner_outer_reference);
    assert!(means[0].0 > 0.5 * means[0].1 && means[2].0 > 0.5 * means[2].1);
    assert!(
        (means[1].0 / means[1].1 - 1.0).abs() < 0.1 && (means[3].0 / means[3].1 - 1.0).abs() < 0.1
    );
}

/// `count` points spread over the triangles of `frame` by area (none on emitters), each with its
/// triangle's geometric normal turned towards the inside of `interior` (min, max).
fn surface_points(
    scene: &Scene,
    frame: &SceneFrame,
    interior: (Vec3, Vec3),
    count: usize,
    seed: u64,
) -> Vec<(Vec3, Vec3)> {
    let candidates: Vec<(usize, f32)> = frame
        .triangles
        .iter()
        .enumerate()
        .filter(|(i, _)| {
            let material = frame.attributes[*i].material as usize;
            scene
                .materials
                .get(material)
                .is_none_or(|m| m.emissive == Vec3::ZERO)
        })
        .map(|(i, t)| {
            (
                i,
                0.5 * Vec3::from((t.v1 - t.v0).cross(t.v2 - t.v0)).length(),
            )
        })
        .collect();
    let total: f32 = candidates.iter().map(|c| c.1).sum();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let mut points = Vec::new();
    while points.len() < count {
        let mut pick = rng.random_range(0.0..total);
        let &(index, _) = candidates
            .iter()
            .find(|c| {
                pick -= c.1;
                pick <= 0.0
            })
            .unwrap_or(candidates.last().unwrap());
        let t = &frame.triangles[index];
        let (mut b1, mut b2) = (rng.random_range(0.0..1.0f32), rng.random_range(0.0..1.0f32));
        if b1 + b2 > 1.0 {
            (b1, b2) = (1.0 - b1, 1.0 - b2);
        }
        let (v0, v1, v2) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
        let p = v0 + (v1 - v0) * b1 + (v2 - v0) * b2;
        let mut n = (v1 - v0).cross(v2 - v0).normalize();
        let inside = |q: Vec3| q.cmpgt(interior.0).all() && q.cmplt(interior.1).all();
        if !inside(p + n * 0.02) {
            n = -n;
        }
        // Faces resting on the floor (block bottoms) see nothing; skip them.
        if !inside(p + n * 0.02) || (n.y < -0.5 && p.y < 0.01) {
            continue;
        }
        points.push((p, n));
    }
    points
}

/// True when no surface of another orientation or plane lies within `distance` of `p` (on a
/// surface of normal `n`): the point is away from every edge and contact by more than the
/// voxels can resolve.
fn resolved(frame: &SceneFrame, p: Vec3, n: Vec3, distance: f32) -> bool {
    frame.triangles.iter().all(|t| {
        let v = [Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2)];
        let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
        let coplanar = normal.dot(n).abs() > 0.999 && normal.dot(p - v[0]).abs() < 1e-3;
        let b = closest_point_barycentrics(v, p);
        let q = v[0] * b.x + v[1] * b.y + v[2] * b.z;
        coplanar || q.distance(p) > distance
    })
}

/// One surface point's comparison (luminances).
struct Compared {
    cache: f32,
    reference: f32,
    /// Relative difference of two independent reference estimates, halved.
    noise: f32,
    /// Relative change of the cache's value over four more frames.
    change: f32,
    /// Farther than 1.5 voxels from any other surface.
    resolved: bool,
}

#[test]
fn cornell_box_irradiance_matches_the_reference() {
    let Some(ctx) = GpuContext::new_or_skip("cornell_box_irradiance_matches_the_reference") else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = converging_config(3);
    let mut lit = LitCache::new(&ctx, &config, &scene, &frame);
    let frames = 40;
    let timings = run_frames(&ctx, &mut lit, &frame.sky, frames);
    println!(
        "cornell-box: {} bricks, {frames} frames; median of the last {}:\n{timings}",
        lit.bricks.len(),
        frames / 2
    );
    let interior = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.97, 1.0));
    let points = surface_points(&scene, &frame, interior, 160, 11);
    let voxel = config.voxel_size_m;
    let cache = cache_irradiance(&ctx, &lit, &points);
    // The cache's own fluctuation: the same points four frames later.
    run_frames(&ctx, &mut lit, &frame.sky, 4);
    let cache_later = cache_irradiance(&ctx, &lit, &points);
    // Two independent reference estimates per point give the reference's own noise.
    let reference = Reference::new(&scene, frame.clone());
    let samples = 256;
    // Per point: luminance of the cache, of the reference (mean of both estimates), the
    // reference's noise, the cache's change over four frames, and whether the voxels resolve it.
    let mut rows = Vec::new();
    for (i, &(p, n)) in points.iter().enumerate() {
        let a = luminance(reference.irradiance(p, n, samples, 2 * i as u64));
        let b = luminance(reference.irradiance(p, n, samples, 2 * i as u64 + 1));
        let r = 0.5 * (a + b);
        // Points under a block receive nothing at all: not a surface anyone sees.
        if r <= 0.0 {
            continue;
        }
        let c = luminance(cache[i]);
        let noise = (a - b).abs() / (2.0 * r);
        let change = (c - luminance(cache_later[i])).abs() / r;
        rows.push(Compared {
            cache: c,
            reference: r,
            noise,
            change,
            resolved: resolved(&frame, p, n, 1.5 * voxel),
        });
    }
    let stats = |keep: &dyn Fn(bool) -> bool| {
        let rows: Vec<&Compared> = rows.iter().filter(|row| keep(row.resolved)).collect();
        let count = rows.len() as f32;
        let mean =
            |f: &dyn Fn(&Compared) -> f32| rows.iter().map(|row| f(row)).sum::<f32>() / count;
        let relative = |row: &Compared| (row.cache - row.reference).abs() / row.reference;
        let abs_rel = mean(&relative);
        let bias = mean(&|row| row.cache) / mean(&|row| row.reference) - 1.0;
        let mut rel: Vec<f32> = rows.iter().map(|row| relative(row)).collect();
        rel.sort_by(f32::total_cmp);
        let (noise, change) = (mean(&|row| row.noise), mean(&|row| row.change));
        (rows.len(), abs_rel, rel[rel.len() / 2], bias, noise, change)
    };
    let all = stats(&|_| true);
    let away = stats(&|resolved| resolved);
    for (name, (count, abs_rel, median, bias, noise, change)) in [
        ("all points", all),
        ("points > 1.5 voxels from edges", away),
    ] {
        println!(
            "cornell-box, {name} ({count}): mean relative error {abs_rel:.4} (median {median:.3}), \
             bias {bias:+.3}; reference noise {noise:.4}, cache change over 4 frames {change:.3}"
        );
    }
    assert!(
        all.1 <= CORNELL_MAX_ERROR_ALL && away.1 <= CORNELL_MAX_ERROR_AWAY_FROM_EDGES,
        "mean relative errors {:.3} (all), {:.3} (away from edges)",
        all.1,
        away.1
    );
    assert!(
        away.3.abs() <= CORNELL_MAX_BIAS_AWAY_FROM_EDGES,
        "bias {:+.3} away from edges",
        away.3
    );
}

/// Largest mean relative error of the cache's irradiance against the reference over all
/// cornell-box sample points. Propagation gathers from the previous update's lighting, so the
/// result does not depend on the order workgroups run in: every run measures the same (the
/// reference being seeded too), now 0.4546, with reference noise 0.0415 (the mean over points
/// of half the relative difference of two independent estimates). The bound is the
/// measurement plus that noise, rounded up: each point's |cache - reference| moves by at most
/// the reference's own change, so a reference estimate within its noise moves the mean
/// relative error by at most the mean noise. History: 0.3607 (noise 0.0391) before the BRDF
/// weighed its Lambert base by what the specular layer does not reflect: where walls meet,
/// they exchange light at grazing angles, where the reference's base reflects less (8% less
/// at roughness 1) and its specular layer sends the rest onward, while the cache reflects
/// diffusely with the base's albedo at the mean view cosine (the median point's error barely
/// moved, 0.081 to 0.082; the points away from edges 0.1022 to 0.1038); 0.4167 while rays hit a voxel anywhere
/// in it rather than in the box around its geometry; 0.4410 (0.4507 earlier) while emitter
/// samples were taken at the side point, most of a voxel towards the light; 0.417 to 0.468
/// when propagation read values written earlier in its own dispatch; 0.595 per axis face,
/// voxels at concave edges reading their hidden faces' zeros.
const CORNELL_MAX_ERROR_ALL: f32 = 0.50;

/// The same over points farther than 1.5 voxels from any other surface: measured 0.1022,
/// reference noise 0.0343, bound their sum rounded up (0.1377 before the geometry box; 0.1586
/// with emitter samples at the side point; 0.160 to 0.171 depending on the run before that;
/// 0.176 per axis face).
const CORNELL_MAX_ERROR_AWAY_FROM_EDGES: f32 = 0.14;

/// Largest |bias| (the cache's mean irradiance over the reference's, minus 1) over the points
/// away from edges. Measured +0.006 (+0.017 before the geometry box); it was +0.057 while
/// emitter samples were taken at the side point, which this bound catches. The reference's
/// noise in a mean over 117 points is about 0.0343 / sqrt(117) = 0.003, so the bound leaves
/// room for that and for another adapter's rounding.
const CORNELL_MAX_BIAS_AWAY_FROM_EDGES: f32 = 0.03;

// ---------------------------------------------------------------------------------------------
// Reproducibility.
// ---------------------------------------------------------------------------------------------

#[test]
fn identical_inputs_give_bit_identical_lighting() {
    let Some(ctx) = GpuContext::new_or_skip("identical_inputs_give_bit_identical_lighting") else {
        return;
    };
    // Two caches of the same scene, lit frame by frame in alternation: every frame's gather
    // reads other bricks' indirect light, so a propagation that saw values written earlier in
    // its own dispatch would make the two differ with the order their workgroups ran in. Each
    // relights part of its bricks a frame (round-robin and settling budgets as the product
    // spends them, scaled to the scene), so they also agree only if they give every brick the
    // same pool ID: the box's symmetry puts many bricks at the same distance from the camera,
    // and the fill order breaks those ties by position, not by the hash order they were found
    // in (which differs from one cache to the next).
    let scene = gi_scene::load("cornell-box").unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig {
        levels: 3,
        light_bricks_per_frame: 48,
        settle_bricks_per_frame: 48,
        ..Default::default()
    };
    let mut a = LitCache::new(&ctx, &config, &scene, &frame);
    let mut b = LitCache::new(&ctx, &config, &scene, &frame);
    let frames = 12;
    for _ in 0..frames {
        a.frame(&ctx, &frame.sky);
        b.frame(&ctx, &frame.sky);
    }
    assert_eq!(a.bricks.len(), b.bricks.len());
    let moved = a
        .bricks
        .iter()
        .zip(&b.bricks)
        .filter(|(x, y)| x != y)
        .count();
    assert_eq!(
        moved,
        0,
        "{moved} of {} bricks differ in place or pool ID between the caches",
        a.bricks.len()
    );
    assert!(
        a.bricks.len() > 96,
        "{} bricks: every one relit every frame",
        a.bricks.len()
    );
    let (indirect_a, indirect_b) = (
        ctx.read_buffer::<u32>(&a.buffers.indirect),
        ctx.read_buffer::<u32>(&b.buffers.indirect),
    );
    let (voxels_a, voxels_b) = (a.buffers.read_voxels(&ctx), b.buffers.read_voxels(&ctx));
    let (mut sides, mut lit, mut differing, mut states_differing) = (0, 0, 0, 0);
    for brick in &a.bricks {
        let id_b = brick.brick_id;
        let mask = a.cpu.structure.brick_mask(brick.brick_id);
        assert_eq!(mask, b.cpu.structure.brick_mask(id_b));
        for bit in (0..64).filter(|bit| mask & (1u64 << bit) != 0) {
            let (voxel_a, voxel_b) = (
                voxels_a[voxel_index(brick.brick_id, bit) as usize],
                voxels_b[voxel_index(id_b, bit) as usize],
            );
            states_differing += usize::from(voxel_a.state != voxel_b.state);
            for side in 0..SIDE_COUNT {
                let value = indirect_a[side_slot(brick.brick_id, bit, side) as usize];
                sides += 1;
                lit += usize::from(unpack_rgb9e5(value) != Vec3::ZERO);
                differing += usize::from(value != indirect_b[side_slot(id_b, bit, side) as usize]);
            }
        }
    }
    println!(
        "cornell-box, {} bricks, {frames} frames: {differing} of {sides} sides' cache_indirect \
         differ ({lit} lit), {states_differing} voxel states differ",
        a.bricks.len()
    );
    assert!(
        lit > sides / 2,
        "too few lit sides to compare: {lit} of {sides}"
    );
    assert_eq!((differing, states_differing), (0, 0));
}

// ---------------------------------------------------------------------------------------------
// A changed light.
// ---------------------------------------------------------------------------------------------

/// A sunlit floor and a wall facing it whose +x side the light cannot reach (the wall's light
/// is all indirect: the floor's bounce), lit by a cache of `config`: the scene, the cache, and
/// the slots of the wall's sides facing the floor and of the floor's sides facing up.
fn sunlit_floor_and_wall(
    ctx: &GpuContext,
    config: &CacheConfig,
) -> (gi_scene::Scene, LitCache, Vec<usize>, Vec<usize>) {
    let mut builder = SceneBuilder::new(Sky::default());
    builder
        .quad(
            Vec3::new(0.9, 0.03, 0.0),
            Vec3::X * 0.85,
            Vec3::NEG_Z * 0.9,
            0.8,
        )
        .quad(
            Vec3::new(0.03, 0.5, 0.0),
            Vec3::Z * 0.9,
            Vec3::Y * 0.45,
            0.8,
        )
        .directional(5.0, Vec3::new(0.5, -1.0, 0.3));
    let scene = builder.scene.clone();
    let mut frame = scene.evaluate(0.0, None);
    frame.camera.position = Vec3::new(0.5, 0.5, 0.0);
    let lit = LitCache::new(ctx, config, &scene, &frame);
    let sides = voxel_sides(&lit.cpu);
    let wall: Vec<usize> = sides
        .iter()
        .filter(|f| f.normal.x.abs() > 0.99 && f.side_normal().x > 0.99 && f.center.y > 0.2)
        .map(|f| f.slot)
        .collect();
    let floor: Vec<usize> = sides
        .iter()
        .filter(|f| f.normal.y > 0.99 && f.side_normal().y > 0.99 && f.center.x > 0.8)
        .map(|f| f.slot)
        .collect();
    (scene, lit, wall, floor)
}

#[test]
fn the_lighting_converges_until_its_bricks_settle_and_again_after_a_light_change() {
    let Some(ctx) = GpuContext::new_or_skip("the_lighting_converges_until_its_bricks_settle")
    else {
        return;
    };
    // A brick is young for its first 3 updates; 8 bricks relit per frame by the round-robin
    // and 8 more while some are young.
    let config = CacheConfig {
        light_bricks_per_frame: 8,
        settle_bricks_per_frame: 8,
        settle_updates: 3,
        ..small_config()
    };
    let (scene, mut lit, _, _) = sunlit_floor_and_wall(&ctx, &config);
    let bricks = lit.bricks.len();
    assert!(
        bricks >= 16,
        "{bricks} bricks: too few to watch them settle"
    );
    // Young until their third update, converging while at least one brick in
    // `CONVERGING_FRACTION` is young. The settling budget goes to young bricks first, so all
    // have settled after 3 * bricks / 8 frames (the first, a fill, counts no update).
    let settled_by = (3 * bricks).div_ceil(8) + 1;
    let mut states = Vec::new();
    for _ in 0..settled_by + 4 {
        lit.frame(&ctx, &scene.sky);
        states.push(lit.lighting.converging());
    }
    let first_settled = states.iter().position(|&c| !c);
    println!("{bricks} bricks; converging per frame: {states:?}");
    let first_settled = first_settled.expect("the lighting never settled");
    assert!(states[0], "the first update (a fill) is not converging");
    // Each frame relights 16 bricks: three updates of all but one in `CONVERGING_FRACTION`
    // take at least this many frames.
    let least = 3 * (bricks - bricks / CONVERGING_FRACTION) / 16;
    assert!(
        first_settled >= least,
        "settled after {first_settled} frames, before its bricks could have 3 updates ({least})"
    );
    assert!(
        states[first_settled..].iter().all(|&c| !c),
        "converging again without a change: {states:?}"
    );
    // A change of the lights caps the cache's ages for `max_age` updates, and from the next
    // update, the lights holding still, every brick is young again: converging until both
    // are over, then settled.
    let sky = switch_the_light_off(&ctx, &scene, &mut lit);
    let mut after = Vec::new();
    let mut young = Vec::new();
    for _ in 0..config.max_age as usize + settled_by + 2 {
        lit.frame(&ctx, &sky);
        after.push(lit.lighting.converging());
        young.push(lit.lighting.last_counts().young as usize);
    }
    println!("after the light change: converging {after:?}, young {young:?}");
    assert_eq!(
        young[1], bricks,
        "every brick young once the lights hold still"
    );
    let changed = config.max_age as usize;
    let settled_again = after.iter().position(|&c| !c).expect("never settled again");
    assert!(
        settled_again >= changed && settled_again <= changed.max(settled_by + 1),
        "settled again after {settled_again} updates: {after:?}"
    );
    assert!(
        after[settled_again..].iter().all(|&c| !c),
        "converging again without a change: {after:?}"
    );
}

/// The settling budget is the full `settle_bricks_per_frame` after a load and capped at
/// `relight_bricks_per_frame` after a change of the lights, until every brick has settled.
#[test]
fn a_light_change_settles_the_bricks_with_the_relight_budget() {
    let Some(ctx) = GpuContext::new_or_skip("a_light_change_settles_the_bricks_with_the_relight")
    else {
        return;
    };
    let config = CacheConfig {
        light_bricks_per_frame: 4,
        settle_bricks_per_frame: 12,
        relight_bricks_per_frame: 5,
        settle_updates: 3,
        ..small_config()
    };
    let (scene, mut lit, _, _) = sunlit_floor_and_wall(&ctx, &config);
    let bricks = lit.bricks.len();
    assert!(
        bricks >= 24,
        "{bricks} bricks: too few to spend the budgets"
    );
    // Every brick's 3 updates, at least 4 + 5 a frame, and the first frame (a fill) counts none.
    let bound = (3 * bricks).div_ceil(9) + 2;
    let settle = |lit: &mut LitCache, sky: &Sky| {
        let mut counts = Vec::new();
        for _ in 0..bound {
            lit.frame(&ctx, sky);
            counts.push(lit.lighting.last_counts());
        }
        counts
    };
    let load = settle(&mut lit, &scene.sky);
    let settles = |counts: &[ScheduleCounts]| counts.iter().map(|c| c.settle).collect::<Vec<_>>();
    println!(
        "{bricks} bricks; settling bricks per frame after the load: {:?}",
        settles(&load)
    );
    assert_eq!(load.last().unwrap().young, 0, "not settled after the load");
    assert!(
        load.iter()
            .any(|c| c.settle == config.settle_bricks_per_frame),
        "the load never spent the full settling budget"
    );
    let sky = switch_the_light_off(&ctx, &scene, &mut lit);
    let after = settle(&mut lit, &sky);
    println!("after the light change: {:?}", settles(&after));
    // The update of the change itself finds every brick settled; from the next, all are young.
    assert_eq!(after[0].settle, 0);
    assert_eq!(after[1].young as usize, bricks);
    assert!(
        after
            .iter()
            .all(|c| c.settle <= config.relight_bricks_per_frame),
        "the relighting spent more than its budget"
    );
    assert_eq!(after[1].settle, config.relight_bricks_per_frame);
    assert_eq!(
        after.last().unwrap().young,
        0,
        "not settled again after the change"
    );
}

/// After a change of the lights the old light leaves every brick's indirect light within a
/// few of its own updates, however long the round-robin takes to come round: the bricks settle
/// again from the settling budget, each update weighing at least 1/2.
#[test]
fn a_light_change_leaves_every_brick_within_a_few_updates() {
    let Some(ctx) = GpuContext::new_or_skip("a_light_change_leaves_every_brick") else {
        return;
    };
    // One brick a frame from the round-robin: it alone would come round each brick once per
    // `bricks` frames. Eight more while some are young, and young for 8 updates.
    let config = CacheConfig {
        light_bricks_per_frame: 1,
        settle_bricks_per_frame: 8,
        settle_updates: 8,
        max_age: 32,
        ..small_config()
    };
    let (scene, mut lit, wall, _) = sunlit_floor_and_wall(&ctx, &config);
    let bricks = lit.bricks.len();
    // Settled: every brick has had its 8 updates, 9 a frame.
    let settled_by = 8 * bricks.div_ceil(9) + 1;
    run_frames(&ctx, &mut lit, &scene.sky, settled_by as u32 + 2);
    assert!(!lit.lighting.converging());
    let mean = |values: &[Vec3]| {
        wall.iter().map(|&s| luminance(values[s])).sum::<f32>() / wall.len() as f32
    };
    let lit_wall = mean(&lit.read_sides(&ctx).1);
    assert!(lit_wall > 0.05, "{lit_wall}");

    let sky = switch_the_light_off(&ctx, &scene, &mut lit);
    // Each update at weight 1/2 halves the old light a brick holds, less what it gathers back
    // from the floor's equally stale bounce (the wall-floor-wall loop returns a small share,
    // which slows the halving to about 0.55 an update); 6 updates leave under 3%. With 9
    // bricks a frame that takes 6 * bricks / 9 frames, and one more for the change itself,
    // where the lights have not yet held still.
    let within = (6 * bricks).div_ceil(9) + 2;
    let mut fraction = Vec::new();
    for _ in 0..within {
        lit.frame(&ctx, &sky);
        fraction.push(mean(&lit.read_sides(&ctx).1) / lit_wall);
    }
    println!(
        "{bricks} bricks; the wall's indirect light after switching off, per frame, as a \
         fraction of before: {fraction:.3?}"
    );
    let last = *fraction.last().unwrap();
    assert!(
        last < 0.05,
        "{last} of the old light left after {within} frames"
    );
}

/// The measured change: a still scene measures none, and after the light goes out the wall's
/// light (all of it the floor's bounce) follows within four updates, because its rays see the
/// floor's light change; weighed by age alone (gain 0) it takes many more. Every brick is relit
/// in every frame, so what differs is only the weight of each update.
#[test]
fn a_measured_change_drops_the_old_bounce_within_four_updates_and_none_is_measured_while_still() {
    let Some(ctx) = GpuContext::new_or_skip("a_measured_change_drops_the_old_bounce") else {
        return;
    };
    let mut left = Vec::new();
    for gain in [3.0, 0.0] {
        let config = CacheConfig {
            change_gain: gain,
            ..small_config()
        };
        let (scene, mut lit, wall, floor) = sunlit_floor_and_wall(&ctx, &config);
        assert!(lit.bricks.len() as u32 <= config.light_bricks_per_frame);
        // Past the settling updates and the largest age.
        run_frames(&ctx, &mut lit, &scene.sky, config.max_age + 8);
        let changes = lit.read_changes(&ctx);
        let measured = changes.iter().filter(|&&c| c > 0.0).count();
        assert_eq!(measured, 0, "gain {gain}: change measured in a still scene");
        let mean = |values: &[Vec3]| {
            wall.iter().map(|&s| luminance(values[s])).sum::<f32>() / wall.len() as f32
        };
        let lit_wall = mean(&lit.read_sides(&ctx).1);
        assert!(lit_wall > 0.05, "{lit_wall}");

        let sky = switch_the_light_off(&ctx, &scene, &mut lit);
        let mut fraction = Vec::new();
        for frame in 0..4 {
            lit.frame(&ctx, &sky);
            fraction.push(mean(&lit.read_sides(&ctx).1) / lit_wall);
            if frame == 0 && gain > 0.0 {
                // The floor's voxels (their sides' slots halved) measured nearly all their light
                // going, and kept half of that for their neighbours after their own update.
                let changes = lit.read_changes(&ctx);
                let floor_changed = floor.iter().filter(|&&s| changes[s / 2] >= 0.4).count();
                assert_eq!(
                    floor_changed,
                    floor.len(),
                    "floor sides that measured the change"
                );
            }
        }
        println!("gain {gain}: the wall's light left after each update: {fraction:.3?}");
        left.push(*fraction.last().unwrap());
    }
    // Issue 37's goal for a light switched off: at most 10% of its bounce after 4 frames.
    assert!(left[0] <= 0.10, "{:.3} left after 4 updates", left[0]);
    assert!(
        left[0] * 2.0 < left[1],
        "measured {:.3}, by age alone {:.3}",
        left[0],
        left[1]
    );
}

/// A change is kept until the voxel's next update weighs it, however late, and `cache/change_age`
/// counts the frames since it was measured, which the passes reading the cache on screen use to
/// count only a change measured this frame or the last.
#[test]
fn a_measured_change_waits_for_its_voxels_update_and_counts_its_frames() {
    let Some(ctx) = GpuContext::new_or_skip("a_measured_change_waits_for_its_voxels_update") else {
        return;
    };
    // One brick relit per frame, no settling: most bricks wait many frames for their update.
    let config = CacheConfig {
        light_bricks_per_frame: 1,
        settle_bricks_per_frame: 0,
        settle_updates: 0,
        ..small_config()
    };
    let (scene, mut lit, _, floor) = sunlit_floor_and_wall(&ctx, &config);
    let bricks = lit.bricks.len() as u32;
    assert!(bricks > 4, "{bricks} bricks");
    run_frames(&ctx, &mut lit, &scene.sky, 2 * bricks + 1);
    let sky = switch_the_light_off(&ctx, &scene, &mut lit);
    // The change's frame relights every brick's direct light (`cache/inject_all`) and measures
    // the change there; four frames later at most four bricks had their update since.
    let mut frames = Vec::new();
    for _ in 0..4 {
        lit.frame(&ctx, &sky);
        let states = lit.read_states(&ctx);
        let waiting: Vec<u32> = (floor.iter())
            .map(|&s| states[s / 2])
            .filter(|&state| state_change(state) > 0.0)
            .map(state_change_frames)
            .collect();
        frames.push(waiting);
    }
    let first = &frames[0];
    let last = &frames[3];
    println!(
        "floor voxels with a change after 1 and 4 frames: {}, {}; their frame counts then: {:?}",
        first.len(),
        last.len(),
        last
    );
    assert_eq!(
        first.len(),
        floor.len(),
        "floor voxels that measured the change"
    );
    assert!(first.iter().all(|&f| f == 0), "{first:?}");
    // Still waiting for their update three frames on: counted up to the maximum, 3.
    assert!(
        last.iter().filter(|&&f| f == 3).count() * 2 >= last.len() && !last.is_empty(),
        "{last:?}"
    );
}

/// The scene of [`sunlit_floor_and_wall`] without its light, uploaded into `lit`.
fn switch_the_light_off(ctx: &GpuContext, scene: &gi_scene::Scene, lit: &mut LitCache) -> Sky {
    let mut dark = scene.clone();
    dark.lights.clear();
    dark.nodes.retain(|n| n.light.is_none());
    let dark_frame = dark.evaluate(0.0, None);
    lit.gpu_scene = GpuScene::upload(ctx, &dark, &dark_frame).unwrap();
    lit.lights = dark_frame.lights.clone();
    dark.sky
}

#[test]
fn a_light_change_relights_every_bricks_direct_light_at_once() {
    let Some(ctx) = GpuContext::new_or_skip("a_light_change_relights_every_brick") else {
        return;
    };
    // Four bricks lit per update: the schedule alone would take many updates to reach them all.
    let config = CacheConfig {
        light_bricks_per_frame: 4,
        ..small_config()
    };
    let (scene, mut lit, _, floor) = sunlit_floor_and_wall(&ctx, &config);
    run_frames(&ctx, &mut lit, &scene.sky, 4);
    // Run until every floor side has been scheduled once.
    let mut lit_sides = 0;
    for _ in 0..64 {
        lit.frame(&ctx, &scene.sky);
        let (direct, _) = lit.read_sides(&ctx);
        lit_sides = floor
            .iter()
            .filter(|&&s| direct[s].max_element() > 0.0)
            .count();
        if lit_sides == floor.len() {
            break;
        }
    }
    assert_eq!(
        lit_sides,
        floor.len(),
        "the schedule never reached every floor side"
    );
    let sky = switch_the_light_off(&ctx, &scene, &mut lit);
    lit.frame(&ctx, &sky);
    let (direct, _) = lit.read_sides(&ctx);
    let still_lit = floor
        .iter()
        .filter(|&&s| direct[s].max_element() > 0.0)
        .count();
    println!(
        "{} floor sides, {still_lit} still lit one update after the light went off",
        floor.len()
    );
    assert_eq!(
        still_lit, 0,
        "cache/inject_all must relight every brick at once"
    );
}

#[test]
fn a_light_switched_off_is_followed_within_a_few_frames() {
    let Some(ctx) = GpuContext::new_or_skip("a_light_switched_off_is_followed") else {
        return;
    };
    let config = CacheConfig {
        max_age: 32,
        ..small_config()
    };
    let (scene, mut lit, wall, floor) = sunlit_floor_and_wall(&ctx, &config);
    let mean = |values: &[Vec3], slots: &[usize]| {
        slots.iter().map(|&s| luminance(values[s])).sum::<f32>() / slots.len() as f32
    };
    run_frames(&ctx, &mut lit, &scene.sky, 40);
    let (direct, indirect) = lit.read_sides(&ctx);
    let (floor_before, wall_before) = (mean(&direct, &floor), mean(&indirect, &wall));
    println!(
        "light on, 40 frames: floor direct {floor_before:.4}, wall indirect {wall_before:.4} \
         ({} floor, {} wall sides)",
        floor.len(),
        wall.len()
    );
    assert!(floor_before > 1.0 && wall_before > 0.05);

    // Switch the light off: upload the scene without it.
    let sky = switch_the_light_off(&ctx, &scene, &mut lit);
    let mut followed = None;
    for k in 1..=16 {
        lit.frame(&ctx, &sky);
        let (direct, indirect) = lit.read_sides(&ctx);
        let (floor_now, wall_now) = (mean(&direct, &floor), mean(&indirect, &wall));
        println!(
            "frame {k} after switching off: floor direct {floor_now:.4}, wall indirect \
             {wall_now:.4} ({:.1}% of before)",
            100.0 * wall_now / wall_before
        );
        assert_eq!(floor_now, 0.0, "direct light must follow at once");
        if followed.is_none() && wall_now < 0.05 * wall_before {
            followed = Some(k);
        }
    }
    println!("the wall's indirect light fell below 5% of its value after {followed:?} frames");
    // Stale light fades at least as (3/4)^k (CHANGED_MAX_AGE = 4): below 5% after 11 updates;
    // two frames of slack for the bounce the floor still holds in the first updates.
    assert!(followed.is_some_and(|k| k <= 13));
}

// ---------------------------------------------------------------------------------------------
// Through RadianceCache, on every bundled scene.
// ---------------------------------------------------------------------------------------------

/// Runs `frames` updates of a default-configured [`RadianceCache`] with its lighting attached,
/// and returns the median pass times of the last half and the lighting's last schedule.
fn radiance_cache_frames(ctx: &GpuContext, name: &str, frames: u32) -> (PassTimings, u32) {
    let scene = gi_scene::load(name).unwrap();
    let frame = scene.evaluate(0.0, None);
    let gpu_scene = GpuScene::upload(ctx, &scene, &frame).unwrap();
    let mut cache = RadianceCache::new(ctx, &CacheConfig::default()).unwrap();
    CacheLighting::attach(ctx, &ShaderLibrary::new(), &mut cache).unwrap();
    let mut timer = GpuTimer::new(ctx, "cache.lighting.test", 12);
    let mut timings = Vec::new();
    for i in 0..frames {
        let mut rec = Recorder::new(ctx, &mut timer, "cache.lighting.test");
        cache.record(
            &mut rec,
            &CacheInputs {
                scene: &scene,
                frame: &frame,
                gpu_scene: &gpu_scene,
                camera_position: frame.camera.position,
                gbuffer: None,
            },
        );
        let encoder = rec.into_encoder();
        let t = timer.finish(ctx, encoder);
        if i >= frames / 2 {
            timings.push(t);
        }
    }
    let bricks = cache.stats().allocated_bricks;
    (PassTimings::median(&timings), bricks)
}

#[test]
fn radiance_cache_runs_the_lighting_passes_after_voxelizing() {
    let Some(ctx) = GpuContext::new_or_skip("radiance_cache_runs_the_lighting_passes") else {
        return;
    };
    let (timings, bricks) = radiance_cache_frames(&ctx, "cornell-box", 4);
    println!("cornell-box through RadianceCache, {bricks} bricks:\n{timings}");
    for pass in ["cache/inject", "cache/propagate", "cache/propagate_resolve"] {
        assert!(timings.get(pass).is_some(), "{pass}: {timings}");
    }
    let names: Vec<&str> = timings.0.iter().map(|(n, _)| n.as_str()).collect();
    let voxelize = names.iter().position(|n| n.starts_with("cache/voxelize"));
    let inject = names.iter().position(|&n| n == "cache/inject");
    assert!(
        voxelize.is_none_or(|v| inject.is_some_and(|i| v < i)),
        "{names:?}"
    );
    let propagate = names.iter().position(|&n| n == "cache/propagate");
    let resolve = names.iter().position(|&n| n == "cache/propagate_resolve");
    assert!(propagate < resolve, "{names:?}");
}

// ---------------------------------------------------------------------------------------------
// Furnace.
// ---------------------------------------------------------------------------------------------

/// A closed cube whose six inward faces all emit `le` and reflect `albedo`: every point inside
/// receives the same irradiance, `pi le / (1 - albedo)` (the radiance everywhere inside is
/// `L = le + albedo E / pi` and `E = pi L`).
fn furnace_scene(le: f32, albedo: f32) -> (Scene, Vec3) {
    let center = Vec3::new(0.011, 0.023, 0.037);
    let h = 0.7;
    let mut builder = SceneBuilder::new(Sky::default());
    for n in FACE_DIRECTIONS {
        let u = n.any_orthonormal_vector() * h;
        builder.quad(center - n * h, u, n.cross(u), albedo);
        builder.scene.materials.last_mut().unwrap().emissive = Vec3::splat(le);
    }
    (builder.scene, center)
}

/// One accumulation window of the furnace: the cache's mean irradiance over the front sides of
/// the flat-wall voxels, as a ratio to the exact `pi le / (1 - albedo)`, and those sides'
/// packed `cache_indirect` and `cache_emitted` values in world order.
struct FurnaceWindow {
    ratio: f32,
    indirect: Vec<u32>,
    emitted: Vec<u32>,
}

/// The furnace's windows: every 8th frame from frame 48 to 96 (each an independent window of
/// the accumulation's 8 updates).
fn furnace_windows(ctx: &GpuContext, le: f32, albedo: f32) -> Vec<FurnaceWindow> {
    let (scene, center) = furnace_scene(le, albedo);
    let mut frame = scene.evaluate(0.0, None);
    frame.camera.position = center;
    let config = CacheConfig {
        light_bricks_per_frame: 512,
        max_age: 8,
        keep_emitted: true,
        ..small_config()
    };
    let mut lit = LitCache::new(ctx, &config, &scene, &frame);
    let exact = std::f32::consts::PI * le / (1.0 - albedo);
    // Voxels of one wall (edge and corner voxels hold two or three walls, and their averaged
    // normals lean off every wall's: what reaches their surface point differs).
    let mut sides: Vec<Side> = voxel_sides(&lit.cpu)
        .into_iter()
        .filter(|s| s.side == SIDE_FRONT && s.normal.abs().max_element() > 0.99)
        .collect();
    assert!(sides.len() > 2000, "{} sides", sides.len());
    // In world order: bricks the same distance from the camera get their pool slots in any
    // order, so two runs are compared side by side by place.
    sides.sort_by_key(|s| (s.level, s.voxel.to_array()));
    let mut windows = Vec::new();
    for f in 1..=96 {
        lit.frame(ctx, &scene.sky);
        if f >= 48 && f % 8 == 0 {
            let (direct, indirect) = lit.read_sides(ctx);
            let sum: f32 = sides
                .iter()
                .map(|s| luminance(direct[s.slot] + indirect[s.slot]))
                .sum();
            let packed = |buffer| {
                let all: Vec<u32> = ctx.read_buffer(buffer);
                sides.iter().map(|s| all[s.slot]).collect()
            };
            windows.push(FurnaceWindow {
                ratio: sum / sides.len() as f32 / exact,
                indirect: packed(&lit.buffers.indirect),
                emitted: packed(&lit.buffers.emitted),
            });
        }
    }
    windows
}

fn mean_and_standard_error(values: &[f32]) -> (f32, f32) {
    let n = values.len() as f32;
    let mean = values.iter().sum::<f32>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / (n - 1.0);
    (mean, (variance / n).sqrt())
}

/// White furnace: a closed cube of emitting, reflecting walls, without sky or lights.
/// - With albedo 0 the cache holds only the emitters' next-event samples: pi le within 4
///   standard errors of the mean over the windows, and every side's emitted part
///   (`cache_emitted`) is all of its indirect irradiance, bit for bit.
/// - With albedo 0.5 every bounce adds half the light again (`1 / (1 - albedo)` in all): the
///   gather and the accumulation lose no energy. The two runs draw the same random numbers,
///   so their difference is measured per window, and must be 0 within 4 standard errors of
///   its mean over the windows. Their emitted parts are the same samples, so they must be
///   identical: the bounced light (what the PC tier reads at its hits, which samples the
///   emitters itself) is then exactly the albedo's share.
///
/// Found by this test: the emitters' samples read 1.3% low (0.9887 +- 0.0021; 2.2% with 32
/// rays per side). A sample's shadow ray leaves from the side point, most of a voxel off the
/// wall, and an emitter point below that point's plane (the strip of a neighbouring wall next
/// to the edge, where `1 / d^2` is largest) counted as blocked although the surface sees it.
/// Since those count: 1.0004 +- 0.0018, and cornell-box's cache test is unchanged.
#[test]
fn furnace_propagation_keeps_the_energy_of_every_bounce() {
    let Some(ctx) = GpuContext::new_or_skip("furnace_propagation_keeps_the_energy_of_every_bounce")
    else {
        return;
    };
    let le = 0.5;
    let black_windows = furnace_windows(&ctx, le, 0.0);
    let grey_windows = furnace_windows(&ctx, le, 0.5);
    let ratios = |windows: &[FurnaceWindow]| windows.iter().map(|w| w.ratio).collect::<Vec<_>>();
    let (black, grey) = (ratios(&black_windows), ratios(&grey_windows));
    let (mean_black, se_black) = mean_and_standard_error(&black);
    let differences: Vec<f32> = grey.iter().zip(&black).map(|(g, b)| g - b).collect();
    let (difference, se_difference) = mean_and_standard_error(&differences);
    println!(
        "furnace: albedo 0 {mean_black:.4} +- {se_black:.4} of pi le ({black:?}); albedo 0.5 \
         {grey:?}; difference {difference:.4} +- {se_difference:.4}"
    );
    assert!(
        difference.abs() <= 4.0 * se_difference,
        "albedo 0.5 against 0: {difference} (standard error {se_difference})"
    );
    assert!(
        (mean_black - 1.0).abs() <= 4.0 * se_black,
        "emitters' samples: {mean_black} of pi le (standard error {se_black})"
    );
    for (black, grey) in black_windows.iter().zip(&grey_windows) {
        assert!(black.emitted.iter().any(|&e| e != 0));
        assert_eq!(
            black.emitted, black.indirect,
            "albedo 0: all indirect light is emitted"
        );
        assert_eq!(
            black.emitted, grey.emitted,
            "the emitted part depends on the albedo"
        );
        assert_ne!(grey.emitted, grey.indirect);
    }
}

/// cornell-box's light panel switched off (an edit of its material: the frame's material
/// revision changes, so the GPU scene uploads its material and emitter tables again): the
/// lighting reports the change in that update only, and the cache's light, all of which came
/// from the panel, fades (2.9% left after 16 updates on lavapipe; it would stay where it was if
/// the emitters kept their power).
#[test]
fn a_lamp_switched_off_leaves_the_cache() {
    let Some(ctx) = GpuContext::new_or_skip("a_lamp_switched_off_leaves_the_cache") else {
        return;
    };
    let mut scene = gi_scene::load("cornell-box").unwrap();
    let mut frame = scene.evaluate(0.0, None);
    let config = converging_config(3);
    let mut lit = LitCache::new(&ctx, &config, &scene, &frame);
    run_frames(&ctx, &mut lit, &frame.sky, config.max_age + 8);
    assert!(!lit.lighting.lights_changed());
    let total = |lit: &LitCache| {
        let (direct, indirect) = lit.read_sides(&ctx);
        (direct.iter().chain(&indirect))
            .map(|&v| luminance(v))
            .sum::<f32>()
    };
    let before = total(&lit);
    let light = (scene.materials.iter())
        .position(|m| m.emissive != Vec3::ZERO)
        .unwrap();
    scene.materials[light].emissive = Vec3::ZERO;
    frame.material_revision = 1;
    lit.gpu_scene.update(&ctx, &scene, &frame).unwrap();
    assert_eq!(lit.gpu_scene.emitter_count, 0);
    let mut left = Vec::new();
    for update in 0..16 {
        lit.frame(&ctx, &frame.sky);
        assert_eq!(
            lit.lighting.lights_changed(),
            update == 0,
            "update {update}"
        );
        left.push(total(&lit) / before);
    }
    println!("left after each update: {left:.3?}");
    assert!(left[15] <= 0.10, "{:.3} left after 16 updates", left[15]);
}
