//! Named GPU timer scopes around passes, read back once per frame.
//!
//! A frame records its passes through [`GpuTimer::compute_pass`], each under its pass name
//! (`"bvh/trace"`), and ends with [`GpuTimer::finish`], which submits the frame and returns a
//! [`PassTimings`] table. With timestamp queries each pass writes a GPU timestamp at its
//! beginning and end (`timestamp_writes` on the pass), which costs nothing measurable and
//! keeps the whole frame in one submission. Without them the timer falls back to CPU
//! wall-clock time around a submit-and-wait of each pass alone, which includes submission and
//! driver overhead and serializes the frame: good enough to rank passes, not to quote.
//!
//! [`GpuTimer::finish`] waits for the GPU, so the CPU's work on the next frame cannot overlap
//! the GPU's on this one. A frame loop ends its frames with [`GpuTimer::finish_async`]
//! instead: it copies the frame's timestamps to a readback buffer of its own and returns at
//! once, with the timings of the earlier frames the GPU has finished. At most
//! [`FRAMES_IN_FLIGHT`] frames are submitted and not yet reported; a frame that would exceed
//! that waits for the oldest. [`GpuTimer::drain`] waits for them all.

use std::collections::VecDeque;
use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use crate::GpuContext;
use crate::memory::MemoryTracker;

/// How a [`GpuTimer`] measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimerMode {
    /// GPU timestamp queries at the start and end of each pass.
    Gpu,
    /// CPU wall-clock time around submitting each pass alone and waiting for it.
    Cpu,
}

impl TimerMode {
    /// How the passes were timed, for the heading of a benchmark table.
    pub fn describe(self) -> &'static str {
        match self {
            TimerMode::Gpu => "GPU timestamps",
            TimerMode::Cpu => "CPU wall-clock per pass",
        }
    }
}

/// Frames [`GpuTimer::finish_async`] lets the GPU hold, submitted and not yet reported:
/// while the GPU runs one frame the CPU records the next, and no further (the CPU never runs
/// more than a frame ahead, so the frame it shows is never older than that).
pub const FRAMES_IN_FLIGHT: usize = 2;

/// Timestamp resources of a timer in [`TimerMode::Gpu`].
struct Queries {
    query_set: wgpu::QuerySet,
    /// Resolved timestamps, two `u64` per scope; tracked, released when the timer drops.
    resolved: wgpu::Buffer,
    /// One mappable copy of `resolved` per frame in flight ([`GpuTimer::finish_async`]);
    /// tracked, released when the timer drops.
    readback: Vec<wgpu::Buffer>,
    capacity: u32,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

/// [`InFlight::mapped`]: the map callback has not run yet.
const MAP_PENDING: u8 = 0;
/// [`InFlight::mapped`]: the readback buffer is mapped.
const MAP_DONE: u8 = 1;
/// [`InFlight::mapped`]: mapping failed (a lost device).
const MAP_FAILED: u8 = 2;

/// A frame [`GpuTimer::finish_async`] submitted and has not reported yet.
struct InFlight {
    /// The caller's tag for the frame.
    tag: u32,
    scopes: Vec<String>,
    /// The readback buffer its timestamps were copied to; `None` for a frame without scopes.
    slot: Option<usize>,
    /// One of `MAP_PENDING`, `MAP_DONE`, `MAP_FAILED`, set by the map callback.
    mapped: Arc<AtomicU8>,
    submission: wgpu::SubmissionIndex,
}

/// Times named passes of one frame at a time. Create one per renderer (its resources are
/// reused every frame) with room for the most passes a frame records.
pub struct GpuTimer {
    label: String,
    queries: Option<Queries>,
    /// Scope names of the frame being recorded, in order.
    scopes: Vec<String>,
    /// Milliseconds per scope in [`TimerMode::Cpu`].
    cpu_ms: Vec<f64>,
    /// Frames of [`GpuTimer::finish_async`] not reported yet, oldest first.
    in_flight: VecDeque<InFlight>,
    memory: Arc<MemoryTracker>,
}

impl GpuTimer {
    /// A timer labeled `label` for up to `max_scopes` passes per frame: GPU timestamps when the
    /// context supports them, CPU timing otherwise.
    pub fn new(ctx: &GpuContext, label: &str, max_scopes: u32) -> Self {
        Self::with_mode(ctx, label, max_scopes, TimerMode::Gpu)
    }

