//! The bundled scene generators and the glTF exporter.
//!
//! Scenes are checked in memory (geometry, materials, cameras, motion, lighting set-ups),
//! their glTF output is checked with the `gltf` crate's own reader, and the last tests read the
//! files back through the product's importer.

use std::path::{Path, PathBuf};

use gi_scene::{
    AlphaMode, BUNDLED_SCENES, Camera, Channel, ChannelValues, Interpolation, Light, LightKind,
    Material, Mesh, Node, Primitive, Scene, SceneBvh, Sky, Texture, TextureEncoding, TextureRef,
    TextureTransform, generate, import_gltf, write_gltf,
};
use glam::{Quat, Vec2, Vec3, Vec4};

fn bundled() -> Vec<Scene> {
    BUNDLED_SCENES
        .iter()
        .map(|(name, _)| generate::build(name).unwrap_or_else(|| panic!("no generator for {name}")))
        .collect()
}

fn node_named(scene: &Scene, name: &str) -> usize {
    scene
        .nodes
        .iter()
        .position(|n| n.name == name)
        .unwrap_or_else(|| panic!("{}: no node '{name}'", scene.name))
}

#[test]
fn every_bundled_name_builds_and_unknown_names_do_not() {
    for scene in bundled() {
        assert!(!scene.name.is_empty());
        let frame = scene.evaluate(0.0, None);
        assert!(!frame.triangles.is_empty(), "{}: no triangles", scene.name);
    }
    assert!(generate::build("no-such-scene").is_none());
}

#[test]
fn geometry_is_valid() {
    for scene in bundled() {
        for mesh in &scene.meshes {
            assert!(!mesh.primitives.is_empty(), "{}: empty mesh", scene.name);
            for p in &mesh.primitives {
                let at = format!("{} / {}", scene.name, mesh.name);
                let n = p.positions.len();
                assert!(!p.indices.is_empty() && p.indices.len() % 3 == 0, "{at}");
                assert!(
                    p.indices.iter().all(|&i| (i as usize) < n),
                    "{at}: index range"
                );
                assert_eq!(p.normals.len(), n, "{at}: every vertex has a normal");
                assert!(p.uvs.is_empty() || p.uvs.len() == n, "{at}: uv count");
                assert!(p.material < scene.materials.len(), "{at}: material");
                assert!(p.positions.iter().all(|v| v.is_finite()), "{at}");
                assert!(p.uvs.iter().all(|v| v.is_finite()), "{at}");
                for normal in &p.normals {
                    assert!((normal.length() - 1.0).abs() < 1e-4, "{at}: unit normals");
                }
                for tri in p.indices.chunks_exact(3) {
                    let [a, b, c] = [0, 1, 2].map(|k| p.positions[tri[k] as usize]);
                    let face = (b - a).cross(c - a);
                    assert!(face.length() > 1e-10, "{at}: degenerate triangle");
                    // Winding and shading normals agree: closed solids face outwards.
                    for &i in tri {
                        assert!(
                            face.dot(p.normals[i as usize]) > 0.0,
                            "{at}: normal vs winding"
                        );
                    }
                }
            }
        }
        for node in &scene.nodes {
            assert!(node.translation.is_finite() && node.scale.is_finite());
            assert!((node.rotation.length() - 1.0).abs() < 1e-4);
        }
    }
}

#[test]
fn materials_and_lights_are_in_range() {
    for scene in bundled() {
        for m in &scene.materials {
            let at = format!("{} / {}", scene.name, m.name);
            assert!(
                m.base_color.cmpge(Vec4::ZERO).all() && m.base_color.cmple(Vec4::ONE).all(),
                "{at}"
            );
            assert!((0.0..=1.0).contains(&m.metallic), "{at}");
            assert!((0.0..=1.0).contains(&m.roughness), "{at}");
            assert!(
                m.emissive.is_finite() && m.emissive.cmpge(Vec3::ZERO).all(),
                "{at}"
            );
            // Physically plausible albedo: nothing reflects all light diffusely.
            if m.metallic == 0.0 {
                assert!(m.base_color.truncate().max_element() < 0.9, "{at}: albedo");
            }
        }
        for light in &scene.lights {
            assert!(light.intensity > 0.0 && light.intensity.is_finite());
            assert!(light.color.cmpge(Vec3::ZERO).all() && light.color.max_element() <= 1.0);
        }
        assert!(scene.exposure > 0.0 && scene.exposure.is_finite());
        assert!(scene.frame_time_s > 0.0);
    }
}

