//! The two-level GPU BVH (`GpuBvh::from_scene` + `update`) against the CPU's single BVH over
//! the flattened world-space frame: every bundled scene, the animated `dynamic` scene at several
//! times, and a scene of many moving, mirrored and parented copies of a mesh.
//!
//! Static geometry is traced in world space exactly as the CPU traces it, so its hits must
//! agree as tightly as the single-level test's. A moving node's triangles are traced in object
//! space: the CPU tests `fl(world_from_object * v)` while the GPU tests `v` against
//! `fl(object_from_world * ray)`, so the two see the same surface displaced by the rounding of
//! one 4x4 transform and its inverse. That displacement is bounded by
//! `POSITION_ULPS * f32::EPSILON * (|origin| + |hit| + scene radius)` in world units; along the
//! ray it becomes a distance error of that over `|dir| |cos|` (the cosine between the ray and
//! the triangle's normal). Disagreements on the triangle are accepted only as documented ties:
//! two triangles at the same distance (shared edges), or a ray passing within that displacement
//! of a moving triangle's edge (a silhouette, hit on one side and missed on the other).

mod common;

use common::{Rng, test_rays};
use gi_gpu::bvh::{
    BVH_MISS, BvhTracer, GpuBvh, GpuCwBvhNode, GpuHit, GpuRay, MeshSharing, TraceResults,
};
use gi_gpu::{GpuContext, ShaderLibrary};
use gi_scene::{
    Animation, Channel, ChannelValues, Interpolation, Node, Scene, SceneBvh, SceneFrame, Triangle,
};
use glam::{Quat, Vec2, Vec3, Vec3A};

/// Relative tolerance on distances of static hits (the single-level test's).
const T_REL: f32 = 1e-4;

/// Rounding of the object-space path in units of `f32::EPSILON` times the coordinates'
/// magnitude: the inverse (a few ulps per entry), the ray transform (3 products and sums), and
/// the world-space vertices of the CPU (3 products and sums), with a factor of 4 for the
/// magnitudes of the matrix entries.
const POSITION_ULPS: f32 = 64.0;

/// Largest share of rays allowed to be ties.
const MAX_TIE_SHARE: f64 = 0.01;

#[derive(Debug, Default)]
struct Agreement {
    rays: usize,
    hits: usize,
    ties: usize,
}

/// World-space rounding allowance at a hit point `p` of the ray from `origin`.
fn position_tolerance(origin: Vec3, p: Vec3, radius: f32) -> f32 {
    POSITION_ULPS * f32::EPSILON * (origin.length() + p.length() + radius)
}

/// Distance from the point with barycentrics `(b1, b2)` on `tri` to the nearest edge.
fn edge_distance(tri: &Triangle, b: Vec2) -> f32 {
    let [a, bb, c] = [tri.v0, tri.v1, tri.v2].map(Vec3::from);
    let double_area = (bb - a).cross(c - a).length();
    let weights = [1.0 - b.x - b.y, b.x, b.y];
    let opposite = [(c - bb).length(), (c - a).length(), (bb - a).length()];
    (0..3)
        .map(|i| weights[i].abs() * double_area / opposite[i].max(1e-30))
        .fold(f32::INFINITY, f32::min)
}

fn obvhs_ray(r: &GpuRay) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(
        Vec3A::from_array(r.origin),
        Vec3A::from_array(r.dir),
        r.t_min,
        r.t_max,
    )
}