    /// A timer in `mode`; [`TimerMode::Gpu`] still falls back to CPU timing when the context
    /// has no timestamp queries. Asking for [`TimerMode::Cpu`] is for comparing the two.
    pub fn with_mode(ctx: &GpuContext, label: &str, max_scopes: u32, mode: TimerMode) -> Self {
        let queries = (mode == TimerMode::Gpu && ctx.supports_timestamps()).then(|| {
            let capacity = max_scopes.max(1);
            let bytes = 2 * capacity as u64 * size_of::<u64>() as u64;
            Queries {
                query_set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some(&format!("{label}.queries")),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2 * capacity,
                }),
                resolved: ctx.create_buffer(
                    &format!("{label}.timestamps"),
                    bytes,
                    wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                ),
                readback: (0..FRAMES_IN_FLIGHT)
                    .map(|_| {
                        ctx.create_buffer(
                            &format!("{label}.timestamps_readback"),
                            bytes,
                            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        )
                    })
                    .collect(),
                capacity,
                period_ns: ctx.queue.get_timestamp_period() as f64,
            }
        });
        Self {
            label: label.to_owned(),
            queries,
            scopes: Vec::new(),
            cpu_ms: Vec::new(),
            in_flight: VecDeque::new(),
            memory: ctx.memory.clone(),
        }
    }

    /// How this timer measures.
    pub fn mode(&self) -> TimerMode {
        if self.queries.is_some() {
            TimerMode::Gpu
        } else {
            TimerMode::Cpu
        }
    }

    /// Records a compute pass labeled and timed as `name`; `record` sets pipelines and
    /// dispatches. In CPU mode the commands recorded so far in `encoder` are submitted first
    /// and `encoder` is replaced by a fresh one, so command order is kept.
    ///
    /// # Panics
    /// If the frame already holds `max_scopes` GPU-timed passes.
    pub fn compute_pass<R>(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        name: &str,
        record: impl FnOnce(&mut wgpu::ComputePass<'_>) -> R,
    ) -> R {
        let index = self.scopes.len() as u32;
        self.scopes.push(name.to_owned());
        match &self.queries {
            Some(queries) => {
                assert!(
                    index < queries.capacity,
                    "timer {:?} has room for {} passes per frame; raise max_scopes",
                    self.label,
                    queries.capacity
                );
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(name),
                    timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                        query_set: &queries.query_set,
                        beginning_of_pass_write_index: Some(2 * index),
                        end_of_pass_write_index: Some(2 * index + 1),
                    }),
                });
                record(&mut pass)
            }
            None => {
                let earlier = std::mem::replace(encoder, ctx.create_encoder(&self.label));
                ctx.submit_and_wait(earlier);
                let mut pass_encoder = ctx.create_encoder(name);
                let result = {
                    let mut pass = pass_encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(name),
                        timestamp_writes: None,
                    });
                    record(&mut pass)
                };
                let start = Instant::now();
                ctx.submit_and_wait(pass_encoder);
                self.cpu_ms.push(start.elapsed().as_secs_f64() * 1e3);
                result
            }
        }
    }

    /// Submits the commands of `encoder` (part of a frame) without waiting and without
    /// ending the frame: its passes are reported with the rest of the frame by the next
    /// [`GpuTimer::finish`] or [`GpuTimer::finish_async`]. For a frame recorded in several
    /// encoders, where a later one needs `queue.write_buffer` data written after the earlier
    /// one was recorded. In CPU mode it waits, as every pass does there.
    pub fn submit(&mut self, ctx: &GpuContext, encoder: wgpu::CommandEncoder) {
        if self.queries.is_some() {
            ctx.queue.submit([encoder.finish()]);
        } else {
            ctx.submit_and_wait(encoder);
        }
    }

    /// Submits `encoder` (the rest of the frame), waits for the GPU and returns the time of
    /// every pass recorded since the last `finish`, in recording order. Resets for the next
    /// frame. Frames of [`GpuTimer::finish_async`] still in flight stay there: the next
    /// `finish_async` or [`GpuTimer::drain`] reports them.
    pub fn finish(&mut self, ctx: &GpuContext, mut encoder: wgpu::CommandEncoder) -> PassTimings {
        let scopes = std::mem::take(&mut self.scopes);
        let cpu_ms = std::mem::take(&mut self.cpu_ms);
        let Some(queries) = &self.queries else {
            ctx.submit_and_wait(encoder);
            return PassTimings(scopes.into_iter().zip(cpu_ms).collect());
        };
        if scopes.is_empty() {
            ctx.submit_and_wait(encoder);
            return PassTimings(Vec::new());
        }
        let count = 2 * scopes.len() as u32;
        encoder.resolve_query_set(&queries.query_set, 0..count, &queries.resolved, 0);
        ctx.queue.submit([encoder.finish()]);
        let ticks: Vec<u64> = ctx.read_buffer(&queries.resolved);
        queries.timings(scopes, &ticks)
    }

    /// Ends the frame as [`GpuTimer::finish`] does without waiting for the GPU: submits
    /// `encoder` with a copy of the frame's timestamps and returns, tagged with the `tag`
    /// each frame was given (a frame index), the timings of the frames the GPU has finished
    /// since the last call, oldest first; this frame's come from a later call. Waits only
    /// when [`FRAMES_IN_FLIGHT`] frames would be in flight, for the oldest. In CPU mode every
    /// pass has already waited: the frame is reported at once.
    pub fn finish_async(
        &mut self,
        ctx: &GpuContext,
        mut encoder: wgpu::CommandEncoder,
        tag: u32,
    ) -> Vec<(u32, PassTimings)> {
        if self.queries.is_none() {
            return vec![(tag, self.finish(ctx, encoder))];
        }
        let mut done = self.collect(ctx, FRAMES_IN_FLIGHT - 1);
        let scopes = std::mem::take(&mut self.scopes);
        let queries = self.queries.as_ref().expect("GPU mode");
        let mapped = Arc::new(AtomicU8::new(MAP_PENDING));
        let slot = (!scopes.is_empty()).then(|| {
            (0..FRAMES_IN_FLIGHT)
                .find(|&slot| self.in_flight.iter().all(|f| f.slot != Some(slot)))
                .expect("collect left a readback buffer free")
        });
        if let Some(slot) = slot {
            let count = 2 * scopes.len() as u32;
            let bytes = u64::from(count) * size_of::<u64>() as u64;
            encoder.resolve_query_set(&queries.query_set, 0..count, &queries.resolved, 0);
            encoder.copy_buffer_to_buffer(&queries.resolved, 0, &queries.readback[slot], 0, bytes);
        }
        let submission = ctx.queue.submit([encoder.finish()]);
        match slot {
            Some(slot) => {
                let flag = mapped.clone();
                queries.readback[slot].map_async(wgpu::MapMode::Read, .., move |result| {
                    let state = if result.is_ok() { MAP_DONE } else { MAP_FAILED };
                    flag.store(state, Ordering::Release);
                });
            }
            None => mapped.store(MAP_DONE, Ordering::Release),
        }
        self.in_flight.push_back(InFlight {
            tag,
            scopes,
            slot,
            mapped,
            submission,
        });
        done.extend(self.collect(ctx, FRAMES_IN_FLIGHT));
        done
    }

    /// Waits for every frame of [`GpuTimer::finish_async`] still in flight and returns their
    /// timings, oldest first.
    pub fn drain(&mut self, ctx: &GpuContext) -> Vec<(u32, PassTimings)> {
        self.collect(ctx, 0)
    }

    /// Frames of [`GpuTimer::finish_async`] submitted and not reported yet.
    pub fn frames_in_flight(&self) -> usize {
        self.in_flight.len()
    }

    /// Reports the frames in flight the GPU has finished, oldest first, waiting for the
    /// oldest until at most `keep` are left.
    fn collect(&mut self, ctx: &GpuContext, keep: usize) -> Vec<(u32, PassTimings)> {
        let mut done = Vec::new();
        if self.in_flight.is_empty() {
            return done;
        }
        // Runs the map callbacks of whatever has finished.
        if let Err(err) = ctx.device.poll(wgpu::PollType::Poll) {
            tracing::error!(%err, "polling the GPU failed");
        }
        while let Some(oldest) = self.in_flight.front() {
            if oldest.mapped.load(Ordering::Acquire) == MAP_PENDING {
                if self.in_flight.len() <= keep {
                    break;
                }
                let wait = wgpu::PollType::Wait {
                    submission_index: Some(oldest.submission.clone()),
                    timeout: None,
                };
                if let Err(err) = ctx.device.poll(wait) {
                    tracing::error!(%err, "waiting for the GPU failed");
                }
                if oldest.mapped.load(Ordering::Acquire) == MAP_PENDING {
                    // The submission is done, so its map callback has run unless the device
                    // is lost: report the frame as failed rather than wait forever.
                    oldest.mapped.store(MAP_FAILED, Ordering::Release);
                }
                continue;
            }
            let frame = self.in_flight.pop_front().expect("front exists");
            done.push((frame.tag, self.read_frame(frame)));
        }
        done
    }

    /// The timings of `frame`, whose readback has been mapped (or failed: every pass reads
    /// NaN, never a made-up time), and unmaps its buffer for reuse.
    fn read_frame(&self, frame: InFlight) -> PassTimings {
        let queries = self
            .queries
            .as_ref()
            .expect("only GPU mode has frames in flight");
        let failed = || PassTimings(frame.scopes.iter().map(|n| (n.clone(), f64::NAN)).collect());
        let Some(slot) = frame.slot else {
            return PassTimings(Vec::new());
        };
        let buffer = &queries.readback[slot];
        if frame.mapped.load(Ordering::Acquire) != MAP_DONE {
            tracing::error!(timer = %self.label, "a frame's timestamps could not be read back");
            return failed();
        }
        let bytes = 2 * frame.scopes.len() as u64 * size_of::<u64>() as u64;
        let ticks: Vec<u64> = match buffer.get_mapped_range(..bytes) {
            Ok(view) => bytemuck::pod_collect_to_vec(&view),
            Err(err) => {
                tracing::error!(timer = %self.label, %err, "reading a frame's timestamps failed");
                buffer.unmap();
                return failed();
            }
        };
        buffer.unmap();
        queries.timings(frame.scopes, &ticks)
    }
}

