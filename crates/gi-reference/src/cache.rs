//! A disk cache of reference renders, shared by every tool that measures a tier against the
//! reference (the `gi` command and the render service), so each view is path traced once.
//!
//! The key covers everything the reference image depends on: the scene's content (every
//! vertex, material, texel, light, setting), the camera, the frame time, the image size, the
//! sample count, the seed and the version of this crate. A changed scene file therefore never
//! hits a stale entry.
//!
//! Entries are written to temporary files and renamed into place (the image first, then its
//! description), so a reader running at the same time, in this process or another, sees either
//! a whole entry or none.
//!
//! A cache renders with the [`ReferenceEngine`] it is given ([`CpuEngine`] unless
//! [`ReferenceCache::with_engine`] says otherwise; the GPU engine lives in gi-tiers), and each
//! entry's description records which engine made it. Under [`EngineChoice::Auto`] an entry of
//! either engine serves (they compute the same estimator from the same random numbers); under
//! an explicit choice only the chosen engine's entries do.
//!
//! ```no_run
//! # fn demo(scene: &gi_scene::Scene) -> Result<(), gi_reference::cache::CacheError> {
//! use gi_reference::cache::{ReferenceCache, ReferenceRequest};
//!
//! let request = ReferenceRequest::new(scene, scene.default_view(0.0), 0.0, (64, 48), 256, 7);
//! let cache = ReferenceCache::new(gi_reference::cache::default_dir());
//! let reference = cache
//!     .get_or_render(&request, true, &|_| {}, &|| false)?
//!     .expect("never cancelled");
//! println!("{} s, cached: {}", reference.seconds, reference.cached);
//! # Ok(()) }
//! ```

use std::{
    fmt, fs,
    path::{Path, PathBuf},
    sync::{
        Arc,
        atomic::{AtomicU64, Ordering},
    },
};

use gi_image::{Image, ImageError};
use gi_scene::{CameraView, Scene};
use serde::{Deserialize, Serialize};

use crate::engine::{CpuEngine, EngineChoice, EngineKind, ReferenceEngine};
use crate::{Mode, Reference, RenderError, RenderSettings, RenderStats, Strategy};

/// Samples per pixel of a reference when the caller does not say: enough that the reference's
/// own noise is small next to the error of a real-time tier at 16 spp.
pub const DEFAULT_REFERENCE_SPP: u32 = 1024;

/// Seed of reference renders, kept apart from the tiers' default seed (1) so a tier's noise is
/// never correlated with the reference's.
pub const REFERENCE_SEED: u64 = 0x005e_ed0f_7e7e;

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
    /// File name of the entry without extension: the scene name (kept to its file-safe
    /// characters, so an uploaded scene's name cannot leave the folder) and the key's hash.
    fn file_stem(&self) -> String {
        let mut hasher = Fnv1a::new();
        hasher.write(serde_json::to_string(self).unwrap_or_default().as_bytes());
        let name: String = self
            .scene
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_'))
            .take(64)
            .collect();
        format!("{name}-{:016x}", hasher.0)
    }
}

/// One reference render: which scene, camera, time, size, samples and seed.
pub struct ReferenceRequest<'a> {
    pub scene: &'a Scene,
    pub view: CameraView,
    pub time_s: f32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
}

impl<'a> ReferenceRequest<'a> {
    /// A request for `scene` seen through `view` at `time_s`.
    pub fn new(
        scene: &'a Scene,
        view: CameraView,
        time_s: f32,
        (width, height): (u32, u32),
        spp: u32,
        seed: u64,
    ) -> Self {
        Self {
            scene,
            view,
            time_s,
            width,
            height,
            spp,
            seed,
        }
    }

