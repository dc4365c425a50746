//! The three sampling strategies estimate the same integral, so they must agree everywhere
//! within their noise. A strategy with a wrong pdf or MIS weight converges elsewhere.

use gi_reference::Strategy;

use crate::common::{Estimate, Rendered, image_mean, region_mean, render, settings, showcase};

/// 4x4-pixel block means of a 32x32 render.
fn blocks(r: &Rendered, c: usize) -> Vec<Estimate> {
    (0..64u32)
        .map(|b| region_mean(r, c, |x, y| x / 4 == b % 8 && y / 4 == b / 8))
        .collect()
}

#[test]
fn strategies_converge_to_the_same_image() {
    let reference = showcase();
    let renders: Vec<(Strategy, Rendered)> = [
        (Strategy::Mis, 512, 1),
        (Strategy::LightOnly, 1024, 2),
        (Strategy::BsdfOnly, 1024, 3),
    ]
    .into_iter()
    .map(|(strategy, spp, seed)| {
        (
            strategy,
            render(&reference, &settings(32, spp, seed, strategy)),
        )
    })
    .collect();
    for (i, (sa, a)) in renders.iter().enumerate() {
        for (sb, b) in &renders[i + 1..] {
            for c in 0..3 {
                let what = format!("{sa:?} vs {sb:?} channel {c}");
                image_mean(a, c)
                    .minus(image_mean(b, c))
                    .assert_near(0.0, 0.0, &what);
                for (k, (ba, bb)) in blocks(a, c).into_iter().zip(blocks(b, c)).enumerate() {
                    ba.minus(bb)
                        .assert_near(0.0, 0.0, &format!("{what} block {k}"));
                }
            }
        }
    }
    // MIS should be the least noisy per sample: compare variance per sample (se^2 * spp).
    let per_sample = |r: &Rendered, spp: f64| image_mean(r, 1).se.powi(2) * spp;
    let mis = per_sample(&renders[0].1, 512.0);
    assert!(mis < per_sample(&renders[1].1, 1024.0) && mis < per_sample(&renders[2].1, 1024.0));
}
