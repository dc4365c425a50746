//! GPU BVH traversal against the CPU's: every ray's nearest triangle, distance and
//! barycentrics, and every shadow ray's occlusion, on bundled scenes (lavapipe in CI).
//!
//! Camera rays, random rays from in and around the scene bounds (some with a finite `t_max`),
//! shadow rays from camera hits towards the lights, and diffuse-like rays leaving those hits.
//! The only accepted disagreements are ties: rays the CPU finds at (nearly) the same distance
//! on two triangles (a shared edge, overlapping faces), where either answer is right. Their
//! count is reported and must stay rare.

mod common;

use common::{ray, test_rays};
use gi_gpu::GpuContext;
use gi_gpu::ShaderLibrary;
use gi_gpu::bvh::{BvhTracer, GpuBvh, GpuRay};
use gi_scene::{SceneBvh, Triangle};
use glam::{Vec2, Vec3, Vec3A};

/// Relative tolerance on hit distances: the GPU repeats the CPU's f32 operations, but may
/// fuse multiply-adds differently.
const T_REL: f32 = 1e-4;

/// Largest share of rays allowed to be ties (two triangles at the same distance): they are
/// rays through shared edges and vertices, a measure-zero set that rounding makes a little
/// larger.
const MAX_TIE_SHARE: f64 = 0.005;

/// How one scene's rays compared.
#[derive(Debug, Default)]
struct Agreement {
    rays: usize,
    hits: usize,
    occluded: usize,
    ties: usize,
}

fn compare_scene(ctx: &GpuContext, tracer: &BvhTracer, name: &str, seed: u64) -> Agreement {
    let scene = gi_scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
    let frame = scene.evaluate(0.0, None);
    let cpu = SceneBvh::build(&frame.triangles);
    let gpu = GpuBvh::upload(ctx, &cpu.bvh, &frame.triangles).expect("BVH uploads");
    let rays = test_rays(&frame, &cpu, seed);
    let results = tracer.trace(ctx, &gpu, &rays);
    assert_eq!(results.hits.len(), rays.len());
    gpu.release(ctx);

    let triangles = &frame.triangles;
    let mut agreement = Agreement {
        rays: rays.len(),
        ..Default::default()
    };
    for (i, (r, gpu_hit)) in rays.iter().zip(&results.hits).enumerate() {
        let (origin, dir) = (Vec3::from(r.origin), Vec3::from(r.dir));
        let cpu_hit = cpu.closest_hit(triangles, origin, dir, r.t_min, r.t_max);
        let cpu_occluded = cpu.occluded(triangles, origin, dir, r.t_min, r.t_max);
        assert_eq!(
            results.occluded[i], cpu_occluded,
            "{name} ray {i} {r:?}: GPU occluded {} but CPU {cpu_occluded}",
            results.occluded[i]
        );
        agreement.occluded += cpu_occluded as usize;
        match (cpu_hit, gpu_hit.triangle()) {
            (None, None) => {}
            (Some(c), Some(g)) if c.triangle == g => {
                agreement.hits += 1;
                assert!(
                    (gpu_hit.t - c.t).abs() <= T_REL * c.t.max(1e-3),
                    "{name} ray {i}: t GPU {} CPU {}",
                    gpu_hit.t,
                    c.t
                );
                let bary = Vec2::from(gpu_hit.barycentrics);
                assert!(
                    (bary - c.barycentrics).abs().max_element() < 1e-3,
                    "{name} ray {i}: barycentrics GPU {bary} CPU {}",
                    c.barycentrics
                );
            }
            (Some(c), Some(g)) if same_distance(&triangles[g as usize], r, c.t) => {
                agreement.hits += 1;
                agreement.ties += 1;
            }
            (c, g) => {
                panic!("{name} ray {i} {r:?}: CPU hit {c:?}, GPU hit {gpu_hit:?} (triangle {g:?})")
            }
        }
    }
    agreement
}

/// Whether `tri` is hit by the ray at (nearly) `t` too: then the CPU's choice was a tie.
fn same_distance(tri: &Triangle, r: &GpuRay, t: f32) -> bool {
    let ray = obvhs::ray::Ray::new(
        Vec3A::from_array(r.origin),
        Vec3A::from_array(r.dir),
        r.t_min,
        r.t_max,
    );
    let t_other = tri.intersect(&ray);
    (t_other - t).abs() <= T_REL * t.max(1e-3)
}

