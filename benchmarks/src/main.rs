//! `gi-bench`: the product's benchmarks.
//!
//! Without a subcommand it runs the suite ([`suite`]): every scene x tier against a cached CPU
//! reference, written as results.json, results.md, plots and contact sheets into `--out`, with
//! an optional regression check against an earlier results.json:
//!
//! ```text
//! gi-bench [--scenes cornell-box,atrium] [--tiers reference,direct,path,mobile,pc] \
//!     [--size 1280x720] [--frames 16] [--warmup N] [--repeats 3] [--reference-spp 256] \
//!     [--out bench-out] [--baseline old/results.json [--fail-on-regression]]
//! ```
//!
//! The subcommands each measure one subsystem, print a table and can write JSON:
//!
//! ```text
//! gi-bench rays --scene open-world --rays 1048576 --json rays.json
//! gi-bench cache-rays --scene atrium --rays 65536 --json cache-rays.json
//! gi-bench cache-update --scene atrium --frames 16 --json cache-update.json
//! gi-bench deform --rings 256 --sides 64 --frames 30 --rays 262144 --json deform.json
//! gi-bench path --scene atrium --width 1920 --height 1080 --spp 4 --json path.json
//! gi-bench mobile --scenes cornell-box,atrium,thin-wall --size 1920x1080 --frames 64 \
//!     --screen-probes both --json mobile.json
//! gi-bench stability --size 320x240 --screen-probes both --json stability.json
//! gi-bench stability --tier pc --size 320x240 --json pc-stability.json
//! gi-bench churn --tier pc --rounds 100 --size 640x360 --sharing dedicated --json churn.json
//! gi-bench pc --scenes cornell-box,atrium,glossy --size 1920x1080 --frames 64 \
//!     --variants default,with-temporal,spatial,shadow,multi-sample,svgf,restir,specular,rough-specular --json pc.json
//! ```

/// `print!` that ends quietly when the reader has gone (`gi-bench ... | head`): the rest of
/// the output is dropped, the benchmark still finishes and writes its files. Other write
/// errors are returned.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::quiet_broken_pipe({
            use std::io::Write as _;
            write!(std::io::stdout().lock(), $($arg)*)
        })?
    };
}