/// Compares GPU results with the CPU's single BVH over `frame`; `moving[i]` says whether frame
/// triangle `i` belongs to a moving node.
fn compare(
    label: &str,
    frame: &SceneFrame,
    moving: &[bool],
    rays: &[GpuRay],
    results: &TraceResults,
) -> Agreement {
    let triangles = &frame.triangles;
    let cpu = SceneBvh::build(triangles);
    let radius = scene_radius(triangles);
    let mut agreement = Agreement {
        rays: rays.len(),
        ..Default::default()
    };
    for (i, (r, gpu_hit)) in rays.iter().zip(&results.hits).enumerate() {
        let (origin, dir) = (Vec3::from(r.origin), Vec3::from(r.dir));
        let cpu_hit = cpu.closest_hit(triangles, origin, dir, r.t_min, r.t_max);
        // Allowed distance error for a hit at `t` on triangle `tri`.
        let t_tolerance = |tri: u32, t: f32| {
            let mut tolerance = T_REL * t.max(1e-3);
            if moving[tri as usize] {
                let normal = Vec3::from(triangles[tri as usize].compute_normal());
                let cos = normal.dot(dir).abs().max(1e-3);
                let p = origin + dir * t;
                tolerance += position_tolerance(origin, p, radius) / cos;
            }
            tolerance
        };
        // A ray within the rounding allowance of a moving triangle's edge.
        let grazes_edge = |tri: u32, t: f32| {
            let triangle = &triangles[tri as usize];
            let p = origin + dir * t;
            let b = barycentrics(triangle, origin, dir);
            moving[tri as usize]
                && edge_distance(triangle, b) <= position_tolerance(origin, p, radius)
        };
        let tie = match (cpu_hit, gpu_hit.triangle()) {
            (None, None) => false,
            (Some(c), Some(g)) if c.triangle == g => {
                agreement.hits += 1;
                assert!(
                    (gpu_hit.t - c.t).abs() <= t_tolerance(g, c.t),
                    "{label} ray {i}: t GPU {} CPU {} (tolerance {})",
                    gpu_hit.t,
                    c.t,
                    t_tolerance(g, c.t)
                );
                let bary = Vec2::from(gpu_hit.barycentrics);
                let bary_tolerance = if moving[g as usize] { 1e-2 } else { 1e-3 };
                assert!(
                    (bary - c.barycentrics).abs().max_element() < bary_tolerance,
                    "{label} ray {i}: barycentrics GPU {bary} CPU {}",
                    c.barycentrics
                );
                false
            }
            (Some(c), Some(g))
                if (triangles[g as usize].intersect(&obvhs_ray(r)) - c.t).abs()
                    <= t_tolerance(g, c.t).max(t_tolerance(c.triangle, c.t))
                    || grazes_edge(c.triangle, c.t)
                    || grazes_edge(g, gpu_hit.t) =>
            {
                agreement.hits += 1;
                true
            }
            (Some(c), None) if grazes_edge(c.triangle, c.t) => true,
            (None, Some(g)) if grazes_edge(g, gpu_hit.t) => true,
            (c, g) => panic!("{label} ray {i} {r:?}: CPU hit {c:?}, GPU {gpu_hit:?} ({g:?})"),
        };
        agreement.ties += tie as usize;
        let cpu_occluded = cpu.occluded(triangles, origin, dir, r.t_min, r.t_max);
        if results.occluded[i] != cpu_occluded {
            // Occlusion is "a closest hit before t_max": it can only differ on a tie or on a
            // moving hit within the distance tolerance of t_max.
            let near_end = cpu_hit.is_some_and(|c| {
                moving[c.triangle as usize] && (r.t_max - c.t).abs() <= t_tolerance(c.triangle, c.t)
            });
            assert!(
                tie || near_end,
                "{label} ray {i} {r:?}: GPU occluded {}, CPU {cpu_occluded}",
                results.occluded[i]
            );
        }
    }
    agreement
}

/// The CPU's barycentric weights of v1 and v2 where the ray's line meets the triangle's plane.
fn barycentrics(tri: &Triangle, origin: Vec3, dir: Vec3) -> Vec2 {
    let bvh = SceneBvh::build(std::slice::from_ref(tri));
    bvh.closest_hit(
        std::slice::from_ref(tri),
        origin,
        dir,
        f32::MIN,
        f32::INFINITY,
    )
    .map_or(Vec2::ZERO, |h| h.barycentrics)
}

fn scene_radius(triangles: &[Triangle]) -> f32 {
    triangles
        .iter()
        .flat_map(|t| [t.v0, t.v1, t.v2])
        .map(|v| v.length())
        .fold(0.0, f32::max)
}

/// Per frame triangle: whether its node moves.
fn moving_triangles(scene: &Scene, frame: &SceneFrame) -> Vec<bool> {
    let moving = scene.moving_nodes();
    frame
        .attributes
        .iter()
        .map(|a| moving[a.node as usize])
        .collect()
}

fn check(label: &str, agreement: &Agreement) {
    eprintln!("{label}: {agreement:?}");
    assert!(
        agreement.hits > agreement.rays / 4,
        "{label}: too few hits to mean anything"
    );
    assert!(
        agreement.ties as f64 <= MAX_TIE_SHARE * agreement.rays as f64,
        "{label}: {} ties in {} rays",
        agreement.ties,
        agreement.rays
    );
}

fn context(name: &str) -> Option<(GpuContext, BvhTracer)> {
    let ctx = GpuContext::new_or_skip(name)?;
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new()).expect("trace shader composes");
    Some((ctx, tracer))
}

#[test]
fn two_level_matches_cpu_on_every_bundled_scene() {
    let Some((ctx, tracer)) = context("two_level_matches_cpu_on_every_bundled_scene") else {
        return;
    };
    for (seed, (name, _)) in gi_scene::BUNDLED_SCENES.iter().enumerate() {
        let scene = gi_scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let frame = scene.evaluate(0.0, None);
        let gpu = GpuBvh::from_scene(&ctx, &scene, &frame).expect("BVH uploads");
        eprintln!(
            "{name}: {} instances, bottom {} nodes depth {}, top {} nodes depth {}, build {:.1} ms, \
             update {:.3} ms",
            gpu.instance_count,
            gpu.node_count,
            gpu.depth,
            gpu.top_node_count,
            gpu.top_depth,
            gpu.build_seconds * 1e3,
            gpu.update_seconds * 1e3
        );
        let rays = test_rays(&frame, &SceneBvh::build(&frame.triangles), seed as u64 + 11);
        let results = tracer.trace(&ctx, &gpu, &rays);
        let moving = moving_triangles(&scene, &frame);
        check(name, &compare(name, &frame, &moving, &rays, &results));
        gpu.release(&ctx);
    }
    assert_eq!(
        ctx.memory().bytes_with_prefix("bvh."),
        0,
        "every BVH buffer released"
    );
}