impl Queries {
    /// Milliseconds per scope from the resolved `ticks` (two per scope).
    fn timings(&self, scopes: Vec<String>, ticks: &[u64]) -> PassTimings {
        PassTimings(
            scopes
                .into_iter()
                .enumerate()
                .map(|(i, name)| {
                    // A clock that wraps or a driver that reorders would give end < begin: 0
                    // is the honest reading of "too short to see", not a huge unsigned
                    // difference.
                    let elapsed_ticks = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                    (name, elapsed_ticks as f64 * self.period_ns * 1e-6)
                })
                .collect(),
        )
    }
}

impl Drop for GpuTimer {
    fn drop(&mut self) {
        if let Some(queries) = &self.queries {
            self.memory.release_buffer(&queries.resolved);
            for buffer in &queries.readback {
                self.memory.release_buffer(buffer);
            }
        }
    }
}

/// Milliseconds per named pass of one frame, in recording order. A name may repeat when a
/// pass runs several times in a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassTimings(pub Vec<(String, f64)>);

impl PassTimings {
    /// Milliseconds of all passes named `name` in the frame, or `None` if none ran.
    pub fn get(&self, name: &str) -> Option<f64> {
        let mut matches = self.0.iter().filter(|(n, _)| n == name).peekable();
        matches.peek()?;
        Some(matches.map(|(_, ms)| ms).sum())
    }

