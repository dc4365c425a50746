//! Temporal-stability metrics of a GI term, as pure functions on per-pixel data so they can be
//! tested on synthetic images and reused by any temporal tier that exposes its GI, G-buffer
//! depth, motion and dynamic mask (the mobile tier's `MobileFrameData`).
//!
//! - **Flicker**: the mean absolute frame-to-frame change of the GI term's luminance over the
//!   static pixels of two consecutive frames ([`static_change`]), in absolute units and
//!   relative to the mean GI luminance of those pixels. A pixel counts when it is not dynamic
//!   in this frame, its motion vector leads to a pixel inside the previous frame (the nearest
//!   one) that was not dynamic either, both see a surface, and their depths agree within
//!   [`DEPTH_TOLERANCE`] (relative), which rejects disocclusions.
//! - **Settle**: after a lighting change on a still view, the frames until the GI image stays
//!   within `k` times the converged noise of its converged value ([`settle_frames`]): the
//!   converged value is the mean of the last frames of the run ([`mean_image`]), the noise the
//!   mean frame-to-frame change over those frames ([`mean_abs_difference`] of consecutive
//!   frames), and the error of a frame its [`mean_abs_difference`] from the converged value.
//!   Also the frames until the error first reaches the run's error floor ([`error_floor`],
//!   [`frames_to_floor`]), which noise correlated over many frames does not hold back.

use glam::Vec3;

/// Largest relative depth difference between a pixel and its reprojection in the previous
/// frame for both to show the same surface. A camera moving a few centimetres per frame
/// changes depths by far less; a disocclusion changes them by more.
pub const DEPTH_TOLERANCE: f32 = 0.05;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// One frame of a GI term and the G-buffer data that identifies its pixels, row-major.
#[derive(Clone, Copy, Debug)]
pub struct GiFrame<'a> {
    pub width: u32,
    pub height: u32,
    /// Linear radiance of the GI term.
    pub gi: &'a [Vec3],
    /// Pixels showing something an animation moves.
    pub dynamic: &'a [bool],
    /// Previous pixel position minus this pixel's center, in pixels.
    pub motion: &'a [[f32; 2]],
    /// Distance along the pixel's ray, `+inf` for sky.
    pub depth: &'a [f32],
}

/// A frame's GI term and G-buffer data, owned: what a tier's frame data is read into.
#[derive(Clone, Debug)]
pub struct OwnedGiFrame {
    pub width: u32,
    pub height: u32,
    pub gi: Vec<Vec3>,
    pub dynamic: Vec<bool>,
    pub motion: Vec<[f32; 2]>,
    pub depth: Vec<f32>,
}

impl OwnedGiFrame {
    pub fn view(&self) -> GiFrame<'_> {
        GiFrame {
            width: self.width,
            height: self.height,
            gi: &self.gi,
            dynamic: &self.dynamic,
            motion: &self.motion,
            depth: &self.depth,
        }
    }
}

impl<'a> GiFrame<'a> {
    fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    fn check(&self) {
        let n = self.pixels();
        assert!(
            self.gi.len() == n
                && self.dynamic.len() == n
                && self.motion.len() == n
                && self.depth.len() == n,
            "every per-pixel slice must hold {n} entries"
        );
    }
}

/// Sums of a frame-to-frame change over the pixels that counted; add several frames' with
/// [`Change::add`] and read the means.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Change {
    /// Pixels compared.
    pub pixels: u64,
    /// Sum over them of |luminance now - luminance before|.
    pub abs_change_sum: f64,
    /// Sum over them of the luminance now.
    pub luminance_sum: f64,
}

impl Change {
    pub fn add(&mut self, other: Change) {
        self.pixels += other.pixels;
        self.abs_change_sum += other.abs_change_sum;
        self.luminance_sum += other.luminance_sum;
    }

    /// Mean absolute change of the GI luminance per pixel (linear units); 0 without pixels.
    pub fn mean_abs_change(&self) -> f64 {
        if self.pixels == 0 {
            0.0
        } else {
            self.abs_change_sum / self.pixels as f64
        }
    }

