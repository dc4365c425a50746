//! glTF import: Khronos sample models, hand-written documents for the product's extras and the
//! conversions the importer performs, malformed inputs, and corrupted bytes.

mod common;
use common::base64;

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
use std::path::{Path, PathBuf};

use gi_scene::{
    AlphaMode, ChannelValues, ImportWarning, Interpolation, LightKind, Scene, SceneError, Sky,
    TextureEncoding, TextureRef, TextureTransform, import_gltf, import_gltf_slice,
};
use glam::{Quat, Vec2, Vec3, Vec4};
use serde_json::{Value, json};

fn sample(model: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/gltf-samples")
        .join(model)
        .join(file)
}

fn load(path: &Path) -> (Scene, Vec<ImportWarning>) {
    import_gltf(path).unwrap_or_else(|e| panic!("{e}"))
}

/// Imports an in-memory document named `test.gltf`.
fn load_doc(bytes: &[u8]) -> (Scene, Vec<ImportWarning>) {
    import_gltf_slice(bytes, Path::new("test.gltf")).unwrap_or_else(|e| panic!("{e}"))
}

fn doc_error(bytes: &[u8]) -> SceneError {
    match import_gltf_slice(bytes, Path::new("broken.gltf")) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

fn triangles(scene: &Scene) -> usize {
    scene.evaluate(0.0, None).triangles.len()
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-4 * (1.0 + a.abs().max(b.abs()))
}

fn assert_close3(a: Vec3, b: Vec3) {
    assert!(a.abs_diff_eq(b, 1e-4), "{a} != {b}");
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn node(scene: &Scene, name: &str) -> usize {
    scene
        .nodes
        .iter()
        .position(|n| n.name == name)
        .unwrap_or_else(|| panic!("no node {name}"))
}

fn has_warning(warnings: &[ImportWarning], text: &str) -> bool {
    warnings.iter().any(|w| w.0.contains(text))
}

/// Builds small glTF documents whose single buffer is an embedded `data:` URI.
#[derive(Default)]
struct Doc {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(json!({
            "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()
        }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn floats(&mut self, values: &[f32], ty: &str, components: usize) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let mut accessor = json!({
            "bufferView": view, "componentType": 5126,
            "count": values.len() / components, "type": ty
        });
        if ty == "VEC3" {
            let column = |k: usize| values.iter().skip(k).step_by(3).copied();
            let min: Vec<f32> = (0..3).map(|k| column(k).fold(f32::MAX, f32::min)).collect();
            let max: Vec<f32> = (0..3).map(|k| column(k).fold(f32::MIN, f32::max)).collect();
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, values: &[[f32; 3]]) -> usize {
        self.floats(values.as_flattened(), "VEC3", 3)
    }

    fn vec2(&mut self, values: &[[f32; 2]]) -> usize {
        self.floats(values.as_flattened(), "VEC2", 2)
    }

    fn vec4(&mut self, values: &[[f32; 4]]) -> usize {
        self.floats(values.as_flattened(), "VEC4", 4)
    }

    fn scalars(&mut self, values: &[f32]) -> usize {
        self.floats(values, "SCALAR", 1)
    }

    fn indices(&mut self, values: &[u32]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": values.len(), "type": "SCALAR"
        }));
        self.accessors.len() - 1
    }

    /// One triangle in the XZ plane facing +Y, as a mesh object.
    fn triangle_mesh(&mut self) -> Value {
        let positions = self.vec3(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
        json!({ "primitives": [{ "attributes": { "POSITION": positions } }] })
    }

    /// Completes `doc` with the asset header, the buffer, views and accessors.
    fn finish(self, mut doc: Value) -> Vec<u8> {
        doc["asset"] = json!({ "version": "2.0" });
        if !self.bin.is_empty() {
            doc["buffers"] = json!([{
                "byteLength": self.bin.len(),
                "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bin))
            }]);
            doc["bufferViews"] = json!(self.views);
            doc["accessors"] = json!(self.accessors);
        }
        serde_json::to_vec(&doc).unwrap()
    }
}

/// `doc` with its one primitive repeated once per material, the i-th using material i.
fn primitive_per_material(doc: &[u8], count: usize) -> Value {
    let mut doc: Value = serde_json::from_slice(doc).unwrap();
    let primitive = doc["meshes"][0]["primitives"][0].clone();
    let primitives: Vec<Value> = (0..count)
        .map(|m| {
            let mut p = primitive.clone();
            p["material"] = json!(m);
            p
        })
        .collect();
    doc["meshes"][0]["primitives"] = json!(primitives);
    doc
}

/// A document with one triangle node plus `extra` merged into the top level.
fn triangle_doc(extra: Value) -> Vec<u8> {
    let mut d = Doc::default();
    let mesh = d.triangle_mesh();
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "Triangle", "mesh": 0 }],
        "meshes": [mesh]
    });
    for (key, value) in extra.as_object().unwrap() {
        doc[key] = value.clone();
    }
    d.finish(doc)
}

#[test]
fn box_gltf_and_glb_import_identically() {
    let (gltf, gltf_warnings) = load(&sample("Box", "glTF/Box.gltf"));
    let (glb, glb_warnings) = load(&sample("Box", "glTF-Binary/Box.glb"));
    assert!(gltf_warnings.is_empty() && glb_warnings.is_empty());
    for scene in [&gltf, &glb] {
        assert_eq!(scene.name, "Box");
        assert_eq!(triangles(scene), 12);
        assert_eq!(scene.materials.len(), 1);
        let material = &scene.materials[0];
        assert_eq!(material.name, "Red");
        assert!(
            material
                .base_color
                .abs_diff_eq(Vec4::new(0.8, 0.0, 0.0, 1.0), 1e-6)
        );
        assert_eq!((material.metallic, material.roughness), (0.0, 1.0));
        assert_eq!(scene.nodes.len(), 2);
        assert_eq!(scene.nodes[1].parent, Some(0));
        assert_eq!(scene.nodes[1].mesh, Some(0));
        // The root's matrix turns the Z-up mesh to Y-up: -90 degrees about X.
        let expected = Quat::from_rotation_x(-FRAC_PI_2);
        assert!(scene.nodes[0].rotation.angle_between(expected) < 1e-4);
        let primitive = &scene.meshes[0].primitives[0];
        assert!(primitive.normals.iter().all(|n| close(n.length(), 1.0)));
        assert_eq!(scene.default_camera_node, None);
        assert_eq!(scene.sky, Sky::default());
        assert_eq!(scene.exposure, 1.0);
        assert!(close(scene.frame_time_s, 1.0 / 30.0));
    }
    let (a, b) = (&gltf.meshes[0].primitives[0], &glb.meshes[0].primitives[0]);
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.indices, b.indices);
}