    /// Milliseconds of all passes of the frame.
    pub fn total_ms(&self) -> f64 {
        self.0.iter().map(|(_, ms)| ms).sum()
    }

    /// Per pass name, the median over `frames` of that pass's time in a frame (all its runs
    /// summed, as [`PassTimings::get`]); the product's timing statistic, robust to the odd frame
    /// that hits a clock change or a driver stall. Every pass that ran in any frame is listed,
    /// in order of first appearance, and a frame it did not run in counts 0 ms for it: a pass
    /// that runs only in some frames (a re-voxelization when something moved, direct light
    /// re-traced after a change) shows what it costs a typical frame instead of vanishing or
    /// counting as if it ran every frame.
    pub fn median(frames: &[PassTimings]) -> PassTimings {
        let mut names: Vec<&str> = Vec::new();
        for (name, _) in frames.iter().flat_map(|frame| &frame.0) {
            if !names.contains(&name.as_str()) {
                names.push(name);
            }
        }
        let rows = names
            .into_iter()
            .map(|name| {
                let mut samples: Vec<f64> =
                    frames.iter().map(|f| f.get(name).unwrap_or(0.0)).collect();
                samples.sort_by(f64::total_cmp);
                let mid = samples.len() / 2;
                let median = if samples.len() % 2 == 1 {
                    samples[mid]
                } else {
                    0.5 * (samples[mid - 1] + samples[mid])
                };
                (name.to_owned(), median)
            })
            .collect();
        PassTimings(rows)
    }
}