    /// The cache key of this render.
    pub fn key(&self) -> ReferenceKey {
        ReferenceKey {
            scene: self.scene.name.clone(),
            scene_hash: format!("{:016x}", scene_hash(self.scene)),
            camera: format!("{:?}", self.view),
            time_s: self.time_s,
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// The path tracer's settings: full transport with MIS, as the `reference` tier renders.
    pub fn settings(&self) -> RenderSettings {
        RenderSettings {
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            mode: Mode::Full,
            strategy: Strategy::Mis,
            ..RenderSettings::default()
        }
    }

    /// Path traces the reference, calling `progress` with the samples per pixel done after
    /// every pass and stopping between passes once `cancelled` answers true (then `None`).
    /// Passes do not change the image: it equals [`Reference::render`]'s for the same settings.
    pub fn render(
        &self,
        progress: &(dyn Fn(u32) + Sync),
        cancelled: &dyn Fn() -> bool,
    ) -> Result<Option<(Image, RenderStats)>, RenderError> {
        let settings = self.settings();
        settings.validate()?;
        let frame = self.scene.evaluate(self.time_s, Some(self.view));
        let reference = Reference::new(self.scene, frame);
        let mut accumulator = reference.accumulator(&settings)?;
        // About 64k paths per pass: frequent enough progress and cancellation checks, few
        // enough passes that their overhead stays negligible.
        let pass = ((1u64 << 16) / settings.pixel_count()).clamp(1, 1 << 16) as u32;
        while accumulator.samples_per_pixel() < settings.spp {
            if cancelled() {
                return Ok(None);
            }
            accumulator.add_samples(pass.min(settings.spp - accumulator.samples_per_pixel()));
            progress(accumulator.samples_per_pixel());
        }
        Ok(Some((accumulator.image(), accumulator.stats())))
    }
}

/// A reference image, how long it took to render and on what.
pub struct CachedReference {
    pub image: Image,
    /// Seconds the render took when it was made (not the lookup's time).
    pub seconds: f64,
    /// True when it came from the cache rather than being rendered now.
    pub cached: bool,
    /// The engine that rendered it ([`ReferenceEngine::description`]): `"cpu"` or
    /// `"gpu: <adapter name>"`.
    pub engine: String,
}

/// Why a reference could not be rendered or stored.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The engine could not render (no GPU, a device lost...).
    #[error("the {engine} reference engine failed: {message}")]
    Engine { engine: String, message: String },
}

#[derive(Serialize, Deserialize)]
struct Entry {
    key: ReferenceKey,
    seconds: f64,
    /// [`ReferenceEngine::description`] of the engine that made it; entries from before
    /// engines were recorded were all made on the CPU.
    #[serde(default = "cpu_description")]
    engine: String,
}

fn cpu_description() -> String {
    CpuEngine.description()
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

/// A folder of cached reference renders and the engine that renders the missing ones.
#[derive(Clone)]
pub struct ReferenceCache {
    dir: PathBuf,
    engine: Arc<dyn ReferenceEngine>,
    choice: EngineChoice,
}

impl fmt::Debug for ReferenceCache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ReferenceCache")
            .field("dir", &self.dir)
            .field("engine", &self.engine.description())
            .field("choice", &self.choice)
            .finish()
    }
}

impl ReferenceCache {
    /// The cache in `dir` (created when the first entry is stored), rendering on the CPU and
    /// accepting entries of any engine ([`EngineChoice::Auto`]).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: dir.into(),
            engine: Arc::new(CpuEngine),
            choice: EngineChoice::Auto,
        }
    }

    /// The same cache rendering with `engine`, picked for `choice`: under
    /// [`EngineChoice::Auto`] entries of any engine serve, under an explicit choice only
    /// entries made by an engine of `engine`'s kind.
    pub fn with_engine(self, engine: Arc<dyn ReferenceEngine>, choice: EngineChoice) -> Self {
        Self {
            engine,
            choice,
            ..self
        }
    }

    /// The cache folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The engine that renders missing references.
    pub fn engine(&self) -> &dyn ReferenceEngine {
        self.engine.as_ref()
    }

    /// Whether an entry made by the engine described as `description` serves this cache.
    fn accepts(&self, description: &str) -> bool {
        match (self.choice, EngineKind::of_description(description)) {
            (EngineChoice::Auto, _) => true,
            (_, Some(kind)) => kind == self.engine.kind(),
            (_, None) => false,
        }
    }

    /// Looks up a reference; any unreadable or mismatching entry, or one made by an engine
    /// this cache does not accept, counts as a miss.
    pub fn load(&self, key: &ReferenceKey) -> Option<CachedReference> {
        let stem = key.file_stem();
        let meta = fs::read_to_string(self.dir.join(format!("{stem}.json"))).ok()?;
        let entry: Entry = serde_json::from_str(&meta).ok()?;
        if &entry.key != key || !self.accepts(&entry.engine) {
            return None;
        }
        let image = gi_image::read_exr(self.dir.join(format!("{stem}.exr"))).ok()?;
        (image.width == key.width && image.height == key.height).then_some(CachedReference {
            image,
            seconds: entry.seconds,
            cached: true,
            engine: entry.engine,
        })
    }

    /// Stores a reference render made by the engine described as `engine`, replacing any
    /// entry with the same key.
    pub fn store(
        &self,
        key: &ReferenceKey,
        image: &Image,
        seconds: f64,
        engine: &str,
    ) -> Result<(), CacheError> {
        fs::create_dir_all(&self.dir).map_err(|source| CacheError::Io {
            path: self.dir.clone(),
            source,
        })?;
        let stem = key.file_stem();
        // The image goes in before the description that makes the entry visible.
        let exr = self.dir.join(format!("{stem}.exr"));
        let exr_tmp = temporary_path(&exr);
        let written = gi_image::write_exr(image, &exr_tmp)
            .map_err(CacheError::from)
            .and_then(|()| rename(&exr_tmp, &exr));
        if let Err(error) = written {
            let _ = fs::remove_file(&exr_tmp);
            return Err(error);
        }
        let entry = Entry {
            key: key.clone(),
            seconds,
            engine: engine.to_string(),
        };
        let json = self.dir.join(format!("{stem}.json"));
        let json_tmp = temporary_path(&json);
        let text = serde_json::to_string_pretty(&entry).expect("the entry serializes");
        let written = fs::write(&json_tmp, text)
            .map_err(|source| CacheError::Io {
                path: json_tmp.clone(),
                source,
            })
            .and_then(|()| rename(&json_tmp, &json));
        if written.is_err() {
            let _ = fs::remove_file(&json_tmp);
        }
        written
    }

    /// The reference `request` asks for: from the cache when `use_cached` and an identical
    /// render by an accepted engine exists, else rendered now by the cache's engine (see
    /// [`ReferenceEngine::render`]) and stored. A render that could not be stored is still
    /// returned (with a warning logged): the cache only saves time. `None` when `cancelled`
    /// stopped the render.
    pub fn get_or_render(
        &self,
        request: &ReferenceRequest,
        use_cached: bool,
        progress: &(dyn Fn(u32) + Sync),
        cancelled: &dyn Fn() -> bool,
    ) -> Result<Option<CachedReference>, CacheError> {
        let key = request.key();
        if use_cached && let Some(hit) = self.load(&key) {
            return Ok(Some(hit));
        }
        let Some((image, stats)) = self.engine.render(request, progress, cancelled)? else {
            return Ok(None);
        };
        // Preparing the scene (BVH build) is part of what the cache saves.
        let seconds = stats.seconds + stats.bvh_build_seconds;
        let engine = self.engine.description();
        if let Err(error) = self.store(&key, &image, seconds, &engine) {
            tracing::warn!("reference not cached: {error}");
        }
        Ok(Some(CachedReference {
            image,
            seconds,
            cached: false,
            engine,
        }))
    }
}