#[test]
fn box_textured_decodes_the_base_color_texture_to_linear() {
    let png = image::open(sample("BoxTextured", "glTF/CesiumLogoFlat.png"))
        .unwrap()
        .to_rgba8();
    for file in ["glTF/BoxTextured.gltf", "glTF-Binary/BoxTextured.glb"] {
        let (scene, warnings) = load(&sample("BoxTextured", file));
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(triangles(&scene), 12);
        assert_eq!(scene.textures.len(), 1);
        assert_eq!(
            scene.materials[0].base_color_texture,
            Some(TextureRef::new(0))
        );
        let texture = &scene.textures[0];
        assert_eq!((texture.width, texture.height), (256, 256));
        assert_eq!(texture.encoding, TextureEncoding::Srgb);
        for (&texel, pixel) in texture.texels.iter().zip(png.pixels()) {
            let texel = texture.decode(texel);
            let expected = Vec4::new(
                srgb_to_linear(f32::from(pixel[0]) / 255.0),
                srgb_to_linear(f32::from(pixel[1]) / 255.0),
                srgb_to_linear(f32::from(pixel[2]) / 255.0),
                f32::from(pixel[3]) / 255.0,
            );
            assert!(texel.abs_diff_eq(expected, 1e-5), "{texel} != {expected}");
        }
        // Top row first: the logo's sky blue, sRGB (108, 173, 223), is near the top and its
        // green hills, sRGB (92, 135, 39), near the bottom; both stored linear.
        let sky = texture.texel(128, 60);
        let hills = texture.texel(128, 220);
        assert!(
            sky.abs_diff_eq(Vec4::new(0.150, 0.4179, 0.7379, 1.0), 1e-3),
            "{sky}"
        );
        assert!(
            hills.abs_diff_eq(Vec4::new(0.107, 0.2423, 0.0203, 1.0), 1e-3),
            "{hills}"
        );
        let primitive = &scene.meshes[0].primitives[0];
        assert_eq!(primitive.uvs.len(), primitive.positions.len());
    }
}

#[test]
fn emissive_strength_multiplies_the_emissive_factor() {
    let (scene, warnings) = load(&sample(
        "EmissiveStrengthTest",
        "glTF-Binary/EmissiveStrengthTest.glb",
    ));
    assert!(warnings.is_empty(), "{warnings:?}");
    for (name, strength) in [
        ("Emit1", 1.0),
        ("Emit2", 2.0),
        ("Emit4", 4.0),
        ("Emit16", 16.0),
    ] {
        let material = scene.materials.iter().find(|m| m.name == name).unwrap();
        assert_close3(material.emissive, Vec3::new(0.1, 0.5, 0.9) * strength);
        assert!(close(material.roughness, 0.8));
    }
}

#[test]
fn box_animated_moves_over_time() {
    let (scene, warnings) = load(&sample("BoxAnimated", "glTF-Binary/BoxAnimated.glb"));
    assert!(warnings.is_empty(), "{warnings:?}");
    assert!(scene.is_animated());
    assert_eq!(scene.animations.len(), 1);
    let channels = &scene.animations[0].channels;
    assert_eq!(channels.len(), 2);
    assert!(
        channels
            .iter()
            .all(|c| c.interpolation == Interpolation::Linear)
    );
    assert!(
        channels
            .iter()
            .any(|c| matches!(c.values, ChannelValues::Rotation(_)))
    );
    assert!(
        channels
            .iter()
            .any(|c| matches!(c.values, ChannelValues::Translation(_)))
    );

    // The inner box hangs below two ancestors; the root of that chain rises 2.52 by t = 1.25.
    let inner = (0..scene.nodes.len())
        .find(|&i| scene.nodes[i].mesh.is_some() && scene.nodes[i].parent.is_some())
        .unwrap();
    let height = |t: f32| scene.world_transforms(t)[inner].w_axis.y;
    assert!(close(height(0.0), 0.0));
    assert!(close(height(0.625), 1.26));
    assert!(close(height(1.25), 2.52));
    let orientation = |t: f32| scene.world_transforms(t)[inner].y_axis;
    assert!(
        orientation(0.0).distance(orientation(2.5)) > 1.0,
        "the box flips over"
    );
}

#[test]
fn texture_coordinates_have_their_origin_at_the_image_top_left() {
    let (scene, _) = load(&sample(
        "TextureCoordinateTest",
        "glTF-Binary/TextureCoordinateTest.glb",
    ));
    let top_left = &scene.nodes[node(&scene, "TopLeftObj")];
    let primitive = &scene.meshes[top_left.mesh.unwrap()].primitives[0];
    assert_eq!(primitive.uvs.len(), primitive.positions.len());
    // Moving right in the scene increases u; moving up decreases v (v points down the image).
    for (p, uv) in primitive.positions.iter().zip(&primitive.uvs) {
        let expected = Vec2::new((p.x + 1.2) * 0.4, (1.2 - p.y) * 0.4);
        assert!(uv.abs_diff_eq(expected, 1e-3), "{p} has uv {uv}");
    }
}

#[test]
fn missing_normals_are_computed() {
    let mut d = Doc::default();
    // A floor triangle (+Y) and a wall triangle (+X) twice the floor's area, sharing edge a-b.
    let (a, b, c, w) = (
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 2.0, 0.0],
    );
    let shared = d.vec3(&[a, b, c, w]);
    let shared_indices = d.indices(&[0, 1, 2, 0, 3, 1]);
    let unshared = d.vec3(&[a, b, c, a, w, b]);
    let given = d.vec3(&[a, b, c]);
    let given_normals = d.vec3(&[[0.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 1.0, 0.0]]);
    let doc = json!({
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [{ "mesh": 0 }, { "mesh": 1 }, { "mesh": 2 }],
        "meshes": [
            { "primitives": [{ "attributes": { "POSITION": shared }, "indices": shared_indices }] },
            { "primitives": [{ "attributes": { "POSITION": unshared } }] },
            { "primitives": [{ "attributes": { "POSITION": given, "NORMAL": given_normals } }] }
        ]
    });
    let (scene, warnings) = load_doc(&d.finish(doc));
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(
        scene.materials.len(),
        1,
        "primitives without material share the default"
    );
    assert_eq!(scene.materials[0].base_color, Vec4::ONE);
    assert_eq!(
        (scene.materials[0].metallic, scene.materials[0].roughness),
        (1.0, 1.0)
    );

    // Indexed: shared vertices average the faces weighted by area.
    let smooth = &scene.meshes[0].primitives[0].normals;
    let blended = Vec3::new(2.0, 1.0, 0.0).normalize();
    for (normal, expected) in smooth.iter().zip([blended, blended, Vec3::Y, Vec3::X]) {
        assert_close3(*normal, expected);
    }
    // Not indexed: flat normals per triangle.
    let flat = &scene.meshes[1].primitives[0].normals;
    let expected = [Vec3::Y, Vec3::Y, Vec3::Y, Vec3::X, Vec3::X, Vec3::X];
    for (normal, expected) in flat.iter().zip(expected) {
        assert_close3(*normal, expected);
    }
    assert_eq!(scene.meshes[1].primitives[0].indices, [0, 1, 2, 3, 4, 5]);
    // Given normals are normalized; a zero normal takes the geometric one.
    for normal in &scene.meshes[2].primitives[0].normals {
        assert_close3(*normal, Vec3::Y);
    }
}

