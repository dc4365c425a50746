//! glTF skins: linear blend skinning against positions and normals computed by hand, the
//! export/import round trip, the accessor encodings `JOINTS_0` and `WEIGHTS_0` may use, and
//! hostile skin data (errors or documented fallbacks, never a panic).

mod common;
use common::base64;

use std::path::Path;

use gi_scene::generate::{ARM_BENT_TIME_S, ARM_LENGTH, ARM_NODE_TRANSLATION, skinned_arm};
use gi_scene::{Scene, SceneError, SceneFrame, import_gltf, import_gltf_slice, write_gltf};
use glam::{Mat4, Vec3, Vec4};
use serde_json::{Value, json};

/// Float rounding of a few products and sums on coordinates of magnitude ~2.
const EPS: f32 = 1e-5;

fn node(scene: &Scene, name: &str) -> usize {
    scene
        .nodes
        .iter()
        .position(|n| n.name == name)
        .unwrap_or_else(|| panic!("no node {name}"))
}

/// Every vertex of node `arm`'s triangles in `frame` with its model-space position, its model
/// normal and the frame's world position and normal.
fn arm_vertices(scene: &Scene, frame: &SceneFrame) -> Vec<(Vec3, Vec3, Vec3, Vec3)> {
    let arm = node(scene, "arm");
    let primitive = &scene.meshes[scene.nodes[arm].mesh.unwrap()].primitives[0];
    let first = frame
        .attributes
        .iter()
        .position(|a| a.node == arm as u32)
        .expect("the arm has triangles");
    let mut out = Vec::new();
    for (t, corners) in primitive.indices.chunks_exact(3).enumerate() {
        let triangle = frame.triangles[first + t];
        let attributes = frame.attributes[first + t];
        assert_eq!(attributes.node, arm as u32);
        let world = [triangle.v0, triangle.v1, triangle.v2].map(Vec3::from);
        for k in 0..3 {
            let v = corners[k] as usize;
            out.push((
                primitive.positions[v],
                primitive.normals[v],
                world[k],
                attributes.normals[k],
            ));
        }
    }
    assert_eq!(out.len(), 16 * 3, "4 sides x 2 segments x 2 triangles");
    out
}

/// The arm bent 90 degrees about +Z at the elbow (0, 1, 0), written out by hand: the bottom
/// ring stays, the top ring (weight 1 on the elbow) turns about the elbow,
/// `(x, 2, z) -> (-1, 1 + x, z)`, and the middle ring (weights 0.5, 0.5) lands halfway,
/// `(x, 1, z) -> (x / 2, 1 + x / 2, z)`. Normals: unchanged, turned by 90 degrees, and by 45
/// degrees (the blended matrix is a 45-degree turn scaled by 1/sqrt(2), whose inverse
/// transpose turns normals by 45 degrees).
fn bent(p: Vec3, n: Vec3) -> (Vec3, Vec3) {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    if p.y == 0.0 {
        (p, n)
    } else if p.y == 1.0 {
        (
            Vec3::new(p.x / 2.0, 1.0 + p.x / 2.0, p.z),
            Vec3::new(s * (n.x - n.y), s * (n.x + n.y), n.z),
        )
    } else {
        assert_eq!(p.y, 2.0);
        (Vec3::new(-1.0, 1.0 + p.x, p.z), Vec3::new(-n.y, n.x, n.z))
    }
}

fn assert_near(a: Vec3, b: Vec3, what: &str) {
    assert!(a.abs_diff_eq(b, EPS), "{what}: {a} != {b}");
}

