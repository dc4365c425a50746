//! Every third-party scene of the shared scene folder (`../shared/scenes` beside the workspace)
//! on every tier, at a tiny size: real files load with their documented warnings, render
//! without an error, give finite images and are not black where the lighting file lights them.
//! The scenes without lights of their own take the lighting files in `benchmarks/lighting/`.

use std::path::{Path, PathBuf};

use gi_scene::{LoadedScene, import_with_lighting};
use gi_tiers::{CameraMode, Renderer, TextureOptions, TierChoice, TierKind, TierSettings};

/// 32 x 24; the path tracers at 16 samples per pixel (an interior lit through an opening needs
/// several for most pixels to find the sun), the real-time tiers at one; textures within 16 MiB
/// so the software adapter's memory and the mip chains stay small (the budget downscales them).
fn settings(kind: TierKind) -> TierSettings {
    TierSettings {
        width: 32,
        height: 24,
        spp: match kind {
            TierKind::Reference | TierKind::Path => 16,
            _ => 1,
        },
        seed: 3,
        textures: TextureOptions {
            budget_bytes: 16 << 20,
            ..TextureOptions::DEFAULT
        },
    }
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The scene file of each shared scene, or `None` (with a note) where the folder is absent.
fn shared_scenes() -> Option<Vec<PathBuf>> {
    let dir = workspace().join("../shared/scenes");
    if !dir.is_dir() {
        eprintln!(
            "skipped: {} is absent (the shared third-party scenes)",
            dir.display()
        );
        return None;
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|entry| {
            let gltf = entry.ok()?.path().join("glTF");
            std::fs::read_dir(gltf)
                .ok()?
                .filter_map(|f| f.ok().map(|f| f.path()))
                .find(|f| f.extension().is_some_and(|e| e == "gltf"))
        })
        .collect();
    files.sort();
    Some(files)
}

/// A shared scene with its lighting file from `benchmarks/lighting/`, if it has one.
fn load(file: &Path) -> LoadedScene {
    let stem = file.file_stem().unwrap().to_string_lossy().into_owned();
    let lighting = workspace()
        .join("benchmarks/lighting")
        .join(format!("{stem}.lighting.json"));
    let lighting = lighting.is_file().then_some(lighting);
    import_with_lighting(file, lighting.as_deref())
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()))
}

fn renders_every_shared_scene(kind: TierKind) {
    let Some(files) = shared_scenes() else {
        return;
    };
    assert!(files.len() >= 5, "shared scenes: {files:?}");
    for file in files {
        let name = file.file_stem().unwrap().to_string_lossy().into_owned();
        let loaded = load(&file);
        assert!(
            !loaded
                .warnings
                .iter()
                .any(|w| w.to_string().contains("renders black")),
            "{name}: {:?}",
            loaded.warnings
        );
        let mut renderer = match Renderer::new(
            loaded.scene,
            TierChoice::Tier(kind),
            settings(kind),
            CameraMode::Default,
        ) {
            Ok(renderer) => renderer,
            // Without an adapter the GPU tiers are unavailable; GI_REQUIRE_GPU (CI) makes
            // that a failure in the GPU crates' own tests.
            Err(e)
                if kind != TierKind::Reference && std::env::var_os("GI_REQUIRE_GPU").is_none() =>
            {
                eprintln!("skipped {name} on {kind:?}: {e}");
                return;
            }
            Err(e) => panic!("{name} on {kind:?}: {e}"),
        };
        // The temporal tiers gather their indirect light over frames (an emissive panel lights
        // the room only through the cache): the eighth frame is checked.
        let frames = if matches!(kind, TierKind::Mobile | TierKind::Pc) {
            8
        } else {
            1
        };
        let mut output = None;
        for _ in 0..frames {
            output = Some(
                renderer
                    .render_frame(None)
                    .unwrap_or_else(|e| panic!("{name} on {kind:?}: {e}")),
            );
        }
        let output = output.expect("at least one frame");
        let pixels = &output.image.pixels;
        assert!(
            pixels.iter().all(|p| p.is_finite()),
            "{name} on {kind:?}: non-finite pixels"
        );
        let lit = pixels.iter().filter(|p| p.max_element() > 0.0).count();
        assert!(
            lit * 4 >= pixels.len(),
            "{name} on {kind:?}: only {lit} of {} pixels receive light",
            pixels.len()
        );
    }
}

#[test]
fn shared_scenes_render_on_the_reference() {
    renders_every_shared_scene(TierKind::Reference);
}

#[test]
fn shared_scenes_render_on_the_path_tier() {
    renders_every_shared_scene(TierKind::Path);
}

#[test]
fn shared_scenes_render_on_the_pc_tier() {
    renders_every_shared_scene(TierKind::Pc);
}

#[test]
fn shared_scenes_render_on_the_mobile_tier() {
    renders_every_shared_scene(TierKind::Mobile);
}