#[test]
fn strips_and_fans_become_triangle_lists_and_points_are_skipped() {
    let mut d = Doc::default();
    // A unit quad in the XY plane facing +Z, as a strip and as a fan around its center.
    let strip = d.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ]);
    let fan = d.vec3(&[
        [0.5, 0.5, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
    ]);
    let points = d.vec3(&[[0.0, 0.0, 0.0]]);
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": strip }, "mode": 5 },
            { "attributes": { "POSITION": fan }, "mode": 6 },
            { "attributes": { "POSITION": points }, "mode": 0 }
        ] }]
    });
    let (scene, warnings) = load_doc(&d.finish(doc));
    assert!(
        has_warning(&warnings, "point and line primitives"),
        "{warnings:?}"
    );
    let primitives = &scene.meshes[0].primitives;
    assert_eq!(primitives.len(), 2);
    assert_eq!(primitives[0].indices.len() / 3, 2);
    assert_eq!(primitives[1].indices.len() / 3, 4);
    for primitive in primitives {
        for tri in primitive.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| primitive.positions[tri[k] as usize]);
            let facing = (b - a).cross(c - a).normalize();
            assert_close3(facing, Vec3::Z);
        }
        assert!(
            primitive
                .normals
                .iter()
                .all(|n| n.abs_diff_eq(Vec3::Z, 1e-5))
        );
    }
}

#[test]
fn lights_cameras_and_product_extras_are_imported() {
    let extras = json!({ "gi": {
        "sky": { "gradient": { "zenith": [0.1, 0.2, 0.9], "horizon": [0.8, 0.8, 0.9], "ground": [0.1, 0.1, 0.1] } },
        "exposure": 2.0,
        "frame_time_s": 0.05,
        "camera": "Main",
        "camera_path": { "yfov": 0.7, "keys": [
            { "time_s": 0.0, "position": [0, 1, 5], "target": [0, 0, 0] },
            { "time_s": 2.0, "position": [5, 1, 0], "target": [0, 0, 0] }
        ] },
        "future_setting": true
    } });
    let doc = |scene_extras: Value| {
        triangle_doc(json!({
            "scenes": [{ "nodes": [0, 1, 2, 3, 4, 5, 6, 7, 8], "extras": scene_extras }],
            "nodes": [
                { "name": "Triangle", "mesh": 0, "extras": { "gi": { "path": {
                    "times": [0.0, 1.0, 2.0], "translations": [[0, 0, 0], [1, 0, 0], [1, 1, 0]] } } } },
                { "name": "Overview", "camera": 0, "translation": [0, 1, 5] },
                { "name": "Main", "camera": 1 },
                { "name": "Ortho", "camera": 2 },
                { "name": "Sun", "extensions": { "KHR_lights_punctual": { "light": 0 } } },
                { "name": "Bulb", "extensions": { "KHR_lights_punctual": { "light": 1 } } },
                { "name": "Spot", "extensions": { "KHR_lights_punctual": { "light": 2 } } },
                { "name": "DefaultSpot", "extensions": { "KHR_lights_punctual": { "light": 3 } } },
                { "name": "Empty", "extras": { "other_tool": 1 } }
            ],
            "cameras": [
                { "type": "perspective", "perspective": { "yfov": 0.9, "znear": 0.1, "aspectRatio": 1.5 } },
                { "type": "perspective", "perspective": { "yfov": 0.5, "znear": 0.01 } },
                { "type": "orthographic", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10 } }
            ],
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": { "KHR_lights_punctual": { "lights": [
                { "type": "directional", "color": [1.0, 0.9, 0.8], "intensity": 3.0 },
                { "type": "point", "range": 10.0 },
                { "type": "spot", "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 } },
                { "type": "spot", "spot": {} }
            ] } }
        }))
    };
    let (scene, warnings) = load_doc(&doc(extras));
    assert!(has_warning(&warnings, "future_setting"), "{warnings:?}");
    assert!(has_warning(&warnings, "orthographic"), "{warnings:?}");
    assert_eq!(scene.name, "test");

    assert_eq!(scene.cameras.len(), 2);
    assert_eq!(scene.nodes[node(&scene, "Ortho")].camera, None);
    let overview = &scene.cameras[scene.nodes[node(&scene, "Overview")].camera.unwrap()];
    assert_eq!(
        (overview.yfov, overview.znear, overview.aspect_ratio),
        (0.9, 0.1, Some(1.5))
    );
    assert_eq!(scene.default_camera_node, Some(node(&scene, "Main")));

    let light = |name: &str| &scene.lights[scene.nodes[node(&scene, name)].light.unwrap()];
    assert_eq!(light("Sun").kind, LightKind::Directional);
    assert_eq!(
        (light("Sun").color, light("Sun").intensity),
        (Vec3::new(1.0, 0.9, 0.8), 3.0)
    );
    assert_eq!(light("Bulb").kind, LightKind::Point);
    assert_eq!(
        (light("Bulb").color, light("Bulb").intensity),
        (Vec3::ONE, 1.0)
    );
    assert_eq!(light("Bulb").range, Some(10.0));
    let spot = LightKind::Spot {
        inner_cone_angle: 0.2,
        outer_cone_angle: 0.5,
    };
    assert_eq!(light("Spot").kind, spot);
    let default_spot = LightKind::Spot {
        inner_cone_angle: 0.0,
        outer_cone_angle: FRAC_PI_4,
    };
    assert_eq!(light("DefaultSpot").kind, default_spot);
    assert_eq!(light("DefaultSpot").range, None);

    let gradient = Sky::Gradient {
        zenith: Vec3::new(0.1, 0.2, 0.9),
        horizon: Vec3::new(0.8, 0.8, 0.9),
        ground: Vec3::new(0.1, 0.1, 0.1),
    };
    assert_eq!(scene.sky, gradient);
    assert_eq!((scene.exposure, scene.frame_time_s), (2.0, 0.05));
    let path = scene.camera_path.as_ref().unwrap();
    assert_eq!((path.yfov, path.keys.len()), (0.7, 2));
    assert_eq!(path.keys[1].position, Vec3::new(5.0, 1.0, 0.0));

    // The node path becomes a linear translation animation named after the node.
    assert_eq!(scene.animations.len(), 1);
    assert_eq!(scene.animations[0].name, "Triangle");
    let triangle = node(&scene, "Triangle");
    let position = scene.world_transforms(1.5)[triangle].w_axis.truncate();
    assert_close3(position, Vec3::new(1.0, 0.5, 0.0));

    // Without a named camera, the first camera in depth-first order is the default.
    let (scene, _) = load_doc(&doc(json!({})));
    assert_eq!(scene.default_camera_node, Some(node(&scene, "Overview")));
    assert_eq!(scene.sky, Sky::default());
    assert!(scene.camera_path.is_none());
}

