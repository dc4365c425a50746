//! Scene model, glTF import and export, the bundled scene generators, and the BVH.
//!
//! Load a scene by bundled name or path with [`load`], evaluate it at a time with
//! [`Scene::evaluate`], and trace rays against the result with [`SceneBvh`] (the CWBVH the GPU
//! tiers upload) or [`WideBvh`] (a four-wide BVH for tracing one ray at a time on the CPU).

mod bundled;
mod bvh;
mod emitters;
mod error;
mod export;
mod frame;
pub mod generate;
mod import;
mod lighting;
mod model;
mod morph;
mod skin;

pub use bundled::{
    BUNDLED_SCENES, LoadedScene, bundled_scene_dir, import_with_lighting, load, load_with_lighting,
    resolve,
};
pub use bvh::{
    Hit, SceneBvh, WideBvh, build_cwbvh, build_triangle_cwbvh, cwbvh_depth, tie_breaking_bounds,
    traversal_build,
};
pub use emitters::{EmitterDistribution, luminance};
pub use error::SceneError;
pub use export::write_gltf;
pub use frame::{CameraView, Evaluation, SceneFrame, TriangleAttributes, WorldLight};
pub use import::{
    ImportOptions, ImportWarning, import_gltf, import_gltf_slice, import_gltf_slice_with,
};
pub use lighting::{
    CameraChoice, LIGHTING_SUN_NAME, Lighting, SkyPreset, SkySetting, Sun, lighting_path_for,
    no_emitter_warning,
};
pub use model::*;
pub use morph::MorphedVertices;

/// Re-exported so callers can name BVH primitives without depending on obvhs directly.
pub use obvhs::triangle::Triangle;
