//! How `<tier>/trace` splits samples into dispatches of bounded cost.
//!
//! A path tracer's work per pixel grows with its samples, and one invocation that loops over
//! all of a frame's samples can run for as long as the caller asks. Two limits end such work
//! silently or fatally:
//!
//! - **Lavapipe's loop limit** (Mesa's software Vulkan, which runs the tests and CI): llvmpipe
//!   ends every loop of an invocation for good once its loops have run 65,535 iterations
//!   together (`LP_MAX_TGSI_LOOP_ITERATIONS`, one counter per 8-wide SIMD batch, so the
//!   slowest lane counts). The sums it leaves behind are short, with no error: 1024 spp of
//!   `cornell-box` in one dispatch came out at about a third of its brightness.
//! - **A watchdog**: a desktop GPU's driver resets the device when one dispatch runs too long
//!   (2 s on Windows, TDR).
//!
//! So every dispatch is planned from a cost estimate in loop iterations
//! (`loop_iterations_per_sample`) and two budgets: [`INVOCATION_LOOP_BUDGET`] caps the
//! samples one invocation adds per dispatch, [`DISPATCH_LOOP_BUDGET`] the work of a whole
//! dispatch, first by fewer samples and then by fewer rows per dispatch ([`DispatchPlan`]).
//! Splitting changes no result: each invocation continues its pixel's sums sample by sample
//! from `sample_offset`, so the sums equal one long render's bit for bit.
//!
//! The estimate is not a bound (a ray's traversal has none below the whole BVH), so the shader
//! checks that its loops ran to completion and counts the invocations whose loops were cut;
//! the path tier then halves the invocation budget and renders the accumulation again.

use gi_gpu::bvh::GpuBvh;
use gi_reference::{RUSSIAN_ROULETTE_MAX_SURVIVAL, RUSSIAN_ROULETTE_START};

use super::PathUniforms;

/// Estimated loop iterations (`loop_iterations_per_sample`) one invocation of
/// `<tier>/trace` may run in one dispatch: half of lavapipe's 65,535, leaving the other half
/// to the estimate's error and to the slowest lane of a SIMD batch. Measured on lavapipe, the
/// bundled scenes run 150 to 360 iterations per sample against estimates of 2,200 to 10,000
/// (paths end well before the 23 vertices the estimate allows), so the budget holds with a
/// wide margin there: 14 samples per dispatch on `cornell-box`, 3 on `open-world`. Higher:
/// fewer, longer dispatches; lower: more dispatches, each with its launch and its tail of slow
/// pixels.
pub const INVOCATION_LOOP_BUDGET: u64 = 1 << 15;

/// Estimated loop iterations one dispatch of `<tier>/trace` may run over all its invocations.
/// An H100 runs about 2.5e12 of them per second (1 spp at 1080p: 2.1 ms on `cornell-box`,
/// 6.6 ms on `open-world`), so a dispatch takes about 3.5 ms there and well under the 2 s of
/// Windows' watchdog on a GPU a hundred times slower. Higher: fewer dispatches on a fast GPU;
/// lower: a slower GPU stays further from its watchdog.
pub const DISPATCH_LOOP_BUDGET: u64 = 1 << 33;

/// Most dispatches one `<tier>/trace` compute pass records: each has a 256-byte uniform slot,
/// so the slots of a pass take at most 256 KiB.
pub(crate) const MAX_DISPATCHES_PER_PASS: u32 = 1024;

/// Pixels per side of a `<tier>/trace` workgroup (`@workgroup_size(8, 8)`); a dispatch covers
/// whole workgroup rows.
pub(crate) const TRACE_TILE: u32 = 8;

/// Iterations of one node visit in `gi::bvh`'s traversal: the traversal loop's own plus the
/// eight child-box tests of `intersect_node`, a loop the compiler may keep.
const NODE_VISIT_ITERATIONS: u64 = 9;

