//! The mobile tier's probe volume (`gi_tiers::mobile::ProbeVolume`) on scenes built in code,
//! with the brick cache filled on the CPU and lit by hand so every expected value is known:
//! open ground under a constant sky against the cache's own radiance, relocation out of a thick
//! slab, no light leaking into a closed room through its wall, and a clipmap shift that keeps
//! the probes that stay. The struct layouts are checked by the unit tests of
//! `mobile::volume` (the GPU structs are not exported).

use gi_cache::layout::{mask_cell, side_normal, voxel_index};
use gi_cache::lighting::side_point;
use gi_cache::packing::unpack_unit_vector;
use gi_cache::{CacheBuffers, CacheConfig, CacheTracer, CpuCache};
use gi_gpu::bvh::GpuRay;
use gi_gpu::{GpuContext, GpuTimer, PassTimings, Recorder, ShaderLibrary, Technique};
use gi_scene::{Scene, Sky};
use gi_tiers::mobile::{ProbeVolume, VolumeConfig, VolumeInputs};
use glam::{Vec3, Vec4};
use rand::Rng as _;
use rand_pcg::Pcg32;

// ---------------------------------------------------------------------------------------------
// Scenes, a hand-lit cache and the volume's frames.
// ---------------------------------------------------------------------------------------------

/// Radiance of the constant sky of every test.
const SKY: f32 = 1.0;

fn sky() -> Sky {
    Sky::Constant {
        radiance: Vec3::splat(SKY),
    }
}

/// A scene assembled in code: one node per quad.
struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    fn new() -> Self {
        Self {
            scene: Scene {
                name: "mobile-volume-test".into(),
                sky: sky(),
                exposure: 1.0,
                ..Default::default()
            },
        }
    }

    /// A parallelogram `center +- u +- v`, front face `u x v`, of grey diffuse `albedo`.
    fn quad(&mut self, center: Vec3, u: Vec3, v: Vec3, albedo: f32) -> &mut Self {
        self.scene.add_diffuse_quad(center, u, v, albedo);
        self
    }

    /// The six faces of the box `[min, max]`, facing out (or in, for a room's inside).
    fn box_faces(&mut self, min: Vec3, max: Vec3, outward: bool, albedo: f32) -> &mut Self {
        self.box_sides(min, max, outward, albedo, true)
    }

    /// The box's faces, its bottom only when `bottom` (a box standing on a ground that closes
    /// it would otherwise put two faces of opposite normals in the same place).
    fn box_sides(
        &mut self,
        min: Vec3,
        max: Vec3,
        outward: bool,
        albedo: f32,
        bottom: bool,
    ) -> &mut Self {
        let c = 0.5 * (min + max);
        let h = 0.5 * (max - min);
        let (x, y, z) = (Vec3::X * h.x, Vec3::Y * h.y, Vec3::Z * h.z);
        // (center offset, u, v) with u x v along the offset.
        let faces = [
            (x, y, z),
            (-x, z, y),
            (y, z, x),
            (-y, x, z),
            (z, x, y),
            (-z, y, x),
        ];
        for (i, (offset, u, v)) in faces.into_iter().enumerate() {
            if i == 3 && !bottom {
                continue;
            }
            let (u, v) = if outward { (u, v) } else { (v, u) };
            self.quad(c + offset, u, v, albedo);
        }
        self
    }

    /// A ground quad of half-size `half_m` at height `y`, facing up.
    fn ground(&mut self, y: f32, half_m: f32, albedo: f32) -> &mut Self {
        self.quad(
            Vec3::new(0.0, y, 0.0),
            Vec3::Z * half_m,
            Vec3::X * half_m,
            albedo,
        )
    }
}

/// The cache shape of the tests: 12.5 cm voxels doubling over 4 levels of 16 x 8 x 16 bricks
/// (8 x 4 x 8 m to 64 x 32 x 64 m), small enough to voxelize on the CPU in a moment.
fn cache_config() -> CacheConfig {
    CacheConfig {
        voxel_size_m: 0.125,
        levels: 4,
        level_bricks: [16, 8, 16],
        pool_bricks: 4096,
        near_levels: 2,
        ..Default::default()
    }
}