/// Built once at time 0, then only updated: at every later time the hits equal the CPU's over
/// that time's flattened frame, and equal a fresh build's at that time bit for bit (the same
/// bottom levels and the same top level, built from the same boxes).
fn updates_match_cpu_and_fresh_builds(scene: &Scene, label: &str, times: &[f32]) {
    let Some((ctx, tracer)) = context(label) else {
        return;
    };
    let first = scene.evaluate(0.0, None);
    let mut gpu = GpuBvh::from_scene(&ctx, scene, &first).expect("BVH uploads");
    assert!(
        gpu.instance_count > 1,
        "{label}: the scene should have moving instances"
    );
    for (k, &time) in times.iter().enumerate() {
        let frame = scene.evaluate(time, None);
        gpu.update(&ctx, &frame).expect("top level fits the stack");
        let rays = test_rays(&frame, &SceneBvh::build(&frame.triangles), 100 + k as u64);
        let updated = tracer.trace(&ctx, &gpu, &rays);
        let moving = moving_triangles(scene, &frame);
        let at = format!("{label} at {time} s");
        check(&at, &compare(&at, &frame, &moving, &rays, &updated));

        let fresh = GpuBvh::from_scene(&ctx, scene, &frame).expect("BVH uploads");
        let rebuilt = tracer.trace(&ctx, &fresh, &rays);
        let bits = |hits: &[GpuHit]| -> Vec<[u32; 4]> {
            hits.iter().map(|h| bytemuck::cast(*h)).collect()
        };
        assert_eq!(
            bits(&updated.hits),
            bits(&rebuilt.hits),
            "{at}: update differs from a rebuild"
        );
        assert_eq!(updated.occluded, rebuilt.occluded, "{at}");
        fresh.release(&ctx);
    }
    gpu.release(&ctx);
}

#[test]
fn dynamic_scene_updates_match_cpu_and_fresh_builds() {
    let scene = gi_scene::load("dynamic").expect("dynamic scene");
    updates_match_cpu_and_fresh_builds(&scene, "dynamic", &[0.35, 1.3, 2.05, 3.7]);
}

/// Eighty moving copies of the `dynamic` scene's meshes: mirrored ones, children of moving
/// parents, shared bottom levels and a top level with many leaves.
#[test]
fn many_moving_instances_match_cpu_and_fresh_builds() {
    let scene = crowd_scene(80);
    updates_match_cpu_and_fresh_builds(&scene, "crowd", &[0.5, 1.7]);
}

/// Static copies of meshes (mirrored ones, children of static parents) share object-space
/// levels when [`MeshSharing`] says so: their hits agree with the CPU's flattened frame within
/// the object-space allowance, the bottom levels hold fewer primitives than flattened ones,
/// and with sharing off the copies go back into the one static level.
#[test]
fn static_copies_share_levels_with_the_cpu_hits() {
    let Some((ctx, tracer)) = context("static_copies_share_levels_with_the_cpu_hits") else {
        return;
    };
    let copies = 60;
    let mut scene = crowd_scene(copies);
    scene.animations.retain(|a| a.name != "crowd");
    let frame = scene.evaluate(0.7, None);
    let shared = GpuBvh::from_scene_with(&ctx, &scene, &frame, MeshSharing::ALL).expect("uploads");
    let flat = GpuBvh::from_scene_with(&ctx, &scene, &frame, MeshSharing::OFF).expect("uploads");
    let default = GpuBvh::from_scene(&ctx, &scene, &frame).expect("uploads");
    eprintln!(
        "instances: shared {}, flattened {}, default {}; primitives {} / {} / {}",
        shared.instance_count,
        flat.instance_count,
        default.instance_count,
        shared.primitive_count,
        flat.primitive_count,
        default.primitive_count
    );
    assert!(
        shared.instance_count as usize >= flat.instance_count as usize + copies - 1,
        "every static copy an instance"
    );
    assert!(
        shared.primitive_count < flat.primitive_count,
        "shared meshes stored once"
    );
    // The copies' meshes are small: the default rule keeps them flattened.
    assert_eq!(default.instance_count, flat.instance_count);
    let rays = test_rays(&frame, &SceneBvh::build(&frame.triangles), 77);
    // Any triangle may be traced in object space here.
    let object_space = vec![true; frame.triangles.len()];
    for (label, gpu) in [("shared", &shared), ("flattened", &flat)] {
        let results = tracer.trace(&ctx, gpu, &rays);
        check(
            label,
            &compare(label, &frame, &object_space, &rays, &results),
        );
    }
    for gpu in [shared, flat, default] {
        gpu.release(&ctx);
    }
}