#[test]
fn every_scene_has_a_default_camera_and_a_camera_path() {
    for scene in bundled() {
        let node = scene.default_camera_node.expect("default camera");
        let camera = scene.nodes[node]
            .camera
            .expect("camera node holds a camera");
        assert!(scene.cameras[camera].yfov > 0.2 && scene.cameras[camera].yfov < 2.0);
        let path = scene.camera_path.as_ref().expect("camera path");
        assert!(
            (3..=6).contains(&path.keys.len()),
            "{}: 3-6 keys",
            scene.name
        );
        assert_eq!(path.keys[0].time_s, 0.0);
        assert!(path.keys.windows(2).all(|k| k[0].time_s < k[1].time_s));
        let duration = path.keys.last().unwrap().time_s;
        assert!(
            (2.0..=12.0).contains(&duration),
            "{}: {duration} s",
            scene.name
        );
        for key in &path.keys {
            assert!(key.position.is_finite() && key.target.is_finite());
            assert!(key.position.distance(key.target) > 0.1);
        }
        // The path starts at the default view.
        let start = scene.path_view(0.0);
        let default = scene.default_view(0.0);
        assert!(start.position.distance(default.position) < 1e-4);
        assert!(start.forward.dot(default.forward) > 0.9999);
    }
}

/// The camera never starts inside a solid (every surface it sees around itself is a front
/// face), its view centre hits the scene, and moving along the path never crosses geometry.
#[test]
fn camera_paths_stay_in_free_space() {
    for scene in bundled() {
        let frame = scene.evaluate(0.0, None);
        let bvh = SceneBvh::build(&frame.triangles);
        let tris = &frame.triangles;
        let eye = frame.camera.position;
        let probes = [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ];
        for dir in probes.into_iter().chain([frame.camera.forward]) {
            if let Some(hit) = bvh.closest_hit(tris, eye, dir, 0.0, f32::MAX) {
                let t = tris[hit.triangle as usize];
                let face = Vec3::from(t.v1 - t.v0).cross(Vec3::from(t.v2 - t.v0));
                let double_sided = scene.materials
                    [frame.attributes[hit.triangle as usize].material as usize]
                    .double_sided;
                assert!(
                    face.dot(dir) < 0.0 || double_sided,
                    "{}: camera inside a solid",
                    scene.name
                );
            }
        }
        let center = bvh.closest_hit(tris, eye, frame.camera.forward, 0.0, f32::MAX);
        assert!(
            center.is_some(),
            "{}: default view looks into the void",
            scene.name
        );

        let duration = scene
            .camera_path
            .as_ref()
            .unwrap()
            .keys
            .last()
            .unwrap()
            .time_s;
        let steps = (duration / 0.05) as usize;
        let positions: Vec<Vec3> = (0..=steps)
            .map(|i| scene.path_view(i as f32 * duration / steps as f32).position)
            .collect();
        for pair in positions.windows(2) {
            let d = pair[1] - pair[0];
            if d.length() > 1e-6 {
                let blocked = bvh.occluded(tris, pair[0], d.normalize(), 0.0, d.length());
                assert!(
                    !blocked,
                    "{}: camera path crosses geometry near {}",
                    scene.name, pair[0]
                );
            }
        }
    }
}

#[test]
fn open_world_spans_512_meters() {
    let scene = generate::build("open-world").unwrap();
    let frame = scene.evaluate(0.0, None);
    let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for t in &frame.triangles {
        for v in [t.v0, t.v1, t.v2] {
            min = min.min(v.into());
            max = max.max(v.into());
        }
    }
    let size = max - min;
    assert!(
        (500.0..530.0).contains(&size.x) && (500.0..530.0).contains(&size.z),
        "{size}"
    );
    assert!(size.y > 40.0 && size.y < 250.0, "hills and towers: {size}");
    // Streamable: the world comes in 16 tiles of 128 m.
    let tiles = scene
        .nodes
        .iter()
        .filter(|n| n.name.starts_with("Tile "))
        .count();
    assert_eq!(tiles, 16);
    assert!(
        frame.triangles.len() < 100_000,
        "cheap enough to path trace"
    );
}

