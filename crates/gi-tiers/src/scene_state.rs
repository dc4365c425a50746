//! What the GPU GI tiers (`mobile`, `pc`) keep of their scene between frames: the uploaded
//! scene and BVH, the direct light's progressive accumulation, and the previous frame (its
//! camera, node transforms, lights and time, which the G-buffer's motion vectors and the
//! tiers' reprojection read).

use gi_gpu::{GpuContext, GpuScene, wgpu};
use gi_image::Image;
use gi_scene::SceneFrame;
use glam::Vec3;

use crate::requirements::{Requirements, check_requirements, image_bytes};
use crate::tier::{FrameInput, TierError, TierKind, TierSettings};
use crate::tracer::{Accumulation, PathPipelines, PathUniforms};

/// Checks what the GPU tier `kind` needs of its settings on `ctx`: usable settings
/// ([`TierSettings::validate`]), an image whose one-`vec4<f32>`-per-pixel buffers fit the
/// device's storage binding limit, and the tier's declared `requirements` (a device the
/// caller opened, e.g. an engine's, may have smaller limits than the adapter's own).
pub(crate) fn check_frame_settings(
    kind: TierKind,
    settings: &TierSettings,
    requirements: &Requirements,
    ctx: &GpuContext,
) -> Result<(), TierError> {
    let unavailable = |reason: String| TierError::Unavailable {
        tier: kind.name(),
        reason,
    };
    settings.validate()?;
    let pixel_bytes = image_bytes(settings);
    let limit = ctx.limits.max_storage_buffer_binding_size;
    if pixel_bytes > limit {
        return Err(unavailable(format!(
            "{}x{} needs {pixel_bytes} bytes per image buffer, over the device's \
             {limit}-byte storage binding limit",
            settings.width, settings.height
        )));
    }
    check_requirements(requirements, &ctx.limits)
        .map_err(|reason| unavailable(format!("on this device: {reason}")))
}

/// Bytes of what a GPU GI tier named `tier` needs besides its GI, by their labels: the scene
/// (textures and GPU skinning included), the BVH, the G-buffer, the direct light, and the tier's
/// output image and pass timers. The tiers' memory reports sum their parts from labels, so a
/// buffer under no known label shows as a gap between the parts and the total.
pub(crate) fn frame_bytes(memory: &gi_gpu::MemoryReport, tier: &str) -> u64 {
    let shared: u64 = ["scene.", "bvh.", "skin.", "gbuffer.", "direct."]
        .iter()
        .map(|prefix| memory.bytes_with_prefix(prefix))
        .sum();
    shared + tier_overhead_bytes(memory, tier)
}

/// Bytes of the tier's output image and pass timers (labels `<tier>.output`,
/// `<tier>.timestamps`).
pub(crate) fn tier_overhead_bytes(memory: &gi_gpu::MemoryReport, tier: &str) -> u64 {
    memory.bytes_with_prefix(&format!("{tier}.output"))
        + memory.bytes_with_prefix(&format!("{tier}.timestamps"))
}

pub(crate) struct SceneState {
    pub(crate) scene: GpuScene,
    /// The direct light (the direct tier's shader), accumulated while the view holds still.
    pub(crate) direct: Accumulation,
    /// The previous frame without its geometry ([`frame_history`]).
    pub(crate) previous: SceneFrame,
    /// Triangles of the scene the upload was made for; another count means another scene.
    triangle_count: usize,
}

/// What [`SceneState::follow`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Followed {
    /// Nothing changed, or the direct accumulation restarted in its buffers.
    Kept,
    /// The direct accumulation has new buffers: bind groups that name them must be made again.
    Replaced,
}

