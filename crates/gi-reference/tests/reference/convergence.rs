//! The error against a converged render falls as 1/sqrt(spp), and the per-pixel standard
//! errors the other tests rely on predict it.

use gi_reference::Strategy;

use crate::common::{Estimate, K_SIGMA, Rendered, render, settings, showcase};

/// Mean over pixels of `value(pixel)`, with its standard error (pixels are independent).
fn pixel_mean(values: impl Iterator<Item = f64>) -> Estimate {
    let values: Vec<f64> = values.collect();
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Estimate {
        mean,
        se: (variance / n).sqrt(),
    }
}

/// Mean squared error against `reference`, summed over channels.
fn mse(r: &Rendered, reference: &Rendered) -> Estimate {
    let pairs = r.image.pixels.iter().zip(&reference.image.pixels);
    pixel_mean(pairs.map(|(a, b)| (*a - *b).as_dvec3().length_squared()))
}

/// The accumulator's own estimate of the same: mean variance of a pixel's mean.
fn predicted_mse(r: &Rendered) -> Estimate {
    pixel_mean(
        r.standard_error
            .pixels
            .iter()
            .map(|se| se.as_dvec3().length_squared()),
    )
}

#[test]
fn error_falls_as_one_over_root_spp() {
    let scene = showcase();
    let size = 24;
    let reference = render(&scene, &settings(size, 1024, 999, Strategy::Mis));
    let reference_noise = predicted_mse(&reference).mean;
    let mut corrected = Vec::new();
    for (seed, spp) in [4u32, 16, 64].into_iter().enumerate() {
        let r = render(&scene, &settings(size, spp, seed as u64, Strategy::Mis));
        let measured = mse(&r, &reference);
        // E[(x - ref)^2] = var(x) + var(ref): the standard errors must predict the error.
        let predicted = predicted_mse(&r);
        measured
            .minus(predicted)
            .assert_near(reference_noise, 0.0, &format!("MSE at {spp} spp"));
        corrected.push(Estimate {
            mean: measured.mean - reference_noise,
            se: measured.se,
        });
    }
    // Each 4x more samples divides the (reference-corrected) MSE by 4: RMSE ~ spp^-1/2. The
    // log of a ratio has standard error sqrt(rel_a^2 + rel_b^2).
    let relative =
        |a: Estimate, b: Estimate| ((a.se / a.mean).powi(2) + (b.se / b.mean).powi(2)).sqrt();
    for pair in corrected.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let log_ratio = (a.mean / b.mean).ln();
        let tolerance = K_SIGMA * relative(a, b);
        assert!(
            (log_ratio - 4f64.ln()).abs() <= tolerance,
            "MSE ratio {:.2} for 4x samples (expected 4, log tolerance {tolerance:.2})",
            log_ratio.exp()
        );
    }
    // Slope of log RMSE against log spp over the 16x range.
    let (first, last) = (corrected[0], corrected[2]);
    let slope = -(first.mean / last.mean).ln() / 16f64.ln() / 2.0;
    let tolerance = K_SIGMA * relative(first, last) / 16f64.ln() / 2.0;
    assert!(
        (slope + 0.5).abs() <= tolerance,
        "RMSE slope {slope:.3} (tolerance {tolerance:.3})"
    );
}