/// At rest the arm is where it was modelled (its node's own translation ignored); bent, every
/// vertex and normal is where the hand computation puts it.
fn check_arm(scene: &Scene, label: &str) {
    assert_eq!(ARM_LENGTH, 2.0, "the hand computation assumes a 2 m arm");
    let rest = scene.evaluate(0.0, None);
    for (p, n, world, normal) in arm_vertices(scene, &rest) {
        assert_near(world, p, &format!("{label}: rest position of {p}"));
        assert_near(normal, n, &format!("{label}: rest normal at {p}"));
    }
    let frame = scene.evaluate(ARM_BENT_TIME_S, None);
    for (p, n, world, normal) in arm_vertices(scene, &frame) {
        let (expected_p, expected_n) = bent(p, n);
        assert_near(world, expected_p, &format!("{label}: bent position of {p}"));
        assert_near(normal, expected_n, &format!("{label}: bent normal at {p}"));
    }
    // The joints move the arm, not the node's transform, and the floor stays.
    let floor = node(scene, "floor");
    let static_tris = |f: &SceneFrame| -> Vec<[f32; 9]> {
        (f.triangles.iter().zip(&f.attributes))
            .filter(|(_, a)| a.node == floor as u32)
            .map(|(t, _)| {
                let v = [t.v0, t.v1, t.v2].map(|v| v.to_array());
                [v[0], v[1], v[2]].concat().try_into().unwrap()
            })
            .collect()
    };
    assert_eq!(static_tris(&rest), static_tris(&frame), "{label}: floor");
    assert!(
        frame.world_from_node[node(scene, "arm")]
            .transform_point3(Vec3::ZERO)
            .abs_diff_eq(ARM_NODE_TRANSLATION, 0.0)
    );
}

#[test]
fn skinned_arm_deforms_as_computed_by_hand() {
    let scene = skinned_arm();
    check_arm(&scene, "built");
    let arm = node(&scene, "arm");
    assert!(scene.is_animated(), "joints are animated");
    assert!(scene.deforming_nodes()[arm], "the arm deforms");
    assert!(!scene.moving_nodes()[arm], "its own transform stays");
    assert_eq!(
        scene.deforming_nodes().iter().filter(|&&d| d).count(),
        1,
        "only the arm deforms"
    );
    // A pose change of a joint is a change of the arm's geometry.
    let (rest, bent) = (scene.evaluate(0.0, None), scene.evaluate(1.0, None));
    assert!(scene.node_geometry_changed(arm, &rest, &bent));
    assert!(!scene.node_geometry_changed(arm, &rest, &rest));
    assert!(!scene.node_geometry_changed(node(&scene, "floor"), &rest, &bent));
}

