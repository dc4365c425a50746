//! Golden-image tests: every tier renders two bundled scenes at 64 x 48 (the Cornell box, lit
//! by its area light alone, and the atrium, by a sun and a sky through many bounces), twice
//! with two seeds `a` and `b`, against a committed golden reference `r` (`golden/*.exr`, 16384
//! samples per pixel, made by the `gi render` commands in `golden/README.md`).
//!
//! Per pixel and channel (linear radiance times the scene's exposure), `(a - r)(b - r)` is an
//! unbiased estimate of `bias^2 + var(r)`, and `(a - b)^2 / 2` of the render's variance: the
//! two independent renders separate the noise from the bias exactly, with no assumption on the
//! noise's distribution (an 8-bit sRGB split would add the curve's own bias to noisy
//! renders). Their means over the image estimate the squared bias and the noise; the standard
//! error of each mean is measured from the spread of its terms.
//!
//! - The unbiased tiers (`reference`, `path`, and `direct` against the direct-light golden of
//!   the atrium): the squared bias may exceed the golden's own variance (the render's at the
//!   golden's sample count, `noise^2 * spp / 16384`) by five standard errors at most.
//! - The approximating tiers (`mobile`, `pc`): neither the squared bias nor the noise may
//!   exceed what `golden/<scene>.json` recorded by more than five standard errors of the two
//!   estimates together (`GI_GOLDEN_RECORD=1` records them anew).
//!
//! On failure the test writes the render, the golden and their error heat map (PNG) into the
//! target folder and names them.

use std::path::{Path, PathBuf};

use gi_image::Image;
use gi_tiers::{Renderer, TierKind};

/// The bundled scenes with golden references.
const SCENES: [&str; 2] = ["cornell-box", "atrium"];
const SIZE: (u32, u32) = (64, 48);
/// Samples per pixel of the golden references.
const GOLDEN_SPP: f64 = 16384.0;
/// Set to record the approximating tiers' bias and noise into the manifest.
const RECORD_ENV: &str = "GI_GOLDEN_RECORD";

/// How a tier renders its golden test.
struct Case {
    tier: TierKind,
    /// Samples per pixel per frame (the temporal tiers: their direct light's cap).
    spp: u32,
    /// Frames rendered; the last is compared (the temporal tiers: their default warm-up).
    frames: u32,
    /// The golden it is compared with: `golden/<scene>-<golden>.exr`.
    golden: &'static str,
    /// Whether the tier is an unbiased estimator of its golden.
    unbiased: bool,
}

fn case(tier: TierKind) -> Case {
    let temporal = tier.default_warmup() + 1;
    match tier {
        TierKind::Reference | TierKind::Path => Case {
            tier,
            spp: 64,
            frames: 1,
            golden: "reference",
            unbiased: true,
        },
        TierKind::Direct => Case {
            tier,
            spp: 64,
            frames: 1,
            golden: "direct",
            unbiased: true,
        },
        TierKind::Mobile | TierKind::Pc => Case {
            tier,
            spp: 16,
            frames: temporal,
            golden: "reference",
            unbiased: false,
        },
    }
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

fn manifest_path(scene: &str) -> PathBuf {
    golden_dir().join(format!("{scene}.json"))
}

/// The last of `case.frames` frames of the tier on `scene` with `seed`.
fn render(scene: &str, case: &Case, seed: u64) -> Image {
    let scene = gi_scene::load(scene).expect("the bundled scene loads");
    let mut renderer = Renderer::builder(scene)
        .tier(case.tier)
        .size(SIZE.0, SIZE.1)
        .spp(case.spp)
        .seed(seed)
        .build()
        .unwrap_or_else(|e| panic!("{}: {e}", case.tier));
    renderer
        .render_frames(case.frames, None)
        .unwrap_or_else(|e| panic!("{}: {e}", case.tier))
        .image
}

/// Writes the render, the golden and their heat map next to the test binary's temporary
/// folder; returns where.
fn write_failure(
    scene: &str,
    tier: TierKind,
    render: &Image,
    golden: &Image,
    exposure: f32,
) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden-failures");
    std::fs::create_dir_all(&dir).expect("the target folder is writable");
    let base = dir.join(format!("{scene}-{tier}"));
    let actual = base.with_extension("actual.png");
    gi_image::save(render, &actual, exposure).expect("the render saves");
    gi_image::save(golden, base.with_extension("golden.png"), exposure).expect("saves");
    gi_image::write_error_heatmap(render, golden, exposure, base.with_extension("diff.png"))
        .expect("the heat map saves");
    base
}

/// The split of a tier's error against a golden: the means of the terms described in the
/// module docs and their standard errors, in linear radiance times exposure, squared.
#[derive(Clone, Copy, Debug)]
struct Split {
    /// Mean of `(a - r)(b - r)`: squared bias plus the golden's variance.
    bias_sq: f64,
    bias_sq_se: f64,
    /// Mean of `(a - b)^2 / 2`: the render's variance.
    noise_sq: f64,
    noise_sq_se: f64,
}

