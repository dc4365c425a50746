//! Lighting files: parsing, validation, applying them to a scene, and the loader's pickup of
//! `<stem>.lighting.json` beside a scene file.

use std::path::Path;

use gi_scene::{
    CameraChoice, LIGHTING_SUN_NAME, LightKind, Lighting, Scene, SceneError, Sky, SkyPreset,
    SkySetting, generate, load_with_lighting, write_gltf,
};
use glam::Vec3;

/// The bundled cornell box with its ceiling light switched off: nothing lights it.
fn dark_scene() -> Scene {
    let mut scene = generate::build("cornell-box").unwrap();
    for m in &mut scene.materials {
        m.emissive = Vec3::ZERO;
    }
    scene.lights.clear();
    for node in &mut scene.nodes {
        node.light = None;
    }
    scene
}

fn parse(text: &str) -> Result<Lighting, SceneError> {
    Lighting::from_json(text, "test.lighting.json")
}

#[test]
fn a_full_lighting_file_parses_and_applies() {
    let lighting = parse(
        r#"{
            "sun": { "direction": [0, -2, 0], "color": [1, 0.5, 0.25], "irradiance": 5 },
            "sky": { "gradient": { "zenith": [0, 0, 1], "horizon": [0, 1, 0], "ground": [1, 0, 0] } },
            "exposure": 0.5,
            "camera": 0
        }"#,
    )
    .unwrap();
    assert_eq!(lighting.camera, Some(CameraChoice::Index(0)));
    let mut scene = dark_scene();
    assert!(gi_scene::no_emitter_warning(&scene).is_some());
    scene.default_camera_node = None;
    lighting.apply(&mut scene).unwrap();
    assert_eq!(gi_scene::no_emitter_warning(&scene), None);

    let light = scene.lights.last().unwrap();
    assert_eq!(light.kind, LightKind::Directional);
    assert_eq!(
        (light.color, light.intensity),
        (Vec3::new(1.0, 0.5, 0.25), 5.0)
    );
    let node = scene.nodes.last().unwrap();
    assert_eq!(node.name, LIGHTING_SUN_NAME);
    assert_eq!(node.light, Some(scene.lights.len() - 1));
    // The light travels down its node's -Z: here straight down.
    assert!((node.rotation * Vec3::NEG_Z).abs_diff_eq(Vec3::NEG_Y, 1e-5));
    let frame = scene.evaluate(0.0, None);
    assert_eq!(frame.lights.len(), 1);

    assert_eq!(
        scene.sky,
        Sky::Gradient {
            zenith: Vec3::Z,
            horizon: Vec3::Y,
            ground: Vec3::X
        }
    );
    assert_eq!(scene.exposure, 0.5);
    let camera = scene.default_camera_node.unwrap();
    assert!(scene.nodes[camera].camera.is_some());
}