    /// Mean GI luminance of the compared pixels.
    pub fn mean_luminance(&self) -> f64 {
        if self.pixels == 0 {
            0.0
        } else {
            self.luminance_sum / self.pixels as f64
        }
    }

    /// The mean change relative to the mean luminance; `None` when the GI is black.
    pub fn relative(&self) -> Option<f64> {
        let mean = self.mean_luminance();
        (mean > 0.0).then(|| self.mean_abs_change() / mean)
    }
}

/// The change of the GI luminance from `previous` to `current` over their static pixels,
/// each pixel compared with the previous frame's pixel nearest to where its motion vector
/// points (see the module docs for which pixels count).
pub fn static_change(current: &GiFrame, previous: &GiFrame, depth_tolerance: f32) -> Change {
    current.check();
    previous.check();
    assert_eq!(
        (current.width, current.height),
        (previous.width, previous.height),
        "frames of different sizes"
    );
    let (width, height) = (current.width as i64, current.height as i64);
    let mut change = Change::default();
    for y in 0..height {
        for x in 0..width {
            let p = (y * width + x) as usize;
            let depth = current.depth[p];
            if current.dynamic[p] || !depth.is_finite() {
                continue;
            }
            let [dx, dy] = current.motion[p];
            let qx = (x as f32 + 0.5 + dx).floor() as i64;
            let qy = (y as f32 + 0.5 + dy).floor() as i64;
            if !(0..width).contains(&qx) || !(0..height).contains(&qy) {
                continue;
            }
            let q = (qy * width + qx) as usize;
            let previous_depth = previous.depth[q];
            if previous.dynamic[q]
                || !previous_depth.is_finite()
                || (previous_depth - depth).abs() > depth_tolerance * depth
            {
                continue;
            }
            let now = luminance(current.gi[p]);
            change.pixels += 1;
            change.abs_change_sum += f64::from((now - luminance(previous.gi[q])).abs());
            change.luminance_sum += f64::from(now);
        }
    }
    change
}

/// Per-pixel luminance of a GI image.
pub fn luminance_image(gi: &[Vec3]) -> Vec<f32> {
    gi.iter().copied().map(luminance).collect()
}

/// Per-pixel mean of equally sized images (of luminance).
pub fn mean_image(frames: &[Vec<f32>]) -> Vec<f32> {
    let Some(first) = frames.first() else {
        return Vec::new();
    };
    let mut sum = vec![0.0f64; first.len()];
    for frame in frames {
        assert_eq!(frame.len(), sum.len(), "frames of different sizes");
        for (s, v) in sum.iter_mut().zip(frame) {
            *s += f64::from(*v);
        }
    }
    let n = frames.len() as f64;
    sum.into_iter().map(|s| (s / n) as f32).collect()
}

/// Mean of |a - b| over the pixels where `mask` is true; 0 when none is.
pub fn mean_abs_difference(a: &[f32], b: &[f32], mask: &[bool]) -> f64 {
    assert!(a.len() == b.len() && a.len() == mask.len(), "sizes differ");
    let (mut sum, mut count) = (0.0f64, 0u64);
    for ((a, b), _) in a.iter().zip(b).zip(mask).filter(|(_, m)| **m) {
        sum += f64::from((a - b).abs());
        count += 1;
    }
    if count == 0 { 0.0 } else { sum / count as f64 }
}

/// Mean of [`mean_abs_difference`] between consecutive frames: the frame-to-frame noise of a
/// converged sequence. 0 for fewer than two frames.
pub fn frame_to_frame_noise(frames: &[Vec<f32>], mask: &[bool]) -> f64 {
    if frames.len() < 2 {
        return 0.0;
    }
    let total: f64 = frames
        .windows(2)
        .map(|pair| mean_abs_difference(&pair[1], &pair[0], mask))
        .sum();
    total / (frames.len() - 1) as f64
}

/// Frames until a sequence settles: `errors[i]` is the error of frame `i + 1` after the change
/// (from the converged value); the result is the least `n` such that frames `n, n + 1, ...`
/// up to the last all have an error of at most `threshold`, so 1 means the first frame after
/// the change was already there. `None` when the last frame is still above the threshold.
pub fn settle_frames(errors: &[f64], threshold: f64) -> Option<usize> {
    let above = errors.iter().rposition(|e| *e > threshold);
    match above {
        None => Some(1),
        Some(last) if last + 1 == errors.len() => None,
        Some(last) => Some(last + 2),
    }
}