/// Traversal-loop iterations a ray runs per BVH level it descends (node visits and triangle
/// tests together). Measured on lavapipe per ray, slowest lane of each batch: 11 per level on
/// `cornell-box` (3 levels), 10 on `thin-wall`, 6.5 on `atrium`, 5.6 on `glossy`, 7.2 on
/// `open-world` (9 levels), 11 on `dynamic` (through its top level).
const TRAVERSAL_ITERATIONS_PER_LEVEL: u64 = 16;

/// Estimated loop iterations `<tier>/trace` runs for one sample of a pixel (its sample loop,
/// path loop, light loop and every ray's traversal loops):
///
/// `1 + V (1 + L + R T)`, where
///
/// - `V`, path vertices: 1 for the direct tier; for full transport the mean under Russian
///   roulette, which after `RUSSIAN_ROULETTE_START` scatterings keeps a path with probability
///   at most `RUSSIAN_ROULETTE_MAX_SURVIVAL`: at most `3 + 1 / (1 - 0.95) = 23` (and at most
///   `max_depth + 1`). The samples of a dispatch sum to about their mean; one sample's long
///   path is what the invocation budget's margin is for.
/// - `L`, punctual lights: one light-loop iteration each per vertex.
/// - `R`, rays per vertex: the closest hit, a shadow ray per punctual light, one for the
///   emitters and one for the sky when they emit (the direct tier: the first two).
/// - `T`, traversal iterations per ray: [`TRAVERSAL_ITERATIONS_PER_LEVEL`] per level of the
///   BVH (the top level's too when rays go through it), but never more than visiting every
///   node and testing every primitive.
pub(crate) fn loop_iterations_per_sample(
    direct_only: bool,
    uniforms: &PathUniforms,
    bvh: &GpuBvh,
) -> u64 {
    let lights = u64::from(uniforms.light_count);
    let mut levels = u64::from(bvh.depth) + 1;
    if !bvh.traces_static_directly() {
        levels += u64::from(bvh.top_depth) + 1;
    }
    let every_node = NODE_VISIT_ITERATIONS
        * (u64::from(bvh.node_count) + u64::from(bvh.top_node_count))
        + u64::from(bvh.primitive_count)
        + u64::from(bvh.instance_count);
    let traversal = (TRAVERSAL_ITERATIONS_PER_LEVEL * levels).min(every_node.max(1));
    let (vertices, rays) = if direct_only {
        (1, 1 + lights)
    } else {
        let survival = f64::from(RUSSIAN_ROULETTE_MAX_SURVIVAL);
        let after_roulette = (1.0 / (1.0 - survival)).ceil() as u64;
        let mean_vertices = u64::from(RUSSIAN_ROULETTE_START) + after_roulette;
        let vertices = mean_vertices.min(u64::from(uniforms.max_depth) + 1);
        let rays =
            1 + lights + u64::from(uniforms.emitter_count > 0) + u64::from(uniforms.sky_emits != 0);
        (vertices, rays)
    };
    1 + vertices * (1 + lights + rays * traversal)
}

/// How one accumulation's `<tier>/trace` work is cut: `samples` per pixel per dispatch over
/// `rows` image rows. A dispatch's estimated cost is at most [`INVOCATION_LOOP_BUDGET`] (>>
/// the accumulation's shift) per invocation and [`DISPATCH_LOOP_BUDGET`] in all, except that
/// a dispatch always holds at least one sample and one workgroup row, and a pass at most
/// `MAX_DISPATCHES_PER_PASS` dispatches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DispatchPlan {
    /// Samples per pixel one dispatch adds, at least 1.
    pub samples: u32,
    /// Image rows one dispatch covers: a multiple of the 8-pixel workgroup, at least 8.
    pub rows: u32,
}