/// A name beside `path` that no other writer (thread or process) uses at the same time.
fn temporary_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".{}.{n}.tmp", std::process::id()));
    path.with_file_name(name)
}

fn rename(from: &Path, to: &Path) -> Result<(), CacheError> {
    fs::rename(from, to).map_err(|source| CacheError::Io {
        path: to.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        gi_scene::generate::build("cornell-box").expect("bundled")
    }

    #[test]
    fn a_stored_render_is_found_under_its_key_only() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path().join("refs"));
        let scene = scene();
        let request = ReferenceRequest::new(&scene, scene.default_view(0.0), 0.0, (6, 4), 2, 3);
        let first = cache
            .get_or_render(&request, true, &|_| {}, &|| false)
            .unwrap()
            .unwrap();
        assert!(!first.cached);
        let second = cache
            .get_or_render(&request, true, &|_| {}, &|| false)
            .unwrap()
            .unwrap();
        assert!(second.cached);
        assert_eq!(first.image.pixels, second.image.pixels);
        // Another seed is another image: a miss.
        let other = ReferenceRequest { seed: 4, ..request };
        assert!(cache.load(&other.key()).is_none());
        // Nothing temporary is left behind.
        let names: Vec<String> = fs::read_dir(cache.dir())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
    }

    #[test]
    fn a_render_equals_the_reference_render_and_stops_when_cancelled() {
        let scene = scene();
        let request = ReferenceRequest::new(&scene, scene.default_view(0.0), 0.0, (5, 3), 3, 9);
        let (image, _) = request.render(&|_| {}, &|| false).unwrap().unwrap();
        let frame = scene.evaluate(0.0, Some(scene.default_view(0.0)));
        let direct = Reference::new(&scene, frame)
            .render(&request.settings(), &|_| {})
            .unwrap();
        assert_eq!(image.pixels, direct.image.pixels);
        assert!(request.render(&|_| {}, &|| true).unwrap().is_none());
    }

    /// An engine of `kind` that paints every pixel `value` and counts its renders.
    struct FakeEngine {
        kind: EngineKind,
        value: f32,
        renders: AtomicU64,
    }

    impl FakeEngine {
        fn new(kind: EngineKind, value: f32) -> Arc<Self> {
            Arc::new(Self {
                kind,
                value,
                renders: AtomicU64::new(0),
            })
        }

        fn renders(&self) -> u64 {
            self.renders.load(Ordering::Relaxed)
        }
    }

    impl ReferenceEngine for FakeEngine {
        fn kind(&self) -> EngineKind {
            self.kind
        }

        fn description(&self) -> String {
            format!("{}: fake", self.kind.name())
        }

        fn render(
            &self,
            request: &ReferenceRequest,
            progress: &(dyn Fn(u32) + Sync),
            _cancelled: &dyn Fn() -> bool,
        ) -> Result<Option<(Image, RenderStats)>, CacheError> {
            self.renders.fetch_add(1, Ordering::Relaxed);
            progress(request.spp);
            let pixels = (request.width * request.height) as usize;
            let image = Image {
                width: request.width,
                height: request.height,
                pixels: vec![glam::Vec3::splat(self.value); pixels],
            };
            Ok(Some((image, RenderStats::default())))
        }
    }

    #[test]
    fn entries_record_their_engine_and_explicit_choices_take_only_their_own() {
        let dir = tempfile::tempdir().unwrap();
        let scene = scene();
        let request = ReferenceRequest::new(&scene, scene.default_view(0.0), 0.0, (3, 2), 4, 5);
        let get = |cache: &ReferenceCache| {
            cache
                .get_or_render(&request, true, &|_| {}, &|| false)
                .unwrap()
                .unwrap()
        };
        let gpu = FakeEngine::new(EngineKind::Gpu, 1.0);
        let cpu = FakeEngine::new(EngineKind::Cpu, 2.0);
        let cache = || ReferenceCache::new(dir.path());
        let explicit_gpu = cache().with_engine(gpu.clone(), EngineChoice::Gpu);
        let explicit_cpu = cache().with_engine(cpu.clone(), EngineChoice::Cpu);
        let auto_gpu = cache().with_engine(gpu.clone(), EngineChoice::Auto);

        let made = get(&explicit_gpu);
        assert!(!made.cached);
        assert_eq!(made.engine, "gpu: fake");
        // The description is stored beside the image.
        let stem = request.key().file_stem();
        let json = fs::read_to_string(dir.path().join(format!("{stem}.json"))).unwrap();
        assert!(json.contains("\"engine\": \"gpu: fake\""), "{json}");
        let again = get(&explicit_gpu);
        assert!(again.cached);
        assert_eq!(again.engine, "gpu: fake");
        assert_eq!(gpu.renders(), 1);

        // An explicit CPU choice does not take the GPU's entry: it renders and replaces it.
        assert!(explicit_cpu.load(&request.key()).is_none());
        let on_cpu = get(&explicit_cpu);
        assert!(!on_cpu.cached);
        assert_eq!(on_cpu.engine, "cpu: fake");
        assert_eq!(on_cpu.image.pixels[0], glam::Vec3::splat(2.0));
        assert_eq!(cpu.renders(), 1);

        // Auto takes an entry of either engine, here the CPU's, without rendering.
        let auto = get(&auto_gpu);
        assert!(auto.cached);
        assert_eq!(auto.engine, "cpu: fake");
        assert_eq!(gpu.renders(), 1);

        // The explicit GPU choice no longer finds its own and renders again.
        assert!(!get(&explicit_gpu).cached);
        assert_eq!(gpu.renders(), 2);
    }

    #[test]
    fn entries_from_before_engines_were_recorded_count_as_the_cpus() {
        let dir = tempfile::tempdir().unwrap();
        let scene = scene();
        let request = ReferenceRequest::new(&scene, scene.default_view(0.0), 0.0, (3, 2), 1, 5);
        let key = request.key();
        let cache = ReferenceCache::new(dir.path());
        cache
            .get_or_render(&request, true, &|_| {}, &|| false)
            .unwrap();
        // Rewrite the description as older versions wrote it: no engine.
        let path = dir.path().join(format!("{}.json", key.file_stem()));
        let old = serde_json::json!({ "key": key, "seconds": 0.5 });
        fs::write(&path, old.to_string()).unwrap();
        let found = cache.load(&key).unwrap();
        assert_eq!(found.engine, "cpu");
        let gpu_only = cache
            .clone()
            .with_engine(FakeEngine::new(EngineKind::Gpu, 1.0), EngineChoice::Gpu);
        assert!(gpu_only.load(&key).is_none());
        let cpu_only = cache.with_engine(Arc::new(CpuEngine), EngineChoice::Cpu);
        assert!(cpu_only.load(&key).is_some());
    }

    #[test]
    fn scene_names_cannot_leave_the_cache_folder() {
        let mut scene = scene();
        scene.name = "../../etc/passwd".to_string();
        let key = ReferenceRequest::new(&scene, scene.default_view(0.0), 0.0, (1, 1), 1, 1).key();
        let stem = key.file_stem();
        assert!(!stem.contains('/') && !stem.contains(".."), "{stem}");
    }
}