/// `scene`'s node forest placed `copies` times under new root nodes, like a tiled level: the
/// first copy is the original nodes, the others renumbered duplicates; the last copy is turned
/// and mirrored.
fn tiled_scene(mut scene: Scene, copies: usize) -> Scene {
    let original = scene.nodes.len();
    let roots: Vec<usize> = (0..original)
        .filter(|&n| scene.nodes[n].parent.is_none())
        .collect();
    for copy in 0..copies {
        let offset = if copy == 0 { 0 } else { scene.nodes.len() };
        if copy > 0 {
            for n in 0..original {
                let mut node = scene.nodes[n].clone();
                node.name = format!("{} copy {copy}", node.name);
                node.parent = node.parent.map(|p| p + offset);
                scene.nodes.push(node);
            }
        }
        let root = scene.nodes.len();
        let last = copy + 1 == copies;
        scene.nodes.push(Node {
            name: format!("copy {copy}"),
            translation: Vec3::new(300.0 * copy as f32, 0.0, 0.0),
            rotation: if last {
                Quat::from_rotation_y(0.7)
            } else {
                Quat::IDENTITY
            },
            scale: if last {
                Vec3::new(-1.0, 1.0, 1.0)
            } else {
                Vec3::ONE
            },
            ..Node::default()
        });
        for &r in &roots {
            scene.nodes[r + offset].parent = Some(root);
        }
    }
    scene
}

/// A static scene tiled four times (one copy mirrored, and a mirrored node inside every copy):
/// each copy's node tree is one instance
/// of one shared level under the default rule, stored once, and its hits agree with the CPU's
/// flattened frame; shared per mesh only (`MeshSharing::OFF` flattens everything) the copies'
/// triangles are all in the static level.
#[test]
fn repeated_node_trees_share_one_level() {
    let Some((ctx, tracer)) = context("repeated_node_trees_share_one_level") else {
        return;
    };
    let copies = 4;
    let mut single = gi_scene::load("open-world").expect("open-world");
    assert!(!single.moving_nodes().contains(&true), "a static scene");
    // A mirrored node inside every copy (its triangles' winding flips in the shared level).
    let mirrored = (single.nodes.iter())
        .position(|n| n.mesh.is_some())
        .expect("a mesh node");
    single.nodes[mirrored].scale.x = -single.nodes[mirrored].scale.x;
    let single_triangles = single.evaluate(0.0, None).triangles.len();
    let scene = tiled_scene(single, copies);
    let frame = scene.evaluate(0.0, None);
    assert_eq!(frame.triangles.len(), copies * single_triangles);
    let shared = GpuBvh::from_scene(&ctx, &scene, &frame).expect("uploads");
    let flat = GpuBvh::from_scene_with(&ctx, &scene, &frame, MeshSharing::OFF).expect("uploads");
    eprintln!(
        "instances: shared {}, flattened {}; primitives {} / {}",
        shared.instance_count, flat.instance_count, shared.primitive_count, flat.primitive_count
    );
    assert_eq!(
        shared.instance_count as usize, copies,
        "one instance per copy"
    );
    assert_eq!(flat.instance_count, 1, "one static level");
    // Spatial splits may reference a triangle from several leaves, so the counts are bounded,
    // not equal: one copy's primitives against four.
    assert!(
        (shared.primitive_count as usize) < flat.primitive_count as usize / (copies - 1),
        "the copies stored once"
    );
    let rays = test_rays(&frame, &SceneBvh::build(&frame.triangles), 91);
    let object_space = vec![true; frame.triangles.len()];
    for (label, gpu) in [("trees", &shared), ("flattened", &flat)] {
        let results = tracer.trace(&ctx, gpu, &rays);
        check(
            label,
            &compare(label, &frame, &object_space, &rays, &results),
        );
    }
    // A copy whose node differs (one mesh node moved) is a different shape: it is flattened
    // into the static level (a shape with one copy is not worth a level) while the others
    // stay shared.
    let mut changed = scene.clone();
    let moved = (0..changed.nodes.len())
        .rev()
        .find(|&n| changed.nodes[n].mesh.is_some())
        .expect("a mesh node");
    changed.nodes[moved].translation += Vec3::new(0.0, 0.01, 0.0);
    let frame = changed.evaluate(0.0, None);
    let gpu = GpuBvh::from_scene(&ctx, &changed, &frame).expect("uploads");
    assert_eq!(
        gpu.instance_count as usize, copies,
        "three copies and the static level"
    );
    let results = tracer.trace(&ctx, &gpu, &rays);
    check(
        "changed",
        &compare("changed", &frame, &object_space, &rays, &results),
    );
    for gpu in [shared, flat, gpu] {
        gpu.release(&ctx);
    }
}