#[test]
fn atrium_stays_moderate() {
    let frame = generate::build("atrium").unwrap().evaluate(0.0, None);
    assert!(frame.triangles.len() < 20_000);
}

#[test]
fn dynamic_scene_moves_and_loops() {
    let scene = generate::build("dynamic").unwrap();
    assert!(scene.is_animated());
    let period = scene.animations[0]
        .channels
        .iter()
        .map(|c| *c.times.last().unwrap())
        .fold(0.0, f32::max);
    assert!((2.0..=8.0).contains(&period));
    for channel in &scene.animations[0].channels {
        assert_eq!(channel.interpolation, Interpolation::Linear);
    }
    let moving_box = node_named(&scene, "Moving box");
    let light = node_named(&scene, "Moving light");
    let position = |t: f32, node: usize| scene.world_transforms(t)[node].w_axis.truncate();
    for node in [moving_box, light] {
        assert!(position(0.0, node).distance(position(1.3, node)) > 0.5);
        for t in [0.0, 0.7, 1.3, 2.9] {
            let again = position(t + period, node);
            assert!(
                position(t, node).distance(again) < 1e-3,
                "loops after {period} s"
            );
        }
    }
    // The light moves in the evaluated frame too.
    let lights = |t: f32| scene.evaluate(t, None).lights;
    assert_eq!(lights(0.0).len(), 1);
    assert!(lights(0.0)[0].position.distance(lights(1.0)[0].position) > 0.5);
}

#[test]
fn cornell_box_is_lit_by_its_ceiling_panel_only() {
    let scene = generate::build("cornell-box").unwrap();
    assert!(scene.lights.is_empty(), "no punctual lights");
    assert!(scene.sky.is_black());
    let frame = scene.evaluate(0.0, None);
    let emissive: Vec<usize> = (0..frame.triangles.len())
        .filter(|&i| {
            scene.materials[frame.attributes[i].material as usize]
                .emissive
                .max_element()
                > 0.0
        })
        .collect();
    assert_eq!(emissive.len(), 2, "one quad");
    for i in emissive {
        let material = &scene.materials[frame.attributes[i].material as usize];
        assert!(!material.double_sided);
        assert!(material.emissive.max_element() > 1.0);
        let t = frame.triangles[i];
        let face = Vec3::from(t.v1 - t.v0)
            .cross(Vec3::from(t.v2 - t.v0))
            .normalize();
        assert!(face.y < -0.999, "faces down");
    }
}

#[test]
fn thin_wall_keeps_the_sun_out() {
    let scene = generate::build("thin-wall").unwrap();
    let frame = scene.evaluate(0.0, None);
    let bvh = SceneBvh::build(&frame.triangles);
    let sun = frame
        .lights
        .iter()
        .find(|l| l.kind == LightKind::Directional)
        .expect("a sun");
    let to_sun = -sun.direction;
    // Points just off the interior floor and the thin wall's inner face (x = 0).
    let mut points = Vec::new();
    for i in 0..20 {
        for j in 0..20 {
            let (u, v) = (i as f32 / 19.0, j as f32 / 19.0);
            points.push(Vec3::new(-3.95 + 3.9 * u, 0.01, -2.95 + 5.9 * v));
            points.push(Vec3::new(-0.01, 0.01 + 2.75 * u, -2.95 + 5.9 * v));
        }
    }
    for p in points {
        assert!(
            bvh.occluded(&frame.triangles, p, to_sun, 1e-4, f32::MAX),
            "sun reaches {p}"
        );
    }
    // Outdoors, right behind the thin wall, the sun shines.
    let outside = Vec3::new(0.5, 0.01, 0.0);
    assert!(!bvh.occluded(&frame.triangles, outside, to_sun, 1e-4, f32::MAX));
    // The wall is 5 cm thick.
    let wall = &scene.meshes[scene.nodes[node_named(&scene, "Thin wall")].mesh.unwrap()];
    let xs = wall.primitives[0].positions.iter().map(|p| p.x);
    let (lo, hi) = xs.fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x), b.max(x)));
    assert!((hi - lo - 0.05).abs() < 1e-4);
}