/// The volume shape of the tests: 2 levels of 12 x 6 x 12 probes, 0.5 m and 2 m apart, and
/// 8 rays per probe and frame so a few dozen frames reach a few dozen samples per face.
fn volume_config() -> VolumeConfig {
    VolumeConfig {
        probes: [12, 6, 12],
        rays_per_probe: 8,
        ..Default::default()
    }
}

/// Builds `scene`'s cache around `camera` on the CPU, lights every voxel side with
/// `irradiance(point the side is lit at, side normal)` (as direct light) and uploads it.
fn lit_cache(
    ctx: &GpuContext,
    scene: &Scene,
    camera: Vec3,
    irradiance: impl Fn(Vec3, Vec3) -> Vec3,
) -> CacheBuffers {
    let config = cache_config();
    let frame = scene.evaluate(0.0, None);
    let mut cpu = CpuCache::build(&config, scene, &frame, camera).unwrap();
    assert_eq!(
        cpu.dropped_for_pool, 0,
        "the test cache's pool is too small"
    );
    for b in cpu.bricks.clone() {
        let size = config.voxel_size_at(b.level);
        let mask = cpu.structure.brick_mask(b.id);
        for bit in (0..64).filter(|bit| mask & (1u64 << bit) != 0) {
            let voxel = b.brick * 4 + mask_cell(bit).as_ivec3();
            let center = (voxel.as_vec3() + 0.5) * size;
            let normal = unpack_unit_vector(cpu.voxels[voxel_index(b.id, bit) as usize].normal);
            for side in 0..2 {
                let n = side_normal(normal, side);
                let e = irradiance(side_point(center, size, n), n);
                cpu.set_side_irradiance(b.id, bit, side, e, Vec3::ZERO);
            }
        }
    }
    cpu.upload(ctx)
}

/// Runs `frames` volume updates (frame indices `first..first + frames`) at `camera` and returns
/// the median pass times of the last half.
fn run(
    ctx: &GpuContext,
    volume: &mut ProbeVolume,
    cache: &CacheBuffers,
    camera: Vec3,
    first: u32,
    frames: u32,
) -> PassTimings {
    let mut timer = GpuTimer::new(ctx, "mobile.volume.test", 2);
    let mut timings = Vec::new();
    for frame in first..first + frames {
        let mut rec = Recorder::new(ctx, &mut timer, "mobile.volume.test");
        let sky = sky();
        let inputs = VolumeInputs {
            cache,
            camera_position: camera,
            sky: &sky,
            frame_index: frame,
            restart: false,
        };
        volume.record(&mut rec, &inputs);
        let encoder = rec.into_encoder();
        let t = timer.finish(ctx, encoder);
        if frame >= first + frames / 2 {
            timings.push(t);
        }
    }
    PassTimings::median(&timings)
}

/// Seeded random numbers for the reference rays.
struct Rng(Pcg32);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(Pcg32::new(seed, 0x0a02_bdbf_7bb3_c0a7))
    }

    fn next_f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    /// A cosine-distributed direction about unit `axis`.
    fn cosine_about(&mut self, axis: Vec3) -> Vec3 {
        let (r, phi) = (
            self.next_f32().sqrt(),
            std::f32::consts::TAU * self.next_f32(),
        );
        let (t, b) = axis.any_orthonormal_pair();
        let z = (1.0 - r * r).max(0.0).sqrt();
        (t * r * phi.cos() + b * r * phi.sin() + axis * z).normalize()
    }
}

/// Outward normals of the ambient cube's faces, in the volume's order.
const FACES: [Vec3; 6] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
];

