//! The bundled scenes as users get them: committed files that match their generators, and
//! addressing by name or path.

use std::path::Path;

fn scenes_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// `scenes/` is what `gi generate-scenes` writes today: a generator change must come with
/// regenerated files (run `gi generate-scenes`).
#[test]
fn committed_scene_files_match_the_generators() {
    let out = tempfile::tempdir().unwrap();
    let written = gi_scene::generate::write_all(out.path()).unwrap();
    assert!(written.len() >= 2 * gi_scene::BUNDLED_SCENES.len());
    for path in written {
        let name = path.file_name().unwrap();
        let committed = std::fs::read(scenes_dir().join(name))
            .unwrap_or_else(|e| panic!("scenes/{}: {e}", name.to_string_lossy()));
        let fresh = std::fs::read(&path).unwrap();
        assert!(
            committed == fresh,
            "scenes/{} is stale: run `gi generate-scenes`",
            name.to_string_lossy()
        );
    }
}

#[test]
fn bundled_names_load_from_their_files_with_the_generated_content() {
    for (name, _) in gi_scene::BUNDLED_SCENES {
        let path = gi_scene::resolve(name)
            .unwrap()
            .expect("bundled file exists");
        assert_eq!(path.file_name().unwrap(), format!("{name}.gltf").as_str());
        let loaded = gi_scene::load(name).unwrap();
        let generated = gi_scene::generate::build(name).unwrap();
        assert_eq!(loaded.name, *name);
        let (a, b) = (loaded.evaluate(0.0, None), generated.evaluate(0.0, None));
        assert_eq!(a.triangles.len(), b.triangles.len(), "{name}");
        assert_eq!(a.lights.len(), b.lights.len(), "{name}");
        assert!(
            (a.camera.position - b.camera.position).length() < 1e-4,
            "{name}"
        );
        assert_eq!(loaded.sky, generated.sky, "{name}");
    }
}

#[test]
fn scenes_load_by_path_and_bad_names_are_clear_errors() {
    let path = scenes_dir().join("cornell-box.gltf");
    let scene = gi_scene::load(path.to_str().unwrap()).unwrap();
    assert_eq!(scene.name, "cornell-box");

    let err = gi_scene::load("no-such-scene").unwrap_err().to_string();
    assert!(
        err.contains("no-such-scene") && err.contains("cornell-box"),
        "{err}"
    );
    let err = gi_scene::load("missing/dir/scene.glb")
        .unwrap_err()
        .to_string();
    assert!(err.contains("missing/dir/scene.glb"), "{err}");
}
