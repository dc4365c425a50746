//! glTF morph targets: shapes at known weights computed by hand, weights from the mesh, the node
//! and animation channels, which nodes deform, morphing before skinning, the export/import
//! round trip, and hostile morph data (errors or warnings, never a panic).

mod common;
use common::base64;

use std::path::Path;

use gi_scene::generate::{ARM_BENT_TIME_S, skinned_arm};
use gi_scene::{
    Animation, Channel, ChannelValues, ImportWarning, Interpolation, Mesh, MorphTarget, Node,
    Primitive, Scene, SceneError, SceneFrame, import_gltf, import_gltf_slice, write_gltf,
};
use glam::{Vec2, Vec3};
use serde_json::{Value, json};

const EPS: f32 = 1e-5;

/// The unit quad in the XY plane facing +Z, with one target that lifts every vertex by 2 along
/// Z and tilts its normal to +X at weight 1 (`z + (1, 0, -1)`), and a second target that moves
/// vertex 0 by +1 along X.
fn quad_scene(mesh_weights: Vec<f32>, node_weights: Option<Vec<f32>>) -> Scene {
    let mut scene = Scene {
        exposure: 1.0,
        frame_time_s: 0.1,
        ..Scene::default()
    };
    scene.add_diffuse_quad(Vec3::ZERO, Vec3::X * 0.5, Vec3::Y * 0.5, 0.5);
    let mesh = &mut scene.meshes[0];
    let primitive = &mut mesh.primitives[0];
    primitive.targets = vec![
        MorphTarget {
            positions: vec![Vec3::Z * 2.0; 4],
            normals: vec![Vec3::new(1.0, 0.0, -1.0); 4],
            tangents: Vec::new(),
        },
        MorphTarget {
            positions: vec![Vec3::X, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO],
            ..MorphTarget::default()
        },
    ];
    mesh.weights = mesh_weights;
    scene.nodes[0].weights = node_weights;
    scene
}

/// Every corner of node `node`'s triangles in `frame`, with its primitive vertex index (the
/// node's mesh has one primitive and the frame keeps its triangle order), world position and
/// normal.
fn corners(scene: &Scene, frame: &SceneFrame, node: usize) -> Vec<(usize, Vec3, Vec3)> {
    let primitive = &scene.meshes[scene.nodes[node].mesh.unwrap()].primitives[0];
    let first = (frame.attributes.iter())
        .position(|a| a.node == node as u32)
        .expect("the node has triangles");
    let mut out = Vec::new();
    for (t, indices) in primitive.indices.chunks_exact(3).enumerate() {
        let triangle = frame.triangles[first + t];
        let attributes = frame.attributes[first + t];
        let world = [triangle.v0, triangle.v1, triangle.v2].map(Vec3::from);
        for k in 0..3 {
            out.push((indices[k] as usize, world[k], attributes.normals[k]));
        }
    }
    out
}

fn assert_near(a: Vec3, b: Vec3, what: &str) {
    assert!(a.abs_diff_eq(b, EPS), "{what}: {a} != {b}");
}

/// Node 0's corners at `time_s` against `p + w0 * (0, 0, 2) + w1 * [vertex 0] (1, 0, 0)` and
/// `normalize(z + w0 * (1, 0, -1))`.
fn check_quad(scene: &Scene, time_s: f32, w: [f32; 2], label: &str) {
    let base = &scene.meshes[0].primitives[0].positions;
    let frame = scene.evaluate(time_s, None);
    for (v, world, normal) in corners(scene, &frame, 0) {
        let shift = if v == 0 { Vec3::X * w[1] } else { Vec3::ZERO };
        let expected = base[v] + Vec3::Z * 2.0 * w[0] + shift;
        assert_near(world, expected, &format!("{label}: vertex {v}"));
        let expected_normal = (Vec3::Z + w[0] * Vec3::new(1.0, 0.0, -1.0)).normalize();
        assert_near(normal, expected_normal, &format!("{label}: normal {v}"));
    }
}

