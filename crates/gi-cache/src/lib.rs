//! The surfel brick radiance cache (HSGI + SmartGI's bricklizer): a clipmapped sparse volume
//! of voxel bricks around the camera that stores the scene's diffuse albedo, normals and
//! emission per voxel and its lighting per voxel face, filled by voxelizing the scene on the
//! GPU, lit by direct injection and multi-bounce gathering, and traced with a hierarchical
//! DDA. It is where the real-time tiers read radiance from.
//!
//! [`CacheConfig`] holds every tunable number with its justification; [`layout`] documents
//! the data structure and its addressing, mirrored by `shaders/cache/data.wgsl`.

pub mod config;
pub mod layout;

pub use config::{CacheConfig, ConfigError};
pub use layout::{GpuCacheLevel, GpuCacheUniforms, VoxelSurface};