#[test]
fn animation_samplers_are_converted() {
    let mut d = Doc::default();
    let mesh = d.triangle_mesh();
    let times = d.scalars(&[0.0, 1.0]);
    let cubic = d.vec3(&[
        [9.0, 9.0, 9.0],
        [0.0, 0.0, 0.0],
        [9.0, 9.0, 9.0],
        [9.0, 9.0, 9.0],
        [2.0, 0.0, 0.0],
        [9.0, 9.0, 9.0],
    ]);
    let scales = d.vec3(&[[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]);
    let rotations = d.vec4(&[[0.0, 0.0, 0.0, 2.0], [0.0, 1.0, 0.0, 0.0]]);
    let weights = d.scalars(&[0.0, 1.0]);
    let doc = json!({
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [{ "mesh": 0 }, { "name": "Outside" }, { "name": "NotInScene" }],
        "meshes": [mesh],
        "animations": [{
            "channels": [
                { "sampler": 0, "target": { "node": 0, "path": "translation" } },
                { "sampler": 1, "target": { "node": 0, "path": "scale" } },
                { "sampler": 2, "target": { "node": 1, "path": "rotation" } },
                { "sampler": 3, "target": { "node": 0, "path": "weights" } },
                { "sampler": 1, "target": { "node": 2, "path": "scale" } }
            ],
            "samplers": [
                { "input": times, "output": cubic, "interpolation": "CUBICSPLINE" },
                { "input": times, "output": scales, "interpolation": "STEP" },
                { "input": times, "output": rotations },
                { "input": times, "output": weights }
            ]
        }]
    });
    let (scene, warnings) = load_doc(&d.finish(doc));
    assert!(has_warning(&warnings, "CUBICSPLINE"), "{warnings:?}");
    assert!(has_warning(&warnings, "no morph targets"), "{warnings:?}");
    assert_eq!(
        scene.nodes.len(),
        2,
        "nodes outside the scene are not imported"
    );
    let channels = &scene.animations[0].channels;
    assert_eq!(channels.len(), 3);
    match &channels[0].values {
        ChannelValues::Translation(v) => assert_eq!(v, &[Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)]),
        other => panic!("{other:?}"),
    }
    assert_eq!(channels[0].interpolation, Interpolation::Linear);
    assert_eq!(channels[1].interpolation, Interpolation::Step);
    match &channels[2].values {
        ChannelValues::Rotation(q) => assert_eq!(q[0], Quat::IDENTITY, "rotations are normalized"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn sparse_normalized_and_small_integer_accessors_are_decoded() {
    let sparse_doc = |sparse_index: u8| {
        let mut d = Doc::default();
        let base = d.vec3(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [9.0, 9.0, 9.0]]);
        let sparse_indices = d.view(&[sparse_index]);
        let sparse_values = d.view(&[1.0f32, 0.0, 0.0].map(f32::to_le_bytes).concat());
        let uvs = d.view(&[0, 0, 255, 0, 0, 255]);
        let indices = d.view(&[0, 1, 2]);
        let mut accessors = d.accessors.clone();
        accessors[base]["sparse"] = json!({
            "count": 1,
            "indices": { "bufferView": sparse_indices, "componentType": 5121 },
            "values": { "bufferView": sparse_values }
        });
        accessors.push(
            json!({ "bufferView": uvs, "componentType": 5121, "normalized": true,
                               "count": 3, "type": "VEC2" }),
        );
        accessors.push(json!({ "bufferView": indices, "componentType": 5121,
                               "count": 3, "type": "SCALAR" }));
        d.accessors = accessors;
        d.finish(json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{
                "attributes": { "POSITION": base, "TEXCOORD_0": base + 1 }, "indices": base + 2
            }] }]
        }))
    };
    let (scene, _) = load_doc(&sparse_doc(2));
    let primitive = &scene.meshes[0].primitives[0];
    assert_eq!(
        primitive.positions[2],
        Vec3::X,
        "the sparse value replaces vertex 2"
    );
    assert_eq!(primitive.uvs, [Vec2::ZERO, Vec2::X, Vec2::Y]);
    assert_eq!(primitive.indices, [0, 1, 2]);
    match doc_error(&sparse_doc(7)) {
        e @ SceneError::Gltf { .. } => assert!(e.to_string().contains("sparse index 7"), "{e}"),
        other => panic!("expected a glTF error, got {other}"),
    }
}

/// A 2x2 RGBA PNG whose every channel is 128, as a data URI.
fn gray_png_uri() -> String {
    let image = image::RgbaImage::from_pixel(2, 2, image::Rgba([128, 128, 128, 255]));
    let mut png = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    format!("data:image/png;base64,{}", base64(&png))
}