#[test]
fn weights_give_the_base_the_displaced_and_the_blended_shapes() {
    check_quad(
        &quad_scene(vec![0.0, 0.0], None),
        0.0,
        [0.0, 0.0],
        "weight 0",
    );
    check_quad(
        &quad_scene(vec![1.0, 0.0], None),
        0.0,
        [1.0, 0.0],
        "weight 1",
    );
    check_quad(
        &quad_scene(vec![0.5, 0.0], None),
        0.0,
        [0.5, 0.0],
        "weight 0.5",
    );
    check_quad(
        &quad_scene(vec![0.5, 1.0], None),
        0.0,
        [0.5, 1.0],
        "two targets",
    );
    // No mesh weights: all zero.
    check_quad(&quad_scene(Vec::new(), None), 0.0, [0.0, 0.0], "no weights");
    let still = quad_scene(vec![1.0, 0.0], None);
    assert!(!still.is_animated());
    assert!(
        !still.deforming_nodes()[0],
        "constant weights are static geometry"
    );
}

#[test]
fn node_weights_override_mesh_weights() {
    let scene = quad_scene(vec![1.0, 1.0], Some(vec![0.0, 0.5]));
    assert_eq!(scene.rest_morph_weights(0), vec![0.0, 0.5]);
    check_quad(&scene, 0.0, [0.0, 0.5], "node weights");
}

#[test]
fn animated_weights_interpolate_and_deform_the_node() {
    let mut scene = quad_scene(vec![0.0, 0.0], Some(vec![0.0, 1.0]));
    scene.animations.push(Animation {
        name: "blink".into(),
        channels: vec![Channel {
            node: 0,
            times: vec![0.0, 2.0, 4.0],
            values: ChannelValues::Weights(vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![0.0, 0.0]]),
            interpolation: Interpolation::Linear,
        }],
    });
    // The channel overrides the node's weights, both targets.
    check_quad(&scene, 0.0, [0.0, 0.0], "t = 0");
    check_quad(&scene, 0.5, [0.25, 0.0], "t = 0.5");
    check_quad(&scene, 2.0, [1.0, 0.0], "t = 2");
    check_quad(&scene, 3.0, [0.5, 0.0], "t = 3");
    assert_eq!(scene.morph_weights(1.0)[0], vec![0.5, 0.0]);
    assert!(scene.is_animated());
    assert!(scene.deforming_nodes()[0], "animated weights deform");
    assert!(
        !scene.moving_nodes()[0],
        "weights do not move the node's transform"
    );
    let (a, b) = (scene.evaluate(0.5, None), scene.evaluate(1.0, None));
    assert!(scene.node_geometry_changed(0, &a, &b));
    assert!(scene.node_geometry_changed(0, &a.without_geometry(), &b.without_geometry()));
    assert!(!scene.node_geometry_changed(0, &a, &scene.evaluate(0.5, None)));

    let mut step = scene.clone();
    step.animations[0].channels[0].interpolation = Interpolation::Step;
    check_quad(&step, 1.5, [0.0, 0.0], "step before the key");
    check_quad(&step, 2.5, [1.0, 0.0], "step after the key");
}

#[test]
fn a_moving_node_drawn_morphed_deforms() {
    // Its shape is not its mesh's, so renderers must not place the mesh rigidly.
    let mut scene = quad_scene(vec![1.0, 0.0], None);
    scene.animations.push(Animation {
        name: "slide".into(),
        channels: vec![Channel {
            node: 0,
            times: vec![0.0, 1.0],
            values: ChannelValues::Translation(vec![Vec3::ZERO, Vec3::X]),
            interpolation: Interpolation::Linear,
        }],
    });
    assert!(scene.moving_nodes()[0]);
    assert!(scene.deforming_nodes()[0]);
    let mut rest = scene.clone();
    rest.meshes[0].weights = vec![0.0, 0.0];
    assert!(
        !rest.deforming_nodes()[0],
        "at zero weights the mesh moves rigidly"
    );
}

