//! What each GPU tier declares for [`crate::select`] and for its own creation: what it needs
//! of an adapter ([`Requirements`]: `path::requirements`, `mobile::requirements`,
//! `pc::requirements`) and its measured frame cost ([`FrameCost`]: `pc::H100_COST`,
//! `mobile::H100_COST`, `path::DIRECT_H100_COST`), with the check of a device's limits
//! against the requirements, which tier creation and the selection policy both run.

use gi_gpu::wgpu;

use crate::tier::{TierKind, TierSettings};

/// What a GPU tier needs of the adapter, from the tier's pipeline layouts and shaders. The
/// test `tier_requirements_match_the_shaders` (tests/select.rs) checks them against the WGSL:
/// each storage-buffer count lies between what one entry point uses and what its file
/// declares, and the other figures are the shaders' own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Requirements {
    /// Storage buffers the tier's largest compute pipeline layout binds, summed over its bind
    /// groups (a layout counts every buffer it binds, used by the entry point or not).
    pub storage_buffers_per_stage: u32,
    /// Bind groups of the pipeline with the most (`@group(0..n)`).
    pub bind_groups: u32,
    /// Sampled textures of one stage: the scene's texture arrays (`gi_gpu::SceneTextures`).
    pub sampled_textures_per_stage: u32,
    /// The largest `@workgroup_size` product.
    pub invocations_per_workgroup: u32,
    /// The largest `@workgroup_size` along x.
    pub workgroup_size_x: u32,
    /// Bytes of the largest buffer bound whole at the requested resolution: one `vec4<f32>` per
    /// pixel for every tier, and the PC tier's reservoirs and surfaces per trace pixel.
    pub largest_binding_bytes: u64,
}

impl Requirements {
    /// What every GPU tier's compute passes share: four bind groups (the scene's texture
    /// arrays in the last), 64-invocation workgroups 64 wide at most; with the tier's own
    /// count of storage buffers in one stage and its largest whole-buffer binding.
    pub fn compute(storage_buffers_per_stage: u32, largest_binding_bytes: u64) -> Self {
        Self {
            storage_buffers_per_stage,
            bind_groups: 4,
            sampled_textures_per_stage: gi_gpu::textures::TEXTURE_ARRAYS,
            invocations_per_workgroup: 64,
            workgroup_size_x: 64,
            largest_binding_bytes,
        }
    }
}

/// Bytes of one `vec4<f32>` per pixel of `settings`' image: the size of every tier's
/// per-pixel buffers.
pub fn image_bytes(settings: &TierSettings) -> u64 {
    u64::from(settings.width) * u64::from(settings.height) * 16
}

/// The first requirement `limits` misses, as a sentence naming the limit and both values.
pub fn check_requirements(req: &Requirements, limits: &wgpu::Limits) -> Result<(), String> {
    let checks: [(&str, u64, u64); 6] = [
        (
            "max_storage_buffers_per_shader_stage",
            req.storage_buffers_per_stage.into(),
            limits.max_storage_buffers_per_shader_stage.into(),
        ),
        (
            "max_bind_groups",
            req.bind_groups.into(),
            limits.max_bind_groups.into(),
        ),
        (
            "max_sampled_textures_per_shader_stage",
            req.sampled_textures_per_stage.into(),
            limits.max_sampled_textures_per_shader_stage.into(),
        ),
        (
            "max_compute_invocations_per_workgroup",
            req.invocations_per_workgroup.into(),
            limits.max_compute_invocations_per_workgroup.into(),
        ),
        (
            "max_compute_workgroup_size_x",
            req.workgroup_size_x.into(),
            limits.max_compute_workgroup_size_x.into(),
        ),
        (
            "max_storage_buffer_binding_size",
            req.largest_binding_bytes,
            limits.max_storage_buffer_binding_size,
        ),
    ];
    match checks
        .iter()
        .find(|(_, needed, available)| needed > available)
    {
        Some((limit, needed, available)) => Err(format!(
            "needs {limit} >= {needed}, the adapter has {available}"
        )),
        None => Ok(()),
    }
}

/// A tier's measured whole-frame cost on the H100 at one or two sizes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameCost {
    pub kind: TierKind,
    /// `(megapixels, ms per frame)`, smallest first. With two points the model is
    /// `fixed + per-megapixel x megapixels` through both; with one it is proportional.
    pub points: &'static [(f64, f64)],
    /// Where the figures were measured.
    pub source: &'static str,
}
