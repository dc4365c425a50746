//! What a render computes ([`Mode`], [`Strategy`], [`RenderSettings`]) and how it can be refused
//! ([`RenderError`]).

/// Largest accepted image side in pixels.
pub const MAX_SIDE: u32 = 16_384;

/// Largest accepted pixel count (`width * height`), 2^26 (e.g. 8192 x 8192): the accumulation
/// buffers use 48 bytes per pixel, so this caps them at 3 GiB.
pub const MAX_PIXELS: u64 = 1 << 26;

/// Which light transport a render computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Full global illumination: unbiased path tracing with next-event estimation, up to
    /// [`RenderSettings::max_depth`] bounces. The ground truth of every tier's error.
    #[default]
    Full,
    /// Direct light only, the product's "None" GI baseline: emission and sky seen by camera
    /// rays, plus every punctual light at the first hit with an exact shadow ray and the full
    /// BRDF. Emissive triangles and the sky light nothing, and nothing bounces. Apart from the
    /// pixel jitter it is deterministic, so few samples suffice (they only anti-alias).
    Direct,
}

/// How [`Mode::Full`] finds light. All three converge to the same image; they differ only in
/// noise, which is what the tests use them for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Strategy {
    /// Next-event estimation and BRDF sampling combined with the power heuristic (default; the
    /// lowest noise in almost every scene).
    #[default]
    Mis,
    /// Next-event estimation only: emission and sky found by BRDF-sampled rays are ignored
    /// except on camera rays. Noisy on glossy surfaces; exists to test the light sampling.
    LightOnly,
    /// BRDF sampling only for emissive triangles and the sky (found with weight 1). Punctual
    /// lights are still sampled explicitly, since no ray can hit them. Noisy with small emitters;
    /// exists to test the BRDF sampling.
    BsdfOnly,
}

/// Everything a render depends on besides the scene and camera. The image is a pure function of
/// (scene, camera, `width`, `height`, `spp`, `seed`, `mode`, `strategy`, `max_depth`): never of
/// thread count, scheduling or how samples were split into passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RenderSettings {
    /// Image width in pixels, `1..=MAX_SIDE`.
    pub width: u32,
    /// Image height in pixels, `1..=MAX_SIDE`; `width * height <= MAX_PIXELS`.
    pub height: u32,
    /// Samples (camera paths) per pixel, at least 1. Noise falls as `1/sqrt(spp)` while time
    /// grows linearly; [`Mode::Direct`] needs only enough to anti-alias edges.
    pub spp: u32,
    /// Seed of every pixel's random numbers; different seeds give independent noise.
    pub seed: u64,
    pub mode: Mode,
    /// Ignored by [`Mode::Direct`].
    pub strategy: Strategy,
    /// Most scattering events per path (0: emitters and sky seen directly, 1: direct lighting,
    /// 2: one indirect bounce...). Russian roulette ends most paths much earlier, so a high
    /// limit costs little; a low one darkens bright interreflections (bias). Ignored by
    /// [`Mode::Direct`].
    pub max_depth: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 640,
            height: 360,
            spp: 256,
            seed: 0,
            mode: Mode::Full,
            strategy: Strategy::Mis,
            max_depth: 64,
        }
    }
}

impl RenderSettings {
    /// Checks the image size and sample count.
    pub fn validate(&self) -> Result<(), RenderError> {
        let (width, height) = (self.width, self.height);
        if width == 0 || height == 0 {
            return Err(RenderError::EmptyImage { width, height });
        }
        if width > MAX_SIDE || height > MAX_SIDE || self.pixel_count() > MAX_PIXELS {
            return Err(RenderError::ImageTooLarge { width, height });
        }
        if self.spp == 0 {
            return Err(RenderError::ZeroSamples);
        }
        Ok(())
    }

    /// `width * height`.
    pub fn pixel_count(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

/// Why a render was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    #[error("image size {width}x{height} has no pixels")]
    EmptyImage { width: u32, height: u32 },
    #[error(
        "image size {width}x{height} is too large (at most {MAX_SIDE} per side and {MAX_PIXELS} pixels)"
    )]
    ImageTooLarge { width: u32, height: u32 },
    #[error("samples per pixel must be at least 1")]
    ZeroSamples,
}