/// A table of pass names and milliseconds, with the total last.
impl fmt::Display for PassTimings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let width = self
            .0
            .iter()
            .map(|(n, _)| n.len())
            .max()
            .unwrap_or(0)
            .max(5);
        writeln!(f, "{:<width$}  {:>10}", "pass", "ms")?;
        for (name, ms) in &self.0 {
            writeln!(f, "{name:<width$}  {ms:>10.3}")?;
        }
        writeln!(f, "{:<width$}  {:>10.3}", "total", self.total_ms())
    }
}

#[cfg(test)]
mod tests {
    use super::PassTimings;

    fn frame(passes: &[(&str, f64)]) -> PassTimings {
        PassTimings(passes.iter().map(|(n, ms)| (n.to_string(), *ms)).collect())
    }

    #[test]
    fn the_median_lists_passes_of_any_frame_and_counts_their_absence_as_zero() {
        let frames = [
            frame(&[("a", 1.0), ("b", 2.0), ("b", 1.0)]),
            frame(&[("a", 3.0), ("c", 5.0)]),
            frame(&[("a", 2.0), ("b", 4.0), ("c", 6.0)]),
        ];
        let median = PassTimings::median(&frames);
        // "c" is missing from the first frame and still listed; "b" ran twice in frame 0.
        assert_eq!(median, frame(&[("a", 2.0), ("b", 3.0), ("c", 5.0)]));
        // A pass that ran in one frame of three has a median of 0: a typical frame lacks it.
        let rare = [
            frame(&[("a", 1.0)]),
            frame(&[("a", 1.0), ("rare", 9.0)]),
            frame(&[("a", 1.0)]),
        ];
        assert_eq!(
            PassTimings::median(&rare),
            frame(&[("a", 1.0), ("rare", 0.0)])
        );
        assert_eq!(PassTimings::median(&[]), PassTimings::default());
    }
}