fn read_dir_sorted(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&path).unwrap())
        })
        .collect();
    files.sort();
    files
}

#[test]
fn write_all_is_deterministic() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let written = generate::write_all(a.path()).unwrap();
    generate::write_all(b.path()).unwrap();
    for (name, _) in BUNDLED_SCENES {
        for ext in ["gltf", "bin"] {
            assert!(written.contains(&a.path().join(format!("{name}.{ext}"))));
        }
    }
    let (fa, fb) = (read_dir_sorted(a.path()), read_dir_sorted(b.path()));
    assert_eq!(fa.len(), written.len());
    assert_eq!(fa.len(), fb.len());
    for ((na, da), (nb, db)) in fa.iter().zip(&fb) {
        assert_eq!(na, nb);
        assert!(da == db, "{na} differs between runs");
    }
}

/// Reads a written file with the `gltf` crate (which validates the document) and returns the
/// triangle count of the default scene, instancing meshes per node.
fn gltf_triangles(path: &Path) -> (gltf::Document, usize) {
    let (document, buffers, _) = gltf::import(path).expect("valid glTF");
    let mut triangles = 0;
    for node in document.nodes() {
        if let Some(mesh) = node.mesh() {
            for primitive in mesh.primitives() {
                let reader = primitive.reader(|b| Some(&buffers[b.index()]));
                let positions = reader.read_positions().unwrap().count();
                let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
                assert!(indices.iter().all(|&i| (i as usize) < positions));
                assert!(reader.read_normals().is_some());
                triangles += indices.len() / 3;
            }
        }
    }
    (document, triangles)
}

#[test]
fn bundled_scenes_export_valid_gltf() {
    let dir = tempfile::tempdir().unwrap();
    generate::write_all(dir.path()).unwrap();
    for scene in bundled() {
        let path = dir.path().join(format!("{}.gltf", scene.name));
        let (document, triangles) = gltf_triangles(&path);
        assert_eq!(
            triangles,
            scene.evaluate(0.0, None).triangles.len(),
            "{}",
            scene.name
        );
        assert_eq!(
            document.lights().map_or(0, |l| l.count()),
            scene.lights.len()
        );
        assert_eq!(document.animations().count(), scene.animations.len());
        for view in document.views() {
            assert_eq!(view.offset() % 4, 0);
        }
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(json["asset"]["version"], "2.0");
        assert_eq!(json["asset"]["generator"], "gi");
        for mesh in json["meshes"].as_array().unwrap() {
            for primitive in mesh["primitives"].as_array().unwrap() {
                let position = primitive["attributes"]["POSITION"].as_u64().unwrap();
                let accessor = &json["accessors"][position as usize];
                assert!(accessor["min"].is_array() && accessor["max"].is_array());
            }
        }
        let gi = &json["scenes"][0]["extras"]["gi"];
        assert_eq!(gi["camera"], "Camera");
        assert!(gi["exposure"].as_f64().unwrap() > 0.0);
        assert!(gi["frame_time_s"].as_f64().unwrap() > 0.0);
        assert!(gi["sky"]["constant"].is_array() || gi["sky"]["gradient"]["zenith"].is_array());
        assert!(gi["camera_path"]["keys"].as_array().unwrap().len() >= 3);
        // Names are unique, so the camera can be found by name.
        let names: std::collections::BTreeSet<_> =
            document.nodes().filter_map(|n| n.name()).collect();
        assert_eq!(names.len(), document.nodes().count());
    }
}

#[test]
fn emission_above_one_uses_the_strength_extension() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell-box.gltf");
    write_gltf(&generate::build("cornell-box").unwrap(), &path).unwrap();
    let (document, _) = gltf_triangles(&path);
    let light = document
        .materials()
        .find(|m| m.name() == Some("Light"))
        .unwrap();
    let strength = light.emissive_strength().unwrap();
    let factor = Vec3::from_array(light.emissive_factor());
    assert!((strength - 17.0).abs() < 1e-5);
    assert!((factor * strength).distance(Vec3::new(17.0, 12.0, 4.0)) < 1e-4);
    let json = std::fs::read_to_string(&path).unwrap();
    assert!(json.contains("KHR_materials_emissive_strength"));
}