fn luminance(v: Vec3) -> f32 {
    v.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

// ---------------------------------------------------------------------------------------------
// Open ground under a constant sky.
// ---------------------------------------------------------------------------------------------

#[test]
fn open_ground_faces_match_the_cache_and_the_sky() {
    let Some(ctx) = GpuContext::new_or_skip("open_ground_faces_match_the_cache_and_the_sky") else {
        return;
    };
    // A 60 x 60 m ground of albedo 0.5 at y = -0.1 whose every side receives pi * L_sky (what
    // a plane under a constant sky and nothing else receives): its radiance is 0.5 L_sky.
    let mut builder = SceneBuilder::new();
    builder.ground(-0.1, 30.0, 0.5);
    let scene = builder.scene.clone();
    let camera = Vec3::new(0.3, 1.0, 0.2);
    let e_ground = std::f32::consts::PI * SKY;
    let cache = lit_cache(&ctx, &scene, camera, |_, _| Vec3::splat(e_ground));
    let shaders = ShaderLibrary::new();
    let config = volume_config();
    let mut volume = ProbeVolume::new(&ctx, &shaders, &config).unwrap();
    let frames = 24;
    let timings = run(&ctx, &mut volume, &cache, camera, 0, frames);
    println!("{frames} frames, median of the last half:\n{timings}");

    let probes = volume.read_probes(&ctx);
    let active: Vec<_> = probes.iter().filter(|p| p.active && !p.buried).collect();
    // Activity: the probes of level 0 within a spacing of the ground (one row per level, as
    // seen from the bricks' grid) are active, none far above it.
    assert!(!active.is_empty());
    for p in &probes {
        let height = p.coord.y as f32 * config.spacing_at(p.level) + 0.1;
        if p.active {
            assert!(height < 2.0 * config.spacing_at(p.level), "{p:?}");
        }
    }
    // Every active level-0 probe above the ground: all six faces against the cache's radiance
    // along cosine rays from the same spot (its `CacheTracer`).
    let tracer = CacheTracer::new(&ctx, &shaders).unwrap();
    let checked: Vec<_> = active
        .iter()
        .filter(|p| p.level == 0 && p.position.y > 0.0 && p.position.x.abs() < 1.5)
        .take(6)
        .collect();
    assert!(
        checked.len() >= 4,
        "{} probes above the ground",
        checked.len()
    );
    let rays_per_face = 2048;
    let mut rng = Rng::new(7);
    let mut worst = 0.0f32;
    for p in &checked {
        for (face, &axis) in FACES.iter().enumerate() {
            let dirs: Vec<Vec3> = (0..rays_per_face).map(|_| rng.cosine_about(axis)).collect();
            let rays: Vec<GpuRay> = dirs
                .iter()
                .map(|&d| GpuRay::new(p.position, d, 0.0, 1e30))
                .collect();
            let samples: Vec<f32> = tracer
                .trace(&ctx, &cache, &rays)
                .iter()
                .map(|h| {
                    let l = if h.hit { h.radiance } else { Vec3::splat(SKY) };
                    std::f32::consts::PI * luminance(l)
                })
                .collect();
            let n_ref = samples.len() as f32;
            let mean = samples.iter().sum::<f32>() / n_ref;
            let variance = samples.iter().map(|s| (s - mean).powi(2)).sum::<f32>() / (n_ref - 1.0);
            let n_probe = p.face_samples[face].min(config.max_age) as f32;
            assert!(n_probe >= 8.0, "face {face} of {p:?}");
            // The probe's face is the mean of its own n samples (n <= max_age here): both means
            // are estimates of the same integral, so their difference has variance
            // sigma^2 (1/n + 1/N); 4 sigma, plus 1e-4 relative for f32 sums.
            let sigma = (variance * (1.0 / n_probe + 1.0 / n_ref)).sqrt();
            let got = luminance(p.irradiance[face]);
            let tolerance = 4.0 * sigma + 1e-4 * mean;
            if sigma > 1e-3 {
                worst = worst.max((got - mean).abs() / sigma);
            }
            assert!(
                (got - mean).abs() <= tolerance,
                "face {face} of probe at {}: {got} vs cache {mean} +- {tolerance} (n = {n_probe})",
                p.position
            );
            if face == 2 {
                // The upper hemisphere sees only sky: exactly pi L_sky.
                assert!(
                    (got - std::f32::consts::PI * SKY).abs() <= 1e-4 * got,
                    "{got}"
                );
            }
        }
    }
    println!(
        "{} probes x 6 faces within {worst:.2} sigma of the cache's radiance; E(+y) = pi L_sky",
        checked.len()
    );

    // The ground itself: the volume's irradiance for an upward normal is what the cache holds
    // there (pi L_sky: the ground sees only sky).
    let points: Vec<(Vec3, Vec3)> = (0..8)
        .map(|i| {
            (
                Vec3::new(-1.2 + 0.33 * i as f32, -0.1, 0.4 - 0.1 * i as f32),
                Vec3::Y,
            )
        })
        .collect();
    let cached = tracer.irradiance(&ctx, &cache, &points);
    let gathered = volume.irradiance_at(&ctx, &cache, &points);
    for ((&(point, _), e_cache), e_volume) in points.iter().zip(&cached).zip(&gathered) {
        let e_cache = luminance(e_cache.expect("the cache holds the ground"));
        let e = luminance(e_volume.truncate());
        // RGB9E5 rounds the cache's value by up to 2^-9 of it.
        assert!(e_volume.w > 0.0, "{point}: no probe");
        assert!(
            (e - e_cache).abs() <= 4e-3 * e_cache,
            "{point}: volume {e} vs cache {e_cache}"
        );
    }
    println!(
        "ground: volume {:?} vs cache pi L_sky",
        gathered.iter().map(|e| e.x).collect::<Vec<_>>()
    );
    volume.release(&ctx);
    assert_eq!(ctx.memory().bytes_with_prefix("mobile.volume."), 0);
}

// ---------------------------------------------------------------------------------------------
// Relocation.
// ---------------------------------------------------------------------------------------------

#[test]
fn probes_inside_a_thick_slab_move_out_of_it() {
    let Some(ctx) = GpuContext::new_or_skip("probes_inside_a_thick_slab_move_out_of_it") else {
        return;
    };
    // A closed 2.2 x 1.1 x 2.2 m slab holding 5 x 3 x 5 level-0 grid points (0.5 m apart): the
    // rows y = 0.5 and y = 1.5 lie 5 cm inside its bottom and top faces, the row y = 1.0 0.55 m
    // deep. A probe moves by at most 0.45 spacings (0.225 m) per axis, so the outer rows and
    // the grid points 10 cm inside its sides can leave it; the 3 x 3 deep ones cannot and are
    // buried.
    let (min, max) = (Vec3::new(-1.1, 0.45, -1.1), Vec3::new(1.1, 1.55, 1.1));
    let mut builder = SceneBuilder::new();
    builder.box_faces(min, max, true, 0.5);
    let scene = builder.scene.clone();
    let camera = Vec3::new(0.2, 1.2, 0.2);
    let cache = lit_cache(&ctx, &scene, camera, |_, _| Vec3::ONE);
    let config = volume_config();
    let spacing = config.spacing_at(0);
    let mut volume = ProbeVolume::new(&ctx, &ShaderLibrary::new(), &config).unwrap();
    run(&ctx, &mut volume, &cache, camera, 0, 2);

    let inside = |q: Vec3| q.cmpgt(min).all() && q.cmplt(max).all();
    let probes = volume.read_probes(&ctx);
    let (mut moved, mut buried) = (0, 0);
    for p in probes.iter().filter(|p| p.level == 0) {
        let grid = p.coord.as_vec3() * spacing;
        let offset = p.position - grid;
        assert!(
            offset.abs().max_element() <= 0.45 * spacing + 1e-5,
            "{p:?}: offset {offset}"
        );
        if !inside(grid) {
            if p.active
                && ((grid - min).abs().min_element()).min((grid - max).abs().min_element()) > 0.25
            {
                // Grid points more than two cache voxels from every face plane stay put.
                assert_eq!(offset, Vec3::ZERO, "{p:?}");
            }
            continue;
        }
        let deep = (grid - min).min(max - grid).min_element() > 0.45 * spacing;
        if deep {
            // No surface within a spacing (the cache holds surfaces): inactive, or buried.
            buried += 1;
            assert!((!p.active || p.buried) && p.age == 0, "{p:?}");
        } else {
            moved += 1;
            assert!(p.active && !p.buried, "{p:?}");
            // Out of the slab by more than 0.8 cache voxels (12.5 cm), its own voxel empty.
            let q = p.position;
            let clearance = (min - q).max(q - max).max_element();
            assert!(
                clearance > 0.1,
                "{grid} -> {q}: {clearance} m outside the slab"
            );
        }
    }
    assert_eq!((moved, buried), (66, 9), "grid points inside the slab");
    // The moved probes were traced from free space: the face of a moved probe that looks at
    // the slab (across the face plane it left through, at distance h) sees its lit side (each
    // sample pi L = 0.5: radiance 0.5 / pi), and the sky's pi only past that face's edges. The
    // face's cosine-weighted share of directions passing an edge at inside distance d is
    // (1 - d / sqrt(d^2 + h^2)) / 2; the sum over the four edges bounds the sky's share f
    // (corners counted twice). The face's value is the mean of its n samples, so it may exceed
    // its expectation 0.5 + f (pi - 0.5) by 4 standard deviations of that mean,
    // (pi - 0.5) sqrt(f (1 - f) / n). Over all moved probes the mean stays below half the
    // sky's pi.
    run(&ctx, &mut volume, &cache, camera, 2, 6);
    let probes = volume.read_probes(&ctx);
    let (mut below, mut above, mut beside) = (0, 0, 0);
    let sky = std::f32::consts::PI * SKY;
    let mut sum = 0.0;
    for p in probes
        .iter()
        .filter(|p| p.level == 0 && p.active && !p.buried && inside(p.coord.as_vec3() * spacing))
    {
        let q = p.position;
        let outside = (min - q).max(q - max);
        let axis = outside.max_position();
        let h = outside[axis];
        let towards_slab = if q[axis] < min[axis] {
            2 * axis
        } else {
            2 * axis + 1
        };
        match towards_slab {
            2 => below += 1,
            3 => above += 1,
            _ => beside += 1,
        }
        let n = p.face_samples[towards_slab].min(config.max_age);
        assert!(n > 0, "{p:?}");
        let f = [(axis + 1) % 3, (axis + 2) % 3]
            .into_iter()
            .flat_map(|b| [q[b] - min[b], max[b] - q[b]])
            .map(|d| 0.5 * (1.0 - d / (d * d + h * h).sqrt()))
            .sum::<f32>()
            .min(1.0);
        let expected = 0.5 + f * (sky - 0.5);
        let deviation = (sky - 0.5) * (f * (1.0 - f) / n as f32).sqrt();
        let e = luminance(p.irradiance[towards_slab]);
        assert!(
            e <= expected + 4.0 * deviation + 1e-3,
            "{e} (sky's share at most {f}, expected at most {expected} + 4 x {deviation}): {p:?}"
        );
        sum += e;
    }
    assert_eq!(
        below + above + beside,
        moved,
        "({below}, {above}, {beside})"
    );
    // The 3 x 3 inner probes of the bottom and top rows can only leave downwards or upwards.
    assert!(below >= 9 && above >= 9, "({below}, {above}, {beside})");
    let mean = sum / moved as f32;
    assert!(
        mean < 0.5 * sky,
        "mean {mean} over the probes facing the slab"
    );
    println!(
        "{moved} probes moved out of the slab ({below} below, {above} above, {beside} beside), \
         {buried} buried"
    );
}

// ---------------------------------------------------------------------------------------------
// No leak through a wall.
// ---------------------------------------------------------------------------------------------

#[test]
fn a_closed_dark_room_stays_dark_beside_a_bright_outside() {
    let Some(ctx) =
        GpuContext::new_or_skip("a_closed_dark_room_stays_dark_beside_a_bright_outside")
    else {
        return;
    };
    // A closed room (interior x in [-2.65, 0.35], y in [0, 2.4], z in [-1.65, 1.65]) with
    // 10 cm walls on a large ground. Its +x wall, x in [0.35, 0.45], sits between the level-0
    // probe planes x = 0 and x = 0.5. Every side lit inside the room is black, every side
    // outside receives 3 (as if sunlit).
    let (inner_min, inner_max) = (Vec3::new(-2.65, 0.0, -1.65), Vec3::new(0.35, 2.4, 1.65));
    let wall = 0.1;
    let mut builder = SceneBuilder::new();
    builder
        .ground(-wall, 30.0, 0.5)
        .box_faces(inner_min, inner_max, false, 0.5)
        .box_sides(inner_min - wall, inner_max + wall, true, 0.5, false);
    let scene = builder.scene.clone();
    // The camera outside the wall at mid height; 8 probe rows (4 m) keep every query point
    // at least 2 cells inside level 0's window, where level 1 (2 m apart, too coarse for a
    // 10 cm wall) does not blend in.
    let camera = Vec3::new(0.6, 0.6, 0.1);
    let inside = move |q: Vec3| q.cmpgt(inner_min).all() && q.cmplt(inner_max).all();
    let cache = lit_cache(&ctx, &scene, camera, |p, _| {
        if inside(p) {
            Vec3::ZERO
        } else {
            Vec3::splat(3.0)
        }
    });
    let shaders = ShaderLibrary::new();
    let config = VolumeConfig {
        probes: [12, 8, 12],
        ..volume_config()
    };
    let mut volume = ProbeVolume::new(&ctx, &shaders, &config).unwrap();
    let frames = 24;
    let timings = run(&ctx, &mut volume, &cache, camera, 0, frames);
    println!("{frames} frames, median of the last half:\n{timings}");

    // Points on the wall's inner face (normal -x) and on the floor beside it (normal +y),
    // and their mirror images outside (outer face x = 0.45, normal +x; ground beyond).
    let mut inner = Vec::new();
    let mut outer = Vec::new();
    for i in 0..6 {
        let y = 0.4 + 0.1 * i as f32;
        let z = -0.6 + 0.25 * i as f32;
        inner.push((Vec3::new(inner_max.x, y, z), Vec3::NEG_X));
        outer.push((Vec3::new(inner_max.x + wall, y, z), Vec3::X));
        inner.push((Vec3::new(inner_max.x - 0.1, 0.0, z), Vec3::Y));
        outer.push((Vec3::new(inner_max.x + wall + 0.1, -wall, z), Vec3::Y));
    }
    let tracer = CacheTracer::new(&ctx, &shaders).unwrap();
    let mean =
        |values: &[Vec3]| values.iter().map(|&v| luminance(v)).sum::<f32>() / values.len() as f32;
    let cache_of = |points: &[(Vec3, Vec3)]| -> Vec<Vec3> {
        tracer
            .irradiance(&ctx, &cache, points)
            .into_iter()
            .map(|e| e.unwrap())
            .collect()
    };
    let volume_of =
        |points: &[(Vec3, Vec3)]| -> Vec<Vec4> { volume.irradiance_at(&ctx, &cache, points) };
    let (cache_in, cache_out) = (mean(&cache_of(&inner)), mean(&cache_of(&outer)));
    let v_in = volume_of(&inner);
    let v_out = volume_of(&outer);
    assert!(
        v_in.iter().chain(&v_out).all(|e| e.w > 0.0),
        "{v_in:?} {v_out:?}"
    );
    let volume_in = mean(&v_in.iter().map(|e| e.truncate()).collect::<Vec<_>>());
    let volume_out = mean(&v_out.iter().map(|e| e.truncate()).collect::<Vec<_>>());
    println!(
        "inside: volume {volume_in:.5}, cache {cache_in:.5}; outside: volume {volume_out:.4}, \
         cache {cache_out:.4}; ratio inside / outside {:.2e}",
        volume_in / volume_out
    );
    assert_eq!(cache_in, 0.0, "the room is closed and unlit");
    assert!(cache_out > 1.0);
    // Outside, the volume is bright: of the order of the cache's value (the hand lighting, 3 on
    // every outside side, is not what this sky would deliver, so the two need not agree).
    assert!(volume_out > 0.5 * cache_out, "{volume_out} vs {cache_out}");
    // Inside: the wall's inner points take 45% of their trilinear weight from the probes beyond
    // the wall (the floor points 30%), so a volume without visibility would put them at about
    // 0.4 of the outside value; the back-face term and the depth moments must keep them dark.
    // Measured: 5e-5 of the outside (deterministic: the rays are seeded). The bound, 1%, is
    // 40 times below the leak without visibility.
    assert!(volume_in < 0.01 * volume_out, "{volume_in} vs {volume_out}");
}

// ---------------------------------------------------------------------------------------------
// Clipmap shift.
// ---------------------------------------------------------------------------------------------

#[test]
fn a_camera_move_keeps_staying_probes_and_resets_entering_ones() {
    let Some(ctx) =
        GpuContext::new_or_skip("a_camera_move_keeps_staying_probes_and_resets_entering_ones")
    else {
        return;
    };
    let mut builder = SceneBuilder::new();
    builder.ground(-0.1, 30.0, 0.5).box_faces(
        Vec3::new(-1.0, -0.1, -0.6),
        Vec3::new(0.2, 0.8, 0.4),
        true,
        0.5,
    );
    let scene = builder.scene.clone();
    let camera = Vec3::new(0.6, 1.0, 0.2);
    let cache = lit_cache(&ctx, &scene, camera, |_, n| Vec3::splat(1.0 + n.y));
    let shaders = ShaderLibrary::new();
    let config = volume_config();
    // Two volumes with the same history, then one moves by one level-0 spacing along x (the
    // level-1 window stays: floor(0.6 / 2) = floor(1.1 / 2)). Random sequences are indexed by
    // slot and frame, and a world coordinate keeps its slot, so a probe that stays must hold
    // exactly what it holds in the volume that did not move.
    let mut still = ProbeVolume::new(&ctx, &shaders, &config).unwrap();
    let mut moved = ProbeVolume::new(&ctx, &shaders, &config).unwrap();
    let frames = 8;
    run(&ctx, &mut still, &cache, camera, 0, frames + 1);
    run(&ctx, &mut moved, &cache, camera, 0, frames);
    let shift = Vec3::X * config.spacing_at(0);
    run(&ctx, &mut moved, &cache, camera + shift, frames, 1);

    let a = still.read_probes(&ctx);
    let b = moved.read_probes(&ctx);
    let new_max_x = (camera.x + shift.x) / config.spacing_at(0);
    let entering_x = new_max_x.floor() as i32 + config.probes[0] as i32 / 2 - 1;
    let (mut kept, mut entered, mut kept_active) = (0, 0, 0);
    for (slot, (pa, pb)) in a.iter().zip(&b).enumerate() {
        if pb.level == 0 && pb.coord.x == entering_x {
            entered += 1;
            assert_ne!(pa.coord, pb.coord, "slot {slot}");
            // Reset on entry, then one frame of rays at most.
            assert!(pb.age <= config.rays_per_probe, "{pb:?}");
            assert!(
                pb.face_samples.iter().sum::<u32>() <= config.rays_per_probe,
                "{pb:?}"
            );
        } else {
            kept += 1;
            assert_eq!(pa, pb, "slot {slot}");
            kept_active += usize::from(pb.active && pb.age > config.rays_per_probe);
        }
    }
    let per_plane = (config.probes[1] * config.probes[2]) as usize;
    assert_eq!(entered, per_plane);
    assert!(kept_active > 20, "{kept_active} active probes kept");
    println!("{kept} slots kept ({kept_active} active with history), {entered} reset");
    still.release(&ctx);
    moved.release(&ctx);
}

// ---------------------------------------------------------------------------------------------
// Memory and cost of the default configuration.
// ---------------------------------------------------------------------------------------------

#[test]
fn default_volume_memory_and_frame_cost() {
    let Some(ctx) = GpuContext::new_or_skip("default_volume_memory_and_frame_cost") else {
        return;
    };
    let mut builder = SceneBuilder::new();
    builder.ground(-0.1, 30.0, 0.5).box_faces(
        Vec3::new(-2.0, -0.1, -2.0),
        Vec3::new(2.0, 2.5, 2.0),
        false,
        0.5,
    );
    let scene = builder.scene.clone();
    let camera = Vec3::new(0.3, 1.2, 0.1);
    let cache = lit_cache(&ctx, &scene, camera, |_, n| Vec3::splat(1.0 + n.y));
    let config = VolumeConfig::default();
    let mut volume = ProbeVolume::new(&ctx, &ShaderLibrary::new(), &config).unwrap();
    let bytes = volume.memory_bytes(&ctx);
    println!(
        "default volume: {bytes} bytes ({:.2} MiB)",
        bytes as f64 / (1 << 20) as f64
    );
    assert!(bytes <= 3 << 20, "{bytes}");
    let timings = run(&ctx, &mut volume, &cache, camera, 0, 8);
    let active = volume.read_probes(&ctx).iter().filter(|p| p.active).count();
    println!(
        "{active} of {} probes active; median frame of the last 4:\n{timings}",
        config.slot_count()
    );
    assert!(timings.get("mobile/volume").is_some());
    volume.release(&ctx);
}
