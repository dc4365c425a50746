//! Named GPU timer scopes around passes, read back once per frame.
//!
//! A frame records its passes through [`GpuTimer::compute_pass`], each under its pass name
//! (`"bvh/trace"`), and ends with [`GpuTimer::finish`], which submits the frame and returns a
//! [`PassTimings`] table. With timestamp queries each pass writes a GPU timestamp at its
//! beginning and end (`timestamp_writes` on the pass), which costs nothing measurable and
//! keeps the whole frame in one submission. Without them the timer falls back to CPU
//! wall-clock time around a submit-and-wait of each pass alone, which includes submission and
//! driver overhead and serializes the frame: good enough to rank passes, not to quote.

use std::fmt;
use std::sync::Arc;
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

/// Timestamp resources of a timer in [`TimerMode::Gpu`].
struct Queries {
    query_set: wgpu::QuerySet,
    /// Resolved timestamps, two `u64` per scope; tracked, released when the timer drops.
    resolved: wgpu::Buffer,
    capacity: u32,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
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
            Queries {
                query_set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some(&format!("{label}.queries")),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2 * capacity,
                }),
                resolved: ctx.create_buffer(
                    &format!("{label}.timestamps"),
                    2 * capacity as u64 * size_of::<u64>() as u64,
                    wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                ),
                capacity,
                period_ns: ctx.queue.get_timestamp_period() as f64,
            }
        });
        Self {
            label: label.to_owned(),
            queries,
            scopes: Vec::new(),
            cpu_ms: Vec::new(),
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

    /// Submits `encoder` (the rest of the frame), waits for the GPU and returns the time of
    /// every pass recorded since the last `finish`, in recording order. Resets for the next
    /// frame.
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
        let timings = scopes
            .into_iter()
            .enumerate()
            .map(|(i, name)| {
                // A clock that wraps or a driver that reorders would give end < begin: 0 is the
                // honest reading of "too short to see", not a huge unsigned difference.
                let elapsed_ticks = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                (name, elapsed_ticks as f64 * queries.period_ns * 1e-6)
            })
            .collect();
        PassTimings(timings)
    }
}

impl Drop for GpuTimer {
    fn drop(&mut self) {
        if let Some(queries) = &self.queries {
            self.memory.release_buffer(&queries.resolved);
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
