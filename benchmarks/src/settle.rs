//! Waiting for the GPU's clock before timing frames.
//!
//! A GPU left idle sits at a low clock and climbs only under load; a frame of a few
//! milliseconds that waits for its timestamps leaves it idle often enough that the climb takes
//! a second or more. Frames timed during the climb read slow (on the H100, a process that
//! started timing at once read 1.7 times the cost it read at full clock). [`settle`] renders
//! still warm-up frames until their GI time stops falling, and [`GiSpread`] reports how much
//! the measured frames varied, so a clock dip during the measurement shows in the table.

use std::time::Instant;

use gi_gpu::PassTimings;
use gi_tiers::{Renderer, TierError, TierKind};

use crate::suite::median;

/// Frames per window whose median GI time is compared with the previous window's.
const WINDOW: usize = 16;
/// Two windows whose medians differ by at most this fraction are steady.
const STEADY_TOLERANCE: f64 = 0.02;
/// The longest wait, as a multiple of the shortest.
const MAX_FACTOR: f64 = 5.0;

/// What [`settle`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settled {
    /// Still warm-up frames it rendered.
    pub frames: u32,
    /// Wall-clock seconds they took.
    pub seconds: f64,
    /// Whether the last two windows' median GI times agreed; false when it gave up.
    pub steady: bool,
}

/// Sum of the GI passes (`kind`'s [`TierKind::is_gi_pass`]) of one frame.
pub fn gi_ms(kind: TierKind, passes: &[(String, f64)]) -> f64 {
    passes
        .iter()
        .filter(|(name, _)| kind.is_gi_pass(name))
        .map(|(_, ms)| ms)
        .sum()
}

/// Renders still warm-up frames ([`Renderer::warm_up_frame`]) for at least `min_seconds` and
/// until the median GI time of the last [`WINDOW`] frames is within 2% of the window's before,
/// giving up after 5 times `min_seconds`. `min_seconds` 0 renders nothing.
pub fn settle(
    renderer: &mut Renderer,
    kind: TierKind,
    min_seconds: f64,
) -> Result<Settled, TierError> {
    let mut settled = Settled {
        frames: 0,
        seconds: 0.0,
        steady: true,
    };
    if min_seconds <= 0.0 {
        return Ok(settled);
    }
    let start = Instant::now();
    let mut previous: Option<f64> = None;
    loop {
        let mut window: Vec<f64> = Vec::with_capacity(WINDOW);
        for _ in 0..WINDOW {
            window.push(gi_ms(kind, &renderer.warm_up_frame()?));
        }
        settled.frames += WINDOW as u32;
        settled.seconds = start.elapsed().as_secs_f64();
        let current = median(&window);
        let steady = previous.is_some_and(|p| (current - p).abs() <= STEADY_TOLERANCE * p);
        if steady && settled.seconds >= min_seconds {
            return Ok(settled);
        }
        if settled.seconds >= MAX_FACTOR * min_seconds {
            settled.steady = false;
            return Ok(settled);
        }
        previous = Some(current);
    }
}

/// How the measured frames' GI time spread: 10th percentile, median and 90th percentile of
/// the per-frame sums. The table's GI figure is the sum of the per-pass medians, which is
/// close to this median; a wide p10-p90 range means the clock (or something else) moved
/// during the measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GiSpread {
    pub p10: f64,
    pub median: f64,
    pub p90: f64,
}

impl GiSpread {
    /// Over `frames` (at least one), GI passes as `kind` counts them.
    pub fn of(kind: TierKind, frames: &[PassTimings]) -> Self {
        let mut sums: Vec<f64> = frames.iter().map(|f| gi_ms(kind, &f.0)).collect();
        sums.sort_by(f64::total_cmp);
        let median = median(&sums);
        let at = |q: f64| sums[((sums.len() - 1) as f64 * q).round() as usize];
        Self {
            p10: at(0.1),
            median,
            p90: at(0.9),
        }
    }

    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({ "p10": self.p10, "median": self.median, "p90": self.p90 })
    }
}