#[test]
fn gpu_traversal_matches_cpu_on_bundled_scenes() {
    let Some(ctx) = GpuContext::new_or_skip("gpu_traversal_matches_cpu_on_bundled_scenes") else {
        return;
    };
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new()).expect("trace shader composes");
    for (seed, name) in ["cornell-box", "atrium", "glossy", "open-world"]
        .into_iter()
        .enumerate()
    {
        let agreement = compare_scene(&ctx, &tracer, name, seed as u64 + 1);
        eprintln!("{name}: {agreement:?}");
        assert!(
            agreement.hits > agreement.rays / 4,
            "{name}: too few hits to mean anything"
        );
        assert!(
            agreement.ties as f64 <= MAX_TIE_SHARE * agreement.rays as f64,
            "{name}: {} ties in {} rays",
            agreement.ties,
            agreement.rays
        );
    }
    assert_eq!(
        ctx.memory().bytes_with_prefix("bvh."),
        0,
        "every BVH buffer released"
    );
}

/// Two stacked triangles: the nearer one is the closest hit, a segment ending between them is
/// blocked only by the nearer one, and a ray beside them misses.
#[test]
fn known_answers_on_two_triangles() {
    let Some(ctx) = GpuContext::new_or_skip("known_answers_on_two_triangles") else {
        return;
    };
    let tri = |z: f32| Triangle {
        v0: Vec3A::new(0.0, 0.0, z),
        v1: Vec3A::new(4.0, 0.0, z),
        v2: Vec3A::new(0.0, 4.0, z),
    };
    let triangles = [tri(-5.0), tri(-2.0)];
    let cpu = SceneBvh::build(&triangles);
    let gpu = GpuBvh::upload(&ctx, &cpu.bvh, &triangles).expect("BVH uploads");
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new()).expect("trace shader composes");
    let origin = Vec3::new(1.0, 2.0, 0.0);
    let rays = [
        ray(origin, Vec3::NEG_Z, 0.0, 100.0),
        ray(origin, Vec3::NEG_Z, 0.0, 1.5),
        ray(Vec3::new(3.5, 3.5, 0.0), Vec3::NEG_Z, 0.0, 100.0),
        // Negative zeros (what negating an axis-aligned direction gives) trace like +0.0.
        ray(origin, Vec3::new(-0.0, -0.0, -1.0), 0.0, 100.0),
        ray(origin, Vec3::new(0.0, -0.0, -1.0), 0.0, 100.0),
    ];
    let results = tracer.trace(&ctx, &gpu, &rays);
    for (i, hit) in results.hits.iter().enumerate().skip(3) {
        assert_eq!(hit.triangle(), Some(1), "ray {i}");
        assert!((hit.t - 2.0).abs() < 1e-5, "ray {i}");
    }
    assert_eq!(results.hits[0].triangle(), Some(1));
    assert!((results.hits[0].t - 2.0).abs() < 1e-5);
    let bary = Vec2::from(results.hits[0].barycentrics);
    assert!((bary - Vec2::new(0.25, 0.5)).length() < 1e-5, "{bary}");
    assert_eq!(results.occluded, [true, false, false, true, true]);
    assert_eq!(results.hits[1].triangle(), None);
    assert_eq!(results.hits[2].triangle(), None);
}

/// A scene without triangles uploads a childless root: every ray misses.
#[test]
fn empty_bvh_misses_everything() {
    let Some(ctx) = GpuContext::new_or_skip("empty_bvh_misses_everything") else {
        return;
    };
    let cpu = SceneBvh::build(&[]);
    let gpu = GpuBvh::upload(&ctx, &cpu.bvh, &[]).expect("empty BVH uploads");
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new()).expect("trace shader composes");
    let rays = [ray(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY)];
    let results = tracer.trace(&ctx, &gpu, &rays);
    assert_eq!(results.hits[0].triangle(), None);
    assert_eq!(results.occluded, [false]);
}
