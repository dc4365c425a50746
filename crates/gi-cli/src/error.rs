//! `gi error`: the error of saved renders against a saved reference, with the split into noise
//! and bias when a second render of the same view (another seed) is given.

use std::path::PathBuf;

use clap::Args;

#[derive(Args, Debug)]
pub struct ErrorArgs {
    /// The reference image (.exr for linear metrics; .png is read as 8-bit sRGB).
    #[arg(long)]
    reference: PathBuf,
    /// The render to measure.
    image: PathBuf,
    /// A second render of the same view with another seed: splits the error into noise (how
    /// far one render lies from the renderer's expected image) and bias (how far that expected
    /// image lies from the reference).
    #[arg(long)]
    second: Option<PathBuf>,
    /// Exposure of the 8-bit sRGB encoding, as the scene's (`gi compare` uses the scene's).
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
}

pub fn run(args: &ErrorArgs) -> anyhow::Result<()> {
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        anyhow::bail!(
            "--exposure must be positive and finite, not {}",
            args.exposure
        );
    }
    // The image errors name the file.
    let load = |path: &PathBuf| gi_image::load(path);
    let reference = load(&args.reference)?;
    let image = load(&args.image)?;
    let measured = gi_image::compare(&image, &reference, args.exposure)?;
    outln!("rmse_srgb8     {:.3}", measured.rmse_srgb8);
    outln!("flip           {:.4}", measured.flip);
    outln!("rmse_linear    {:.5}", measured.rmse_linear);
    outln!("rel_mse        {:.5}", measured.rel_mse);
    match gi_image::luminance_bias(&image, &reference)? {
        Some(bias) => outln!("luminance_bias {:+.3}%", 100.0 * bias),
        None => outln!("luminance_bias - (black reference)"),
    }
    if let Some(path) = &args.second {
        let second = load(path)?;
        let split = gi_image::error_split_srgb8(&reference, &image, &second, args.exposure)?;
        outln!("second_rmse    {:.3}", split.rmse_b);
        outln!("noise_srgb8    {:.3}", split.noise);
        outln!("bias_srgb8     {:.3}", split.bias);
    }
    Ok(())
}
