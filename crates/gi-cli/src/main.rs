//! `gi`: render glTF scenes at a global-illumination tier, compare tiers against a path-traced
//! reference, and manage the bundled scenes.

/// `println!` that ends quietly when the reader has gone (`gi ... | head`): the rest of the
/// output is dropped, the work still finishes and writes its files. Other write errors are
/// returned.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::quiet_broken_pipe({
            use std::io::Write as _;
            writeln!(std::io::stdout().lock(), $($arg)*)
        })?
    };
}

mod compare;
mod debug_cache;
mod error;
mod render;
mod tiers;

use std::{
    path::{Path, PathBuf},
    process::ExitCode,
};

use clap::{Args, Parser, Subcommand};
use gi_tiers::pc::denoise::AtrousKernel;
use gi_tiers::pc::{HitLights, TraceMode};
use gi_tiers::{MobileConfig, PcConfig, TierKind};
use tiers::{CameraChoice, RenderRequest, ScreenProbes};

/// Real-time global illumination tiers, measured against a path-traced reference.
#[derive(Parser, Debug)]
#[command(name = "gi", version, about, long_about = None)]
struct Cli {
    /// Log more (-v: info, -vv: debug). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render one image of a scene at one tier.
    Render(render::RenderArgs),
    /// Render several tiers and report their error against a cached path-traced reference.
    Compare(compare::CompareArgs),
    /// Render what the brick radiance cache holds for a scene (albedo, normals, radiance,
    /// occupancy per level) and report its size.
    DebugCache(debug_cache::DebugCacheArgs),
    /// Measure a saved render against a saved reference; with a second render of another seed,
    /// split its error into noise and bias.
    Error(error::ErrorArgs),
    /// List the bundled scenes.
    Scenes,
    /// Load a scene and report its content and BVH build time.
    Info {
        /// Bundled scene name or path to a .gltf/.glb file.
        scene: String,
        /// Lighting file (JSON: sun, sky, exposure, default camera) applied to the scene; without
        /// it, `<stem>.lighting.json` beside the scene file is used when it exists.
        #[arg(long, value_name = "FILE")]
        lighting: Option<PathBuf>,
    },
    /// Write the bundled scenes as glTF (.gltf + .bin) into a folder.
    GenerateScenes {
        /// Destination folder (default: the bundled scene folder, `scenes/`).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// Options shared by every command that renders.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Image width in pixels (1..=16384).
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Image height in pixels (1..=16384).
    #[arg(long, default_value_t = 240)]
    height: u32,
    /// Frames to simulate; the last one is measured and written. Scene time advances by the
    /// scene's `frame_time_s` per frame.
    #[arg(long, default_value_t = 1)]
    frames: u32,
    /// Which camera to look through.
    #[arg(long, value_enum, default_value_t = CameraChoice::Default)]
    camera: CameraChoice,
    /// Random seed; the same seed gives the same image.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Still warm-up frames before the frames: each shows frame 0 again without advancing
    /// scene time, so temporal tiers converge before the measurement (default: each tier's
    /// own, 63 for mobile so the measured frame is the 64th of a still view, 0 for the
    /// others). Tiers without history skip it; each warm-up frame costs a frame.
    #[arg(long)]
    warmup: Option<u32>,
    /// Screen probes of the mobile tier: hsgi (a fresh probe per 64-pixel tile each frame,
    /// the default) or smartgi (16-pixel tiles, a quarter of them traced per frame, the
    /// rest reprojected). Only the mobile tier reads it.
    #[arg(long, value_enum)]
    screen_probes: Option<ScreenProbes>,
    /// Switch one stage of the PC tier off, for ablations: spatial, shadow, multi-sample,
    /// svgf, restir (all reuse off: one sample per trace pixel, the same denoiser), specular
    /// (no specular rays: the smooth surfaces reflect the irradiance over pi) or
    /// rough-specular (the rough surfaces reflect the irradiance over pi, not the diffuse
    /// samples weighted by their lobe) or gradients (no temporal gradients: the denoiser's
    /// histories follow a change of the light at their own rate); temporal and boiling are off
    /// by default. Only the PC tier reads it.
    #[arg(long, value_name = "STAGE", conflicts_with = "pc_with")]
    pc_without: Option<String>,
    /// Switch one stage of the PC tier on that is off by default, for ablations: temporal
    /// (temporal reuse with its boiling filter). Only the PC tier reads it.
    #[arg(long, value_name = "STAGE")]
    pc_with: Option<String>,
    /// Full-resolution pixels per trace pixel of the PC tier along each axis: 2 (the default)
    /// traces a quarter of the pixels, 1 all of them. Only the PC tier reads it.
    #[arg(long, value_name = "N")]
    pc_trace_scale: Option<u32>,
    /// Roughness below which the PC tier traces specular rays (default 0.4, HSGI's); rougher
    /// surfaces reflect the diffuse irradiance. Only the PC tier reads it.
    #[arg(long, value_name = "R")]
    pc_specular_roughness: Option<f32>,
    /// Roughness above which the PC tier's reflection of the rough surfaces (the diffuse
    /// samples weighted by the lobe) blends linearly to the irradiance over pi, reached at 1
    /// (default 1: never; HSGI blends from 0.8). Only the PC tier reads it.
    #[arg(long, value_name = "R")]
    pc_specular_diffuse_from: Option<f32>,
    /// What the PC tier's diffuse rays read: rays (the default: whole BVH rays) or probes
    /// (HSGI's trace-probe mode: a short BVH ray, then the brick cache's radiance beyond it).
    /// Only the PC tier reads it.
    #[arg(long, value_name = "MODE", value_parser = parse_trace_mode)]
    pc_trace_mode: Option<TraceMode>,
    /// The PC denoiser's a-trous kernel: 3x3 (the linear B-spline, the default) or 5x5
    /// (SVGF's B3-spline: 25 taps instead of 9, twice the reach per iteration). Only the PC
    /// tier reads it.
    #[arg(long, value_name = "KERNEL", value_parser = parse_atrous_kernel)]
    pc_atrous_kernel: Option<AtrousKernel>,
    /// The PC denoiser's a-trous iterations (default 5, at most 8; 0: no spatial filter).
    /// Only the PC tier reads it.
    #[arg(long, value_name = "N")]
    pc_atrous_iterations: Option<u32>,
    /// Where the PC tier's diffuse rays' hits get the sun's and the other punctual lights'
    /// direct light: rays (a shadow ray per light at each hit, the default) or cache (the brick
    /// cache's direct light: no rays, shadows as sharp as its voxels). Only the PC tier reads
    /// it.
    #[arg(long, value_name = "FROM", value_parser = parse_hit_lights)]
    pc_hit_lights: Option<HitLights>,
    /// Half-width, in standard deviations of the noisy input's 3 x 3 neighbourhood, of the box
    /// the PC denoiser clamps its short history into before each blend (0: off, the default):
    /// the history then follows a lighting change within a frame or two. Only the PC tier
    /// reads it.
    #[arg(long, value_name = "SIGMA")]
    pc_short_clamp_sigma: Option<f32>,
    /// Bricks the brick cache's pool holds (default 12288, about 2.8 KB each). A scene whose
    /// geometry needs more (the cache warns) loses its farthest bricks from the GI. Only the
    /// mobile and PC tiers read it.
    #[arg(long, value_name = "N")]
    cache_pool_bricks: Option<u32>,
}

/// Largest accepted image side, and largest pixel count (a 16K x 4K image).
const MAX_SIDE: u32 = 16384;
const MAX_PIXELS: u64 = 1 << 26;
const MAX_SPP: u32 = 1 << 20;
const MAX_FRAMES: u32 = 1_000_000;

impl ViewArgs {
    /// Checks sizes and builds the request; errors read as one line.
    fn request(&self, spp: u32) -> anyhow::Result<RenderRequest> {
        for (name, value) in [("width", self.width), ("height", self.height)] {
            anyhow::ensure!(
                (1..=MAX_SIDE).contains(&value),
                "--{name} {value} is out of range (1..={MAX_SIDE})"
            );
        }
        let pixels = u64::from(self.width) * u64::from(self.height);
        anyhow::ensure!(
            pixels <= MAX_PIXELS,
            "{}x{} is {pixels} pixels, more than the {MAX_PIXELS} allowed",
            self.width,
            self.height
        );
        anyhow::ensure!(
            (1..=MAX_SPP).contains(&spp),
            "--spp {spp} is out of range (1..={MAX_SPP})"
        );
        anyhow::ensure!(
            (1..=MAX_FRAMES).contains(&self.frames),
            "--frames {} is out of range (1..={MAX_FRAMES})",
            self.frames
        );
        if let Some(warmup) = self.warmup {
            anyhow::ensure!(
                warmup <= MAX_FRAMES,
                "--warmup {warmup} is out of range (0..={MAX_FRAMES})"
            );
        }
        Ok(RenderRequest {
            width: self.width,
            height: self.height,
            spp,
            frames: self.frames,
            seed: self.seed,
            camera: self.camera,
            warmup: self.warmup,
            mobile: self.mobile_config()?,
            pc: self.pc_config()?,
            pc_without: self.pc_without.clone(),
            pc_with: self.pc_with.clone(),
        })
    }
}

impl ViewArgs {
    /// The PC tier's configuration from `--pc-without` or `--pc-with`, `--pc-trace-scale`,
    /// `--pc-specular-roughness`, `--pc-specular-diffuse-from`, `--pc-trace-mode`,
    /// `--pc-atrous-kernel`, `--pc-atrous-iterations`, `--pc-hit-lights` and
    /// `--pc-short-clamp-sigma`.
    fn pc_config(&self) -> anyhow::Result<PcConfig> {
        let mut config = match (&self.pc_without, &self.pc_with) {
            (Some(stage), _) => PcConfig::without(stage).map_err(anyhow::Error::msg)?,
            (None, Some(stage)) => PcConfig::with(stage).map_err(anyhow::Error::msg)?,
            (None, None) => PcConfig::default(),
        };
        if let Some(scale) = self.pc_trace_scale {
            config.trace_scale = scale;
        }
        if let Some(roughness) = self.pc_specular_roughness {
            config.specular.max_roughness = roughness;
        }
        if let Some(roughness) = self.pc_specular_diffuse_from {
            config.specular.diffuse_from = roughness;
        }
        if let Some(mode) = self.pc_trace_mode {
            config.trace_mode = mode;
        }
        if let Some(kernel) = self.pc_atrous_kernel {
            config.denoise.atrous_kernel = kernel;
        }
        if let Some(iterations) = self.pc_atrous_iterations {
            config.denoise.atrous_iterations = iterations;
        }
        if let Some(hit_lights) = self.pc_hit_lights {
            config.hit_lights = hit_lights;
        }
        if let Some(sigma) = self.pc_short_clamp_sigma {
            config.denoise.short_clamp_sigma = sigma;
        }
        if let Some(bricks) = self.cache_pool_bricks {
            config.cache.pool_bricks = bricks;
        }
        config.validate().map_err(anyhow::Error::msg)?;
        Ok(config)
    }