#[test]
fn one_image_used_as_srgb_and_linear_becomes_two_textures() {
    let doc = triangle_doc(json!({
        "materials": [{
            "pbrMetallicRoughness": {
                "baseColorTexture": { "index": 0 },
                "metallicRoughnessTexture": { "index": 0 }
            },
            "emissiveTexture": { "index": 0 }
        }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": gray_png_uri() }]
    }));
    let mut doc: Value = serde_json::from_slice(&doc).unwrap();
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let (scene, warnings) = load_doc(&serde_json::to_vec(&doc).unwrap());
    assert!(has_warning(&warnings, "no TEXCOORD_0"), "{warnings:?}");
    assert_eq!(scene.textures.len(), 2);
    let material = &scene.materials[0];
    assert_eq!(material.base_color_texture, material.emissive_texture);
    let srgb = scene.textures[material.base_color_texture.unwrap().texture].texel(0, 0);
    let linear = scene.textures[material.metallic_roughness_texture.unwrap().texture].texel(0, 0);
    assert!(close(srgb.x, srgb_to_linear(128.0 / 255.0)));
    assert!(close(linear.x, 128.0 / 255.0));
    assert_eq!((srgb.w, linear.w), (1.0, 1.0));
}

#[test]
fn specular_and_ior_extensions_are_imported() {
    // KHR_materials_specular (factor, color factor past 1, both textures: the color one
    // sRGB-decoded, the factor one read from its alpha) and KHR_materials_ior, required by the
    // file; a material without them keeps glTF's defaults.
    let doc = triangle_doc(json!({
        "materials": [
            {
                "extensions": {
                    "KHR_materials_specular": {
                        "specularFactor": 0.25,
                        "specularTexture": { "index": 0 },
                        "specularColorFactor": [2.0, 1.0, 0.5],
                        "specularColorTexture": { "index": 0 }
                    },
                    "KHR_materials_ior": { "ior": 1.33 }
                }
            },
            { "extensions": { "KHR_materials_specular": { "specularFactor": 0.0 } } },
            {}
        ],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": gray_png_uri() }],
        "extensionsUsed": ["KHR_materials_specular", "KHR_materials_ior"],
        "extensionsRequired": ["KHR_materials_specular", "KHR_materials_ior"]
    }));
    let doc = primitive_per_material(&doc, 3);
    let (scene, warnings) = load_doc(&serde_json::to_vec(&doc).unwrap());
    assert!(
        !warnings
            .iter()
            .any(|w| w.to_string().contains("KHR_materials")),
        "{warnings:?}"
    );
    let m = &scene.materials[0];
    assert_eq!((m.specular, m.ior), (0.25, 1.33));
    assert_eq!(m.specular_color, Vec3::new(2.0, 1.0, 0.5));
    let color = scene.textures[m.specular_color_texture.unwrap().texture].texel(0, 0);
    let factor = scene.textures[m.specular_texture.unwrap().texture].texel(0, 0);
    assert!(close(color.x, srgb_to_linear(128.0 / 255.0)));
    assert!(close(factor.x, 128.0 / 255.0));
    assert_eq!(factor.w, 1.0);
    assert_eq!(scene.materials[1].specular, 0.0);
    let default = &scene.materials[2];
    assert_eq!((default.specular, default.ior), (1.0, 1.5));
    assert_eq!(default.specular_color, Vec3::ONE);
    assert_eq!(default.specular_texture, None);

    // An ior the extension does not allow (between 0 and 1) is an error naming it.
    let mut bad = doc.clone();
    bad["materials"][0]["extensions"]["KHR_materials_ior"]["ior"] = json!(0.5);
    let message = doc_error(&serde_json::to_vec(&bad).unwrap()).to_string();
    assert!(message.contains("ior 0.5"), "{message}");
}

#[test]
fn unsupported_features_produce_warnings() {
    let doc = triangle_doc(json!({
        "materials": [
            { "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 2 } } },
            { "emissiveTexture": { "index": 1 } }
        ],
        "textures": [{ "source": 0 }, { "source": 0, "sampler": 0 }],
        "samplers": [{ "wrapS": 33071 }],
        "images": [{ "uri": gray_png_uri() }],
        "extensionsUsed": ["KHR_materials_clearcoat", "EXT_unknown_thing"]
    }));
    let doc = primitive_per_material(&doc, 2);
    let (scene, warnings) = load_doc(&serde_json::to_vec(&doc).unwrap());
    for text in [
        "TEXCOORD_2",
        "CLAMP_TO_EDGE",
        "KHR_materials_clearcoat",
        "EXT_unknown_thing",
    ] {
        assert!(
            has_warning(&warnings, text),
            "no warning about {text}: {warnings:?}"
        );
    }
    assert_eq!(scene.materials[0].base_color_texture, None);
}

#[test]
fn malformed_files_give_errors_naming_the_file() {
    let gltf_error = |bytes: &[u8], expected: &str| match doc_error(bytes) {
        e @ SceneError::Gltf { .. } => {
            let text = e.to_string();
            assert!(text.contains("broken.gltf"), "{text}");
            assert!(text.contains(expected), "{text} lacks {expected}");
        }
        other => panic!("expected a glTF error, got {other}"),
    };
    gltf_error(b"this is not JSON", "expected");
    let glb = std::fs::read(sample("Box", "glTF-Binary/Box.glb")).unwrap();
    gltf_error(&glb[..glb.len() / 2], "length");
    let mut short_header = glb.clone();
    short_header[8..12].copy_from_slice(&4u32.to_le_bytes());
    gltf_error(&short_header, "length");

    let bad_position = triangle_doc(json!({
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 99 } }] }]
    }));
    gltf_error(&bad_position, "POSITION");

    let mut d = Doc::default();
    let positions = d.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let indices = d.indices(&[0, 1, 5]);
    let out_of_range = d.finish(json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": positions }, "indices": indices }] }]
    }));
    gltf_error(&out_of_range, "index 5 is out of range");

    gltf_error(
        &triangle_doc(json!({ "nodes": [{ "mesh": 0, "children": [0] }] })),
        "tree",
    );
    gltf_error(
        &triangle_doc(json!({ "scenes": [{ "nodes": [0, 0] }] })),
        "reached twice",
    );

    let gltf = std::fs::read(sample("Box", "glTF/Box.gltf")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("Box.gltf");
    std::fs::write(&copy, &gltf).unwrap();
    match import_gltf(&copy) {
        Err(e @ SceneError::Gltf { .. }) => {
            let text = e.to_string();
            assert!(
                text.contains("Box.gltf") && text.contains("Box0.bin"),
                "{text}"
            );
        }
        other => panic!("expected a missing-buffer error, got {other:?}"),
    }
    match import_gltf(&dir.path().join("absent.glb")) {
        Err(SceneError::Io { path, .. }) => assert!(path.ends_with("absent.glb")),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

#[test]
fn unusable_content_gives_invalid_errors() {
    let invalid = |bytes: &[u8], expected: &str| match doc_error(bytes) {
        e @ SceneError::Invalid { .. } => {
            let text = e.to_string();
            assert!(
                text.contains("broken.gltf") && text.contains(expected),
                "{text}"
            );
        }
        other => panic!("expected an Invalid error about {expected}, got {other}"),
    };
    let with_scene_gi =
        |gi: Value| triangle_doc(json!({ "scenes": [{ "nodes": [0], "extras": { "gi": gi } }] }));
    invalid(&with_scene_gi(json!({ "exposure": -1.0 })), "gi.exposure");
    invalid(
        &with_scene_gi(json!({ "exposure": "bright" })),
        "gi.exposure",
    );
    invalid(
        &with_scene_gi(json!({ "sky": { "constant": [1.0, -1.0, 0.0] } })),
        "gi.sky.constant",
    );
    invalid(
        &with_scene_gi(json!({ "sky": { "gradient": { "zenith": [1, 1, 1] } } })),
        "horizon",
    );
    invalid(&with_scene_gi(json!({ "camera": "Nobody" })), "gi.camera");
    invalid(
        &with_scene_gi(json!({ "frame_time_s": 0 })),
        "gi.frame_time_s",
    );
    invalid(&with_scene_gi(json!(3)), "gi");
    let key = |t: f32| json!({ "time_s": t, "position": [0, 0, 1], "target": [0, 0, 0] });
    invalid(
        &with_scene_gi(json!({ "camera_path": { "keys": [key(1.0), key(1.0)] } })),
        "gi.camera_path.keys",
    );
    invalid(
        &with_scene_gi(json!({ "camera_path": { "keys": [{ "time_s": 0 }] } })),
        "position",
    );
    let node_path = |path: Value| {
        triangle_doc(
            json!({ "nodes": [{ "name": "Mover", "mesh": 0, "extras": { "gi": { "path": path } } }] }),
        )
    };
    invalid(
        &node_path(json!({ "times": [0, 1], "translations": [[0, 0, 0]] })),
        "node \"Mover\" extras: gi.path",
    );
    invalid(
        &node_path(json!({ "times": [1, 0], "translations": [[0, 0, 0], [1, 1, 1]] })),
        "gi.path.times",
    );
    invalid(
        &triangle_doc(json!({ "extensionsRequired": ["KHR_draco_mesh_compression"] })),
        "KHR_draco_mesh_compression",
    );
    invalid(
        &triangle_doc(json!({ "nodes": [{ "name": "Triangle" }] })),
        "no triangles",
    );
}

#[test]
fn corrupted_bytes_never_panic() {
    for (model, file) in [
        ("Box", "glTF-Binary/Box.glb"),
        ("BoxAnimated", "glTF-Binary/BoxAnimated.glb"),
        ("BoxTextured", "glTF-Binary/BoxTextured.glb"),
    ] {
        let bytes = std::fs::read(sample(model, file)).unwrap();
        let step = (bytes.len() / 400).max(1);
        for len in (0..bytes.len()).step_by(step) {
            assert!(import_gltf_slice(&bytes[..len], Path::new(file)).is_err());
        }
        for at in (0..bytes.len()).step_by(step) {
            for value in [0x00, 0xff, b'9', b'"', 0x7f] {
                let mut corrupted = bytes.clone();
                corrupted[at] = value;
                let _ = import_gltf_slice(&corrupted, Path::new(file));
            }
        }
    }
}

#[test]
fn corrupted_json_values_never_panic() {
    let path = sample("Box", "glTF/Box.gltf");
    let text = std::fs::read_to_string(&path).unwrap();
    // Replace each number in turn with values that break counts, offsets, strides and indices.
    let numbers: Vec<(usize, usize)> = {
        let bytes = text.as_bytes();
        let mut spans = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i].is_ascii_digit() || bytes[i] == b'-' {
                let start = i;
                while i < bytes.len() && (bytes[i].is_ascii_digit() || b"-.eE+".contains(&bytes[i]))
                {
                    i += 1;
                }
                spans.push((start, i));
            }
            i += 1;
        }
        spans
    };
    assert!(numbers.len() > 50);
    for (start, end) in numbers {
        for replacement in ["0", "-1", "3", "4", "4294967295", "1e39", "0.5"] {
            let mutated = format!("{}{}{}", &text[..start], replacement, &text[end..]);
            let _ = import_gltf_slice(mutated.as_bytes(), &path);
        }
    }
    // Hand-made hazards for the parsing library.
    for extra in [
        json!({ "cameras": [{ "type": "perspective", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 2 } }] }),
        json!({ "buffers": [{ "byteLength": 4, "uri": "%FF%FE.bin" }] }),
        json!({ "buffers": [{ "byteLength": 4, "uri": "data:application/octet-stream;base64,@@@" }] }),
        json!({ "buffers": [{ "byteLength": 4, "uri": "https://example.com/a.bin" }] }),
        json!({ "images": [{ "uri": "data:image/png;base64,AAAA" }], "textures": [{ "source": 0 }],
                "materials": [{ "emissiveTexture": { "index": 0 } }] }),
        json!({ "extensions": { "KHR_lights_punctual": { "lights": [{ "type": "spot" }] } } }),
        json!({ "nodes": [{ "mesh": 0, "matrix": [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1] }] }),
        json!({ "nodes": [{ "mesh": 0, "rotation": [0, 0, 0, 0] }] }),
        json!({ "scene": 3 }),
    ] {
        let mut doc: Value = serde_json::from_slice(&triangle_doc(json!({}))).unwrap();
        for (key, value) in extra.as_object().unwrap() {
            doc[key] = value.clone();
        }
        let _ = import_gltf_slice(&serde_json::to_vec(&doc).unwrap(), Path::new("hazard.gltf"));
    }
}