#[test]
fn skins_survive_an_export_import_round_trip() {
    let scene = skinned_arm();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("arm.gltf");
    write_gltf(&scene, &path).unwrap();
    let (imported, warnings) = import_gltf(&path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    check_arm(&imported, "imported");

    assert_eq!(imported.skins.len(), 1);
    let (a, b) = (&scene.skins[0], &imported.skins[0]);
    let names = |s: &Scene, joints: &[usize]| -> Vec<String> {
        joints.iter().map(|&j| s.nodes[j].name.clone()).collect()
    };
    assert_eq!(names(&scene, &a.joints), names(&imported, &b.joints));
    assert_eq!(a.inverse_bind_matrices, b.inverse_bind_matrices);
    let arm = node(&imported, "arm");
    assert_eq!(imported.nodes[arm].skin, Some(0));
    let (pa, pb) = (
        &scene
            .meshes
            .iter()
            .find(|m| m.name == "arm")
            .unwrap()
            .primitives[0],
        &imported.meshes[imported.nodes[arm].mesh.unwrap()].primitives[0],
    );
    assert_eq!(pa.joints, pb.joints);
    assert_eq!(pa.weights, pb.weights);
    // The same triangles at a pose between the keys.
    let bits = |f: &SceneFrame| -> Vec<u32> {
        f.triangles
            .iter()
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .flat_map(|v| v.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!(
        bits(&scene.evaluate(0.37, None)),
        bits(&imported.evaluate(0.37, None))
    );

    // A skin whose joint is not a node is refused before anything is written.
    let mut broken = scene.clone();
    broken.skins[0].joints[1] = 99;
    assert!(matches!(
        write_gltf(&broken, &dir.path().join("broken.gltf")),
        Err(SceneError::Invalid { .. })
    ));
}

#[test]
fn weights_not_summing_to_one_are_renormalized() {
    let scene = skinned_arm();
    let mut scaled = scene.clone();
    for primitive in scaled.meshes.iter_mut().flat_map(|m| &mut m.primitives) {
        for w in &mut primitive.weights {
            *w *= 3.0;
        }
    }
    let (a, b) = (scene.evaluate(1.0, None), scaled.evaluate(1.0, None));
    for (x, y) in a.triangles.iter().zip(&b.triangles) {
        for (p, q) in [(x.v0, y.v0), (x.v1, y.v1), (x.v2, y.v2)] {
            assert_near(Vec3::from(p), Vec3::from(q), "renormalized");
        }
    }
}

#[test]
fn hand_built_scenes_with_bad_skins_fall_back_without_panicking() {
    let base = skinned_arm();
    let arm = node(&base, "arm");
    let arm_mesh = base.nodes[arm].mesh.unwrap();
    let first_vertex = |scene: &Scene, time: f32| -> Vec3 {
        let frame = scene.evaluate(time, None);
        let index = frame
            .attributes
            .iter()
            .position(|a| a.node == arm as u32)
            .unwrap();
        // Triangle 0's first corner is vertex 0 of the primitive.
        Vec3::from(frame.triangles[index].v0)
    };
    // All-zero weights: the vertex is placed by the node's own transform.
    let mut zero = base.clone();
    zero.meshes[arm_mesh].primitives[0].weights[0] = Vec4::ZERO;
    let p0 = base.meshes[arm_mesh].primitives[0].positions[0];
    assert_near(
        first_vertex(&zero, 1.0),
        p0 + ARM_NODE_TRANSLATION,
        "zero weights",
    );
    // A joint index beyond the skin, or a joint that is not a node, counts as weight zero.
    let mut out_of_range = base.clone();
    out_of_range.meshes[arm_mesh].primitives[0].joints[0] = [7, 7, 7, 7];
    assert_near(
        first_vertex(&out_of_range, 1.0),
        p0 + ARM_NODE_TRANSLATION,
        "joint out of range",
    );
    let mut missing_joint = base.clone();
    missing_joint.skins[0].joints = vec![99, 100];
    let _ = missing_joint.evaluate(1.0, None);
    // A skin index that does not exist leaves the mesh unskinned, placed by its node.
    let mut missing_skin = base.clone();
    missing_skin.nodes[arm].skin = Some(5);
    assert_near(
        first_vertex(&missing_skin, 1.0),
        p0 + ARM_NODE_TRANSLATION,
        "missing skin",
    );
    assert!(!missing_skin.deforming_nodes()[arm]);
    // Joints and weights shorter than the positions: not skinned.
    let mut short = base.clone();
    short.meshes[arm_mesh].primitives[0].weights.pop();
    let _ = short.evaluate(1.0, None);
    assert!(!short.deforming_nodes()[arm]);
    // Non-finite weights count as zero.
    let mut nan = base;
    nan.meshes[arm_mesh].primitives[0].weights[0] = Vec4::new(f32::NAN, -1.0, 0.0, 0.0);
    assert_near(
        first_vertex(&nan, 1.0),
        p0 + ARM_NODE_TRANSLATION,
        "NaN weights",
    );
}

// ---------------------------------------------------------------------------------------------
// Hand-written documents.

/// A skinned quad in the XY plane (vertices (0,0,0), (1,0,0), (1,1,0), (0,1,0)), node 0 with
/// skin 0 and mesh 0, node 1 the only joint, translated by (0, 0, 2). `joints` and `weights`
/// are the accessors' component type, normalized flag and raw bytes for the four vertices.
struct SkinDoc {
    joints: (u32, Vec<u8>),
    weights: (u32, bool, Vec<u8>),
    /// Accessor count declared for the weights (4 for a well-formed file).
    weight_count: usize,
    skin: Value,
    extra_attributes: Value,
}

impl SkinDoc {
    fn new() -> Self {
        Self {
            joints: (5121, vec![0; 16]),
            weights: (
                5126,
                false,
                [1.0f32, 0.0, 0.0, 0.0]
                    .repeat(4)
                    .iter()
                    .flat_map(|v| v.to_le_bytes())
                    .collect(),
            ),
            weight_count: 4,
            skin: json!({ "joints": [1] }),
            extra_attributes: json!({}),
        }
    }

    fn bytes(&self) -> Vec<u8> {
        let mut bin: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut view = |bytes: &[u8]| {
            while !bin.len().is_multiple_of(4) {
                bin.push(0);
            }
            views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
            bin.extend_from_slice(bytes);
            views.len() - 1
        };
        let positions: Vec<u8> = [
            0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0,
        ]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
        let indices: Vec<u8> = [0u32, 1, 2, 0, 2, 3]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let ibm: Vec<u8> = Mat4::IDENTITY
            .to_cols_array()
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let (pv, iv, jv, wv, mv) = (
            view(&positions),
            view(&indices),
            view(&self.joints.1),
            view(&self.weights.2),
            view(&ibm),
        );
        let accessors = json!([
            { "bufferView": pv, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] },
            { "bufferView": iv, "componentType": 5125, "count": 6, "type": "SCALAR" },
            { "bufferView": jv, "componentType": self.joints.0, "count": 4, "type": "VEC4" },
            { "bufferView": wv, "componentType": self.weights.0, "normalized": self.weights.1,
              "count": self.weight_count, "type": "VEC4" },
            { "bufferView": mv, "componentType": 5126, "count": 1, "type": "MAT4" },
        ]);
        let mut attributes = json!({ "POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3 });
        // A null removes the attribute.
        for (key, value) in self.extra_attributes.as_object().unwrap() {
            if value.is_null() {
                attributes.as_object_mut().unwrap().remove(key);
            } else {
                attributes[key] = value.clone();
            }
        }
        let doc = json!({
            "asset": { "version": "2.0" },
            "scenes": [{ "nodes": [0, 1] }],
            "nodes": [
                { "name": "quad", "mesh": 0, "skin": 0, "translation": [9.0, 9.0, 9.0] },
                { "name": "joint", "translation": [0.0, 0.0, 2.0] }
            ],
            "meshes": [{ "primitives": [{ "attributes": attributes, "indices": 1 }] }],
            "skins": [self.skin],
            "buffers": [{
                "byteLength": bin.len(),
                "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))
            }],
            "bufferViews": views,
            "accessors": accessors,
        });
        serde_json::to_vec(&doc).unwrap()
    }

    fn import(&self) -> Result<(Scene, Vec<gi_scene::ImportWarning>), SceneError> {
        import_gltf_slice(&self.bytes(), Path::new("skin.gltf"))
    }
}

/// The quad's vertices as evaluated: the joint's translation (0, 0, 2) moves them, the skinned
/// node's own (9, 9, 9) does not.
fn assert_quad_follows_joint(scene: &Scene, label: &str) {
    let frame = scene.evaluate(0.0, None);
    let corners: Vec<Vec3> = frame
        .triangles
        .iter()
        .flat_map(|t| [t.v0, t.v1, t.v2])
        .map(Vec3::from)
        .collect();
    assert_eq!(corners.len(), 6, "{label}");
    for c in corners {
        assert_eq!(c.z, 2.0, "{label}: {c}");
        assert!(
            c.x >= 0.0 && c.x <= 1.0 && c.y >= 0.0 && c.y <= 1.0,
            "{label}: {c}"
        );
    }
}

#[test]
fn joints_and_weights_decode_from_every_allowed_encoding() {
    let u16s = |v: &[u16]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let cases = [
        ("u8 joints, float weights", SkinDoc::new()),
        (
            "u16 joints, normalized u8 weights",
            SkinDoc {
                joints: (5123, u16s(&[0; 16])),
                weights: (5121, true, [255u8, 0, 0, 0].repeat(4)),
                ..SkinDoc::new()
            },
        ),
        (
            "normalized u16 weights, inverse bind matrices",
            SkinDoc {
                weights: (5123, true, u16s(&[65535, 0, 0, 0].repeat(4))),
                skin: json!({ "joints": [1], "inverseBindMatrices": 4 }),
                ..SkinDoc::new()
            },
        ),
    ];
    for (label, doc) in cases {
        let (scene, warnings) = doc.import().unwrap_or_else(|e| panic!("{label}: {e}"));
        assert!(warnings.is_empty(), "{label}: {warnings:?}");
        assert_eq!(
            scene.skins[0].joints,
            vec![node(&scene, "joint")],
            "{label}"
        );
        assert_eq!(scene.skins[0].inverse_bind_matrices, vec![Mat4::IDENTITY]);
        let primitive = &scene.meshes[0].primitives[0];
        assert_eq!(primitive.joints, vec![[0; 4]; 4], "{label}");
        assert_eq!(primitive.weights, vec![Vec4::X; 4], "{label}");
        assert_quad_follows_joint(&scene, label);
    }
}

#[test]
fn hostile_skin_data_gives_errors_or_warnings_never_panics() {
    let error = |doc: SkinDoc, expected: &str| match doc.import() {
        Ok(_) => panic!("expected an error about {expected}"),
        Err(e) => {
            let text = e.to_string();
            assert!(
                text.contains(expected),
                "{text} does not mention {expected}"
            );
            assert!(text.contains("skin.gltf"), "{text} does not name the file");
        }
    };
    // A weighted joint index beyond the skin's joint list.
    let mut joints = vec![0u8; 16];
    joints[4] = 3;
    error(
        SkinDoc {
            joints: (5121, joints),
            ..SkinDoc::new()
        },
        "names joint 3, but its skin",
    );
    // The same index with weight zero is never read: accepted.
    let mut joints = vec![0u8; 16];
    joints[5] = 3;
    let (scene, _) = SkinDoc {
        joints: (5121, joints),
        ..SkinDoc::new()
    }
    .import()
    .expect("unweighted joint indices are not read");
    assert_quad_follows_joint(&scene, "unweighted out-of-range joint");
    // A weights accessor with fewer entries than vertices.
    let mut short = SkinDoc::new();
    short.weight_count = 3;
    error(short, "WEIGHTS_0 has 3 entries for 4 positions");
    // A skin joint that is not a node.
    error(
        SkinDoc {
            skin: json!({ "joints": [7] }),
            ..SkinDoc::new()
        },
        "skins",
    );
    // Fewer inverse bind matrices than joints.
    error(
        SkinDoc {
            skin: json!({ "joints": [1, 1], "inverseBindMatrices": 4 }),
            ..SkinDoc::new()
        },
        "1 matrices for 2 joints",
    );
    // Joints without weights, and integer weights that are not normalized.
    error(
        SkinDoc {
            extra_attributes: json!({ "WEIGHTS_0": null }),
            ..SkinDoc::new()
        },
        "JOINTS_0 and WEIGHTS_0 must be given together",
    );
    error(
        SkinDoc {
            weights: (5121, false, [1u8, 0, 0, 0].repeat(4)),
            ..SkinDoc::new()
        },
        "normalized",
    );
    // Negative weights.
    error(
        SkinDoc {
            weights: (
                5126,
                false,
                [-1.0f32, 0.0, 0.0, 0.0]
                    .repeat(4)
                    .iter()
                    .flat_map(|v| v.to_le_bytes())
                    .collect(),
            ),
            ..SkinDoc::new()
        },
        "negative weights",
    );
    // All-zero weights: a warning, and the vertices stay where the node puts them.
    let (scene, warnings) = SkinDoc {
        weights: (5126, false, vec![0; 64]),
        ..SkinDoc::new()
    }
    .import()
    .expect("zero weights are a warning");
    assert!(
        warnings
            .iter()
            .any(|w| w.0.contains("weights are all zero")),
        "{warnings:?}"
    );
    let frame = scene.evaluate(0.0, None);
    assert_eq!(Vec3::from(frame.triangles[0].v0), Vec3::splat(9.0));
    // A second joint set: warned and ignored.
    let (scene, warnings) = SkinDoc {
        extra_attributes: json!({ "JOINTS_1": 2, "WEIGHTS_1": 3 }),
        ..SkinDoc::new()
    }
    .import()
    .expect("JOINTS_1 is ignored");
    assert!(
        warnings.iter().any(|w| w.0.contains("JOINTS_1")),
        "{warnings:?}"
    );
    assert_quad_follows_joint(&scene, "second joint set ignored");
    // Corrupted skin fields in every position: errors, never a panic.
    for (key, value) in [
        ("joints", json!([])),
        ("joints", json!([-1])),
        ("joints", json!(["a"])),
        ("inverseBindMatrices", json!(0)),
        ("inverseBindMatrices", json!(99)),
        ("inverseBindMatrices", json!(2)),
        ("skeleton", json!(42)),
    ] {
        let mut doc = SkinDoc::new();
        doc.skin[key] = value;
        let _ = doc.import();
    }
    for (joints, weights) in [(5126, 5126), (5125, 5126), (5121, 5120), (5121, 5125)] {
        let doc = SkinDoc {
            joints: (joints, vec![0; 64]),
            weights: (weights, true, vec![0; 64]),
            ..SkinDoc::new()
        };
        assert!(doc.import().is_err(), "component types {joints}/{weights}");
    }
}

/// A skinned tube large enough to be evaluated in parallel (19,200 triangles, chunks of 4,096)
/// gives the same frame bit for bit on one thread and on four, and every vertex is the blend
/// of its two joints' matrices computed here, within rounding.
#[test]
fn large_skinned_meshes_evaluate_the_same_on_any_number_of_threads() {
    let scene = gi_scene::generate::skinned_tube(200, 48);
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool")
            .install(|| scene.evaluate(ARM_BENT_TIME_S * 0.5, None))
    };
    let (one, four) = (on(1), on(4));
    let bits = |frame: &SceneFrame| -> Vec<u32> {
        let mut out = Vec::new();
        for (t, a) in frame.triangles.iter().zip(&frame.attributes) {
            for v in [t.v0, t.v1, t.v2] {
                out.extend(v.to_array().map(f32::to_bits));
            }
            for k in 0..3 {
                out.extend(a.normals[k].to_array().map(f32::to_bits));
                out.extend(a.uvs[k].to_array().map(f32::to_bits));
                out.extend(a.tangents[k].to_array().map(f32::to_bits));
            }
            out.extend([a.material, a.node]);
        }
        out
    };
    assert_eq!(
        one.triangles.len(),
        2 + 2 * 200 * 48,
        "the floor and the tube"
    );
    assert!(
        bits(&one) == bits(&four),
        "the frame depends on the thread count"
    );

    let arm = node(&scene, "arm");
    let primitive = &scene.meshes[scene.nodes[arm].mesh.unwrap()].primitives[0];
    let skin = &scene.skins[scene.nodes[arm].skin.unwrap()];
    let joints = skin.joint_matrices(&four.world_from_node);
    let first = (four.attributes.iter())
        .position(|a| a.node == arm as u32)
        .unwrap();
    for (t, corners) in primitive.indices.chunks_exact(3).enumerate() {
        let triangle = four.triangles[first + t];
        for (k, world) in [triangle.v0, triangle.v1, triangle.v2]
            .into_iter()
            .enumerate()
        {
            let v = corners[k] as usize;
            let w = primitive.weights[v];
            let blended = joints[0].unwrap() * w.x + joints[1].unwrap() * w.y;
            let expected = blended.transform_point3(primitive.positions[v]);
            assert_near(
                Vec3::from(world),
                expected,
                &format!("triangle {t} vertex {k}"),
            );
        }
    }
}

/// Evaluated with a skinned node's shading left out, a frame has the same triangles (winding
/// included, with a mirroring joint), texture coordinates, materials and nodes as a complete
/// evaluation, bit for bit, and zero normals and tangents on that node only; the other nodes
/// are complete.
#[test]
fn positions_only_evaluation_keeps_geometry_and_leaves_out_shading() {
    let mut scene = gi_scene::generate::skinned_tube(6, 5);
    let arm = node(&scene, "arm");
    let elbow = node(&scene, "elbow");
    scene.nodes[elbow].scale = Vec3::new(-1.0, 1.0, 1.0);
    let tube = &mut scene.meshes[scene.nodes[arm].mesh.unwrap()].primitives[0];
    for i in 0..tube.positions.len() {
        tube.tangents.push(Vec4::new(1.0, 0.0, 0.0, 1.0));
        tube.uvs.push(glam::Vec2::splat(i as f32));
    }
    let mut only = vec![false; scene.nodes.len()];
    only[arm] = true;
    let evaluation = gi_scene::Evaluation {
        positions_only: only.clone(),
    };
    for time in [0.0, 0.5, ARM_BENT_TIME_S] {
        let full = scene.evaluate(time, None);
        let partial = scene.evaluate_with(time, None, &evaluation);
        assert!(full.positions_only.is_empty());
        assert_eq!(partial.positions_only, only);
        assert_eq!(full.triangles.len(), partial.triangles.len());
        let mut mirrored = 0;
        for (t, (a, b)) in full.attributes.iter().zip(&partial.attributes).enumerate() {
            let (x, y) = (&full.triangles[t], &partial.triangles[t]);
            assert_eq!(
                (x.v0, x.v1, x.v2),
                (y.v0, y.v1, y.v2),
                "{time} s, triangle {t}"
            );
            assert_eq!(
                (a.uvs, a.uvs1, a.material, a.node),
                (b.uvs, b.uvs1, b.material, b.node),
                "{time} s, triangle {t}"
            );
            if a.node as usize == arm {
                assert_eq!(b.normals, [Vec3::ZERO; 3], "{time} s, triangle {t}");
                assert_eq!(b.tangents, [Vec4::ZERO; 3], "{time} s, triangle {t}");
                // A mirrored vertex turns its tangent's sign: the complete frame shows it.
                mirrored += usize::from(a.tangents[0].w < 0.0);
            } else {
                assert_eq!((a.normals, a.tangents), (b.normals, b.tangents));
            }
        }
        assert!(mirrored > 0, "{time} s: some triangles mirror");
    }
}