/// A scene whose only instance is the static level starts its rays at that level's root;
/// forced through the top level instead, every hit is the same bit for bit. Scenes with moving
/// instances, and an empty one, always go through the top level.
#[test]
fn static_scenes_skip_the_top_level_with_identical_hits() {
    let Some((ctx, tracer)) = context("static_scenes_skip_the_top_level_with_identical_hits")
    else {
        return;
    };
    let bits =
        |hits: &[GpuHit]| -> Vec<[u32; 4]> { hits.iter().map(|h| bytemuck::cast(*h)).collect() };
    let mut static_scenes = 0;
    for (seed, (name, _)) in gi_scene::BUNDLED_SCENES.iter().enumerate() {
        let scene = gi_scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let frame = scene.evaluate(0.0, None);
        let mut gpu = GpuBvh::from_scene(&ctx, &scene, &frame).expect("BVH uploads");
        let is_static = !scene.moving_nodes().contains(&true);
        assert_eq!(gpu.traces_static_directly(), is_static, "{name}");
        if !is_static {
            gpu.release(&ctx);
            continue;
        }
        static_scenes += 1;
        assert_eq!(gpu.instance_count, 1, "{name}");
        let rays = test_rays(&frame, &SceneBvh::build(&frame.triangles), seed as u64 + 31);
        let direct = tracer.trace(&ctx, &gpu, &rays);
        gpu.set_static_fast_path(&ctx, false);
        assert!(!gpu.traces_static_directly(), "{name}: switch off");
        let through_top = tracer.trace(&ctx, &gpu, &rays);
        assert_eq!(
            bits(&direct.hits),
            bits(&through_top.hits),
            "{name}: direct hits differ from the two-level path"
        );
        assert_eq!(direct.occluded, through_top.occluded, "{name}");
        assert!(
            direct
                .hits
                .iter()
                .filter(|h| h.triangle != BVH_MISS)
                .count()
                > rays.len() / 4,
            "{name}: too few hits to mean anything"
        );
        // An update keeps the choice: off stays off, and on again takes the direct path.
        gpu.update(&ctx, &frame).expect("top level fits the stack");
        assert!(!gpu.traces_static_directly(), "{name}: off after update");
        gpu.set_static_fast_path(&ctx, true);
        gpu.update(&ctx, &frame).expect("top level fits the stack");
        assert!(gpu.traces_static_directly(), "{name}: on after update");
        let updated = tracer.trace(&ctx, &gpu, &rays);
        assert_eq!(
            bits(&direct.hits),
            bits(&updated.hits),
            "{name}: after update"
        );
        gpu.release(&ctx);
    }
    assert!(static_scenes > 0, "no static bundled scene to test");

    // No instance at all: the top level's childless root answers every ray with a miss.
    let empty = GpuBvh::upload(&ctx, &SceneBvh::build(&[]).bvh, &[]).expect("empty BVH uploads");
    assert!(!empty.traces_static_directly(), "empty BVH");
    empty.release(&ctx);
}

/// An update rebuilds only the top level: bottom-level buffers, counts and build time stay as
/// they were, and the update's own time is reported apart.
#[test]
fn update_leaves_bottom_levels_untouched() {
    let Some((ctx, _)) = context("update_leaves_bottom_levels_untouched") else {
        return;
    };
    let scene = crowd_scene(20);
    let mut gpu = GpuBvh::from_scene(&ctx, &scene, &scene.evaluate(0.0, None)).expect("uploads");
    let before = (
        gpu.nodes.clone(),
        gpu.triangles.clone(),
        gpu.node_count,
        gpu.primitive_count,
        gpu.build_seconds,
        gpu.bottom_bytes(),
    );
    let bottom_levels = gpu.bottom_levels().nodes.clone();
    let bytes_before = ctx.memory().bytes_with_prefix("bvh.");
    for (k, time) in [0.4, 1.1, 2.9].into_iter().enumerate() {
        gpu.update(&ctx, &scene.evaluate(time, None))
            .expect("updates");
        assert_eq!(gpu.update_count, k as u32 + 2, "one top level per update");
        assert!(gpu.update_seconds > 0.0);
        eprintln!(
            "update at {time} s: {:.3} ms for {} instances ({} top nodes); build was {:.1} ms",
            gpu.update_seconds * 1e3,
            gpu.instance_count,
            gpu.top_node_count,
            gpu.build_seconds * 1e3
        );
    }
    assert!(
        gpu.nodes == before.0 && gpu.triangles == before.1,
        "bottom buffers replaced"
    );
    assert_eq!(
        (
            gpu.node_count,
            gpu.primitive_count,
            gpu.build_seconds,
            gpu.bottom_bytes()
        ),
        (before.2, before.3, before.4, before.5)
    );
    assert_eq!(gpu.bottom_levels().nodes, bottom_levels);
    assert_eq!(
        ctx.memory().bytes_with_prefix("bvh."),
        bytes_before,
        "nothing reallocated"
    );
    gpu.release(&ctx);
}

