//! The shape of every GPU technique: an object that owns its pipelines, buffers and
//! histories and records its passes of a frame through a [`Recorder`] with
//! [`Technique::record`], from typed inputs to typed outputs.
//!
//! A tier's frame is then a list of named steps, each taking what earlier ones produced:
//!
//! ```text
//! let gbuffer = gbuffer.record(&mut rec, &GBufferInputs { frame, scene, .. });
//! let screen = ScreenInputs::new(&gbuffer, &frame.camera);
//! let cache = cache.record(&mut rec, &CacheInputs { gbuffer: Some(screen), .. });
//! restir.record(&mut rec, &RestirInputs { gbuffer, cache: &cache.buffers.bind_group, .. });
//! denoiser.record(&mut rec, &DenoiseInputs { config: &denoise });
//! ```
//!
//! Outputs borrow the technique that made them (the buffers it owns), so they live until the
//! technique records again, and the borrow checker sees which step reads which.

use crate::{GpuContext, GpuTimer};

/// Where a frame's passes are recorded: the device, the frame's command encoder and the timer
/// that names and times each pass.
pub struct Recorder<'a> {
    /// The device the passes run on.
    pub ctx: &'a GpuContext,
    timer: &'a mut GpuTimer,
    encoder: wgpu::CommandEncoder,
}

impl<'a> Recorder<'a> {
    /// A recorder of a frame whose first encoder is labeled `label`.
    pub fn new(ctx: &'a GpuContext, timer: &'a mut GpuTimer, label: &str) -> Self {
        Self {
            ctx,
            timer,
            encoder: ctx.create_encoder(label),
        }
    }

    /// Records a compute pass named and timed as `name` ([`GpuTimer::compute_pass`]).
    pub fn compute_pass<R>(
        &mut self,
        name: &str,
        record: impl FnOnce(&mut wgpu::ComputePass<'_>) -> R,
    ) -> R {
        self.timer
            .compute_pass(self.ctx, &mut self.encoder, name, record)
    }

    /// The encoder, for commands other than compute passes (copies, clears).
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        &mut self.encoder
    }

    /// The device, the timer and the encoder at once, for code written against them.
    pub fn parts(&mut self) -> (&'a GpuContext, &mut GpuTimer, &mut wgpu::CommandEncoder) {
        (self.ctx, self.timer, &mut self.encoder)
    }

    /// Submits what is recorded so far as part of the frame ([`GpuTimer::submit`]) and goes on
    /// in a fresh encoder labeled `label`: passes recorded after this see what the queue
    /// wrote in between (uniforms written by a later step).
    pub fn submit(&mut self, label: &str) {
        let done = std::mem::replace(&mut self.encoder, self.ctx.create_encoder(label));
        self.timer.submit(self.ctx, done);
    }

    /// The encoder holding the rest of the frame, which the caller ends the timer's frame
    /// with ([`GpuTimer::finish`] or [`GpuTimer::finish_async`]).
    pub fn into_encoder(self) -> wgpu::CommandEncoder {
        self.encoder
    }
}

/// A GPU technique: it owns its pipelines, its buffers and its histories, and each frame
/// records its passes from `Inputs` (what earlier steps produced, borrowed) to `Outputs`
/// (what it produced, borrowed from it).
pub trait Technique {
    /// What one frame reads.
    type Inputs<'i>;
    /// What one frame produced: buffers the technique owns, and what the caller decides on.
    type Outputs<'o>
    where
        Self: 'o;

    /// Records this frame's passes into `rec`.
    fn record<'o>(
        &'o mut self,
        rec: &mut Recorder<'_>,
        inputs: &Self::Inputs<'_>,
    ) -> Self::Outputs<'o>;
}