    /// The mobile tier's configuration from `--screen-probes` and `--cache-pool-bricks`.
    fn mobile_config(&self) -> anyhow::Result<MobileConfig> {
        let mut config = ScreenProbes::mobile_config(self.screen_probes);
        if let Some(bricks) = self.cache_pool_bricks {
            config.cache.pool_bricks = bricks;
        }
        config.validate().map_err(anyhow::Error::msg)?;
        Ok(config)
    }
}

fn parse_trace_mode(s: &str) -> Result<TraceMode, String> {
    s.parse()
}

fn parse_atrous_kernel(s: &str) -> Result<AtrousKernel, String> {
    s.parse()
}

fn parse_hit_lights(s: &str) -> Result<HitLights, String> {
    s.parse()
}

fn parse_tier(s: &str) -> Result<TierKind, String> {
    s.parse().map_err(|e: gi_tiers::TierError| e.to_string())
}

fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .init();
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => render::run(&args),
        Command::Compare(args) => compare::run(&args),
        Command::DebugCache(args) => debug_cache::run(&args),
        Command::Error(args) => error::run(&args),
        Command::Scenes => {
            let dir = gi_scene::bundled_scene_dir();
            for (name, description) in gi_scene::BUNDLED_SCENES {
                outln!("{name:<12} {description}");
            }
            match dir {
                Some(dir) => outln!("\nscene files: {}", dir.display()),
                None => outln!("\nscene files: not found (scenes are generated in memory)"),
            }
            Ok(())
        }
        Command::Info { scene, lighting } => info(&scene, lighting.as_deref()),
        Command::GenerateScenes { out } => {
            let dir = out
                .or_else(gi_scene::bundled_scene_dir)
                .unwrap_or_else(|| PathBuf::from("scenes"));
            for path in gi_scene::generate::write_all(&dir)? {
                outln!("wrote {}", path.display());
            }
            Ok(())
        }
    }
}

