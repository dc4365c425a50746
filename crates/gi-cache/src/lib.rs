//! The surfel brick radiance cache (HSGI + SmartGI's bricklizer): a clipmapped sparse volume
//! of voxel bricks around the camera that stores the scene's diffuse albedo, normals and
//! emission per voxel and its lighting per surfel side, filled by voxelizing the scene on the
//! GPU, lit by direct injection and multi-bounce gathering, and traced with a hierarchical
//! DDA. It is where the real-time tiers read radiance from.
//!
//! Each voxel's surface is one surfel ("voxel + normal", HSGI) with two sides, front along the
//! normal and back against it, each with its own irradiance: the two faces of a wall thinner
//! than a voxel that SmartGI keeps apart with its visible faces, at 32 bytes per voxel instead
//! of the 64 that six axis faces cost, which doubles the bricks the same memory holds
//! ([`layout`] has the details).
//!
//! [`CacheConfig`] holds every tunable number with its justification; [`layout`] documents
//! the data structure and its addressing, mirrored by `shaders/cache/data.wgsl`.
//!
//! The parts: [`BrickAllocator`] hands out pool IDs, [`clipmap`] places the level windows,
//! [`CacheStructure`] mirrors link grids and masks on the CPU, [`binning`] and
//! [`cpu_voxelize`] decide which triangles touch which voxels (the CPU oracle of the GPU
//! voxelizer), [`CacheBuffers`] holds the GPU buffers of bind group 2, and [`CpuCache`] builds
//! a complete cache on the CPU, for tests and tools that need one without the GPU passes.

pub mod alloc;
pub mod binning;
pub mod buffers;
pub mod cache;
pub mod clipmap;
pub mod config;
pub mod cpu_cache;
pub mod cpu_voxelize;
pub mod debug;
pub mod fill_queue;
pub mod layout;
pub mod lighting;
pub mod packing;
pub mod query;
pub mod residency;
pub mod screen_inject;
pub mod structure;
pub mod voxelize;

pub use alloc::{BrickAllocator, FreeError};
pub use buffers::CacheBuffers;
pub use cache::{
    CacheError, CacheFrame, CacheInputs, CacheLightingHook, CacheOutputs, CacheStats,
    CacheUpdateStats, CpuSteps, RadianceCache, ResidentBrick,
};
pub use clipmap::{BrickBox, ClipmapWindows, WindowShift};
pub use config::{CacheConfig, ConfigError};
pub use cpu_cache::CpuCache;
pub use debug::{DebugView, UnknownDebugView, render_debug_view};
pub use layout::{GpuCacheLevel, GpuCacheUniforms, VoxelSurface};
pub use lighting::{CacheLighting, LightSchedule, LightingInputs, ScheduleCounts};
pub use query::{CACHE_LANES, CacheRayHit, CacheTraceTimings, CacheTracer};
pub use residency::{IdSet, Residency};
pub use screen_inject::{ScreenInjectCounts, ScreenInputs};
pub use structure::CacheStructure;