/// The `dynamic` scene plus `count` moving nodes instancing its meshes: every fourth one
/// mirrored (negative x scale), every third one the child of the one before it.
fn crowd_scene(count: usize) -> Scene {
    let mut scene = gi_scene::load("dynamic").expect("dynamic scene");
    let meshes: Vec<usize> = scene.nodes.iter().filter_map(|n| n.mesh).collect();
    let mut rng = Rng(7);
    let mut animation = Animation {
        name: "crowd".to_string(),
        channels: Vec::new(),
    };
    let first = scene.nodes.len();
    for k in 0..count {
        let node = scene.nodes.len();
        let parent = (k % 3 == 2).then_some(node - 1);
        let scale = Vec3::splat(0.1 + 0.1 * rng.next_f32())
            * Vec3::new(if k % 4 == 0 { -1.0 } else { 1.0 }, 1.0, 1.0);
        let start = rng.in_box(Vec3::new(-3.5, 0.2, -3.5), Vec3::new(3.5, 2.5, 3.5));
        let start = if parent.is_some() {
            Vec3::new(0.0, 4.0, 0.0)
        } else {
            start
        };
        scene.nodes.push(Node {
            name: format!("crowd {k}"),
            parent,
            translation: start,
            scale,
            mesh: Some(meshes[k % meshes.len()]),
            ..Node::default()
        });
        let end = start + rng.unit_vector();
        animation.channels.push(Channel {
            node,
            times: vec![0.0, 1.0, 2.0],
            values: ChannelValues::Translation(vec![start, end, start]),
            interpolation: Interpolation::Linear,
        });
        let axis = rng.unit_vector();
        animation.channels.push(Channel {
            node,
            times: vec![0.0, 2.0],
            values: ChannelValues::Rotation(vec![Quat::IDENTITY, Quat::from_axis_angle(axis, 2.0)]),
            interpolation: Interpolation::Linear,
        });
    }
    assert!(scene.nodes.len() > first);
    scene.animations.push(animation);
    scene
}

/// A skinned arm whose elbow bends (a deforming node) in a closed room: built at rest, then only
/// updated, every frame's hits equal the CPU's over that frame's skinned triangles and a fresh
/// build's.
#[test]
fn skinned_scene_updates_match_cpu_and_fresh_builds() {
    let mut scene = gi_scene::generate::skinned_arm();
    add_room(&mut scene);
    updates_match_cpu_and_fresh_builds(&scene, "skinned-arm", &[0.5, 1.0, 1.5]);
}

/// The deforming arm's level follows each update in its own region: the static floor's
/// level stays as built, and a ray through where only the bent forearm is hits it at the
/// distance the hand computation gives, on the GPU as on the CPU.
#[test]
fn deforming_levels_follow_updates_after_the_static_ones() {
    let Some((ctx, tracer)) = context("deforming_levels_follow_updates_after_the_static_ones")
    else {
        return;
    };
    let scene = gi_scene::generate::skinned_arm();
    let arm = scene.nodes.iter().position(|n| n.name == "arm").unwrap() as u32;
    let rest = scene.evaluate(0.0, None);
    let mut gpu = GpuBvh::from_scene(&ctx, &scene, &rest).expect("uploads");
    assert!(gpu.bottom_levels().has_deforming());
    assert_eq!(
        gpu.instance_count, 2,
        "the floor's static level and the arm's"
    );
    assert!(!gpu.traces_static_directly());
    let (fixed_nodes, fixed_triangles) = gpu.bottom_levels().fixed_len();
    let fixed = |gpu: &GpuBvh| {
        let levels = gpu.bottom_levels();
        (
            levels.nodes[..fixed_nodes].to_vec(),
            levels.triangles[..fixed_triangles].to_vec(),
        )
    };
    let static_levels = fixed(&gpu);
    let buffers = (gpu.nodes.clone(), gpu.triangles.clone());

    // Bent at the elbow (0, 1, 0) by 90 degrees: the forearm lies along -X at y 0.75..1.25,
    // its +Z face at z = 0.25. A ray down -Z at x = -0.8, y = 1 meets it there; at rest nothing
    // is on that line.
    let probe = GpuRay::new(Vec3::new(-0.8, 1.0, 5.0), Vec3::NEG_Z, 0.0, f32::INFINITY);
    let at_rest = tracer.trace(&ctx, &gpu, &[probe]);
    assert_eq!(at_rest.hits[0].triangle, BVH_MISS, "nothing there at rest");
    let bent = scene.evaluate(gi_scene::generate::ARM_BENT_TIME_S, None);
    gpu.update(&ctx, &bent).expect("updates");
    let hit = tracer.trace(&ctx, &gpu, &[probe]).hits[0];
    let triangle = hit.triangle().expect("the bent forearm is hit");
    assert_eq!(bent.attributes[triangle as usize].node, arm);
    assert!((hit.t - 4.75).abs() < 1e-4, "t {}", hit.t);
    let cpu = SceneBvh::build(&bent.triangles)
        .closest_hit(
            &bent.triangles,
            Vec3::new(-0.8, 1.0, 5.0),
            Vec3::NEG_Z,
            0.0,
            f32::INFINITY,
        )
        .expect("the CPU hits it too");
    assert_eq!(cpu.triangle, triangle);

    for time in [0.25, 0.5, 1.75] {
        gpu.update(&ctx, &scene.evaluate(time, None))
            .expect("updates");
        assert!(gpu.deform_seconds > 0.0);
    }
    assert!(fixed(&gpu) == static_levels, "the static level was rebuilt");
    if gpu.bottom_reallocations == 0 {
        assert!(
            (gpu.nodes.clone(), gpu.triangles.clone()) == buffers,
            "bottom buffers replaced without growing"
        );
    }
    gpu.release(&ctx);
    assert_eq!(
        ctx.memory().bytes_with_prefix("bvh."),
        0,
        "every BVH buffer released"
    );
}