/// Loads a scene by bundled name or path with its lighting file (`lighting`, else the one
/// beside the scene file), logging what the importer ignored and whether nothing lights it.
pub fn load_scene(name: &str, lighting: Option<&Path>) -> anyhow::Result<gi_scene::Scene> {
    let loaded = gi_scene::load_with_lighting(name, lighting)?;
    for warning in &loaded.warnings {
        tracing::warn!("{name}: {warning}");
    }
    if let Some(file) = &loaded.lighting {
        tracing::info!("{name}: lighting from {}", file.display());
    }
    Ok(loaded.scene)
}

/// `gi info`: what the renderers will see of a scene at time zero.
fn info(name: &str, lighting: Option<&Path>) -> anyhow::Result<()> {
    let scene = load_scene(name, lighting)?;
    let frame = scene.evaluate(0.0, None);
    let bvh = gi_scene::SceneBvh::build(&frame.triangles);
    let emissive = scene
        .materials
        .iter()
        .filter(|m| m.emissive != glam::Vec3::ZERO)
        .count();
    outln!("scene        {}", scene.name);
    outln!("nodes        {}", scene.nodes.len());
    outln!("triangles    {}", frame.triangles.len());
    outln!(
        "materials    {} ({emissive} emissive)",
        scene.materials.len()
    );
    outln!("textures     {}", scene.textures.len());
    outln!("lights       {} punctual", frame.lights.len());
    outln!("cameras      {}", scene.cameras.len());
    outln!("animated     {}", scene.is_animated());
    outln!("camera path  {}", scene.camera_path.is_some());
    outln!("sky          {:?}", scene.sky);
    outln!("exposure     {}", scene.exposure);
    outln!(
        "bvh          CWBVH, {} nodes, built in {:.2} ms",
        bvh.node_count(),
        bvh.build_time.as_secs_f64() * 1e3
    );
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // One line: the error and its causes, outermost first; a cause that an outer
            // message already quotes (as `ImageError` quotes its I/O error) is not repeated.
            let mut line = String::new();
            for cause in error.chain().map(|c| c.to_string()) {
                if line.contains(&cause) {
                    continue;
                }
                if !line.is_empty() {
                    line.push_str(": ");
                }
                line.push_str(&cause);
            }
            eprintln!("error: {line}");
            ExitCode::FAILURE
        }
    }
}

/// A write to standard output that failed only because its reader is gone counts as done.
fn quiet_broken_pipe(result: std::io::Result<()>) -> std::io::Result<()> {
    match result {
        Err(error) if error.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}
