//! A disk cache of reference renders, so `gi compare` path traces each view once.
//!
//! The key covers everything the reference image depends on: the scene's content (every
//! vertex, material, texel, light, setting), the camera, the frame time, the image size, the
//! sample count, the seed and the version of this program. A changed scene file therefore never
//! hits a stale entry.

use std::{
    fs,
    path::{Path, PathBuf},
};

use anyhow::{Context, Result};
use gi_image::Image;
use gi_scene::{CameraView, Scene};
use serde::{Deserialize, Serialize};

/// 64-bit FNV-1a: small, stable across platforms and releases (unlike std's hasher), and
/// plenty for a cache key that is also checked against its stored description.
struct Fnv1a(u64);

impl Fnv1a {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// Hash of a scene's full content. The derived `Debug` output lists every field of the model
/// (floats printed exactly), so any change to the scene changes the hash.
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut hasher = Fnv1a::new();
    hasher.write(format!("{scene:?}").as_bytes());
    hasher.0
}

/// What a cached reference was rendered from; stored beside the image and compared on lookup.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceKey {
    pub scene: String,
    pub scene_hash: String,
    pub camera: String,
    pub time_s: f32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    pub version: String,
}

impl ReferenceKey {
    pub fn new(
        scene: &Scene,
        camera: &CameraView,
        time_s: f32,
        (width, height): (u32, u32),
        spp: u32,
        seed: u64,
    ) -> Self {
        Self {
            scene: scene.name.clone(),
            scene_hash: format!("{:016x}", scene_hash(scene)),
            camera: format!("{camera:?}"),
            time_s,
            width,
            height,
            spp,
            seed,
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    fn file_stem(&self) -> String {
        let mut hasher = Fnv1a::new();
        hasher.write(serde_json::to_string(self).unwrap_or_default().as_bytes());
        format!("{}-{:016x}", self.scene, hasher.0)
    }
}

/// A cached reference render: the image and how long it took to make.
pub struct CachedReference {
    pub image: Image,
    pub seconds: f64,
}

#[derive(Serialize, Deserialize)]
struct Entry {
    key: ReferenceKey,
    seconds: f64,
}

/// The cache folder: `$GI_CACHE_DIR`, else `$XDG_CACHE_HOME/gi`, else `~/.cache/gi`, else
/// `.gi-cache` in the current folder.
pub fn default_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("GI_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("gi");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache/gi");
    }
    PathBuf::from(".gi-cache")
}

/// Looks up a reference; any unreadable or mismatching entry counts as a miss.
pub fn load(dir: &Path, key: &ReferenceKey) -> Option<CachedReference> {
    let stem = key.file_stem();
    let meta = fs::read_to_string(dir.join(format!("{stem}.json"))).ok()?;
    let entry: Entry = serde_json::from_str(&meta).ok()?;
    if &entry.key != key {
        return None;
    }
    let image = gi_image::read_exr(dir.join(format!("{stem}.exr"))).ok()?;
    (image.width == key.width && image.height == key.height).then_some(CachedReference {
        image,
        seconds: entry.seconds,
    })
}

/// Stores a reference render.
pub fn store(dir: &Path, key: &ReferenceKey, image: &Image, seconds: f64) -> Result<()> {
    fs::create_dir_all(dir).with_context(|| format!("creating cache folder {}", dir.display()))?;
    let stem = key.file_stem();
    gi_image::write_exr(image, dir.join(format!("{stem}.exr")))?;
    let entry = Entry {
        key: key.clone(),
        seconds,
    };
    let path = dir.join(format!("{stem}.json"));
    fs::write(&path, serde_json::to_string_pretty(&entry)?)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
