//! The GPU scene tables against the CPU reference's: the emitter table must hold the same
//! triangles with the same probabilities, or GPU and CPU would pick different lights.

use gi_gpu::EmitterTable;
use gi_reference::Reference;

#[test]
fn emitter_tables_match_the_reference_on_every_bundled_scene() {
    for (name, _) in gi_scene::BUNDLED_SCENES {
        let scene = gi_scene::load(name).unwrap();
        let frame = scene.evaluate(0.0, None);
        let table = EmitterTable::build(&scene, &frame);
        let reference = Reference::new(&scene, frame.clone());
        assert_eq!(
            table.entries.len(),
            reference.emissive_triangle_count(),
            "{name}"
        );
        assert_eq!(table.selection.len(), frame.triangles.len(), "{name}");
        let Some(last) = table.entries.last() else {
            continue;
        };
        // The last cdf is exactly 1: no 24-bit uniform number reaches its threshold, so every
        // draw lands in the table.
        assert_eq!(last.threshold, 1 << 24, "{name}");
        assert!(
            table
                .entries
                .windows(2)
                .all(|w| w[0].threshold <= w[1].threshold),
            "{name}: thresholds must not decrease"
        );
        let total: f64 = table.selection.iter().map(|&p| f64::from(p)).sum();
        assert!(
            (total - 1.0).abs() < 1e-5,
            "{name}: probabilities sum to {total}"
        );
        for entry in &table.entries {
            assert!(table.selection[entry.triangle as usize] > 0.0, "{name}");
        }
    }
}

/// Uploaded at time 0 and then only updated, the scene's shading buffers and emitter table
/// hold what a fresh upload at each later time holds, bit for bit, although updates rewrite
/// only the triangles of moving and deforming nodes and rebuild the table only when one of
/// them emits: the animated `dynamic` scene (moving nodes, static ones, tangents, a static
/// emitter), a skinned tube on a static floor, and the same tube glowing (a deforming
/// emitter).
#[test]
fn updates_rewrite_moving_triangles_like_a_fresh_upload() {
    let Some(ctx) = gi_gpu::GpuContext::new_or_skip("updates_rewrite_moving_triangles") else {
        return;
    };
    let dynamic = gi_scene::load("dynamic").unwrap();
    let tube = gi_scene::generate::skinned_tube(16, 8);
    let mut glowing = tube.clone();
    let arm = glowing.nodes.iter().position(|n| n.name == "arm").unwrap();
    let material = glowing.meshes[glowing.nodes[arm].mesh.unwrap()].primitives[0].material;
    glowing.materials[material].emissive = glam::Vec3::splat(3.0);
    for (label, scene) in [
        ("dynamic", dynamic),
        ("skinned-tube", tube),
        ("glowing-tube", glowing),
    ] {
        assert!(scene.is_animated(), "{label}");
        let mut gpu =
            gi_gpu::GpuScene::upload(&ctx, &scene, &scene.evaluate(0.0, None)).expect("uploads");
        for time in [0.4, 1.1, 2.3] {
            let frame = scene.evaluate(time, None);
            gpu.update(&ctx, &scene, &frame).expect("updates");
            let fresh = gi_gpu::GpuScene::upload(&ctx, &scene, &frame).expect("uploads");
            let read = |buffer: &wgpu::Buffer| ctx.read_buffer::<u32>(buffer);
            assert!(
                read(&gpu.triangles) == read(&fresh.triangles),
                "{label} at {time} s: shading differs from a fresh upload"
            );
            assert!(
                read(&gpu.triangle_extras) == read(&fresh.triangle_extras),
                "{label} at {time} s: extras differ from a fresh upload"
            );
            assert_eq!(
                gpu.emitter_count, fresh.emitter_count,
                "{label} at {time} s"
            );
            assert!(
                read(&gpu.emitters) == read(&fresh.emitters)
                    && read(&gpu.selection) == read(&fresh.selection),
                "{label} at {time} s: the emitter table differs from a fresh upload"
            );
            fresh.release(&ctx);
        }
        gpu.release(&ctx);
    }
}