#[test]
fn morph_targets_apply_before_the_skin() {
    let mut scene = skinned_arm();
    let arm = (scene.nodes.iter()).position(|n| n.name == "arm").unwrap();
    let mesh = scene.nodes[arm].mesh.unwrap();
    let shift = Vec3::new(0.25, 0.0, 0.0);
    let primitive = &mut scene.meshes[mesh].primitives[0];
    primitive.targets = vec![MorphTarget {
        positions: vec![shift; primitive.positions.len()],
        ..MorphTarget::default()
    }];
    scene.meshes[mesh].weights = vec![1.0];
    let base = scene.meshes[mesh].primitives[0].positions.clone();
    // At rest the skin is the identity: the morphed shape.
    let rest = scene.evaluate(0.0, None);
    for (v, world, _) in corners(&scene, &rest, arm) {
        assert_near(world, base[v] + shift, "rest");
    }
    // Bent, the top ring turns 90 degrees about the elbow (0, 1, 0): a displacement along X
    // before skinning ends up along Y, `(x, 2, z) -> (-1, 1 + x, z)`.
    let bent = scene.evaluate(ARM_BENT_TIME_S, None);
    for (v, world, _) in corners(&scene, &bent, arm) {
        let p = base[v] + shift;
        if p.y == 2.0 {
            assert_near(world, Vec3::new(-1.0, 1.0 + p.x, p.z), "top ring");
        }
    }
}

#[test]
fn hand_built_scenes_with_bad_morph_data_do_not_panic() {
    let mut scene = quad_scene(vec![f32::NAN, 1.0, 7.0], Some(vec![f32::INFINITY, 1.0]));
    scene.meshes[0].primitives[0].targets[1].positions.pop();
    scene.animations.push(Animation {
        name: "broken".into(),
        channels: vec![Channel {
            node: 5,
            times: vec![0.0, 1.0],
            values: ChannelValues::Weights(vec![vec![1.0], Vec::new()]),
            interpolation: Interpolation::Linear,
        }],
    });
    // Non-finite weights count as zero, a short displacement list is not applied.
    check_quad(&scene, 0.5, [0.0, 0.0], "bad weights");
    let dir = tempfile::tempdir().unwrap();
    assert!(matches!(
        write_gltf(&scene, &dir.path().join("bad.gltf")),
        Err(SceneError::Invalid { .. })
    ));
}

#[test]
fn morph_targets_survive_an_export_import_round_trip() {
    let mut scene = quad_scene(vec![0.25, 0.0], Some(vec![0.5, 0.0]));
    scene.meshes[0].primitives[0].uvs = vec![Vec2::ZERO; 4];
    scene.animations.push(Animation {
        name: "blink".into(),
        channels: vec![Channel {
            node: 0,
            times: vec![0.0, 2.0],
            values: ChannelValues::Weights(vec![vec![0.0, 1.0], vec![1.0, 0.0]]),
            interpolation: Interpolation::Linear,
        }],
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("morph.gltf");
    write_gltf(&scene, &path).unwrap();
    let (imported, warnings) = import_gltf(&path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(imported.meshes[0].weights, scene.meshes[0].weights);
    assert_eq!(imported.nodes[0].weights, scene.nodes[0].weights);
    assert_eq!(
        imported.meshes[0].primitives[0].targets,
        scene.meshes[0].primitives[0].targets
    );
    let bits = |f: &SceneFrame| -> Vec<u32> {
        (f.triangles.iter())
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .flat_map(|v| v.to_array().map(f32::to_bits))
            .collect()
    };
    for t in [0.0, 0.7, 1.9] {
        assert_eq!(
            bits(&scene.evaluate(t, None)),
            bits(&imported.evaluate(t, None))
        );
    }
    assert!(imported.deforming_nodes()[0]);
}

// ---------------------------------------------------------------------------------------------
// Hand-written documents.

fn floats(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A quad document: mesh 0 (positions (0,0,0), (1,0,0), (1,1,0), (0,1,0), normals +Z) with the targets
/// `targets` (each a map from attribute name to the raw floats of its accessor, VEC3, count
/// from the data), on node 0; `extra` is merged into the document and may name accessors
/// from `extra_accessors` (raw floats, SCALAR), which come after the targets'.
fn morph_doc(
    targets: &[Vec<(&str, Vec<f32>)>],
    extra_accessors: &[Vec<f32>],
    extra: Value,
) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut add = |bytes: &[u8], count: usize, ty: &str, bounds: bool| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
        bin.extend_from_slice(bytes);
        let mut accessor = json!({
            "bufferView": views.len() - 1, "componentType": 5126, "count": count, "type": ty
        });
        if bounds {
            accessor["min"] = json!([0.0, 0.0, 0.0]);
            accessor["max"] = json!([1.0, 1.0, 1.0]);
        }
        accessors.push(accessor);
        accessors.len() - 1
    };
    let positions = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    let position = add(&floats(&positions), 4, "VEC3", true);
    let normal = add(&floats(&[0.0, 0.0, 1.0].repeat(4)), 4, "VEC3", false);
    let target_json: Vec<Value> = targets
        .iter()
        .map(|attributes| {
            let mut target = json!({});
            for (name, data) in attributes {
                target[*name] = json!(add(
                    &floats(data),
                    data.len() / 3,
                    "VEC3",
                    *name == "POSITION"
                ));
            }
            target
        })
        .collect();
    for data in extra_accessors {
        add(&floats(data), data.len(), "SCALAR", false);
    }
    let indices: Vec<u8> = [0u32, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": indices.len() }));
    bin.extend_from_slice(&indices);
    accessors.push(json!({
        "bufferView": views.len() - 1, "componentType": 5125, "count": 6, "type": "SCALAR"
    }));
    let mut primitive = json!({
        "attributes": { "POSITION": position, "NORMAL": normal },
        "indices": accessors.len() - 1
    });
    if !targets.is_empty() {
        primitive["targets"] = json!(target_json);
    }
    let mut doc = json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "quad", "mesh": 0 }],
        "meshes": [{ "primitives": [primitive] }],
        "buffers": [{ "byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}", base64(&bin)) }],
        "bufferViews": views,
        "accessors": accessors,
    });
    merge(&mut doc, &extra);
    serde_json::to_vec(&doc).unwrap()
}