/// A unit quad in the XY plane facing +Z with TEXCOORD_0 running along +X (u) and -Y (v, as
/// glTF's image rows go down), TEXCOORD_1 mirrored in u, and `material` 0; `extra` is merged
/// into the document's top level and `attributes` into the primitive's attributes.
fn quad_doc(extra: Value, attributes: impl FnOnce(&mut Doc) -> Value) -> Vec<u8> {
    let mut d = Doc::default();
    let positions = d.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let normals = d.vec3(&[[0.0, 0.0, 1.0]; 4]);
    let uv0 = d.vec2(&[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]);
    let uv1 = d.vec2(&[[1.0, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]]);
    let indices = d.indices(&[0, 1, 2, 0, 2, 3]);
    let mut attrs =
        json!({ "POSITION": positions, "NORMAL": normals, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1 });
    for (key, value) in attributes(&mut d).as_object().unwrap() {
        attrs[key] = value.clone();
    }
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "Quad", "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": attrs, "indices": indices, "material": 0 }] }]
    });
    for (key, value) in extra.as_object().unwrap() {
        doc[key] = value.clone();
    }
    d.finish(doc)
}

#[test]
fn alpha_modes_normal_and_occlusion_textures_and_texture_transforms_are_imported() {
    let doc = quad_doc(
        json!({
            "materials": [
                {
                    "alphaMode": "MASK", "alphaCutoff": 0.25,
                    "pbrMetallicRoughness": { "baseColorTexture": {
                        "index": 0, "texCoord": 0,
                        "extensions": { "KHR_texture_transform": {
                            "offset": [0.5, -0.25], "rotation": 0.5, "scale": [2.0, 4.0], "texCoord": 1
                        } }
                    } },
                    "normalTexture": { "index": 0, "scale": 0.6, "texCoord": 1,
                        "extensions": { "KHR_texture_transform": { "scale": [3.0, 3.0] } } },
                    "occlusionTexture": { "index": 0, "strength": 0.3 }
                },
                { "alphaMode": "MASK" },
                { "alphaMode": "BLEND" },
                {}
            ],
            "textures": [{ "source": 0 }],
            "images": [{ "uri": gray_png_uri() }],
            "extensionsUsed": ["KHR_texture_transform"],
            "extensionsRequired": ["KHR_texture_transform"]
        }),
        |_| json!({}),
    );
    let doc = primitive_per_material(&doc, 4);
    let (scene, warnings) = load_doc(&serde_json::to_vec(&doc).unwrap());
    assert!(
        !has_warning(&warnings, "KHR_texture_transform"),
        "{warnings:?}"
    );
    let m = &scene.materials[0];
    assert_eq!(m.alpha_mode, AlphaMode::Mask { cutoff: 0.25 });
    let base = m.base_color_texture.unwrap();
    assert_eq!(base.tex_coord, 1, "the transform's texCoord overrides");
    assert_eq!(
        base.transform,
        TextureTransform {
            offset: Vec2::new(0.5, -0.25),
            rotation: 0.5,
            scale: Vec2::new(2.0, 4.0)
        }
    );
    let normal = m.normal_texture.unwrap();
    assert_eq!((normal.tex_coord, m.normal_scale), (1, 0.6));
    assert_eq!(normal.transform.scale, Vec2::splat(3.0));
    assert_eq!(
        scene.textures[normal.texture].encoding,
        TextureEncoding::Linear
    );
    let occlusion = m.occlusion_texture.unwrap();
    assert_eq!(
        (
            occlusion.tex_coord,
            occlusion.transform,
            m.occlusion_strength
        ),
        (0, TextureTransform::IDENTITY, 0.3)
    );
    assert_eq!(
        scene.textures[occlusion.texture].encoding,
        TextureEncoding::Linear
    );
    assert_eq!(scene.textures[base.texture].encoding, TextureEncoding::Srgb);
    assert_eq!(
        scene.materials[1].alpha_mode,
        AlphaMode::Mask { cutoff: 0.5 }
    );
    assert_eq!(scene.materials[2].alpha_mode, AlphaMode::Blend);
    assert_eq!(scene.materials[3].alpha_mode, AlphaMode::Opaque);
    let primitive = &scene.meshes[0].primitives[0];
    assert_eq!(primitive.uvs1[1], Vec2::new(0.0, 1.0));
    assert_eq!(primitive.uvs[1], Vec2::new(1.0, 1.0));

    let mut bad: Value = serde_json::from_slice(&serde_json::to_vec(&doc).unwrap()).unwrap();
    bad["materials"][1]["alphaCutoff"] = json!(1e39);
    let message = doc_error(&serde_json::to_vec(&bad).unwrap()).to_string();
    assert!(message.contains("alphaCutoff"), "{message}");
}