/// A small scene using what the bundled ones do not: a hierarchy, textures, a spot light,
/// STEP rotation and scale keys, an aspect ratio.
fn feature_scene() -> Scene {
    let texels = vec![
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.5, 0.25, 1.0),
        Vec4::new(0.2, 0.2, 0.2, 0.5),
        Vec4::ONE,
    ];
    let color = Texture::from_linear("checker", 2, 2, TextureEncoding::Srgb, &texels);
    let data = Texture::from_linear("checker data", 2, 2, TextureEncoding::Linear, &texels);
    let quad = Primitive {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)],
        normals: vec![Vec3::Z; 3],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE],
        indices: vec![0, 1, 2],
        material: 0,
        ..Default::default()
    };
    Scene {
        name: "features".into(),
        nodes: vec![
            Node {
                name: "Parent".into(),
                translation: Vec3::new(1.0, 2.0, 3.0),
                ..Node::default()
            },
            Node {
                name: "Child".into(),
                parent: Some(0),
                mesh: Some(0),
                ..Node::default()
            },
            Node {
                name: "Spot".into(),
                parent: Some(0),
                light: Some(0),
                rotation: Quat::from_rotation_x(-0.5),
                ..Node::default()
            },
            Node {
                name: "View".into(),
                camera: Some(0),
                ..Node::default()
            },
        ],
        meshes: vec![Mesh {
            name: "tri".into(),
            weights: Vec::new(),
            primitives: vec![quad],
        }],
        materials: vec![Material {
            name: "textured".into(),
            base_color_texture: Some(TextureRef::new(0)),
            metallic_roughness_texture: Some(TextureRef::new(1)),
            emissive: Vec3::new(0.5, 0.25, 0.0),
            metallic: 0.0,
            roughness: 0.5,
            double_sided: true,
            specular: 0.5,
            specular_texture: Some(TextureRef::new(1)),
            specular_color: Vec3::new(1.5, 1.0, 0.5),
            ior: 1.33,
            ..Material::default()
        }],
        textures: vec![color, data],
        lights: vec![Light {
            name: "spot".into(),
            kind: LightKind::Spot {
                inner_cone_angle: 0.2,
                outer_cone_angle: 0.6,
            },
            color: Vec3::new(1.0, 0.9, 0.8),
            intensity: 40.0,
            range: Some(12.0),
        }],
        cameras: vec![Camera {
            name: "cam".into(),
            yfov: 0.9,
            aspect_ratio: Some(1.5),
            znear: 0.1,
        }],
        animations: vec![gi_scene::Animation {
            name: "steps".into(),
            channels: vec![
                Channel {
                    node: 1,
                    times: vec![0.0, 0.5, 1.0],
                    values: ChannelValues::Scale(vec![Vec3::ONE, Vec3::splat(2.0), Vec3::ONE]),
                    interpolation: Interpolation::Step,
                },
                Channel {
                    node: 1,
                    times: vec![0.0, 1.0],
                    values: ChannelValues::Rotation(vec![
                        Quat::IDENTITY,
                        Quat::from_rotation_y(1.0),
                    ]),
                    interpolation: Interpolation::Linear,
                },
            ],
        }],
        // Skins round-trip in tests/skin.rs.
        skins: Vec::new(),
        sky: Sky::Constant {
            radiance: Vec3::splat(0.5),
        },
        exposure: 1.25,
        default_camera_node: Some(3),
        camera_path: None,
        frame_time_s: 0.04,
    }
}