/// Wall-clock time of a frame in the two ways a frame loop can run ([`time_frames`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameWall {
    /// Median wall-clock ms of a frame that waits for its GPU work
    /// ([`Renderer::advance_frame`]): the CPU's work, the submission and the GPU's, in series.
    pub waiting_ms: f64,
    /// Median wall-clock ms of a frame submitted without waiting ([`Renderer::submit_frame`]):
    /// the CPU records it while the GPU runs the one before, so it costs about the larger of
    /// the two.
    pub pipelined_ms: f64,
    /// Median GI ms (GPU timestamps) of the pipelined frames.
    pub pipelined_gi_ms: f64,
}

impl FrameWall {
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "waiting_ms": self.waiting_ms,
            "pipelined_ms": self.pipelined_ms,
            "pipelined_gi_ms": self.pipelined_gi_ms,
        })
    }
}

/// Renders `frames` frames (at least one) that each wait for the GPU, returning their
/// passes, then as many more submitted without waiting, timing every frame's call on the
/// wall clock both ways. The pipelined frames come second, so neither pays the renderer's
/// first frames; the GPU's work is the same (their GI time is reported to show it).
pub fn time_frames(
    renderer: &mut Renderer,
    kind: TierKind,
    frames: u32,
) -> Result<(Vec<PassTimings>, FrameWall), TierError> {
    let mut timings = Vec::new();
    let mut waiting = Vec::new();
    for _ in 0..frames.max(1) {
        let start = Instant::now();
        timings.push(PassTimings(renderer.advance_frame(None)?));
        waiting.push(start.elapsed().as_secs_f64() * 1e3);
    }
    let mut pipelined = Vec::new();
    let mut reported = Vec::new();
    for _ in 0..frames.max(1) {
        let start = Instant::now();
        reported.extend(renderer.submit_frame(None)?);
        pipelined.push(start.elapsed().as_secs_f64() * 1e3);
    }
    reported.extend(renderer.flush_frames());
    let gi: Vec<f64> = reported.iter().map(|f| gi_ms(kind, &f.passes)).collect();
    let wall = FrameWall {
        waiting_ms: median(&waiting),
        pipelined_ms: median(&pipelined),
        pipelined_gi_ms: median(&gi),
    };
    Ok((timings, wall))
}

impl Settled {
    /// The table's words for it.
    pub fn describe(&self) -> String {
        if self.frames == 0 {
            return "no clock settling".to_owned();
        }
        format!(
            "{} more to settle the GPU clock in {:.1} s{}",
            self.frames,
            self.seconds,
            if self.steady {
                ""
            } else {
                ", NOT steady: timings may be low-clock"
            }
        )
    }

    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "frames": self.frames,
            "seconds": self.seconds,
            "steady": self.steady,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(gi: f64, other: f64) -> PassTimings {
        PassTimings(vec![
            ("pc/trace".to_owned(), gi),
            ("gbuffer".to_owned(), other),
        ])
    }

    #[test]
    fn the_spread_counts_only_gi_passes() {
        let frames: Vec<PassTimings> = (1..=11).map(|i| frame(i as f64, 100.0)).collect();
        let spread = GiSpread::of(TierKind::Pc, &frames);
        assert_eq!(spread.median, 6.0);
        assert_eq!(spread.p10, 2.0);
        assert_eq!(spread.p90, 10.0);
        let one = GiSpread::of(TierKind::Pc, &[frame(3.0, 1.0)]);
        assert_eq!((one.p10, one.median, one.p90), (3.0, 3.0, 3.0));
    }

    #[test]
    fn settling_for_no_time_renders_nothing() {
        let Some(_) = gi_gpu::GpuContext::new_or_skip("settle::no_time") else {
            return;
        };
        let scene = gi_scene::load("cornell-box").unwrap();
        let mut renderer = crate::pc::pc_renderer(
            scene,
            (16, 12),
            gi_tiers::PcConfig::default(),
            gi_tiers::CameraMode::Default,
        )
        .unwrap();
        let none = settle(&mut renderer, TierKind::Pc, 0.0).unwrap();
        assert_eq!(none.frames, 0);
        assert_eq!(renderer.warm_up_frames(), 0);
        // A short wait renders whole windows of still frames and counts them as warm-up.
        let some = settle(&mut renderer, TierKind::Pc, 1e-3).unwrap();
        assert!(some.frames >= 2 * WINDOW as u32 || !some.steady, "{some:?}");
        assert_eq!(some.frames % WINDOW as u32, 0);
        assert_eq!(renderer.warm_up_frames(), some.frames);
        assert!(some.seconds > 0.0);
    }
}