/// The mean of `terms` and its standard error (sample standard deviation over sqrt(n)).
fn mean_and_se(terms: &[f64]) -> (f64, f64) {
    let n = terms.len() as f64;
    let mean = terms.iter().sum::<f64>() / n;
    let var = terms.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

fn split(golden: &Image, a: &Image, b: &Image, exposure: f32) -> Split {
    let channels = |image: &Image| -> Vec<f64> {
        (image.pixels.iter())
            .flat_map(|p| (*p * exposure).to_array())
            .map(f64::from)
            .collect()
    };
    let (r, a, b) = (channels(golden), channels(a), channels(b));
    let products: Vec<f64> = (0..r.len())
        .map(|i| (a[i] - r[i]) * (b[i] - r[i]))
        .collect();
    let halves: Vec<f64> = (0..r.len()).map(|i| (a[i] - b[i]).powi(2) / 2.0).collect();
    let (bias_sq, bias_sq_se) = mean_and_se(&products);
    let (noise_sq, noise_sq_se) = mean_and_se(&halves);
    Split {
        bias_sq,
        bias_sq_se,
        noise_sq,
        noise_sq_se,
    }
}

/// What the manifest of `scene` recorded for `tier`.
fn recorded(scene: &str, tier: TierKind) -> Split {
    let path = manifest_path(scene);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (GI_GOLDEN_RECORD=1 records it)", path.display()));
    let manifest: serde_json::Value = serde_json::from_str(&text).expect("the manifest is JSON");
    let entry = &manifest["tiers"][tier.name()];
    let field = |name: &str| {
        entry[name]
            .as_f64()
            .unwrap_or_else(|| panic!("golden/{scene}.json lacks tiers.{tier}.{name}"))
    };
    Split {
        bias_sq: field("bias_sq"),
        bias_sq_se: field("bias_sq_se"),
        noise_sq: field("noise_sq"),
        noise_sq_se: field("noise_sq_se"),
    }
}

/// Writes `tier`'s measured split into the manifest of `scene` (record mode).
fn record(scene: &str, tier: TierKind, split: &Split) {
    let path = manifest_path(scene);
    let mut manifest: serde_json::Value = std::fs::read_to_string(&path)
        .ok()
        .and_then(|text| serde_json::from_str(&text).ok())
        .unwrap_or_else(|| serde_json::json!({}));
    manifest["scene"] = scene.into();
    manifest["size"] = serde_json::json!([SIZE.0, SIZE.1]);
    manifest["units"] = "linear radiance times the scene's exposure, squared".into();
    manifest["tiers"][tier.name()] = serde_json::json!({
        "bias_sq": split.bias_sq,
        "bias_sq_se": split.bias_sq_se,
        "noise_sq": split.noise_sq,
        "noise_sq_se": split.noise_sq_se,
    });
    let text = serde_json::to_string_pretty(&manifest).expect("JSON") + "\n";
    std::fs::write(&path, text).expect("the manifest is writable");
    println!("recorded {scene} {tier}: {split:?}");
}

/// Checks `tier` on every golden scene.
fn check(tier: TierKind) {
    let gpu = !matches!(tier, TierKind::Reference | TierKind::Direct);
    if gpu && gi_gpu::GpuContext::new_or_skip(&format!("golden {tier}")).is_none() {
        return;
    }
    // The Cornell box's direct light is its area light seen directly, nothing else: no
    // punctual light, a black sky.
    let scenes = SCENES
        .iter()
        .filter(|s| tier != TierKind::Direct || **s != "cornell-box");
    for scene in scenes {
        check_scene(scene, tier);
    }
}

fn check_scene(scene: &str, tier: TierKind) {
    let case = case(tier);
    let file = golden_dir().join(format!("{scene}-{}.exr", case.golden));
    let golden = gi_image::load(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let exposure = gi_scene::load(scene).expect("loads").exposure;
    let a = render(scene, &case, 1);
    let b = render(scene, &case, 2);
    let split = split(&golden, &a, &b, exposure);
    let (bias_bound, noise_bound) = if case.unbiased {
        let golden_variance = split.noise_sq * f64::from(case.spp) / GOLDEN_SPP;
        (golden_variance + 5.0 * split.bias_sq_se, f64::INFINITY)
    } else if std::env::var_os(RECORD_ENV).is_some() {
        record(scene, tier, &split);
        return;
    } else {
        let then = recorded(scene, tier);
        (
            then.bias_sq + 5.0 * split.bias_sq_se.hypot(then.bias_sq_se),
            then.noise_sq + 5.0 * split.noise_sq_se.hypot(then.noise_sq_se),
        )
    };
    let report = format!(
        "{scene} {tier}: squared bias {:.3e} (bound {:.3e}), noise {:.3e} (bound {:.3e})",
        split.bias_sq, bias_bound, split.noise_sq, noise_bound
    );
    println!("{report}");
    if split.bias_sq > bias_bound || split.noise_sq > noise_bound {
        let written = write_failure(scene, tier, &a, &golden, exposure);
        panic!(
            "{report}; render, golden and heat map: {}.*.png",
            written.display()
        );
    }
}

#[test]
fn reference_matches_its_golden() {
    check(TierKind::Reference);
}

#[test]
fn direct_matches_its_golden() {
    check(TierKind::Direct);
}

#[test]
fn path_matches_its_golden() {
    check(TierKind::Path);
}

#[test]
fn mobile_keeps_its_recorded_error() {
    check(TierKind::Mobile);
}

#[test]
fn pc_keeps_its_recorded_error() {
    check(TierKind::Pc);
}