#[test]
fn exporter_writes_hierarchy_textures_spot_lights_and_step_keys() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("features.gltf");
    write_gltf(&feature_scene(), &path).unwrap();
    let (document, triangles) = gltf_triangles(&path);
    assert_eq!(triangles, 1);
    let scene = document.default_scene().unwrap();
    let roots: Vec<_> = scene
        .nodes()
        .map(|n| n.name().unwrap().to_string())
        .collect();
    assert_eq!(roots, ["Parent", "View"]);
    let parent = document
        .nodes()
        .find(|n| n.name() == Some("Parent"))
        .unwrap();
    assert_eq!(parent.children().count(), 2);
    let spot = document.lights().unwrap().next().unwrap();
    assert!(matches!(
        spot.kind(),
        gltf::khr_lights_punctual::Kind::Spot { .. }
    ));
    assert_eq!(spot.range(), Some(12.0));
    let camera = document.cameras().next().unwrap();
    match camera.projection() {
        gltf::camera::Projection::Perspective(p) => assert_eq!(p.aspect_ratio(), Some(1.5)),
        gltf::camera::Projection::Orthographic(_) => panic!("perspective expected"),
    }
    let animation = document.animations().next().unwrap();
    let interpolations: Vec<_> = animation.samplers().map(|s| s.interpolation()).collect();
    assert_eq!(
        interpolations,
        [
            gltf::animation::Interpolation::Step,
            gltf::animation::Interpolation::Linear
        ]
    );

    // The sRGB base color and the linear metallic-roughness texture: one PNG each.
    let srgb = image::open(dir.path().join("features_0.png"))
        .unwrap()
        .to_rgba8();
    let linear = image::open(dir.path().join("features_1.png"))
        .unwrap()
        .to_rgba8();
    assert_eq!(srgb.get_pixel(1, 0).0, [255, 188, 137, 255]);
    assert_eq!(linear.get_pixel(1, 0).0, [255, 128, 64, 255]);
    assert_eq!(srgb.get_pixel(0, 1).0[3], 128, "alpha stays linear");
    let material = document.materials().next().unwrap();
    let pbr = material.pbr_metallic_roughness();
    let base = pbr
        .base_color_texture()
        .unwrap()
        .texture()
        .source()
        .expect("core source")
        .index();
    let mr = pbr
        .metallic_roughness_texture()
        .unwrap()
        .texture()
        .source()
        .expect("core source")
        .index();
    assert_ne!(base, mr);
    assert!(material.double_sided());
    assert_eq!(material.emissive_strength(), None);

    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let gi = &json["scenes"][0]["extras"]["gi"];
    assert_eq!(gi["camera"], "View");
    assert_eq!(gi["exposure"].as_f64(), Some(1.25));
    assert_eq!(gi["frame_time_s"].as_f64(), Some(0.04));
    assert_eq!(gi["sky"]["constant"][0].as_f64(), Some(0.5));
}

#[test]
fn exporter_rejects_invalid_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = feature_scene();
    scene.meshes[0].primitives[0].indices = vec![0, 1, 7];
    assert!(write_gltf(&scene, &dir.path().join("bad.gltf")).is_err());
    let mut scene = feature_scene();
    scene.nodes[0].parent = Some(1);
    assert!(write_gltf(&scene, &dir.path().join("cycle.gltf")).is_err());
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * (1.0 + a.abs().max(b.abs()))
}

fn export_and_import(scene: &Scene, dir: &Path) -> Scene {
    let path: PathBuf = dir.join(format!("{}.gltf", scene.name));
    write_gltf(scene, &path).unwrap();
    let (imported, warnings) = import_gltf(&path).unwrap();
    assert!(warnings.is_empty(), "{}: {warnings:?}", scene.name);
    imported
}