/// Walls and a ceiling around the skinned arm's floor, so that most test rays hit something.
fn add_room(scene: &mut Scene) {
    let (x, y, z) = (Vec3::X * 3.0, Vec3::Y * 1.5, Vec3::Z * 3.0);
    for (center, u, v) in [
        (x + y, z, y),
        (-x + y, y, z),
        (z + y, y, x),
        (-z + y, x, y),
        (y * 2.0, x, z),
    ] {
        scene.add_diffuse_quad(center, u, v, 0.5);
    }
}

/// The skinned arm in its closed room, its tube made of 48 rings of 16 sides (1,536 triangles,
/// a level of several depths).
fn skinned_room() -> Scene {
    let mut scene = gi_scene::generate::skinned_tube(48, 16);
    add_room(&mut scene);
    scene
}

/// The deforming levels' nodes as the GPU holds them.
fn gpu_deforming_nodes(ctx: &GpuContext, gpu: &GpuBvh) -> Vec<GpuCwBvhNode> {
    let (fixed_nodes, _) = gpu.bottom_levels().fixed_len();
    let words: Vec<u32> = ctx.read_buffer(&gpu.nodes);
    let bytes: &[u8] = bytemuck::cast_slice(&words);
    let node = size_of::<GpuCwBvhNode>();
    bytemuck::pod_collect_to_vec(&bytes[fixed_nodes * node..gpu.node_count as usize * node])
}

/// Refitting at the pose the levels were built in gives back the builder's nodes bit for bit:
/// the shader's exact boxes, grid exponents and rounding of child planes are obvhs's.
#[test]
fn refit_at_the_build_pose_gives_the_built_nodes() {
    let Some((ctx, _)) = context("refit_at_the_build_pose_gives_the_built_nodes") else {
        return;
    };
    let scene = skinned_room();
    for time in [0.0, 0.5, gi_scene::generate::ARM_BENT_TIME_S] {
        let frame = scene.evaluate(time, None);
        let mut gpu = GpuBvh::from_scene(&ctx, &scene, &frame).expect("uploads");
        gpu.set_deforming_rebuild_growth(f32::INFINITY);
        let (fixed_nodes, _) = gpu.bottom_levels().fixed_len();
        let built = gpu.bottom_levels().nodes[fixed_nodes..].to_vec();
        assert!(built.len() > 1, "the arm's level has inner nodes");
        // Zero the boxes first, so that every node must be written by the refit.
        let blank: Vec<GpuCwBvhNode> = built
            .iter()
            .map(|n| GpuCwBvhNode {
                p: [0.0; 3],
                e: [0; 3],
                child_min_x: [0; 8],
                child_max_x: [0; 8],
                ..*n
            })
            .collect();
        let offset = (fixed_nodes * size_of::<GpuCwBvhNode>()) as u64;
        ctx.queue
            .write_buffer(&gpu.nodes, offset, bytemuck::cast_slice(&blank));
        gpu.update(&ctx, &frame).expect("updates");
        assert_eq!((gpu.deform_refits, gpu.deform_rebuilds), (1, 0));
        let refit = gpu_deforming_nodes(&ctx, &gpu);
        assert_eq!(refit.len(), built.len());
        for (i, (r, b)) in refit.iter().zip(&built).enumerate() {
            assert_eq!(r, b, "at {time} s, node {i} of the arm's level");
        }
        gpu.release(&ctx);
    }
}

/// Built at rest, then only refit while the elbow bends through 90 degrees: every frame's hits
/// agree with the CPU's over that frame's skinned triangles, the nearest distances equal a
/// fresh build's bit for bit and so does occlusion, and every refit node's decoded child boxes
/// hold the triangles below them.
#[test]
fn refit_levels_trace_like_fresh_builds() {
    let Some((ctx, tracer)) = context("refit_levels_trace_like_fresh_builds") else {
        return;
    };
    let scene = skinned_room();
    let rest = scene.evaluate(0.0, None);
    let mut gpu = GpuBvh::from_scene(&ctx, &scene, &rest).expect("uploads");
    gpu.set_deforming_rebuild_growth(f32::INFINITY);
    let buffers = (gpu.nodes.clone(), gpu.triangles.clone());
    let times = [0.25, 0.5, 1.0, gi_scene::generate::ARM_BENT_TIME_S, 1.75];
    for (k, &time) in times.iter().enumerate() {
        let frame = scene.evaluate(time, None);
        gpu.update(&ctx, &frame).expect("updates");
        assert_eq!((gpu.deform_refits, gpu.deform_rebuilds), (k as u32 + 1, 0));
        let rays = test_rays(&frame, &SceneBvh::build(&frame.triangles), 700 + k as u64);
        let refit = tracer.trace(&ctx, &gpu, &rays);
        let moving = moving_triangles(&scene, &frame);
        let at = format!("refit arm at {time} s");
        check(&at, &compare(&at, &frame, &moving, &rays, &refit));

        let fresh = GpuBvh::from_scene(&ctx, &scene, &frame).expect("uploads");
        let rebuilt = tracer.trace(&ctx, &fresh, &rays);
        for (i, (a, b)) in refit.hits.iter().zip(&rebuilt.hits).enumerate() {
            assert_eq!(a.t.to_bits(), b.t.to_bits(), "{at}, ray {i}: {a:?} / {b:?}");
        }
        assert_eq!(refit.occluded, rebuilt.occluded, "{at}");
        fresh.release(&ctx);

        check_boxes_hold_triangles(&at, &gpu, &gpu_deforming_nodes(&ctx, &gpu));
    }
    assert!(
        (gpu.nodes.clone(), gpu.triangles.clone()) == buffers,
        "a refit never replaces the bottom buffers"
    );
    gpu.release(&ctx);
}