mod cache_rays;
mod cache_update;
mod churn;
mod deform;
mod mobile;
mod path;
mod pc;
mod rays;
mod realtime;
mod settle;
mod stability;
mod suite;
mod tier_stability;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "gi-bench",
    version,
    about = "Benchmarks of the GI product: without a subcommand, the scenes x tiers suite",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    suite: suite::SuiteArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Ray tracing throughput of the GPU BVH traversal against the CPU's (obvhs, all cores):
    /// primary (camera), shadow (towards lights) and incoherent (diffuse bounce) rays.
    Rays {
        /// Bundled scene name or glTF path.
        #[arg(long, default_value = "cornell-box")]
        scene: String,
        /// Rays per kind. More rays fill a large GPU better; lavapipe wants few.
        #[arg(long, default_value_t = 1 << 20)]
        rays: usize,
        /// Timed repetitions (after one warm-up); the median is reported.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Which static meshes get a bottom level shared by their copies: `auto` (the tiers'
        /// rule), `off` (all static geometry flattened) or `all` (every mesh placed twice).
        #[arg(long, default_value = "auto", value_parser = rays::parse_sharing)]
        mesh_sharing: gi_gpu::bvh::MeshSharing,
        /// Seconds of tracing before timing, while the GPU's clock climbs.
        #[arg(long, default_value_t = 1.0)]
        settle_s: f64,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Deforming geometry in the GPU BVH: per-frame CPU and GPU cost of refitting a skinned
    /// tube's level against building it again, and the rays per second through each.
    Deform {
        /// Rings of the tube (2 x rings x sides triangles).
        #[arg(long, default_value_t = 256)]
        rings: u32,
        /// Vertices around each ring.
        #[arg(long, default_value_t = 64)]
        sides: u32,
        /// Animation frames followed (at the scene's 30 frames per second; the 30th is the
        /// most bent).
        #[arg(long, default_value_t = 30)]
        frames: u32,
        /// Rays traced at the last frame, aimed at the tube.
        #[arg(long, default_value_t = 1 << 18)]
        rays: usize,
        /// Timed repetitions of the trace; the median is reported.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Seconds of tracing before each timed trace, while the GPU's clock climbs.
        #[arg(long, default_value_t = 1.0)]
        settle_s: f64,
        /// Static triangles around the tube (a grid below it, as a level around an animated
        /// character): what a frame's evaluation keeps rather than evaluates again.
        #[arg(long, default_value_t = 0)]
        level_triangles: u32,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Ray throughput of the brick cache's hierarchical DDA against the GPU BVH on the same
    /// camera and diffuse bounce rays (the cache filled on the CPU around the camera).
    CacheRays {
        /// Bundled scene name or glTF path.
        #[arg(long, default_value = "cornell-box")]
        scene: String,
        /// Camera rays (and at most as many bounce rays). Lavapipe wants few.
        #[arg(long, default_value_t = 1 << 20)]
        rays: usize,
        /// Timed repetitions (after one warm-up); the median is reported.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Cost of one frame of the brick cache with its lighting along the scene's camera path:
    /// the fill frame's pass times, then the median per pass over the remaining frames.
    CacheUpdate {
        /// Bundled scene name or glTF path.
        #[arg(long, default_value = "cornell-box")]
        scene: String,
        /// Frames along the camera path; the first fills the cache, the rest are the steady
        /// state. Lavapipe wants few.
        #[arg(long, default_value_t = 16)]
        frames: u32,
        /// Override of the pool size in bricks (default: the cache's default).
        #[arg(long)]
        pool_bricks: Option<u32>,
        /// Override of the number of clipmap levels.
        #[arg(long)]
        levels: Option<u32>,
        /// Override of the level-0 voxel edge in meters.
        #[arg(long)]
        voxel_size: Option<f32>,
        /// Override of the triangle list entries binning scans per frame
        /// (`voxelize_scan_per_frame`).
        #[arg(long)]
        voxelize_scan: Option<u32>,
        /// Override of the triangle list entries per `cache/voxelize` part
        /// (`voxelize_part_triangles`).
        #[arg(long)]
        voxelize_part: Option<u32>,
        /// Also ray-cast a G-buffer each frame and correct visible bricks from it
        /// (`cache/screen_inject`).
        #[arg(long)]
        screen_inject: bool,
        /// G-buffer size for `--screen-inject`, WIDTHxHEIGHT.
        #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
        size: (u32, u32),
        /// Seconds of G-buffer frames before the fill frame for the GPU's clock to climb
        /// (with `--screen-inject`; 0 times at once).
        #[arg(long, default_value_t = 1.0, value_parser = parse_settle)]
        settle_s: f64,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Samples per second of the GPU path tracer: median `path/trace` time over still frames.
    Path {
        /// Bundled scene name or glTF path.
        #[arg(long, default_value = "cornell-box")]
        scene: String,
        #[arg(long, default_value_t = 1920)]
        width: u32,
        #[arg(long, default_value_t = 1080)]
        height: u32,
        /// Samples per pixel per frame. More samples per dispatch amortize launch overhead but
        /// lengthen each frame; lavapipe wants a tiny image and 1.
        #[arg(long, default_value_t = 1)]
        spp: u32,
        /// Timed frames (after one warm-up); the median is reported.
        #[arg(long, default_value_t = 5)]
        frames: u32,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Cost and memory of the mobile tier per scene and screen-probe mode: a still warm-up,
    /// then the median per pass over the measured frames, the GI sum (cache/* + mobile/*)
    /// apart from the other passes, and the memory breakdown against the 32 MB bar.
    Mobile {
        /// Comma-separated bundled scene names or glTF paths.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "cornell-box,atrium,thin-wall"
        )]
        scenes: Vec<String>,
        /// Image size, WIDTHxHEIGHT. Lavapipe wants a tiny one.
        #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
        size: (u32, u32),
        /// Still warm-up frames (showing frame 0) before the measured frames (default: the
        /// mobile tier's 63).
        #[arg(long)]
        warmup: Option<u32>,
        /// Measured frames; each pass's median over them is reported.
        #[arg(long, default_value_t = 64)]
        frames: u32,
        /// Screen probes: hsgi, smartgi or both (one run each).
        #[arg(long, default_value = "hsgi", value_parser = mobile::parse_modes)]
        screen_probes: ModeList,
        /// Seconds of still frames for the GPU's clock to settle before timing (as for `pc`).
        #[arg(long, default_value_t = 2.0, value_parser = parse_settle)]
        settle_s: f64,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Cost and memory of the PC tier per scene and pipeline variant (the default, or one
    /// stage switched off): a still warm-up, then the median per pass over the measured
    /// frames and the GI sum (cache/* + pc/*).
    Pc {
        /// Comma-separated bundled scene names or glTF paths.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "cornell-box,atrium,glossy"
        )]
        scenes: Vec<String>,
        /// Image size, WIDTHxHEIGHT. Lavapipe wants a tiny one.
        #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
        size: (u32, u32),
        /// Still warm-up frames before the measured frames (default: the PC tier's 63).
        #[arg(long)]
        warmup: Option<u32>,
        /// Measured frames; each pass's median over them is reported.
        #[arg(long, default_value_t = 64)]
        frames: u32,
        /// Comma-separated variants: default, a stage to switch off (spatial, shadow,
        /// multi-sample, svgf, restir, specular, rough-specular; temporal and boiling are off
        /// by default), or with-temporal (temporal reuse and its boiling filter switched on).
        #[arg(long, value_delimiter = ',', default_value = "default", value_parser = pc::parse_variant)]
        variants: Vec<String>,
        /// Full-resolution pixels per trace pixel along each axis (1 or 2).
        #[arg(long, default_value_t = 2)]
        trace_scale: u32,
        /// What the diffuse rays read: rays, or probes (trace-probe mode).
        #[arg(long, default_value = "rays", value_parser = |s: &str| s.parse::<gi_tiers::pc::TraceMode>())]
        trace_mode: gi_tiers::pc::TraceMode,
        /// After the warm-up, keep rendering still frames for at least this many seconds and
        /// until the GI time of two 16-frame windows agrees within 2% (at most 5 times as
        /// long), so an idle GPU's clock has climbed before frames are timed; 0 times at once.
        #[arg(long, default_value_t = 2.0, value_parser = parse_settle)]
        settle_s: f64,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Temporal stability of a GPU GI tier's GI term (the mobile tier's by default):
    /// flicker (mean absolute frame-to-frame change of its luminance on static pixels, still,
    /// animated and along a camera path) and settle time after a light turns (frames until
    /// within k x the converged noise of the converged image).
    #[command(alias = "mobile-stability")]
    Stability(Box<StabilityArgs>),
    /// Creates renderers one after another in one process, as the render service does job
    /// after job: each round opens a GPU context, creates the tier, renders its frames and
    /// drops them. Reports each creation's time, resident memory, and the round that failed
    /// if one did.
    Churn {
        /// The tier: pc or mobile (at its defaults).
        #[arg(long, default_value = "pc", value_parser = ["pc", "mobile"])]
        tier: String,
        /// Bundled scene name or glTF path.
        #[arg(long, default_value = "cornell-box")]
        scene: String,
        /// Image size, WIDTHxHEIGHT. Lavapipe wants a tiny one.
        #[arg(long, default_value = "640x360", value_parser = parse_size)]
        size: (u32, u32),
        /// Renderers to create, one after another.
        #[arg(long, default_value_t = 100)]
        rounds: u32,
        /// Frames each renderer renders before it is dropped.
        #[arg(long, default_value_t = 2)]
        frames: u32,
        /// Device sharing of each round's context: auto (shared on hardware adapters),
        /// shared, or dedicated (a device opened and destroyed every round).
        #[arg(long, default_value = "auto", value_parser = churn::parse_sharing)]
        sharing: gi_gpu::DeviceSharing,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// One scene of the suite, in its own process (the suite starts these).
    #[command(hide = true)]
    SuiteScene(suite::SceneArgs),
}

/// The arguments of `gi-bench stability` (boxed in [`Command`]: they are many).
#[derive(clap::Args)]
struct StabilityArgs {
    /// The tier: mobile or pc (the PC tier at its defaults).
    #[arg(long, default_value = "mobile", value_parser = ["mobile", "pc"])]
    tier: String,
    /// Image size, WIDTHxHEIGHT. Every frame is read back, so keep it small.
    #[arg(long, default_value = "320x240", value_parser = parse_size)]
    size: (u32, u32),
    /// Still warm-up frames before each case (default: the tier's own, 63).
    #[arg(long)]
    warmup: Option<u32>,
    /// Measured frames of each flicker case.
    #[arg(long, default_value_t = 32)]
    frames: u32,
    /// The mobile tier's screen probes: hsgi, smartgi or both (one run each; default
    /// hsgi).
    #[arg(long, value_parser = mobile::parse_modes)]
    screen_probes: Option<ModeList>,
    /// Scene of the still and animated flicker cases, seen by its still default camera.
    #[arg(long, default_value = "dynamic")]
    still_scene: String,
    /// Scene of the camera-path flicker case (it needs a camera path).
    #[arg(long, default_value = "atrium")]
    path_scene: String,
    /// Static scene whose first punctual light turns for the settle measurement.
    #[arg(long, default_value = "atrium")]
    settle_scene: String,
    /// What changes in the settle scene: its first punctual light turns (by
    /// --light-turn-deg), is switched off, or on (off through the warm-up, then on),
    /// --move-node moves away (`move`; figures over the pixels it leaves), or its brightest
    /// emissive material stops emitting (`emissive-off`).
    #[arg(long, default_value = "turn")]
    change: tier_stability::SettleChange,
    /// How far the light turns about the world vertical, degrees.
    #[arg(long, default_value_t = 30.0)]
    light_turn_deg: f32,
    /// The node `--change move` moves (by name, e.g. "Tall block" in cornell-box).
    #[arg(long)]
    move_node: Option<String>,
    /// How far it moves, X,Y,Z metres in its parent's space (default: its width along x
    /// plus 10%, along x).
    #[arg(long, value_parser = parse_vec3)]
    move_by: Option<glam::Vec3>,
    /// Skip the flicker cases: only the settle case and its cost.
    #[arg(long)]
    no_flicker: bool,
    /// The PC denoiser's short-history clamp (`DenoiseConfig::short_clamp_sigma`; 0: off,
    /// the default). Only the PC tier reads it.
    #[arg(long)]
    pc_short_clamp_sigma: Option<f32>,
    /// A PC tier stage to switch off (`PcConfig::without`, e.g. `gradients`). Only the PC
    /// tier reads it.
    #[arg(long)]
    pc_without: Option<String>,
    /// The PC tier's temporal-gradient gain (`GradientConfig::gain`).
    #[arg(long)]
    pc_gradient_gain: Option<f32>,
    /// Both tiers' brick cache's measured-change gain (`CacheConfig::change_gain`; 0: the
    /// cache's updates weigh by age alone).
    #[arg(long)]
    cache_change_gain: Option<f32>,
    /// Both tiers' brick cache's bricks relit per frame on top of the round-robin while the
    /// lights' change settles (`CacheConfig::relight_bricks_per_frame`; the settling budget
    /// is raised to it where lower).
    #[arg(long)]
    cache_relight_bricks: Option<u32>,
    /// The mobile tier without its light window (`ScreenConfig::light_window`: after a
    /// switch of the lights, the cache's surfels where the gather reads the probe volume,
    /// short histories, the volume restarted).
    #[arg(long)]
    mobile_without_light_window: bool,
    /// Frames rendered after the light turns.
    #[arg(long, default_value_t = 160)]
    settle_frames: u32,
    /// The last frames, whose mean is the converged image and whose frame-to-frame change
    /// is the noise.
    #[arg(long, default_value_t = 10)]
    converged_frames: u32,
    /// Settled means within this many times the converged noise of the converged image.
    #[arg(long, default_value_t = 2.0)]
    settle_k: f64,
    /// Seconds of still frames for the GPU's clock to settle before the light turns, so
    /// that the GI times around the change compare (as `--settle-s` for `pc`); 0 times at
    /// once.
    #[arg(long, default_value_t = 2.0, value_parser = parse_settle)]
    clock_settle_s: f64,
    /// Also write each run's contact strip of the settle case into this folder
    /// (`<scene>-<change>-<tier>.png`: the GI term before the change, 1, 2, 4 and 8
    /// frames after it, and converged).
    #[arg(long)]
    strip_dir: Option<PathBuf>,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// Screen-probe modes of a run (clap needs a named type for a parsed list).
type ModeList = Vec<gi_tiers::mobile::ScreenProbeMode>;

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let Some(command) = cli.command else {
        return suite::run(&cli.suite);
    };
    match command {
        Command::SuiteScene(args) => suite::run_scene(&args),
        Command::Rays {
            scene,
            rays,
            repeats,
            mesh_sharing,
            settle_s,
            json,
        } => {
            let report = rays::run(&scene, rays, repeats.max(1), mesh_sharing, settle_s)?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::Deform {
            rings,
            sides,
            frames,
            rays,
            repeats,
            settle_s,
            level_triangles,
            json,
        } => {
            let report = deform::run(&deform::DeformOptions {
                rings,
                sides,
                frames,
                rays,
                repeats: repeats.max(1),
                settle_s,
                level_triangles,
            })?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::CacheRays {
            scene,
            rays,
            repeats,
            json,
        } => {
            let report = cache_rays::run(&scene, rays, repeats.max(1))?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::CacheUpdate {
            scene,
            frames,
            pool_bricks,
            levels,
            voxel_size,
            voxelize_scan,
            voxelize_part,
            screen_inject,
            size,
            settle_s,
            json,
        } => {
            let defaults = gi_cache::CacheConfig::default();
            let config = gi_cache::CacheConfig {
                pool_bricks: pool_bricks.unwrap_or(defaults.pool_bricks),
                levels: levels.unwrap_or(defaults.levels),
                // Fewer levels than the default near field keep every level near.
                near_levels: defaults.near_levels.min(levels.unwrap_or(defaults.levels)),
                voxel_size_m: voxel_size.unwrap_or(defaults.voxel_size_m),
                voxelize_scan_per_frame: voxelize_scan.unwrap_or(defaults.voxelize_scan_per_frame),
                voxelize_part_triangles: voxelize_part.unwrap_or(defaults.voxelize_part_triangles),
                ..defaults
            };
            let options = cache_update::CacheUpdateOptions {
                scene,
                frames,
                config,
                screen_inject: screen_inject.then_some(size),
                settle_s,
            };
            let report = cache_update::run(&options)?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::Path {
            scene,
            width,
            height,
            spp,
            frames,
            json,
        } => {
            let report = path::run(&scene, (width, height), spp, frames)?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::Mobile {
            scenes,
            size,
            warmup,
            frames,
            screen_probes,
            settle_s,
            json,
        } => {
            let report = mobile::run(&mobile::MobileOptions {
                scenes,
                size,
                schedule: realtime::Schedule {
                    warmup: warmup.unwrap_or(gi_tiers::TierKind::Mobile.default_warmup()),
                    settle_s,
                    frames,
                },
                modes: screen_probes,
            })?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::Pc {
            scenes,
            size,
            warmup,
            frames,
            variants,
            trace_scale,
            trace_mode,
            settle_s,
            json,
        } => {
            let report = pc::run(&pc::PcOptions {
                scenes,
                size,
                schedule: realtime::Schedule {
                    warmup: warmup.unwrap_or(gi_tiers::TierKind::Pc.default_warmup()),
                    settle_s,
                    frames,
                },
                variants,
                trace_scale,
                trace_mode,
            })?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::Churn {
            tier,
            scene,
            size,
            rounds,
            frames,
            sharing,
            json,
        } => {
            let report = churn::run(&churn::ChurnOptions {
                tier: tier.parse().map_err(anyhow::Error::msg)?,
                scene,
                size,
                rounds,
                frames,
                sharing,
            })?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
        Command::Stability(args) => {
            let StabilityArgs {
                tier,
                size,
                warmup,
                frames,
                screen_probes,
                still_scene,
                path_scene,
                settle_scene,
                change,
                light_turn_deg,
                move_node,
                move_by,
                no_flicker,
                pc_short_clamp_sigma,
                pc_without,
                pc_gradient_gain,
                cache_change_gain,
                cache_relight_bricks,
                mobile_without_light_window,
                settle_frames,
                converged_frames,
                settle_k,
                clock_settle_s,
                strip_dir,
                json,
            } = *args;
            if let Some(dir) = &strip_dir {
                std::fs::create_dir_all(dir)
                    .map_err(|e| anyhow::anyhow!("creating {}: {e}", dir.display()))?;
            }
            let (kind, variants) = match (tier.as_str(), screen_probes) {
                ("pc", None) => (gi_tiers::TierKind::Pc, vec![tier_stability::Variant::Pc]),
                ("pc", Some(_)) => anyhow::bail!("--screen-probes applies to the mobile tier only"),
                (_, modes) => (
                    gi_tiers::TierKind::Mobile,
                    modes
                        .unwrap_or_else(|| vec![gi_tiers::mobile::ScreenProbeMode::Hsgi])
                        .into_iter()
                        .map(tier_stability::Variant::Mobile)
                        .collect(),
                ),
            };
            let report = tier_stability::run(&tier_stability::StabilityOptions {
                size,
                warmup: warmup.unwrap_or(kind.default_warmup()),
                frames,
                variants,
                still_scene,
                path_scene,
                settle_scene,
                change,
                light_turn_deg,
                move_node,
                move_by,
                flicker: !no_flicker,
                cache_change_gain,
                cache_relight_bricks,
                mobile_light_window: !mobile_without_light_window,
                pc_config: {
                    let mut config = match pc_without {
                        Some(stage) => {
                            gi_tiers::PcConfig::without(&stage).map_err(anyhow::Error::msg)?
                        }
                        None => gi_tiers::PcConfig::default(),
                    };
                    if let Some(sigma) = pc_short_clamp_sigma {
                        config.denoise.short_clamp_sigma = sigma;
                    }
                    if let Some(gain) = pc_gradient_gain {
                        config.gradients.gain = gain;
                    }
                    config.validate().map_err(anyhow::Error::msg)?;
                    config
                },
                settle_frames,
                converged_frames,
                settle_k,
                clock_settle_s,
                strip_dir,
            })?;
            out!("{}", report.table());
            write_json(json, &report.json())
        }
    }
}

/// Parses `--settle-s`: finite seconds within 0..=60.
fn parse_settle(value: &str) -> Result<f64, String> {
    value
        .parse::<f64>()
        .ok()
        .filter(|s| (0.0..=60.0).contains(s))
        .ok_or_else(|| format!("expected seconds within 0..=60, not `{value}`"))
}

/// Parses `WIDTHxHEIGHT` (each side at least 1).
pub(crate) fn parse_size(size: &str) -> Result<(u32, u32), String> {
    size.split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)))
        .filter(|&(w, h): &(u32, u32)| w > 0 && h > 0)
        .ok_or_else(|| "expected WIDTHxHEIGHT with both sides at least 1, e.g. 320x180".to_owned())
}

/// `X,Y,Z`, three finite numbers.
fn parse_vec3(value: &str) -> Result<glam::Vec3, String> {
    let parts: Vec<f32> = value
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("expected X,Y,Z: {e}"))?;
    match parts[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
            Ok(glam::Vec3::new(x, y, z))
        }
        _ => Err("expected three finite numbers X,Y,Z, e.g. 0.5,0,0".to_owned()),
    }
}

fn write_json(path: Option<PathBuf>, value: &serde_json::Value) -> anyhow::Result<()> {
    if let Some(path) = path {
        std::fs::write(&path, serde_json::to_string_pretty(value)?)?;
        out!("wrote {}\n", path.display());
    }
    Ok(())
}

/// A write to standard output that failed only because its reader is gone counts as done.
fn quiet_broken_pipe(result: std::io::Result<()>) -> std::io::Result<()> {
    match result {
        Err(error) if error.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}
