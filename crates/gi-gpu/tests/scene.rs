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
/// hold what a fresh upload at each later time holds, bit for bit (the triangles skinned on
/// the GPU up to rounding: [`assert_same_shading`]), although updates rewrite
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
            assert_same_shading(
                &ctx,
                &scene,
                &frame,
                &gpu,
                &fresh,
                &format!("{label} at {time} s"),
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

/// The shading buffers of `updated` hold what the CPU computes for `frame` (a complete
/// evaluation of `scene`): the triangles of nodes not skinned on the GPU bit for bit as a
/// `fresh` upload of `frame` holds them; those of nodes skinned on the GPU
/// ([`gi_gpu::gpu_skinned_nodes`]; an upload skins them on the GPU too) against the CPU's own
/// values ([`gi_gpu::triangle_shading`]), their positions, normals and tangents up to rounding (1e-5
/// relative), their texture coordinates, node and material exactly. Returns the number of
/// GPU-skinned triangles compared.
fn assert_same_shading(
    ctx: &gi_gpu::GpuContext,
    scene: &gi_scene::Scene,
    frame: &gi_scene::SceneFrame,
    updated: &gi_gpu::GpuScene,
    fresh: &gi_gpu::GpuScene,
    label: &str,
) -> usize {
    use gi_gpu::{GpuTriangleExtras, GpuTriangleShading};
    let skinned_nodes = gi_gpu::gpu_skinned_nodes(scene);
    let a: Vec<GpuTriangleShading> = ctx.read_buffer(&updated.triangles);
    let b: Vec<GpuTriangleShading> = ctx.read_buffer(&fresh.triangles);
    let extras_a: Vec<GpuTriangleExtras> = ctx.read_buffer(&updated.triangle_extras);
    let extras_b: Vec<GpuTriangleExtras> = ctx.read_buffer(&fresh.triangle_extras);
    assert_eq!(a.len(), b.len(), "{label}");
    assert_eq!(extras_a.len(), extras_b.len(), "{label}");
    let has_extras = extras_b.len() >= frame.triangles.len();
    let close = |x: &[f32], y: &[f32]| {
        x.iter()
            .zip(y)
            .all(|(x, y)| (x - y).abs() <= 1e-5 * (1.0 + y.abs()))
    };
    let mut skinned = 0;
    for (t, attributes) in frame.attributes.iter().enumerate() {
        if !skinned_nodes[attributes.node as usize] {
            assert!(
                a[t] == b[t],
                "{label}: triangle {t} differs from a fresh upload"
            );
            if has_extras {
                assert!(
                    extras_a[t] == extras_b[t],
                    "{label}: extras of triangle {t} differ from a fresh upload"
                );
            }
            continue;
        }
        skinned += 1;
        let (cpu, cpu_extras) = (
            gi_gpu::triangle_shading(frame, t..t + 1)[0],
            gi_gpu::triangle_extras(frame, t..t + 1)[0],
        );
        let (x, y) = (a[t], cpu);
        let xyz = |v: [f32; 4]| [v[0], v[1], v[2]];
        let geometry =
            |s: &GpuTriangleShading| [s.pa, s.pb, s.pc, s.na, s.nb, s.nc].map(xyz).concat();
        let exact = |s: &GpuTriangleShading| {
            (
                s.pa[3], s.na[3], s.nb[3], s.nc[3], s.v, s.material, s.pb[3], s.pc[3],
            )
        };
        assert!(
            close(&geometry(&x), &geometry(&y)),
            "{label}: skinned triangle {t}: GPU {x:?}, CPU {y:?}"
        );
        assert!(
            exact(&x) == exact(&y),
            "{label}: skinned triangle {t}: GPU {x:?}, CPU {y:?}"
        );
        if has_extras {
            let (x, y) = (extras_a[t], cpu_extras);
            let tangents = |e: &GpuTriangleExtras| [e.ta, e.tb, e.tc].concat();
            assert!(
                close(&tangents(&x), &tangents(&y))
                    && (x.uv_ab, x.uv_c, x.pad) == (y.uv_ab, y.uv_c, y.pad),
                "{label}: extras of skinned triangle {t}: GPU {x:?}, CPU {y:?}"
            );
        }
    }
    skinned
}

/// A skinned arm with every case the skinning handles: tangents of both handedness, a second
/// texture coordinate set, a morph target at a constant weight, a mirroring joint (negative
/// scale), weights that do not sum to 1, weights the CPU ignores (negative, NaN, a joint
/// outside the skin), a vertex with no usable weight (placed by the node's transform) and an
/// unskinned primitive on the skinned node. Uploaded and updated from frames that leave the
/// arm's normals and tangents out (`Evaluation::positions_only`, as the GPU tiers evaluate),
/// its shading buffers hold what a fresh upload of the CPU's complete evaluation holds at
/// every time. Leaving out a node the GPU does not skin is refused.
#[test]
fn gpu_skinning_matches_the_cpu_on_awkward_vertices() {
    let Some(ctx) = gi_gpu::GpuContext::new_or_skip("gpu_skinning_matches_the_cpu") else {
        return;
    };
    let mut scene = gi_scene::generate::skinned_tube(5, 6);
    let arm = scene.nodes.iter().position(|n| n.name == "arm").unwrap();
    let elbow = scene.nodes.iter().position(|n| n.name == "elbow").unwrap();
    scene.nodes[elbow].scale = glam::Vec3::new(-1.0, 1.0, 1.0);
    let mesh = scene.nodes[arm].mesh.unwrap();
    scene.meshes[mesh].weights = vec![0.5];
    let tube = &mut scene.meshes[mesh].primitives[0];
    let count = tube.positions.len();
    for i in 0..count {
        let f = i as f32;
        let normal = tube.normals[i];
        let tangent = normal.cross(glam::Vec3::Y).normalize_or(glam::Vec3::X);
        let sign = if i % 3 == 0 { -1.0 } else { 1.0 };
        tube.tangents.push(tangent.extend(sign));
        tube.uvs.push(glam::Vec2::new(f * 0.1, 1.0 - f * 0.05));
        tube.uvs1.push(glam::Vec2::new(f * 0.3, f * 0.7));
    }
    tube.targets.push(gi_scene::MorphTarget {
        positions: (0..count)
            .map(|i| glam::Vec3::new(0.01 * i as f32, 0.0, -0.02))
            .collect(),
        normals: Vec::new(),
        tangents: Vec::new(),
    });
    tube.weights[7] *= 1.7;
    tube.weights[8] = glam::Vec4::new(-0.5, 1.0, 0.0, 0.0);
    tube.weights[9] = glam::Vec4::new(f32::NAN, 0.4, 0.0, 0.0);
    tube.joints[10] = [0, 9, 0, 0];
    tube.weights[10] = glam::Vec4::new(0.6, 0.4, 0.0, 0.0);
    tube.weights[11] = glam::Vec4::ZERO;
    let material = tube.material;
    let quad = gi_scene::Primitive {
        positions: vec![
            glam::Vec3::new(1.0, 0.0, 0.0),
            glam::Vec3::new(1.5, 0.0, 0.0),
            glam::Vec3::new(1.5, 0.5, 0.0),
        ],
        normals: vec![glam::Vec3::Z; 3],
        tangents: vec![glam::Vec4::new(1.0, 0.0, 0.0, 1.0); 3],
        uvs: vec![glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::ONE],
        uvs1: vec![glam::Vec2::ZERO; 3],
        targets: vec![gi_scene::MorphTarget::default()],
        indices: vec![0, 1, 2],
        material,
        ..gi_scene::Primitive::default()
    };
    scene.meshes[mesh].primitives.push(quad);
    let skinned = gi_gpu::gpu_skinned_nodes(&scene);
    assert!(skinned[arm]);
    assert_eq!(skinned.iter().filter(|&&s| s).count(), 1);
    let evaluation = gi_scene::Evaluation {
        positions_only: skinned,
    };
    let mut wrong = evaluation.clone();
    wrong.positions_only[0] = true;
    match gi_gpu::GpuScene::upload(&ctx, &scene, &scene.evaluate_with(0.0, None, &wrong)) {
        Err(gi_gpu::SceneUploadError::PositionsOnly { node: 0 }) => {}
        Err(other) => panic!("unexpected error {other}"),
        Ok(_) => panic!("a frame without the floor's normals was uploaded"),
    }

    let mut gpu =
        gi_gpu::GpuScene::upload(&ctx, &scene, &scene.evaluate_with(0.0, None, &evaluation))
            .expect("uploads");
    let at_rest = gi_gpu::GpuScene::upload(&ctx, &scene, &scene.evaluate(0.0, None)).unwrap();
    assert_same_shading(
        &ctx,
        &scene,
        &scene.evaluate(0.0, None),
        &gpu,
        &at_rest,
        "upload",
    );
    at_rest.release(&ctx);
    let (vertices, triangles) = gpu.gpu_skinned().expect("the arm is skinned on the GPU");
    assert_eq!(vertices as usize, count + 3);
    let mut mirrored = 0;
    for time in [0.3, 0.8, 1.0, 1.7] {
        let partial = scene.evaluate_with(time, None, &evaluation);
        gpu.update(&ctx, &scene, &partial).expect("updates");
        let frame = scene.evaluate(time, None);
        let fresh = gi_gpu::GpuScene::upload(&ctx, &scene, &frame).expect("uploads");
        let compared =
            assert_same_shading(&ctx, &scene, &frame, &gpu, &fresh, &format!("{time} s"));
        assert_eq!(compared, triangles as usize);
        let world = frame.world_from_node[elbow];
        mirrored += usize::from(world.determinant() < 0.0);
        fresh.release(&ctx);
    }
    assert!(mirrored > 0, "the elbow mirrors");
    // An update from a frame without the floor's normals is refused too.
    match gpu.update(&ctx, &scene, &scene.evaluate_with(0.5, None, &wrong)) {
        Err(gi_gpu::SceneUploadError::PositionsOnly { node: 0 }) => {}
        other => panic!("unexpected {:?}", other.map_err(|e| e.to_string())),
    }
    gpu.release(&ctx);
}