impl SceneState {
    /// Uploads `input`'s scene for a tier named `tier` rendering `size` images.
    pub(crate) fn upload(
        ctx: &GpuContext,
        tier: &'static str,
        input: &FrameInput,
        pipelines: &PathPipelines,
        size: (u32, u32),
        seed: u64,
        textures: &gi_gpu::TextureOptions,
    ) -> Result<Self, TierError> {
        let frame = input.frame;
        let scene = GpuScene::upload_with(ctx, input.scene, frame, textures)
            .map_err(|e| unavailable(tier, e))?;
        let direct = Accumulation::new(
            ctx,
            pipelines,
            &scene,
            PathUniforms::new(frame, &scene, size, seed),
        );
        Ok(Self {
            scene,
            direct,
            previous: frame_history(frame),
            triangle_count: frame.triangles.len(),
        })
    }

    /// Whether `frame` comes from the scene this state was uploaded for.
    pub(crate) fn holds(&self, frame: &SceneFrame) -> bool {
        self.triangle_count == frame.triangles.len()
            && self.previous.world_from_node.len() == frame.world_from_node.len()
    }

    /// Makes the state follow a new frame of the same scene: an animated frame, a node the
    /// caller moved, or lights edited between frames (a tool moving a light) update the GPU
    /// scene's transforms and
    /// lights; that or a camera move restarts the direct accumulation (the GI keeps its own
    /// history and reprojects it).
    pub(crate) fn follow(
        &mut self,
        ctx: &GpuContext,
        tier: &'static str,
        input: &FrameInput,
        pipelines: &PathPipelines,
        size: (u32, u32),
        seed: u64,
    ) -> Result<Followed, TierError> {
        let frame = input.frame;
        let moved = frame.content_changed_from(&self.previous);
        if self.previous.camera == frame.camera && !moved {
            return Ok(Followed::Kept);
        }
        let mut replaced = false;
        if moved {
            replaced = self
                .scene
                .update(ctx, input.scene, frame)
                .map_err(|e| unavailable(tier, e))?;
        }
        let uniforms = PathUniforms::new(frame, &self.scene, size, seed);
        if replaced {
            let direct = Accumulation::new(ctx, pipelines, &self.scene, uniforms);
            std::mem::replace(&mut self.direct, direct).release(ctx);
            return Ok(Followed::Replaced);
        }
        self.direct.restart(uniforms);
        Ok(Followed::Kept)
    }

    /// Remembers `frame` as the previous frame of the next one.
    pub(crate) fn finish_frame(&mut self, frame: &SceneFrame) {
        self.previous = frame_history(frame);
    }

    pub(crate) fn release(self, ctx: &GpuContext) {
        self.direct.release(ctx);
        self.scene.release(ctx);
    }
}

fn unavailable(tier: &'static str, e: impl std::fmt::Display) -> TierError {
    TierError::Unavailable {
        tier,
        reason: e.to_string(),
    }
}

/// What the next frame needs of `frame`: everything but its triangles and their attributes,
/// which a copy per frame would cost megabytes on large scenes.
pub(crate) fn frame_history(frame: &SceneFrame) -> SceneFrame {
    frame.without_geometry()
}

/// A `size` image read back from an `array<vec4<f32>>` buffer (rgb; stalls the GPU).
pub(crate) fn read_image(ctx: &GpuContext, buffer: &wgpu::Buffer, size: (u32, u32)) -> Image {
    let texels: Vec<[f32; 4]> = ctx.read_buffer(buffer);
    Image {
        width: size.0,
        height: size.1,
        pixels: texels.iter().map(|t| Vec3::from_slice(t)).collect(),
    }
}

/// An image of `size` read back from a buffer of `pack_color64` pixels, its first
/// `width x height` (the buffer may be larger; stalls the GPU).
pub(crate) fn read_packed_image(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    size: (u32, u32),
) -> Image {
    let texels: Vec<[u32; 2]> = ctx.read_buffer(buffer);
    Image {
        width: size.0,
        height: size.1,
        pixels: (texels.iter().take(size.0 as usize * size.1 as usize))
            .map(|&t| gi_cache::packing::unpack_color64(t).truncate())
            .collect(),
    }
}