/// Export then import through the product's importer keeps what renders depend on. The
/// importer may order materials and nodes differently, so they are matched by name.
#[test]
fn bundled_scenes_round_trip_through_the_importer() {
    let dir = tempfile::tempdir().unwrap();
    for scene in bundled() {
        let back = export_and_import(&scene, dir.path());
        let at = scene.name.as_str();
        let (a, b) = (scene.evaluate(0.0, None), back.evaluate(0.0, None));
        assert_eq!(a.triangles.len(), b.triangles.len(), "{at}");
        assert_eq!(scene.materials.len(), back.materials.len(), "{at}");
        for m in &scene.materials {
            let n = back
                .materials
                .iter()
                .find(|n| n.name == m.name)
                .expect("material");
            let same = (m.base_color - n.base_color).abs().max_element() < 1e-5
                && close(m.metallic, n.metallic)
                && close(m.roughness, n.roughness)
                && (m.emissive - n.emissive).abs().max_element() < 1e-4
                && m.double_sided == n.double_sided;
            assert!(same, "{at}: material {}", m.name);
        }
        // Triangles per material survive too.
        let per_material = |s: &Scene, f: &gi_scene::SceneFrame, name: &str| {
            let attrs = f.attributes.iter();
            attrs
                .filter(|t| s.materials[t.material as usize].name == name)
                .count()
        };
        for m in &scene.materials {
            let (x, y) = (
                per_material(&scene, &a, &m.name),
                per_material(&back, &b, &m.name),
            );
            assert_eq!(x, y, "{at}: triangles of {}", m.name);
        }
        assert_eq!(scene.lights.len(), back.lights.len(), "{at}");
        let (world_a, world_b) = (scene.world_transforms(0.0), back.world_transforms(0.0));
        for (i, node) in scene.nodes.iter().enumerate() {
            let Some(light) = node.light else { continue };
            let k = node_named(&back, &node.name);
            let (la, lb) = (
                &scene.lights[light],
                &back.lights[back.nodes[k].light.unwrap()],
            );
            assert_eq!(la.kind, lb.kind, "{at}");
            assert!(
                close(la.intensity, lb.intensity)
                    && (la.color - lb.color).abs().max_element() < 1e-6
            );
            assert_eq!(la.range, lb.range);
            let placed = world_a[i].abs_diff_eq(world_b[k], 1e-4);
            assert!(placed, "{at}: light placement");
        }
        assert!(
            a.camera.position.distance(b.camera.position) < 1e-4,
            "{at}: default view"
        );
        assert!(
            a.camera.forward.dot(b.camera.forward) > 0.99999 && close(a.camera.yfov, b.camera.yfov)
        );
        assert_eq!(scene.sky, back.sky, "{at}");
        assert!(
            close(scene.exposure, back.exposure) && close(scene.frame_time_s, back.frame_time_s)
        );
        let name = |s: &Scene| s.default_camera_node.map(|n| s.nodes[n].name.clone());
        assert_eq!(name(&scene), name(&back), "{at}");
        let (p, q) = (
            scene.camera_path.as_ref().unwrap(),
            back.camera_path.as_ref().unwrap(),
        );
        assert_eq!(p.keys.len(), q.keys.len());
        assert!(close(p.yfov, q.yfov));
        for (k, j) in p.keys.iter().zip(&q.keys) {
            assert!(close(k.time_s, j.time_s));
            assert!(k.position.distance(j.position) < 1e-4 && k.target.distance(j.target) < 1e-4);
        }
        assert_eq!(scene.animations.len(), back.animations.len(), "{at}");
        assert_eq!(scene.is_animated(), back.is_animated());
        for t in [0.0, 0.37, 1.5, 3.9, 5.2] {
            let (wa, wb) = (scene.world_transforms(t), back.world_transforms(t));
            for (i, node) in scene.nodes.iter().enumerate() {
                let j = node_named(&back, &node.name);
                assert!(
                    wa[i].abs_diff_eq(wb[j], 1e-3),
                    "{at}: {} at {t} s",
                    node.name
                );
            }
        }
    }
}