/// Asserts `tangent` is a unit vector orthogonal to `normal` with a sign of +1 or -1.
fn assert_tangent_frame(tangent: Vec4, normal: Vec3) {
    assert!(
        (tangent.truncate().length() - 1.0).abs() < 1e-4,
        "{tangent}"
    );
    assert!(tangent.truncate().dot(normal).abs() < 1e-4, "{tangent}");
    assert!(tangent.w == 1.0 || tangent.w == -1.0, "{tangent}");
}

#[test]
fn file_tangents_are_read_and_broken_ones_repaired() {
    let extra = json!({
        "materials": [{ "normalTexture": { "index": 0 } }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": gray_png_uri() }]
    });
    let doc = quad_doc(extra, |d| {
        let tangents = d.vec4(&[
            [0.0, 2.0, 0.0, -1.0],
            [0.0, 1.0, 0.0, -1.0],
            [0.0, 0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0, -0.5],
        ]);
        json!({ "TANGENT": tangents })
    });
    let (scene, warnings) = load_doc(&doc);
    let primitive = &scene.meshes[0].primitives[0];
    assert_eq!(primitive.tangents.len(), 4);
    assert_eq!(primitive.tangents[0], Vec4::new(0.0, 1.0, 0.0, -1.0));
    assert_eq!(primitive.tangents[3], Vec4::new(0.0, 1.0, 0.0, -1.0));
    for &tangent in &primitive.tangents {
        assert_tangent_frame(tangent, Vec3::Z);
    }
    assert!(has_warning(&warnings, "zero or non-finite"), "{warnings:?}");
}

#[test]
fn mikktspace_tangents_follow_the_normal_texture_uv_set() {
    // TEXCOORD_0: u along +X, v down the image along -Y, so the tangent is +X and the
    // bitangent (w * n x t, where texture v grows) is -Y.
    // TEXCOORD_1 is mirrored in u: tangent -X, same bitangent, so the sign flips.
    for (set, tangent_dir) in [(0, Vec3::X), (1, Vec3::NEG_X)] {
        let extra = json!({
            "materials": [{ "normalTexture": { "index": 0, "texCoord": set } }],
            "textures": [{ "source": 0 }],
            "images": [{ "uri": gray_png_uri() }]
        });
        let (scene, warnings) = load_doc(&quad_doc(extra, |_| json!({})));
        assert!(warnings.is_empty(), "{warnings:?}");
        let primitive = &scene.meshes[0].primitives[0];
        assert_eq!(primitive.tangents.len(), primitive.positions.len());
        for (&tangent, &normal) in primitive.tangents.iter().zip(&primitive.normals) {
            assert_tangent_frame(tangent, normal);
            assert!(
                tangent.truncate().abs_diff_eq(tangent_dir, 1e-4),
                "TEXCOORD_{set}: {tangent}"
            );
            let bitangent = tangent.w * normal.cross(tangent.truncate());
            assert!(bitangent.abs_diff_eq(Vec3::NEG_Y, 1e-4), "{bitangent}");
        }
    }
}

#[test]
fn mikktspace_splits_vertices_at_mirrored_uv_seams() {
    // Two triangles sharing an edge, the second with its u mirrored: the shared vertices need
    // one tangent per side.
    let mut d = Doc::default();
    let positions = d.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let uvs = d.vec2(&[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [2.0, 0.0]]);
    let indices = d.indices(&[0, 1, 2, 0, 2, 3]);
    let doc = d.finish(json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{
            "attributes": { "POSITION": positions, "TEXCOORD_0": uvs }, "indices": indices, "material": 0
        }] }],
        "materials": [{ "normalTexture": { "index": 0 } }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": gray_png_uri() }]
    }));
    let (scene, _) = load_doc(&doc);
    let p = &scene.meshes[0].primitives[0];
    assert_eq!(p.tangents.len(), p.positions.len());
    assert_eq!(
        (p.uvs.len(), p.normals.len()),
        (p.positions.len(), p.positions.len())
    );
    for &tangent in &p.tangents {
        assert_tangent_frame(tangent, Vec3::Z);
    }
    for triangle in p.indices.chunks(3) {
        let [a, b, c] = [0, 1, 2].map(|k| p.tangents[triangle[k] as usize]);
        assert!(
            a.abs_diff_eq(b, 1e-4) && b.abs_diff_eq(c, 1e-4),
            "one tangent per flat triangle: {a} {b} {c}"
        );
    }
}

