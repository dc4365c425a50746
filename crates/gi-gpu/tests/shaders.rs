//! Shader library tests that need no GPU: every WGSL file composes and validates, errors name
//! their file and line, and shared Rust/WGSL structs have the same layout.

use gi_gpu::{
    FrameUniforms, GpuError, SHADER_CAPABILITIES, ShaderDefValue, ShaderLibrary,
    rust_field_offsets, wgsl_struct_layout,
};

fn validate(module: &naga::Module) -> Result<(), String> {
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), SHADER_CAPABILITIES)
        .validate(module)
        .map(|_| ())
        .map_err(|err| format!("{err:?}"))
}

/// Composes and validates each of `paths`, returning one message per failure.
fn compose_all<'a>(library: &ShaderLibrary, paths: impl Iterator<Item = &'a str>) -> Vec<String> {
    paths
        .filter_map(|path| match library.compose(path, &[]) {
            Ok(module) => validate(&module).err().map(|err| format!("{path}: {err}")),
            Err(err) => Some(err.to_string()),
        })
        .collect()
}

#[test]
fn every_entry_shader_composes_and_validates() {
    let library = ShaderLibrary::new();
    let files: Vec<&str> = library.files().collect();
    assert!(
        files.contains(&"common/math.wgsl") && files.contains(&"test/double.wgsl"),
        "the shader library is missing files (found {files:?}); is the shaders/ folder there?"
    );
    // Import modules are composed as part of the entry files that import them.
    let entry_files = files
        .iter()
        .copied()
        .filter(|path| library.import_path(path).is_none());
    let failures = compose_all(&library, entry_files);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn every_shared_module_composes_on_its_own() {
    // The shared modules are everyone's building blocks: they must be valid before any entry
    // file uses them, and composing one on its own keeps all its items and checks that
    // naga_oil can import every identifier it declares.
    let library = ShaderLibrary::new();
    let modules: Vec<&str> = library
        .files()
        .filter(|path| path.starts_with("common/"))
        .collect();
    assert!(modules.len() >= 3, "shared modules missing: {modules:?}");
    for path in &modules {
        assert!(
            library.import_path(path).is_some(),
            "{path} declares no import path"
        );
    }
    let failures = compose_all(&library, modules.into_iter());
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn import_modules_are_told_apart_from_entry_files() {
    let library = ShaderLibrary::new();
    assert_eq!(
        library.import_path("common/math.wgsl").as_deref(),
        Some("gi::math")
    );
    assert_eq!(library.import_path("test/double.wgsl"), None);
    let module = library.compose("test/double.wgsl", &[]).unwrap();
    assert!(
        module
            .entry_points
            .iter()
            .any(|e| e.name == "double_values")
    );
}

#[test]
fn a_syntax_error_names_its_file_and_line() {
    let library = ShaderLibrary::new().with_source(
        "test/broken.wgsl",
        "// A shader with a syntax error on line 6.\n\
         #import gi::math::PI\n\
         \n\
         @compute @workgroup_size(1)\n\
         fn main() {\n\
         \x20   let x: f32 = PI + ;\n\
         }\n",
    );
    let err = library.compose("test/broken.wgsl", &[]).unwrap_err();
    let GpuError::Shader { file, line, .. } = &err else {
        panic!("expected a shader error, got {err}");
    };
    assert_eq!((file.as_str(), *line), ("test/broken.wgsl", 6), "{err}");
    assert!(err.to_string().starts_with("test/broken.wgsl:6:"), "{err}");
}

#[test]
fn an_error_in_an_imported_module_names_the_module_file() {
    let library = ShaderLibrary::new()
        .with_source(
            "common/broken.wgsl",
            "#define_import_path gi::broken\n\
             \n\
             fn half_of(x: f32) -> f32 {\n\
             \x20   let y: u32 = x;\n\
             \x20   return f32(y) * 0.5;\n\
             }\n",
        )
        .with_source(
            "test/uses_broken.wgsl",
            "#import gi::broken::half_of\n\
             @compute @workgroup_size(1)\n\
             fn main() { _ = half_of(1.0); }\n",
        );
    let err = library.compose("test/uses_broken.wgsl", &[]).unwrap_err();
    let GpuError::Shader { file, line, .. } = &err else {
        panic!("expected a shader error, got {err}");
    };
    assert_eq!((file.as_str(), *line), ("common/broken.wgsl", 4), "{err}");
}

#[test]
fn a_missing_file_is_a_shader_error() {
    let err = ShaderLibrary::new()
        .compose("no/such.wgsl", &[])
        .unwrap_err();
    assert!(matches!(err, GpuError::Shader { ref file, line: 0, .. } if file == "no/such.wgsl"));
}

#[test]
fn shader_defs_select_code() {
    let library = ShaderLibrary::new().with_source(
        "test/defs.wgsl",
        "@compute @workgroup_size(1)\n\
         #ifdef FAST_PATH\n\
         fn fast_main() {}\n\
         #else\n\
         fn slow_main() {}\n\
         #endif\n",
    );
    let fast = library
        .compose(
            "test/defs.wgsl",
            &[("FAST_PATH", ShaderDefValue::Bool(true))],
        )
        .unwrap();
    let slow = library.compose("test/defs.wgsl", &[]).unwrap();
    assert_eq!(fast.entry_points[0].name, "fast_main");
    assert_eq!(slow.entry_points[0].name, "slow_main");
}

#[test]
fn shaders_load_from_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("common")).unwrap();
    std::fs::write(
        dir.path().join("common/only.wgsl"),
        "#define_import_path gi::only\nconst ONE: f32 = 1.0;\n",
    )
    .unwrap();
    let library = ShaderLibrary::from_dir(dir.path()).unwrap();
    assert_eq!(library.files().collect::<Vec<_>>(), ["common/only.wgsl"]);
    library.compose("common/only.wgsl", &[]).unwrap();
}

