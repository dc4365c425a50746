//! Third-party scenes from the shared scene folder (`../shared/scenes` beside the workspace):
//! each imports without error, with the warnings its known quirks call for. Skipped with a
//! note when the folder is absent.

use std::path::{Path, PathBuf};

use gi_scene::{AlphaMode, ImportWarning, Scene, import_gltf};

/// The shared scene folder, or `None` (with a printed note) when it is absent.
fn scenes_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!(
            "skipped: {} is absent (the shared third-party scenes)",
            dir.display()
        );
        None
    }
}

fn import(dir: &Path, name: &str, file: &str) -> (Scene, Vec<ImportWarning>) {
    let path = dir.join(name).join("glTF").join(file);
    import_gltf(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn warnings_with<'a>(warnings: &'a [ImportWarning], text: &str) -> Vec<&'a ImportWarning> {
    warnings.iter().filter(|w| w.0.contains(text)).collect()
}

fn masked(scene: &Scene, name: &str) -> bool {
    scene.materials.iter().any(|m| {
        m.name == name && matches!(m.alpha_mode, AlphaMode::Mask { cutoff } if cutoff == 0.5)
    })
}

#[test]
fn sponza_loads_without_its_missing_curtains_and_dds_maps() {
    let Some(dir) = scenes_dir() else { return };
    let (scene, warnings) = import(&dir, "Sponza", "Sponza.gltf");
    // One warning lists every texture whose images are missing: the curtains' PNGs with their
    // DDS stand-ins, and the DDS-only roughness and metallic maps of
    // AMD_split_roughnessMetallic, which the folder lacks. The factors apply.
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let text = &warnings[0].0;
    let split = text.matches("AMD_split_roughnessMetallic").count();
    let curtains = text.matches("baseColorTexture").count();
    assert_eq!(curtains, 3, "{text}");
    assert!(split >= 20, "{text}");
    assert!(
        text.starts_with(&format!(
            "the texture is dropped and the material's factor applies ({} times): ",
            curtains + split
        )),
        "{text}"
    );
    for curtain in [
        "sponza_curtain_diff",
        "sponza_curtain_blue_diff",
        "sponza_curtain_green_diff",
    ] {
        assert!(
            text.contains(&format!("{curtain}.png")),
            "{curtain}: {text}"
        );
    }
    assert_eq!(
        text.matches(".dds\": No such file").count(),
        curtains + split,
        "{text}"
    );
    for name in ["Plants", "Chain", "PotPlant1"] {
        assert!(masked(&scene, name), "{name} is alpha-masked");
    }
    // Normal-mapped materials get tangents on every primitive that uses them.
    let normal_mapped = scene
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter(|p| scene.materials[p.material].normal_texture.is_some())
        .collect::<Vec<_>>();
    assert!(!normal_mapped.is_empty());
    for p in normal_mapped {
        assert_eq!(p.tangents.len(), p.positions.len());
    }
    assert!(scene.textures.len() > 20);
    assert_eq!(scene.cameras.len(), 4);
}

#[test]
fn gas_station_loads_with_the_dds_extension_it_requires() {
    let Some(dir) = scenes_dir() else { return };
    let (scene, warnings) = import(&dir, "GasStation", "GasStation.gltf");
    assert!(
        warnings_with(&warnings, "MSFT_texture_dds").is_empty(),
        "{warnings:?}"
    );
    let blended = scene
        .materials
        .iter()
        .filter(|m| m.alpha_mode == AlphaMode::Blend)
        .count();
    assert_eq!(blended, 2);
    // Its one animation holds a single key per channel: a pose, not motion, so nothing is
    // rebuilt from frame to frame.
    assert_eq!(scene.animations.len(), 1);
    assert!(!scene.is_animated());
    assert!(!scene.moving_nodes().contains(&true));
}

#[test]
fn sheen_chair_reads_its_texture_transforms() {
    let Some(dir) = scenes_dir() else { return };
    let (scene, warnings) = import(&dir, "SheenChair", "SheenChair.gltf");
    assert!(
        warnings_with(&warnings, "KHR_texture_transform").is_empty(),
        "{warnings:?}"
    );
    assert_eq!(warnings_with(&warnings, "KHR_materials_sheen").len(), 1);
    assert_eq!(warnings_with(&warnings, "KHR_materials_variants").len(), 1);
    let transformed = scene
        .materials
        .iter()
        .flat_map(|m| m.texture_refs())
        .filter(|r| r.transform.scale == glam::Vec2::splat(7.0))
        .count();
    assert!(transformed > 0, "the fabric's 7x tiling");
    let occlusion_on_uv1 = scene
        .materials
        .iter()
        .filter_map(|m| m.occlusion_texture)
        .any(|r| r.tex_coord == 1);
    assert!(occlusion_on_uv1);
    assert!(
        scene
            .meshes
            .iter()
            .flat_map(|m| &m.primitives)
            .any(|p| !p.uvs1.is_empty())
    );
}

#[test]
fn toy_car_warns_about_its_layered_materials() {
    let Some(dir) = scenes_dir() else { return };
    let (scene, warnings) = import(&dir, "ToyCar", "ToyCar.gltf");
    for ext in [
        "KHR_materials_clearcoat",
        "KHR_materials_transmission",
        "KHR_materials_sheen",
    ] {
        assert_eq!(
            warnings_with(&warnings, ext).len(),
            1,
            "{ext}: {warnings:?}"
        );
    }
    assert!(scene.materials.iter().any(|m| m.normal_texture.is_some()));
    assert_eq!(scene.cameras.len(), 8);
}

#[test]
fn cornell_box_has_its_emissive_panel() {
    let Some(dir) = scenes_dir() else { return };
    let (scene, _) = import(&dir, "CornellBox", "cornell-box.gltf");
    assert!(
        scene
            .materials
            .iter()
            .any(|m| m.emissive.max_element() > 0.0)
    );
    assert_eq!(gi_scene::no_emitter_warning(&scene), None);
}