#[test]
fn a_normal_map_without_uvs_warns_and_gets_no_tangents() {
    let mut d = Doc::default();
    let mesh = d.triangle_mesh();
    let mut doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [mesh],
        "materials": [{ "normalTexture": { "index": 0 } }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": gray_png_uri() }]
    });
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let (scene, warnings) = load_doc(&d.finish(doc));
    assert!(scene.meshes[0].primitives[0].tangents.is_empty());
    assert!(
        has_warning(&warnings, "no TEXCOORD_0; no tangents"),
        "{warnings:?}"
    );
}

#[test]
fn unusable_images_drop_their_texture_with_a_warning() {
    let doc = triangle_doc(json!({
        "materials": [
            { "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "baseColorTexture": { "index": 0 } } },
            { "normalTexture": { "index": 1 } },
            { "emissiveTexture": { "index": 2 } },
            { "occlusionTexture": { "index": 3 } },
            { "pbrMetallicRoughness": { "baseColorTexture": { "index": 4 } } }
        ],
        "textures": [
            { "source": 0 }, { "source": 1 }, { "source": 2 },
            { "extensions": { "MSFT_texture_dds": { "source": 3 } } },
            { "source": 4 }
        ],
        "images": [
            { "uri": "missing_curtain.png" },
            { "uri": "data:image/png;base64,AAAA" },
            { "uri": "data:image/ktx2;base64,AAAA", "mimeType": "image/ktx2" },
            { "uri": "texture.dds" },
            { "uri": gray_png_uri() }
        ],
        "extensionsUsed": ["MSFT_texture_dds"]
    }));
    let doc = primitive_per_material(&doc, 5);
    let (scene, warnings) = load_doc(&serde_json::to_vec(&doc).unwrap());
    for text in [
        "materials[0] (\"material 0\").baseColorTexture: images[0] (\"missing_curtain.png\") cannot be read",
        "normalTexture: images[1]",
        "image/ktx2",
        "occlusionTexture: images[3] (\"texture.dds\") cannot be read",
    ] {
        assert!(
            has_warning(&warnings, text),
            "no warning with {text}: {warnings:?}"
        );
    }
    for m in &scene.materials[..4] {
        assert_eq!(m.texture_refs().count(), 0, "{}", m.name);
    }
    assert_eq!(scene.materials[0].base_color.x, 0.5);
    assert!(scene.materials[4].base_color_texture.is_some());
}

#[test]
fn oversized_images_are_refused_before_decoding() {
    // A PNG header declaring 9000 x 9000 texels, with no data behind it.
    let image = image::RgbaImage::from_pixel(1, 1, image::Rgba([1, 2, 3, 255]));
    let mut png = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    // IHDR's width and height follow the 8-byte signature, the chunk length and its type.
    png[16..20].copy_from_slice(&9000u32.to_be_bytes());
    png[20..24].copy_from_slice(&9000u32.to_be_bytes());
    // The chunk's CRC-32 (over type and data) follows its 13 data bytes.
    let mut crc = !0u32;
    for &byte in &png[12..29] {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    png[29..33].copy_from_slice(&(!crc).to_be_bytes());
    let doc = triangle_doc(json!({
        "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": format!("data:image/png;base64,{}", base64(&png)) }]
    }));
    let doc = primitive_per_material(&doc, 1);
    let (scene, warnings) = load_doc(&serde_json::to_vec(&doc).unwrap());
    assert!(
        has_warning(&warnings, "larger than 8192 x 8192"),
        "{warnings:?}"
    );
    assert_eq!(scene.materials[0].base_color_texture, None);
}

#[test]
fn required_extensions_are_supported_warned_or_refused() {
    let with = |required: &str| {
        triangle_doc(json!({
            "extensionsUsed": [required],
            "extensionsRequired": [required]
        }))
    };
    for (ext, lost) in [
        ("KHR_materials_clearcoat", "clearcoat"),
        ("KHR_materials_sheen", "sheen"),
        ("KHR_materials_variants", "variants"),
        ("KHR_materials_made_up", "material extension"),
    ] {
        let (_, warnings) = load_doc(&with(ext));
        assert!(
            warnings
                .iter()
                .any(|w| w.0.contains(ext) && w.0.contains(lost)),
            "{ext}: {warnings:?}"
        );
    }
    for ext in [
        "KHR_texture_transform",
        "KHR_mesh_quantization",
        "MSFT_texture_dds",
        "AMD_split_roughnessMetallic",
    ] {
        let (_, warnings) = load_doc(&with(ext));
        assert!(warnings.is_empty(), "{ext}: {warnings:?}");
    }
    for ext in [
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "EXT_made_up",
    ] {
        match doc_error(&with(ext)) {
            e @ SceneError::Invalid { .. } => assert!(e.to_string().contains(ext), "{e}"),
            other => panic!("{ext}: expected Invalid, got {other}"),
        }
    }
}