/// Merges `extra` into `doc`, object by object.
fn merge(doc: &mut Value, extra: &Value) {
    match (doc, extra) {
        (Value::Object(doc), Value::Object(extra)) => {
            for (key, value) in extra {
                merge(doc.entry(key.clone()).or_insert(Value::Null), value);
            }
        }
        (Value::Array(doc), Value::Array(extra)) if doc.len() == extra.len() => {
            for (d, e) in doc.iter_mut().zip(extra) {
                merge(d, e);
            }
        }
        (doc, extra) => *doc = extra.clone(),
    }
}

fn load(bytes: &[u8]) -> (Scene, Vec<ImportWarning>) {
    import_gltf_slice(bytes, Path::new("morph.gltf")).unwrap_or_else(|e| panic!("{e}"))
}

fn error(bytes: &[u8]) -> String {
    match import_gltf_slice(bytes, Path::new("morph.gltf")) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

/// One target lifting every vertex by 2 along Z.
fn lift() -> Vec<(&'static str, Vec<f32>)> {
    vec![("POSITION", [0.0, 0.0, 2.0].repeat(4))]
}

/// The Z of every corner of node 0 at `time_s`.
fn heights(scene: &Scene, time_s: f32) -> Vec<f32> {
    let frame = scene.evaluate(time_s, None);
    (frame.triangles.iter())
        .flat_map(|t| [t.v0.z, t.v1.z, t.v2.z])
        .collect()
}

fn assert_heights(scene: &Scene, time_s: f32, z: f32) {
    let heights = heights(scene, time_s);
    assert!(
        heights.iter().all(|h| (h - z).abs() < EPS),
        "at {time_s} s: {heights:?}, expected {z}"
    );
}

#[test]
fn imported_targets_take_mesh_node_and_animated_weights() {
    let (scene, warnings) = load(&morph_doc(
        &[lift()],
        &[],
        json!({ "meshes": [{ "weights": [0.5] }] }),
    ));
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(scene.meshes[0].weights, vec![0.5]);
    assert_heights(&scene, 0.0, 1.0);

    let (scene, _) = load(&morph_doc(
        &[lift()],
        &[],
        json!({ "meshes": [{ "weights": [0.5] }], "nodes": [{ "weights": [1.0] }] }),
    ));
    assert_heights(&scene, 0.0, 2.0);

    // Keys at 0 and 1 s, weights 0 then 1: linear, step and cubic (in-tangent, value,
    // out-tangent per key; approximated linearly between the values).
    let times = vec![0.0, 1.0];
    for (interpolation, output, at_quarter) in [
        ("LINEAR", vec![0.0, 1.0], 0.5),
        ("STEP", vec![0.0, 1.0], 0.0),
        ("CUBICSPLINE", vec![9.0, 0.0, 9.0, 9.0, 1.0, 9.0], 0.5),
    ] {
        let animation = json!({ "animations": [{
            "channels": [{ "sampler": 0, "target": { "node": 0, "path": "weights" } }],
            "samplers": [{ "input": 3, "output": 4, "interpolation": interpolation }]
        }] });
        let (scene, _) = load(&morph_doc(&[lift()], &[times.clone(), output], animation));
        assert_heights(&scene, 0.25, at_quarter);
        assert!(scene.deforming_nodes()[0], "{interpolation}");
        let (a, b) = (scene.evaluate(0.25, None), scene.evaluate(0.75, None));
        assert_eq!(
            scene.node_geometry_changed(0, &a, &b),
            interpolation != "STEP",
            "{interpolation}"
        );
    }
}

#[test]
fn hostile_morph_data_gives_errors_or_warnings() {
    let cases: Vec<(Vec<u8>, &str)> = vec![
        // A displacement accessor shorter than the positions.
        (
            morph_doc(&[vec![("POSITION", vec![0.0; 9])]], &[], json!({})),
            "3 entries for 4 positions",
        ),
        // Mesh and node weights that are not one per target.
        (
            morph_doc(
                &[lift()],
                &[],
                json!({ "meshes": [{ "weights": [0.5, 0.5] }] }),
            ),
            "2 entries for 1 morph targets",
        ),
        (
            morph_doc(&[lift()], &[], json!({ "nodes": [{ "weights": [] }] })),
            "0 entries for 1 morph targets",
        ),
        // A NaN displacement.
        (
            morph_doc(
                &[vec![("NORMAL", [f32::NAN, 0.0, 0.0].repeat(4))]],
                &[],
                json!({}),
            ),
            "NaN",
        ),
        // A weights channel with one weight for two keys.
        (
            morph_doc(
                &[lift()],
                &[vec![0.0, 1.0], vec![0.0]],
                json!({ "animations": [{
                    "channels": [{ "sampler": 0, "target": { "node": 0, "path": "weights" } }],
                    "samplers": [{ "input": 3, "output": 4 }]
                }] }),
            ),
            "1 output weights for 2 keyframes",
        ),
    ];
    for (doc, expected) in cases {
        let message = error(&doc);
        assert!(message.contains(expected), "{message} lacks {expected}");
    }

    // More targets than supported.
    let many = vec![lift(); Mesh::MAX_MORPH_TARGETS + 1];
    assert!(matches!(
        import_gltf_slice(&morph_doc(&many, &[], json!({})), Path::new("many.gltf")),
        Err(SceneError::Invalid { .. })
    ));

    // Primitives with different numbers of targets.
    let mut doc: Value = serde_json::from_slice(&morph_doc(&[lift()], &[], json!({}))).unwrap();
    let mut plain = doc["meshes"][0]["primitives"][0].clone();
    plain.as_object_mut().unwrap().remove("targets");
    doc["meshes"][0]["primitives"]
        .as_array_mut()
        .unwrap()
        .push(plain);
    let message = error(&serde_json::to_vec(&doc).unwrap());
    assert!(message.contains("same number"), "{message}");

    // Texture coordinate and tangent targets are ignored with warnings.
    let (scene, warnings) = load(&morph_doc(
        &[vec![
            ("POSITION", [0.0, 0.0, 2.0].repeat(4)),
            ("TEXCOORD_0", vec![0.0; 12]),
            ("TANGENT", vec![0.0; 12]),
        ]],
        &[],
        json!({ "meshes": [{ "weights": [1.0] }] }),
    ));
    for text in ["TEXCOORD_0", "TANGENT"] {
        assert!(
            warnings.iter().any(|w| w.0.contains(text)),
            "no warning about {text}: {warnings:?}"
        );
    }
    assert_heights(&scene, 0.0, 2.0);
}

/// Sanity check of the model defaults the other tests rely on.
#[test]
fn nodes_and_meshes_have_no_morph_data_by_default() {
    assert_eq!(Node::default().weights, None);
    assert!(Mesh::default().weights.is_empty());
    assert!(Primitive::default().targets.is_empty());
}