/// Fraction of the errors of a settle run's later part at or under its error floor
/// ([`error_floor`]).
pub const FLOOR_QUANTILE: f64 = 0.9;

/// The error floor of a settle run: how far single frames of the settled GI lie from the
/// converged value, the [`FLOOR_QUANTILE`] quantile of the errors from the middle of the run
/// to `2 x converged_frames` before the converged window (`errors` ends where that window
/// begins). Noise that is correlated over many frames (the brick cache's, each brick relit
/// every few dozen frames) keeps single frames further from a short converged mean than the
/// frame-to-frame noise says; the floor measures that. Frames that close to the window share
/// its noise and read low, so they are left out. `None` when that part of the run is empty.
pub fn error_floor(errors: &[f64], converged_frames: usize) -> Option<f64> {
    let end = errors.len().checked_sub(2 * converged_frames)?;
    let start = errors.len() / 2;
    if start >= end {
        return None;
    }
    let mut later = errors[start..end].to_vec();
    later.sort_by(f64::total_cmp);
    let index = ((later.len() - 1) as f64 * FLOOR_QUANTILE).round() as usize;
    Some(later[index])
}

/// Frames until the error first reaches `floor` ([`error_floor`]): frame 1 is the first after
/// the change. `None` when no frame does.
pub fn frames_to_floor(errors: &[f64], floor: f64) -> Option<usize> {
    errors.iter().position(|e| *e <= floor).map(|i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_floor_is_the_later_errors_quantile_and_reached_once() {
        // A decay from 1.0 onto a floor alternating 0.1 and 0.2, then the frames near the
        // converged window, which read low.
        let mut errors: Vec<f64> = (0..20).map(|i| 1.0 / (1.0 + i as f64)).collect();
        errors.extend((0..40).map(|i| if i % 2 == 0 { 0.1 } else { 0.2 }));
        errors.extend([0.01; 8]);
        let floor = error_floor(&errors, 4).unwrap();
        assert_eq!(floor, 0.2);
        // 1 / (1 + i) <= 0.2 from i = 4: the fifth frame.
        assert_eq!(frames_to_floor(&errors, floor), Some(5));
        assert_eq!(frames_to_floor(&[1.0, 0.5], 0.1), None);
        assert_eq!(error_floor(&errors[..10], 4), None);
        assert_eq!(error_floor(&[], 4), None);
    }

    /// A `w x h` still frame of constant depth 2 with no motion and nothing dynamic.
    fn still(width: u32, height: u32, gi: impl Fn(usize) -> f32) -> OwnedGiFrame {
        let n = (width * height) as usize;
        OwnedGiFrame {
            width,
            height,
            gi: (0..n).map(|i| Vec3::splat(gi(i))).collect(),
            dynamic: vec![false; n],
            motion: vec![[0.0; 2]; n],
            depth: vec![2.0; n],
        }
    }

    #[test]
    fn luminance_of_grey_is_its_value_and_weights_green_most() {
        assert!((luminance(Vec3::splat(0.5)) - 0.5).abs() < 1e-6);
        assert!(luminance(Vec3::Y) > luminance(Vec3::X));
        assert!(luminance(Vec3::X) > luminance(Vec3::Z));
    }

    #[test]
    fn a_still_frame_does_not_change_and_a_uniform_step_is_measured_exactly() {
        let before = still(4, 3, |_| 1.0);
        let same = static_change(&before.view(), &before.view(), DEPTH_TOLERANCE);
        assert_eq!(same.pixels, 12);
        assert_eq!(same.mean_abs_change(), 0.0);
        // Alternate +-0.1 around 1: flicker 0.1, relative 0.1.
        let after = still(4, 3, |i| if i % 2 == 0 { 1.1 } else { 0.9 });
        let change = static_change(&after.view(), &before.view(), DEPTH_TOLERANCE);
        assert!((change.mean_abs_change() - 0.1).abs() < 1e-6, "{change:?}");
        assert!((change.relative().unwrap() - 0.1).abs() < 1e-6);
    }

    #[test]
    fn dynamic_sky_and_disoccluded_pixels_are_left_out() {
        let before = still(4, 1, |_| 1.0);
        let mut after = still(4, 1, |_| 5.0);
        after.dynamic[0] = true; // moving object now
        after.depth[2] = f32::INFINITY; // sky
        after.depth[3] = 3.0; // another surface than before (2.0): disocclusion
        let mut before_dynamic = still(4, 1, |_| 1.0);
        before_dynamic.dynamic[1] = true; // moving object before
        let change = static_change(&after.view(), &before.view(), DEPTH_TOLERANCE);
        assert_eq!(change.pixels, 1, "only pixel 1 is static in both");
        assert!((change.mean_abs_change() - 4.0).abs() < 1e-6);
        let change = static_change(&after.view(), &before_dynamic.view(), DEPTH_TOLERANCE);
        assert_eq!(change.pixels, 0);
        assert_eq!(change.relative(), None);
    }

    #[test]
    fn motion_vectors_compare_each_pixel_with_where_it_was() {
        // The image moved one pixel right between the frames: pixel x now shows what pixel
        // x - 1 showed. With its motion vector the change is zero; without it, it is not.
        let before = still(5, 1, |i| i as f32);
        let mut after = still(5, 1, |i| i as f32 - 1.0);
        for m in &mut after.motion {
            *m = [-1.0, 0.0];
        }
        let change = static_change(&after.view(), &before.view(), DEPTH_TOLERANCE);
        assert_eq!(change.pixels, 4, "pixel 0 came from outside the frame");
        assert!(change.mean_abs_change() < 1e-6, "{change:?}");
        let still = still(5, 1, |i| i as f32 - 1.0);
        let wrong = static_change(&still.view(), &before.view(), DEPTH_TOLERANCE);
        assert!((wrong.mean_abs_change() - 1.0).abs() < 1e-6);
        // Sub-pixel motion rounds to the nearest previous pixel.
        for m in &mut after.motion {
            *m = [-0.7, 0.3];
        }
        let change = static_change(&after.view(), &before.view(), DEPTH_TOLERANCE);
        assert!(change.mean_abs_change() < 1e-6, "{change:?}");
    }

    #[test]
    fn changes_add_up_over_frames() {
        let mut total = Change::default();
        total.add(Change {
            pixels: 2,
            abs_change_sum: 1.0,
            luminance_sum: 4.0,
        });
        total.add(Change {
            pixels: 2,
            abs_change_sum: 3.0,
            luminance_sum: 4.0,
        });
        assert_eq!(total.mean_abs_change(), 1.0);
        assert_eq!(total.mean_luminance(), 2.0);
        assert_eq!(total.relative(), Some(0.5));
    }

    #[test]
    fn mean_image_noise_and_masked_difference() {
        let frames = vec![vec![1.0, 10.0], vec![3.0, 10.0], vec![2.0, 10.0]];
        assert_eq!(mean_image(&frames), [2.0, 10.0]);
        let mask = [true, false];
        assert_eq!(mean_abs_difference(&frames[0], &frames[1], &mask), 2.0);
        // |3-1| and |2-3| over the masked pixel.
        assert_eq!(frame_to_frame_noise(&frames, &mask), 1.5);
        assert_eq!(frame_to_frame_noise(&frames, &[false, true]), 0.0);
        assert_eq!(frame_to_frame_noise(&frames[..1], &mask), 0.0);
    }

    #[test]
    fn settling_needs_every_later_frame_under_the_threshold() {
        // A decay that dips under the threshold once (frame 2) before settling at frame 4.
        let errors = [5.0, 0.5, 2.0, 0.9, 0.8, 0.7];
        assert_eq!(settle_frames(&errors, 1.0), Some(4));
        assert_eq!(settle_frames(&[0.1, 0.2], 1.0), Some(1));
        assert_eq!(settle_frames(&[0.1, 2.0], 1.0), None);
        assert_eq!(settle_frames(&[], 1.0), Some(1));
    }
}