#[test]
fn frame_uniforms_match_their_wgsl_layout() {
    let library = ShaderLibrary::new().with_source(
        "test/frame_layout.wgsl",
        "#import gi::frame::FrameUniforms\n\
         @group(0) @binding(0) var<uniform> frame: FrameUniforms;\n\
         @compute @workgroup_size(1)\n\
         fn main() { _ = frame.seed; }\n",
    );
    let module = library.compose("test/frame_layout.wgsl", &[]).unwrap();
    let wgsl = wgsl_struct_layout(&module, FrameUniforms::WGSL_NAME).expect("FrameUniforms");
    let rust = rust_field_offsets!(FrameUniforms {
        clip_from_world,
        world_from_clip,
        camera_position_ws,
        exposure,
        size_px,
        frame_index,
        seed,
    });
    assert_eq!(wgsl.members, rust);
    assert_eq!(wgsl.size as usize, size_of::<FrameUniforms>());
    assert_eq!(size_of::<FrameUniforms>() % wgsl.align as usize, 0);
}

/// Composed modules are kept for the process by the library's sources, file and defs: the
/// same sources give the kept module again, and a changed import is composed anew, not
/// answered with the module kept for the old one.
#[test]
fn a_changed_import_is_composed_again() {
    let library = |size: u32| {
        ShaderLibrary::new()
            .with_source(
                "test/size.wgsl",
                format!("#define_import_path gi::test_size\nconst SIZE: u32 = {size}u;\n"),
            )
            .with_source(
                "test/sized.wgsl",
                "#import gi::test_size::SIZE\n\
                 @compute @workgroup_size(SIZE)\n\
                 fn main() {}\n",
            )
    };
    let size = |library: &ShaderLibrary| {
        library
            .compose("test/sized.wgsl", &[])
            .unwrap()
            .entry_points[0]
            .workgroup_size
    };
    assert_eq!(size(&library(4)), [4, 1, 1]);
    assert_eq!(size(&library(4)), [4, 1, 1]);
    assert_eq!(size(&library(8)), [8, 1, 1]);
    // One library changed after it composed.
    let changed = library(4);
    assert_eq!(size(&changed), [4, 1, 1]);
    let changed = changed.with_source(
        "test/size.wgsl",
        "#define_import_path gi::test_size\nconst SIZE: u32 = 16u;\n",
    );
    assert_eq!(size(&changed), [16, 1, 1]);
}