#[test]
fn sun_angles_presets_and_defaults() {
    let lighting = parse(
        r#"{ "sun": { "azimuth_deg": 90, "elevation_deg": 30 }, "sky": { "preset": "overcast" } }"#,
    )
    .unwrap();
    assert_eq!(lighting.sky, Some(SkySetting::Preset(SkyPreset::Overcast)));
    let mut scene = dark_scene();
    let camera = scene.default_camera_node;
    let exposure = scene.exposure;
    lighting.apply(&mut scene).unwrap();
    let node = scene.nodes.last().unwrap();
    // Towards the sun: 30 degrees up, azimuth 90 from +X towards +Z, so the light travels
    // down and towards -Z.
    let travels = node.rotation * Vec3::NEG_Z;
    let expected = -Vec3::new(0.0, 30f32.to_radians().sin(), 30f32.to_radians().cos());
    assert!(travels.abs_diff_eq(expected, 1e-5), "{travels}");
    assert_eq!(scene.sky, SkyPreset::Overcast.sky());
    assert_eq!(
        (scene.default_camera_node, scene.exposure),
        (camera, exposure)
    );
    assert!(scene.lights.last().unwrap().intensity > 0.0);

    let mut scene = dark_scene();
    parse(r#"{ "sky": { "constant": [0.1, 0.2, 0.3] } }"#)
        .unwrap()
        .apply(&mut scene)
        .unwrap();
    assert_eq!(
        scene.sky,
        Sky::Constant {
            radiance: Vec3::new(0.1, 0.2, 0.3)
        }
    );
    assert!(parse("{}").unwrap() == Lighting::default());
}

#[test]
fn invalid_lighting_files_give_errors() {
    for (text, expected) in [
        (r#"{ "sun": {} }"#, "needs a direction"),
        (r#"{ "sun": { "direction": [0, 0, 0] } }"#, "not zero"),
        (r#"{ "sun": { "azimuth_deg": 10 } }"#, "both"),
        (
            r#"{ "sun": { "direction": [0, -1, 0], "elevation_deg": 10 } }"#,
            "give one",
        ),
        (
            r#"{ "sun": { "direction": [0, -1, 0], "irradiance": -1 } }"#,
            "irradiance",
        ),
        (r#"{ "sky": { "constant": [1, -1, 0] } }"#, "sky.constant"),
        (r#"{ "sky": { "preset": "dusk" } }"#, "unknown variant"),
        (r#"{ "exposure": 0 }"#, "exposure"),
        (r#"{ "sunn": {} }"#, "unknown field"),
        ("not json", "expected"),
    ] {
        match parse(text) {
            Err(e @ SceneError::Lighting { .. }) => {
                let message = e.to_string();
                assert!(message.contains(expected), "{text}: {message}");
                assert!(message.contains("test.lighting.json"), "{message}");
            }
            other => panic!("{text}: expected a lighting error, got {other:?}"),
        }
    }
}

#[test]
fn an_unknown_camera_names_the_cameras_there_are() {
    let mut scene = dark_scene();
    let before = scene.lights.len();
    let lighting = parse(r#"{ "sun": { "direction": [0, -1, 0] }, "camera": "Nope" }"#).unwrap();
    let message = lighting.apply(&mut scene).unwrap_err().to_string();
    let camera = scene.default_camera_node.unwrap();
    assert!(message.contains("\"Nope\""), "{message}");
    assert!(
        message.contains(&format!("0 \"{}\"", scene.nodes[camera].name)),
        "{message}"
    );
    assert_eq!(scene.lights.len(), before, "a failed apply changes nothing");
    let message = parse(r#"{ "camera": 3 }"#)
        .unwrap()
        .apply(&mut scene)
        .unwrap_err()
        .to_string();
    assert!(message.contains("camera 3"), "{message}");
}

fn write(scene: &Scene, dir: &Path) -> std::path::PathBuf {
    let path = dir.join("dark.gltf");
    write_gltf(scene, &path).unwrap();
    path
}

#[test]
fn the_loader_picks_up_the_lighting_file_beside_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dark_scene(), dir.path());
    let path_str = path.to_str().unwrap();

    let loaded = load_with_lighting(path_str, None).unwrap();
    assert_eq!(loaded.lighting, None);
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.0.contains("renders black")),
        "{:?}",
        loaded.warnings
    );

    let beside = dir.path().join("dark.lighting.json");
    std::fs::write(
        &beside,
        r#"{ "sky": { "preset": "day" }, "exposure": 0.75 }"#,
    )
    .unwrap();
    let loaded = load_with_lighting(path_str, None).unwrap();
    assert_eq!(loaded.lighting.as_deref(), Some(beside.as_path()));
    assert_eq!(loaded.scene.sky, SkyPreset::Day.sky());
    assert_eq!(loaded.scene.exposure, 0.75);
    assert!(
        !loaded
            .warnings
            .iter()
            .any(|w| w.0.contains("renders black")),
        "{:?}",
        loaded.warnings
    );

    // An explicit file wins over the one beside the scene.
    let explicit = dir.path().join("night.json");
    std::fs::write(&explicit, r#"{ "sky": { "preset": "night" } }"#).unwrap();
    let loaded = load_with_lighting(path_str, Some(&explicit)).unwrap();
    assert_eq!(loaded.lighting.as_deref(), Some(explicit.as_path()));
    assert_eq!(loaded.scene.sky, SkyPreset::Night.sky());

    // A broken file beside the scene is an error naming it.
    std::fs::write(&beside, r#"{ "exposure": -1 }"#).unwrap();
    let message = load_with_lighting(path_str, None).unwrap_err().to_string();
    assert!(message.contains("dark.lighting.json"), "{message}");
    let missing = dir.path().join("missing.json");
    assert!(load_with_lighting(path_str, Some(&missing)).is_err());
}
