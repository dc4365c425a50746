//! What the real-time GI tiers (`mobile`, `pc`) share besides their passes: the frame driver
//! (the [`Tier`](crate::Tier) methods around the frame a tier records, [`real_time_tier!`])
//! and their memory report ([`GiMemory`]).

use gi_cache::{CacheInputs, CacheOutputs, RadianceCache, ScreenInputs};
use gi_gpu::{GBuffer, GBufferInputs, GBufferOutputs, Recorder, Technique};

use crate::scene_state::{self, SceneState};
use crate::tier::FrameInput;

/// GPU memory of a real-time GI tier by what it scales with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GiMemory {
    /// World-space GI structures, fixed by the configuration's coverage: the brick cache (and
    /// the mobile tier's probe volume).
    pub coverage_bytes: u64,
    /// Resolution-dependent GI buffers (the mobile tier's lite G-buffer, screen probes and
    /// half-resolution irradiance; the PC tier's surfaces, reservoirs, irradiance and denoiser
    /// history).
    pub screen_bytes: u64,
    /// What every tier of the product needs besides GI: scene, BVH, G-buffer, direct light,
    /// output and pass timers. The three parts are summed from the buffers' labels, so a buffer
    /// none of them names makes their sum fall short of the tier's total.
    pub frame_bytes: u64,
}

impl GiMemory {
    /// The GI's own memory: coverage plus screen buffers.
    pub fn gi_bytes(&self) -> u64 {
        self.coverage_bytes + self.screen_bytes
    }

    /// The parts of `memory`, the account of the tier named `tier`: coverage is the brick
    /// cache (`cache.*`) and the tier's buffers under `coverage` (label prefixes within
    /// `<tier>.`), screen the rest of `<tier>.*` but its output and timers.
    pub(crate) fn of(memory: &gi_gpu::MemoryReport, tier: &str, coverage: &[&str]) -> Self {
        let own_coverage: u64 = coverage
            .iter()
            .map(|prefix| memory.bytes_with_prefix(prefix))
            .sum();
        let screen_bytes = memory.bytes_with_prefix(&format!("{tier}."))
            - own_coverage
            - scene_state::tier_overhead_bytes(memory, tier);
        Self {
            coverage_bytes: memory.bytes_with_prefix("cache.") + own_coverage,
            screen_bytes,
            frame_bytes: scene_state::frame_bytes(memory, tier),
        }
    }
}

/// Implements [`Tier`](crate::Tier) for a real-time GI tier `$tier` of kind `$kind`: temporal,
/// skinning on the GPU, its frame recorded by `self.record_frame(input)` (which submits all
/// but the last encoder) and ended by `self.timer` on `self.ctx`, waiting for it or not; its
/// image read back from, and its textures made from, `self.output()`. And the accessors both
/// tiers offer: `open` (on a context of its own, for a `$config`), `config`, `context`,
/// `shaders`, `cache` and `memory` (a [`GiMemory`] whose coverage adds the label prefixes
/// `$coverage` to the brick cache).
macro_rules! real_time_tier {
    ($tier:ty, $kind:expr, $config:ty, $coverage:expr) => {
        impl $tier {
            /// Opens the default GPU context and makes the tier on it; `Unavailable` with the
            /// GPU error when there is no adapter.
            pub fn open(
                settings: $crate::tier::TierSettings,
                config: $config,
            ) -> Result<Self, $crate::tier::TierError> {
                let ctx = gi_gpu::GpuContext::new().map_err(|e| {
                    $crate::tier::TierError::Unavailable {
                        tier: $kind.name(),
                        reason: e.to_string(),
                    }
                })?;
                Self::new(settings, config, ctx)
            }

            pub fn config(&self) -> &$config {
                &self.config
            }

            pub fn context(&self) -> &gi_gpu::GpuContext {
                &self.ctx
            }

            /// The shader library the tier compiled its passes from.
            pub fn shaders(&self) -> &gi_gpu::ShaderLibrary {
                &self.shaders
            }

            /// The brick cache the tier reads.
            pub fn cache(&self) -> &gi_cache::RadianceCache {
                &self.cache
            }

            /// The tier's GPU memory now, by what it scales with.
            pub fn memory(&self) -> $crate::realtime::GiMemory {
                $crate::realtime::GiMemory::of(&self.ctx.memory(), $kind.name(), $coverage)
            }
        }

        impl $crate::tier::Tier for $tier {
            fn kind(&self) -> $crate::tier::TierKind {
                $kind
            }

            /// Temporal: the cache and the tier's histories converge over frames.
            fn is_temporal(&self) -> bool {
                true
            }

            fn skins_on_gpu(&self) -> bool {
                true
            }

            fn render(
                &mut self,
                input: &$crate::tier::FrameInput,
            ) -> Result<$crate::tier::FrameOutput, $crate::tier::TierError> {
                let passes = self.advance(input)?;
                let output = self.output().expect("a frame was rendered");
                let image = $crate::scene_state::read_image(output.ctx, output.image, output.size);
                Ok($crate::tier::FrameOutput {
                    image,
                    passes,
                    stats: None,
                })
            }

            /// The frame without reading its image back (it stays in the output buffer).
            fn advance(
                &mut self,
                input: &$crate::tier::FrameInput,
            ) -> Result<Vec<(String, f64)>, $crate::tier::TierError> {
                let encoder = self.record_frame(input)?;
                Ok(self.timer.finish(&self.ctx, encoder).0)
            }

            fn submit(
                &mut self,
                input: &$crate::tier::FrameInput,
            ) -> Result<Vec<$crate::tier::FrameTimings>, $crate::tier::TierError> {
                let encoder = self.record_frame(input)?;
                let reported = self.timer.finish_async(&self.ctx, encoder, input.index);
                Ok($crate::tier::FrameTimings::from_timer(reported))
            }

            fn flush(&mut self) -> Vec<$crate::tier::FrameTimings> {
                $crate::tier::FrameTimings::from_timer(self.timer.drain(&self.ctx))
            }

            /// Everything counted by the tier's own context.
            fn memory_bytes(&self) -> u64 {
                self.ctx.memory().total_bytes()
            }

            fn gpu_context(&self) -> Option<&gi_gpu::GpuContext> {
                Some(&self.ctx)
            }

            fn gpu_output(&self) -> Option<$crate::output::GpuOutput<'_>> {
                self.output()
            }
        }
    };
}

pub(crate) use real_time_tier;

/// The first two steps of every real-time frame: the G-buffer, then the brick cache's update,
/// which corrects the bricks it sees from that G-buffer. Returns both techniques' outputs.
pub(crate) fn record_gbuffer_and_cache<'g, 'c>(
    rec: &mut Recorder<'_>,
    gbuffer: &'g mut GBuffer,
    cache: &'c mut RadianceCache,
    input: &FrameInput,
    state: &SceneState,
) -> (GBufferOutputs<'g>, CacheOutputs<'c>) {
    let (frame, scene) = (input.frame, &state.scene);
    let gbuffer = gbuffer.record(
        rec,
        &GBufferInputs {
            frame,
            scene,
            previous: &state.previous,
        },
    );
    let cache = cache.record(
        rec,
        &CacheInputs {
            scene: input.scene,
            frame,
            gpu_scene: scene,
            camera_position: frame.camera.position,
            gbuffer: Some(ScreenInputs::new(&gbuffer, &frame.camera)),
        },
    );
    (gbuffer, cache)
}