/// Every child box that `nodes` (the deforming region, as refit) decode to holds the triangles
/// below that child.
fn check_boxes_hold_triangles(label: &str, gpu: &GpuBvh, nodes: &[GpuCwBvhNode]) {
    let levels = gpu.bottom_levels();
    let (fixed_nodes, _) = levels.fixed_len();
    // Exact box of node `index` (absolute), from its subtree's triangles.
    fn subtree(
        nodes: &[GpuCwBvhNode],
        base: usize,
        triangles: &[gi_gpu::bvh::GpuBvhTriangle],
        index: usize,
    ) -> (Vec3, Vec3) {
        let node = &nodes[index - base];
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for slot in 0..8 {
            let (a, b) = child_exact(nodes, base, triangles, node, slot);
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        (lo, hi)
    }
    fn child_exact(
        nodes: &[GpuCwBvhNode],
        base: usize,
        triangles: &[gi_gpu::bvh::GpuBvhTriangle],
        node: &GpuCwBvhNode,
        slot: usize,
    ) -> (Vec3, Vec3) {
        let info = node.child_meta[slot];
        if info == 0 {
            return (Vec3::INFINITY, Vec3::NEG_INFINITY);
        }
        if node.imask & (1 << slot) != 0 {
            let rank = (node.imask & ((1u8 << slot) - 1)).count_ones();
            return subtree(
                nodes,
                base,
                triangles,
                (node.child_base_idx + rank) as usize,
            );
        }
        let first = (node.primitive_base_idx + u32::from(info & 0x1f)) as usize;
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for tri in &triangles[first..first + (info & 0xe0).count_ones() as usize] {
            for v in [tri.a, tri.b, tri.c].map(Vec3::from) {
                (lo, hi) = (lo.min(v), hi.max(v));
            }
        }
        (lo, hi)
    }
    let mut children = 0;
    for node in nodes {
        let scale = Vec3::from(node.e.map(|e| f32::from_bits(u32::from(e) << 23)));
        let p = Vec3::from(node.p);
        for slot in 0..8 {
            if node.child_meta[slot] == 0 {
                continue;
            }
            let (lo, hi) = child_exact(nodes, fixed_nodes, &levels.triangles, node, slot);
            let q_lo = Vec3::new(
                f32::from(node.child_min_x[slot]),
                f32::from(node.child_min_y[slot]),
                f32::from(node.child_min_z[slot]),
            );
            let q_hi = Vec3::new(
                f32::from(node.child_max_x[slot]),
                f32::from(node.child_max_y[slot]),
                f32::from(node.child_max_z[slot]),
            );
            let (decoded_lo, decoded_hi) = (p + q_lo * scale, p + q_hi * scale);
            // The decode's own rounding: a few ulps of the coordinates.
            let slack = (p.abs() + hi.abs()).max_element() * 4.0 * f32::EPSILON;
            assert!(
                decoded_lo.cmple(lo + slack).all() && decoded_hi.cmpge(hi - slack).all(),
                "{label}: child box {decoded_lo}..{decoded_hi} misses {lo}..{hi}"
            );
            children += 1;
        }
    }
    assert!(children > nodes.len(), "{label}: the level has children");
}

/// With a growth of 0 every update builds the deforming levels again; with the default, an
/// arm that bends within its box is refit.
#[test]
fn rebuild_growth_chooses_between_refit_and_rebuild() {
    let Some((ctx, _)) = context("rebuild_growth_chooses_between_refit_and_rebuild") else {
        return;
    };
    let scene = skinned_room();
    let rest = scene.evaluate(0.0, None);
    let mut always = GpuBvh::from_scene(&ctx, &scene, &rest).expect("uploads");
    always.set_deforming_rebuild_growth(0.0);
    let mut default = GpuBvh::from_scene(&ctx, &scene, &rest).expect("uploads");
    for time in [0.25, 0.5, 0.75] {
        let frame = scene.evaluate(time, None);
        always.update(&ctx, &frame).expect("updates");
        default.update(&ctx, &frame).expect("updates");
    }
    assert_eq!((always.deform_refits, always.deform_rebuilds), (0, 3));
    assert_eq!(default.deform_refits + default.deform_rebuilds, 3);
    assert!(
        default.deform_refits > 0,
        "the default refits a bending arm"
    );
    always.release(&ctx);
    default.release(&ctx);
}