#[test]
fn feature_scene_round_trips_through_the_importer() {
    let dir = tempfile::tempdir().unwrap();
    let scene = feature_scene();
    let back = export_and_import(&scene, dir.path());
    let (child, parent) = (node_named(&back, "Child"), node_named(&back, "Parent"));
    assert_eq!(back.nodes[child].parent, Some(parent));
    assert_eq!(back.lights[0].kind, scene.lights[0].kind);
    assert_eq!(back.lights[0].range, Some(12.0));
    assert_eq!(back.cameras[0].aspect_ratio, Some(1.5));
    let texture = &back.textures[back.materials[0].base_color_texture.unwrap().texture];
    // 8-bit sRGB storage: within one code value of the original after decoding.
    assert!(
        (texture.texel(1, 0) - Vec4::new(1.0, 0.5, 0.25, 1.0))
            .abs()
            .max_element()
            < 0.01
    );
    // The specular and ior extensions: factors exactly, the specular texture as linear.
    let m = &back.materials[0];
    assert_eq!((m.specular, m.ior), (0.5, 1.33));
    assert_eq!(m.specular_color, Vec3::new(1.5, 1.0, 0.5));
    assert_eq!(m.specular_texture, m.metallic_roughness_texture);
    let mr = &back.textures[back.materials[0]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert!(
        (mr.texel(1, 0) - Vec4::new(1.0, 0.5, 0.25, 1.0))
            .abs()
            .max_element()
            < 0.01
    );
    for t in [0.0, 0.25, 0.5, 0.75] {
        let (wa, wb) = (scene.world_transforms(t), back.world_transforms(t));
        assert!(
            wa[1].abs_diff_eq(wb[child], 1e-4),
            "animated child at {t} s"
        );
    }
}

/// Normal and occlusion maps with their scale and strength, texture coordinate set 1, texture
/// transforms, alpha modes, `TEXCOORD_1` and tangents survive export and import.
#[test]
fn normal_maps_alpha_modes_and_second_uv_set_round_trip() {
    let texels = vec![Vec4::new(0.5, 0.5, 1.0, 1.0); 4];
    let normal = Texture::from_linear("normal", 2, 2, TextureEncoding::Linear, &texels);
    let transform = TextureTransform {
        offset: Vec2::new(0.25, -0.5),
        rotation: 0.3,
        scale: Vec2::new(2.0, 3.0),
    };
    let primitive = Primitive {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)],
        normals: vec![Vec3::Z; 3],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE],
        uvs1: vec![Vec2::ONE, Vec2::Y, Vec2::ZERO],
        tangents: vec![Vec4::new(1.0, 0.0, 0.0, -1.0); 3],
        joints: Vec::new(),
        weights: Vec::new(),
        targets: Vec::new(),
        indices: vec![0, 1, 2],
        material: 0,
    };
    let material = |name: &str, alpha_mode| Material {
        name: name.into(),
        emissive: Vec3::splat(0.5),
        normal_texture: Some(TextureRef {
            texture: 0,
            tex_coord: 1,
            transform,
        }),
        normal_scale: 0.7,
        occlusion_texture: Some(TextureRef {
            texture: 0,
            tex_coord: 0,
            transform: TextureTransform::IDENTITY,
        }),
        occlusion_strength: 0.4,
        alpha_mode,
        ..Material::default()
    };
    let scene = Scene {
        name: "normal-maps".into(),
        nodes: vec![Node {
            name: "Quad".into(),
            mesh: Some(0),
            ..Node::default()
        }],
        meshes: vec![Mesh {
            name: "quad".into(),
            weights: Vec::new(),
            primitives: vec![
                primitive.clone(),
                Primitive {
                    material: 1,
                    ..primitive.clone()
                },
                Primitive {
                    material: 2,
                    ..primitive
                },
            ],
        }],
        materials: vec![
            material("masked", AlphaMode::Mask { cutoff: 0.3 }),
            material("blended", AlphaMode::Blend),
            material("opaque", AlphaMode::Opaque),
        ],
        textures: vec![normal],
        exposure: 1.0,
        frame_time_s: 1.0 / 30.0,
        ..Scene::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let back = export_and_import(&scene, dir.path());
    for original in &scene.materials {
        let m = back
            .materials
            .iter()
            .find(|m| m.name == original.name)
            .unwrap();
        assert_eq!(m.alpha_mode, original.alpha_mode, "{}", m.name);
        assert_eq!(m.normal_scale, 0.7);
        assert_eq!(m.occlusion_strength, 0.4);
        let n = m.normal_texture.unwrap();
        assert_eq!(n.tex_coord, 1);
        assert!(n.transform.offset.abs_diff_eq(transform.offset, 1e-6));
        assert!((n.transform.rotation - transform.rotation).abs() < 1e-6);
        assert!(n.transform.scale.abs_diff_eq(transform.scale, 1e-6));
        assert_eq!(back.textures[n.texture].encoding, TextureEncoding::Linear);
        let o = m.occlusion_texture.unwrap();
        assert_eq!((o.tex_coord, o.transform), (0, TextureTransform::IDENTITY));
    }
    let p = &back.meshes[0].primitives[0];
    assert_eq!(p.uvs1, scene.meshes[0].primitives[0].uvs1);
    assert_eq!(p.tangents, scene.meshes[0].primitives[0].tangents);
}