impl DispatchPlan {
    /// The plan for samples of `iterations_per_sample` ([`loop_iterations_per_sample`]) in an
    /// image of `width` x `height`, with the invocation budget halved `budget_shift` times.
    pub(crate) fn new(
        iterations_per_sample: u64,
        (width, height): (u32, u32),
        budget_shift: u32,
    ) -> Self {
        let per_sample = iterations_per_sample.max(1);
        let invocation_budget = INVOCATION_LOOP_BUDGET >> budget_shift.min(63);
        let row_cost = u64::from(width.max(1)).saturating_mul(per_sample);
        let image_cost = row_cost.saturating_mul(u64::from(height.max(1)));
        // Whole images while their samples fit the dispatch budget; then one sample per
        // dispatch over as many rows as fit.
        let samples = (invocation_budget / per_sample)
            .min(DISPATCH_LOOP_BUDGET / image_cost)
            .clamp(1, u64::from(u32::MAX));
        let image_rows = height.max(1).next_multiple_of(TRACE_TILE);
        let fitting_rows = DISPATCH_LOOP_BUDGET / row_cost.saturating_mul(samples);
        // Beyond MAX_DISPATCHES_PER_PASS bands a pass could not hold one sample.
        let fewest_rows = height
            .div_ceil(MAX_DISPATCHES_PER_PASS)
            .next_multiple_of(TRACE_TILE);
        let rows = (fitting_rows.min(u64::from(image_rows)) as u32 / TRACE_TILE * TRACE_TILE)
            .max(fewest_rows)
            .max(TRACE_TILE);
        Self {
            samples: samples as u32,
            rows,
        }
    }

    /// Dispatches per sample chunk: the bands of `rows` that cover `height`.
    pub(crate) fn bands(&self, height: u32) -> u32 {
        height.max(1).div_ceil(self.rows)
    }

    /// Samples per pixel one compute pass of at most [`MAX_DISPATCHES_PER_PASS`] dispatches
    /// adds: whole chunks of `samples`, every band of each.
    pub(crate) fn samples_per_pass(&self, height: u32) -> u32 {
        let chunks = (MAX_DISPATCHES_PER_PASS / self.bands(height)).max(1);
        self.samples.saturating_mul(chunks)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plan_keeps_each_dispatch_within_both_budgets() {
        for per_sample in [1, 150, 2_232, 9_983, 40_000, 1 << 20] {
            for size in [(1, 1), (16, 12), (160, 120), (1920, 1080), (8192, 8192)] {
                for shift in [0, 3] {
                    let plan = DispatchPlan::new(per_sample, size, shift);
                    assert!(plan.samples >= 1 && plan.rows >= TRACE_TILE);
                    assert_eq!(plan.rows % TRACE_TILE, 0);
                    let invocation = u64::from(plan.samples) * per_sample;
                    if plan.samples > 1 {
                        assert!(invocation <= INVOCATION_LOOP_BUDGET >> shift, "{plan:?}");
                    }
                    let rows = plan.rows.min(size.1.next_multiple_of(TRACE_TILE));
                    let dispatch = invocation * u64::from(size.0) * u64::from(rows);
                    // The fewest rows a dispatch may have, which may be over the budget.
                    let floor = size
                        .1
                        .div_ceil(MAX_DISPATCHES_PER_PASS)
                        .next_multiple_of(TRACE_TILE)
                        .max(TRACE_TILE);
                    if plan.rows > floor {
                        assert!(dispatch <= DISPATCH_LOOP_BUDGET, "{size:?} {plan:?}");
                    }
                    assert!(plan.bands(size.1) <= MAX_DISPATCHES_PER_PASS);
                    assert!(plan.samples_per_pass(size.1) >= plan.samples);
                }
            }
        }
    }

    #[test]
    fn small_images_take_many_samples_per_dispatch_and_large_ones_take_bands() {
        // cornell-box's estimate: a few samples per dispatch, the whole image at once.
        let tiny = DispatchPlan::new(2_232, (16, 12), 0);
        assert_eq!((tiny.samples, tiny.bands(12)), (14, 1));
        // Halving the budget halves the samples, never below one.
        assert_eq!(DispatchPlan::new(2_232, (16, 12), 1).samples, 7);
        assert_eq!(DispatchPlan::new(2_232, (16, 12), 20).samples, 1);
        // One sample of open-world's estimate at 1080p is over the dispatch budget: bands.
        let large = DispatchPlan::new(9_983, (1920, 1080), 0);
        assert_eq!(large.samples, 1);
        assert!(large.bands(1080) > 1, "{large:?}");
    }
}
