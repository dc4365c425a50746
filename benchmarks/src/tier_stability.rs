//! `gi-bench stability` (also `mobile-stability`): how steady a GPU GI tier's GI term is and
//! how fast it follows a lighting change, with the metrics of [`crate::stability`] (their
//! definitions are in its docs): the mobile tier in each screen-probe mode asked for, or the
//! PC tier at its defaults. Every case first renders a still warm-up of frame 0.
//!
//! Flicker, over `frames` measured frames after the warm-up:
//! - `still`: the still scene frozen at frame 0 (every frame the same view): the tier's own
//!   temporal noise.
//! - `animated`: the still scene's animation running under its still default camera. Static
//!   pixels' GI also changes for real when a light moves (the `dynamic` scene's light circles
//!   the room), so this is an upper bound of the flicker there; `still` is the noise floor.
//! - `camera path`: the path scene through its camera path, pixels reprojected through the
//!   motion vectors.
//!
//! Settle: the settle scene (static, with a punctual light) warms up, then its first punctual
//! light changes ([`SettleChange`]: it turns by `light_turn_deg` about the world vertical (a
//! directional or spot light's direction; a point light's position about the vertical axis
//! through the origin), is switched off, or, off through the warm-up, is switched on), its
//! brightest emissive material stops emitting (`emissive-off`, through
//! `Renderer::set_material`: a lamp's shade or a screen switched off), or one of its nodes
//! moves away (`move`: `move_node`, made movable before the renderer, by `move_by`), and
//! `settle_frames` still frames follow. For a move every figure is taken over
//! the pixels the node covered before it and no longer covers after it (where it leaves a
//! trail), not over the whole image: the share left after 4 frames is the trail's. The converged value is the mean of the last
//! `converged_frames`, the noise their mean frame-to-frame change, the threshold `k` times the
//! noise, and the settle time the frames from the change until every later frame (before the
//! converged window) is within the threshold of the converged value. Errors and noise are mean
//! absolute luminance differences over the pixels that see a static surface. When the mean of
//! the window before the converged one still differs from it by more than the threshold
//! (`converged_drift`), the GI had not converged and the settle time is a lower bound.
//! Noise correlated over many frames holds single frames further from the converged value than
//! the frame-to-frame noise, so the settle time can end up measuring that noise rather than the
//! change; the error floor (the 90th percentile of the later frames' errors) and the frames
//! until the error first reaches it measure the change alone. Two figures follow a game's
//! view of lag: the share of the change still left after 4 and after 8 frames (error over the
//! light change: for a light or emitter switched off, the share of its light still shown), and
//! the share of the resolvable part (the light change down to the error floor) resolved within
//! 8 frames.
//!
//! Cost of the change, in a run of its own on a fresh renderer of the settle scene (the
//! settle case reads every frame back, and the idle GPU between frames lets its clock fall, by
//! up to 5 times on the H100): still frames wait for the GPU's clock
//! ([`crate::settle::settle`], `clock_settle_s`) before the warm-up's last [`COST_WINDOW`]
//! frames, whose GI time (GPU timestamps, the tier's GI passes) is the baseline; the light
//! turns and `settle_frames` frames follow, each timed, none read back. A light change makes the
//! brick cache relight every brick again (with the relight budget's extra updates,
//! `relight_bricks_per_frame`), which costs until the bricks settle again.

use anyhow::{Context, bail};
use gi_scene::LightKind;
use gi_tiers::{CameraMode, PcConfig, PcTier, Renderer, mobile::ScreenProbeMode};
use glam::{Quat, Vec3};

use crate::mobile::{mobile, mobile_renderer_with};
use crate::pc::pc_renderer;
use crate::settle::{Settled, gi_ms};
use crate::stability::{
    Change, DEPTH_TOLERANCE, OwnedGiFrame, error_floor, frame_to_frame_noise, frames_to_floor,
    luminance_image, mean_abs_difference, mean_image, settle_frames, static_change,
};
use crate::suite::median;

/// What `gi-bench stability` runs.
#[derive(Clone, Debug)]
pub struct StabilityOptions {
    pub size: (u32, u32),
    pub warmup: u32,
    /// Measured frames of each flicker case.
    pub frames: u32,
    /// One run each.
    pub variants: Vec<Variant>,
    /// Scene of the `still` and `animated` flicker cases (default `dynamic`).
    pub still_scene: String,
    /// Scene of the `camera path` flicker case; it needs a camera path.
    pub path_scene: String,
    /// Static scene with a punctual light for the settle measurement.
    pub settle_scene: String,
    /// What happens to the settle scene: its first punctual light changes, or a node moves.
    pub change: SettleChange,
    pub light_turn_deg: f32,
    /// The node that moves away with [`SettleChange::Move`] (by name).
    pub move_node: Option<String>,
    /// How far it moves, metres in its parent's space; `None`: its width along x plus 10%.
    pub move_by: Option<Vec3>,
    /// Run the flicker cases (off: the settle and cost cases only).
    pub flicker: bool,
    /// The PC tier's configuration (its runs only).
    pub pc_config: PcConfig,
    /// Both tiers' brick cache's `CacheConfig::change_gain`; `None`: each tier's default.
    pub cache_change_gain: Option<f32>,
    /// Both tiers' brick cache's `CacheConfig::relight_bricks_per_frame` (the settling budget
    /// raised to it where lower); `None`: each tier's default.
    pub cache_relight_bricks: Option<u32>,
    /// The mobile tier's `ScreenConfig::light_window`.
    pub mobile_light_window: bool,
    /// Frames rendered after the light turns.
    pub settle_frames: u32,
    /// The last frames, whose mean is the converged value.
    pub converged_frames: u32,
    /// Threshold as a multiple of the converged frame-to-frame noise.
    pub settle_k: f64,
    /// Seconds of still frames for the GPU's clock to settle before the settle case's light
    /// turns ([`crate::settle::settle`]); 0 times at once.
    pub clock_settle_s: f64,
    /// Folder for each run's contact strip of the settle case (`<scene>-<change>-<tier>.png`):
    /// the GI term before the change, 1, 2, 4 and 8 frames after it, and converged.
    pub strip_dir: Option<std::path::PathBuf>,
}

/// Frames after the change that the contact strip shows.
const STRIP_FRAMES: [usize; 4] = [1, 2, 4, 8];

/// What the settle case changes after the warm-up: the settle scene's first punctual light,
/// its brightest emissive material, or where one of its nodes is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SettleChange {
    /// The light turns by `light_turn_deg` about the world vertical.
    Turn,
    /// The light is switched off.
    Off,
    /// Off through the warm-up, the light is switched on.
    On,
    /// `move_node` moves by `move_by`.
    Move,
    /// The emissive material that emits the most power ([`brightest_emitter`]) stops emitting
    /// (`Renderer::set_material`).
    EmissiveOff,
}

impl SettleChange {
    pub const NAMES: [&str; 5] = ["turn", "off", "on", "move", "emissive-off"];

    pub fn name(self) -> &'static str {
        match self {
            Self::Turn => "turn",
            Self::Off => "off",
            Self::On => "on",
            Self::Move => "move",
            Self::EmissiveOff => "emissive-off",
        }
    }
}

impl std::str::FromStr for SettleChange {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "turn" => Ok(Self::Turn),
            "off" => Ok(Self::Off),
            "on" => Ok(Self::On),
            "move" => Ok(Self::Move),
            "emissive-off" => Ok(Self::EmissiveOff),
            other => Err(format!(
                "unknown light change '{other}' (expected {})",
                Self::NAMES.join(", ")
            )),
        }
    }
}

/// Still frames before the light turns whose GI time is the baseline (the warm-up's last, as
/// many as it has), and frames after it whose median is the first cost.
pub const COST_WINDOW: usize = 16;

/// GI time around the light change, ms per frame (GPU timestamps).
#[derive(Clone, Debug)]
pub struct ChangeCost {
    /// The GPU clock's settling before the baseline.
    pub clock: Settled,
    /// Median over the last [`COST_WINDOW`] still frames before the turn (the warm-up's).
    pub before_ms: f64,
    /// Median over the first [`COST_WINDOW`] frames after it (fewer when the run is shorter).
    pub first_ms: f64,
    /// The most expensive frame after it.
    pub peak_ms: f64,
    /// Median over the converged window.
    pub converged_ms: f64,
    /// Frames after the turn until the GI time is back within 10% of the baseline for good:
    /// through the last frame above it (0 when none is; `None` when the last frame still is).
    pub elevated_frames: Option<usize>,
    /// Frames after the turn through the end of the first unbroken run above 110% of the
    /// baseline: how long the relighting lasts, which a single noisy frame later does not
    /// lengthen (0 when no frame is above it; `None` when the run lasts to the last frame).
    pub relight_frames: Option<usize>,
    /// Every frame's GI time after the turn.
    pub after_ms: Vec<f64>,
}

/// One flicker case.
pub struct FlickerCase {
    pub case: &'static str,
    pub scene: String,
    pub change: Change,
}

/// The settle measurement.
pub struct Settle {
    pub scene: String,
    /// Mean GI luminance of the converged value over the measured pixels.
    pub converged_luminance: f64,
    /// Mean |converged after - last frame before| the change: how much the turn changed the GI.
    pub light_change: f64,
    pub noise: f64,
    pub threshold: f64,
    /// Mean |converged - mean of the window of as many frames just before it|: above the
    /// threshold, the GI was still drifting at the end and the settle time is a lower bound.
    pub converged_drift: f64,
    /// Error of frame 1, 2, ... after the change (before the converged window).
    pub errors: Vec<f64>,
    pub settle_frames: Option<usize>,
    /// The error floor of the settled GI ([`crate::stability::error_floor`]).
    pub floor: Option<f64>,
    /// Frames until the error first reaches the floor.
    pub floor_frames: Option<usize>,
}

impl Settle {
    /// The share of the light change still left `frames` frames after it: that frame's error
    /// over the light change.
    pub fn left_after(&self, frames: usize) -> Option<f64> {
        let error = self.errors.get(frames.checked_sub(1)?)?;
        (self.light_change > 0.0).then(|| error / self.light_change)
    }

    /// The share of the resolvable part of the change (the light change down to the error
    /// floor) resolved `frames` frames after it.
    pub fn resolved_within(&self, frames: usize) -> Option<f64> {
        let error = self.errors.get(frames.checked_sub(1)?)?;
        let resolvable = self.light_change - self.floor?;
        (resolvable > 0.0).then(|| (self.light_change - error) / resolvable)
    }
}

/// The tier a run measures, and for the mobile tier its screen probes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    Mobile(ScreenProbeMode),
    /// The PC tier's default configuration.
    Pc,
}

impl Variant {
    pub fn tier(self) -> &'static str {
        match self {
            Variant::Mobile(_) => "mobile",
            Variant::Pc => "pc",
        }
    }

    /// The mobile tier's screen-probe mode; `None` for the PC tier.
    pub fn screen_probes(self) -> Option<&'static str> {
        match self {
            Variant::Mobile(mode) => Some(mode.name()),
            Variant::Pc => None,
        }
    }

    /// `mobile hsgi`, `mobile smartgi`, `pc`.
    pub fn name(self) -> String {
        match self.screen_probes() {
            Some(mode) => format!("{} {mode}", self.tier()),
            None => self.tier().to_owned(),
        }
    }

    fn renderer(
        self,
        scene: &gi_scene::Scene,
        options: &StabilityOptions,
        camera: CameraMode,
    ) -> anyhow::Result<Renderer> {
        let size = options.size;
        match self {
            Variant::Mobile(mode) => {
                let mut config = crate::mobile::config_for(mode);
                options.apply_to_cache(&mut config.cache);
                config.screen.light_window = options.mobile_light_window;
                mobile_renderer_with(scene.clone(), size, config, camera)
            }
            Variant::Pc => {
                let mut config = options.pc_config.clone();
                options.apply_to_cache(&mut config.cache);
                pc_renderer(scene.clone(), size, config, camera)
            }
        }
    }
}

impl StabilityOptions {
    /// The cache overrides of these options applied to a tier's cache configuration.
    fn apply_to_cache(&self, cache: &mut gi_cache::CacheConfig) {
        if let Some(gain) = self.cache_change_gain {
            cache.change_gain = gain;
        }
        if let Some(bricks) = self.cache_relight_bricks {
            cache.relight_bricks_per_frame = bricks;
            cache.settle_bricks_per_frame = cache.settle_bricks_per_frame.max(bricks);
        }
    }
}

pub struct StabilityRun {
    pub variant: Variant,
    pub flicker: Vec<FlickerCase>,
    pub settle: Settle,
    pub cost: ChangeCost,
}

pub struct StabilityReport {
    pub options: StabilityOptions,
    pub runs: Vec<StabilityRun>,
}

pub fn run(options: &StabilityOptions) -> anyhow::Result<StabilityReport> {
    anyhow::ensure!(options.frames >= 1, "--frames must be at least 1");
    anyhow::ensure!(
        options.converged_frames >= 2 && options.converged_frames < options.settle_frames,
        "--converged-frames must be at least 2 and less than --settle-frames"
    );
    anyhow::ensure!(options.settle_k > 0.0, "--settle-k must be positive");
    let load = |name: &str| gi_scene::load(name).with_context(|| format!("loading {name}"));
    let still = load(&options.still_scene)?;
    let path = load(&options.path_scene)?;
    anyhow::ensure!(
        path.camera_path.is_some(),
        "{} has no camera path (try atrium or cornell-box)",
        options.path_scene
    );
    let mut settle_scene = load(&options.settle_scene)?;
    // Checked before anything renders, so a scene that cannot settle costs no frames.
    anyhow::ensure!(
        !settle_scene.is_animated(),
        "the settle scene must be static; {} is animated (try atrium or thin-wall)",
        settle_scene.name
    );
    match options.change {
        SettleChange::Move => {
            let node = moved_node(&settle_scene, options)?;
            settle_scene.nodes[node].movable = true;
        }
        SettleChange::EmissiveOff => {
            brightest_emitter(&settle_scene)?;
        }
        SettleChange::Turn | SettleChange::Off | SettleChange::On => {
            first_light_node(&settle_scene)?;
        }
    }
    anyhow::ensure!(!options.variants.is_empty(), "nothing to measure");
    let mut runs = Vec::new();
    for &variant in &options.variants {
        let renderer = |scene: &gi_scene::Scene, camera| variant.renderer(scene, options, camera);
        let flicker = if !options.flicker {
            Vec::new()
        } else {
            vec![
                FlickerCase {
                    case: "still",
                    scene: still.name.clone(),
                    change: flicker(&mut renderer(&still, CameraMode::Default)?, options, false)?,
                },
                FlickerCase {
                    case: "animated",
                    scene: still.name.clone(),
                    change: flicker(&mut renderer(&still, CameraMode::Default)?, options, true)?,
                },
                FlickerCase {
                    case: "camera path",
                    scene: path.name.clone(),
                    change: flicker(&mut renderer(&path, CameraMode::Path)?, options, true)?,
                },
            ]
        };
        let strip = (options.strip_dir.as_ref()).map(|dir| {
            dir.join(format!(
                "{}-{}-{}.png",
                crate::suite::file_stem(&settle_scene.name),
                options.change.name(),
                variant.name().replace(' ', "-")
            ))
        });
        let settle = settle(
            &mut renderer(&settle_scene, CameraMode::Default)?,
            options,
            strip.as_deref(),
        )?;
        let cost = change_cost(&mut renderer(&settle_scene, CameraMode::Default)?, options)?;
        runs.push(StabilityRun {
            variant,
            flicker,
            settle,
            cost,
        });
    }
    Ok(StabilityReport {
        options: options.clone(),
        runs,
    })
}

/// The GI term and G-buffer data of the frame the tier rendered last.
fn frame_data(renderer: &Renderer) -> anyhow::Result<OwnedGiFrame> {
    let missing = || "the tier returned no frame data after a frame";
    if let Some(tier) = renderer.tier_as::<PcTier>() {
        let data = tier.frame_data().with_context(missing)?;
        return Ok(OwnedGiFrame {
            width: data.gi.width,
            height: data.gi.height,
            gi: data.gi.pixels,
            dynamic: data.dynamic,
            motion: data.motion,
            depth: data.depth,
        });
    }
    let data = mobile(renderer).frame_data().with_context(missing)?;
    Ok(OwnedGiFrame {
        width: data.gi.width,
        height: data.gi.height,
        gi: data.gi.pixels,
        dynamic: data.dynamic,
        motion: data.motion,
        depth: data.depth,
    })
}

/// Warms up, then measures `options.frames` frames, advancing scene time when `advance`.
fn flicker(
    renderer: &mut Renderer,
    options: &StabilityOptions,
    advance: bool,
) -> anyhow::Result<Change> {
    renderer.warm_up(options.warmup, None)?;
    if options.warmup == 0 {
        // The first measured frame needs a frame before it.
        renderer.warm_up(1, None)?;
    }
    let mut previous = frame_data(renderer)?;
    let mut total = Change::default();
    for _ in 0..options.frames {
        if advance {
            renderer.advance_frame(None)?;
        } else {
            renderer.warm_up(1, None)?;
        }
        let current = frame_data(renderer)?;
        total.add(static_change(
            &current.view(),
            &previous.view(),
            DEPTH_TOLERANCE,
        ));
        previous = current;
    }
    Ok(total)
}

/// The node of the scene's first punctual light: the one the settle case turns.
fn first_light_node(scene: &gi_scene::Scene) -> anyhow::Result<usize> {
    let Some(node) = scene.nodes.iter().position(|n| n.light.is_some()) else {
        bail!(
            "{} has no punctual light to turn (thin-wall, atrium and open-world have a sun)",
            scene.name
        );
    };
    Ok(node)
}

/// The node a move moves: `move_node` by name.
fn moved_node(scene: &gi_scene::Scene, options: &StabilityOptions) -> anyhow::Result<usize> {
    let Some(name) = &options.move_node else {
        bail!(
            "--change move needs --move-node (a node of {} with a mesh)",
            scene.name
        );
    };
    scene
        .nodes
        .iter()
        .position(|n| &n.name == name)
        .with_context(|| {
            let names: Vec<&str> = scene.nodes.iter().map(|n| n.name.as_str()).collect();
            format!(
                "{} has no node '{name}' (its nodes: {})",
                scene.name,
                names.join(", ")
            )
        })
}

/// Where `move_node` goes: its translation plus `move_by`, by default its width along x
/// (from the frame's triangles under it) plus 10%.
fn moved_translation(
    renderer: &mut Renderer,
    options: &StabilityOptions,
) -> anyhow::Result<(usize, Vec3)> {
    let node = moved_node(renderer.scene(), options)?;
    let by = match options.move_by {
        Some(by) => by,
        None => {
            let frame = renderer.scene().evaluate(0.0, None);
            let (min, max) = (frame.triangles.iter().zip(&frame.attributes))
                .filter(|(_, a)| a.node as usize == node)
                .flat_map(|(t, _)| [t.v0, t.v1, t.v2])
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v.x), hi.max(v.x))
                });
            anyhow::ensure!(
                min <= max,
                "node {} has no triangles of its own",
                options.move_node.as_deref().unwrap_or("")
            );
            Vec3::new(1.1 * (max - min), 0.0, 0.0)
        }
    };
    Ok((node, renderer.scene().nodes[node].translation + by))
}

/// Readies the settle scene for `change` before its warm-up: a light to switch on is off until
/// then. Returns the light's intensity in the scene as loaded (0 for a move).
fn prepare_change(scene: &mut gi_scene::Scene, change: SettleChange) -> anyhow::Result<f32> {
    if matches!(change, SettleChange::Move | SettleChange::EmissiveOff) {
        return Ok(0.0);
    }
    let light = scene.nodes[first_light_node(scene)?]
        .light
        .expect("found above");
    let intensity = scene.lights[light].intensity;
    if change == SettleChange::On {
        scene.lights[light].intensity = 0.0;
    }
    Ok(intensity)
}

/// Makes `change`: to the scene's first punctual light, whose intensity as loaded is
/// `intensity`, or moves `move_node`.
fn apply_change(
    renderer: &mut Renderer,
    change: SettleChange,
    options: &StabilityOptions,
    intensity: f32,
) -> anyhow::Result<()> {
    if change == SettleChange::Move {
        let (node, translation) = moved_translation(renderer, options)?;
        let n = &renderer.scene().nodes[node];
        let (rotation, scale) = (n.rotation, n.scale);
        renderer.set_node_transform(node, translation, rotation, scale)?;
        return Ok(());
    }
    if change == SettleChange::EmissiveOff {
        let index = brightest_emitter(renderer.scene())?;
        let mut material = renderer.scene().materials[index].clone();
        material.emissive = Vec3::ZERO;
        renderer.set_material(index, material)?;
        return Ok(());
    }
    let scene = renderer.scene_mut();
    let light = scene.nodes[first_light_node(scene)?]
        .light
        .expect("found above");
    match change {
        SettleChange::Turn => turn_first_light(scene, options.light_turn_deg)?,
        SettleChange::Off => scene.lights[light].intensity = 0.0,
        SettleChange::On => scene.lights[light].intensity = intensity,
        SettleChange::Move | SettleChange::EmissiveOff => unreachable!("handled above"),
    }
    Ok(())
}

/// The material of `scene` whose triangles emit the most power at time 0 (exitance times
/// area); an error when nothing emits.
pub fn brightest_emitter(scene: &gi_scene::Scene) -> anyhow::Result<usize> {
    let exitance = gi_scene::EmitterDistribution::exitance(&scene.materials, &scene.textures);
    let frame = scene.evaluate(0.0, None);
    let mut power = vec![0.0f64; scene.materials.len()];
    for (triangle, attributes) in frame.triangles.iter().zip(&frame.attributes) {
        let material = attributes.material as usize;
        if let Some(&e) = exitance.get(material).filter(|&&e| e > 0.0) {
            let area = 0.5
                * (triangle.v1 - triangle.v0)
                    .cross(triangle.v2 - triangle.v0)
                    .length();
            power[material] += f64::from(e * area);
        }
    }
    power
        .iter()
        .enumerate()
        .filter(|&(_, &p)| p > 0.0)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(index, _)| index)
        .with_context(|| {
            format!(
                "{} has no emissive material (try cornell-box or glossy)",
                scene.name
            )
        })
}

/// Turns the scene's first punctual light about the world vertical by `degrees`.
fn turn_first_light(scene: &mut gi_scene::Scene, degrees: f32) -> anyhow::Result<()> {
    let node = first_light_node(scene)?;
    let light = scene.nodes[node].light.expect("found above");
    let turn = Quat::from_rotation_y(degrees.to_radians());
    let node = &mut scene.nodes[node];
    match scene.lights[light].kind {
        LightKind::Directional | LightKind::Spot { .. } => node.rotation = turn * node.rotation,
        LightKind::Point => node.translation = turn * node.translation,
    }
    Ok(())
}

/// The GI time around the settle case's light change on `renderer` (fresh, of the settle
/// scene): see the module docs.
fn change_cost(renderer: &mut Renderer, options: &StabilityOptions) -> anyhow::Result<ChangeCost> {
    // The warm-up's last frames (up to COST_WINDOW) are the baseline, timed after the clock
    // settled; the clock's frames come on top of the warm-up.
    let kind = renderer.tier();
    let intensity = prepare_change(renderer.scene_mut(), options.change)?;
    let warmup = options.warmup.max(1);
    let timed = warmup.min(COST_WINDOW as u32);
    if warmup > timed {
        renderer.warm_up(warmup - timed, None)?;
    }
    let clock = crate::settle::settle(renderer, kind, options.clock_settle_s)?;
    let mut before_ms = Vec::with_capacity(timed as usize);
    for _ in 0..timed {
        before_ms.push(gi_ms(kind, &renderer.warm_up_frame()?));
    }
    apply_change(renderer, options.change, options, intensity)?;
    let mut after_ms = Vec::with_capacity(options.settle_frames as usize);
    for _ in 0..options.settle_frames {
        after_ms.push(gi_ms(kind, &renderer.warm_up_frame()?));
    }
    let before_ms = median(&before_ms);
    let window = after_ms.len() - options.converged_frames as usize;
    Ok(ChangeCost {
        clock,
        before_ms,
        first_ms: median(&after_ms[..COST_WINDOW.min(after_ms.len())]),
        peak_ms: after_ms.iter().copied().fold(0.0, f64::max),
        converged_ms: median(&after_ms[window..]),
        elevated_frames: match after_ms.iter().rposition(|&ms| ms > 1.1 * before_ms) {
            None => Some(0),
            Some(last) if last + 1 == after_ms.len() => None,
            Some(last) => Some(last + 1),
        },
        relight_frames: relight_frames(&after_ms, 1.1 * before_ms),
        after_ms,
    })
}

/// [`ChangeCost::relight_frames`] of `after_ms` above `limit`.
fn relight_frames(after_ms: &[f64], limit: f64) -> Option<usize> {
    let Some(first) = after_ms.iter().position(|&ms| ms > limit) else {
        return Some(0);
    };
    after_ms[first..]
        .iter()
        .position(|&ms| ms <= limit)
        .map(|back| first + back)
}

fn settle(
    renderer: &mut Renderer,
    options: &StabilityOptions,
    strip: Option<&std::path::Path>,
) -> anyhow::Result<Settle> {
    let name = renderer.scene().name.clone();
    let exposure = renderer.scene().exposure;
    let intensity = prepare_change(renderer.scene_mut(), options.change)?;
    renderer.warm_up(options.warmup.max(1), None)?;
    let before_data = frame_data(renderer)?;
    let before = luminance_image(&before_data.gi);
    apply_change(renderer, options.change, options, intensity)?;
    let mut frames = Vec::new();
    let mut last = None;
    let mut shown = vec![("before".to_owned(), before_data.gi.clone())];
    let mut converged_colors = Vec::new();
    // The converged window: the last `converged_frames` (fewer than `settle_frames`, checked).
    let window = (options.settle_frames - options.converged_frames) as usize;
    for index in 0..options.settle_frames as usize {
        renderer.warm_up(1, None)?;
        let data = frame_data(renderer)?;
        frames.push(luminance_image(&data.gi));
        if strip.is_some() {
            if STRIP_FRAMES.contains(&(index + 1)) {
                shown.push((format!("{} after", index + 1), data.gi.clone()));
            }
            if index >= window {
                converged_colors.push(data.gi.clone());
            }
        }
        last = Some(data);
    }
    if let Some(path) = strip {
        let count = converged_colors.len().max(1) as f32;
        let mut mean = vec![Vec3::ZERO; before_data.gi.len()];
        for frame in &converged_colors {
            for (m, c) in mean.iter_mut().zip(frame) {
                *m += *c / count;
            }
        }
        shown.push(("converged".to_owned(), mean));
        let (width, height) = (before_data.width, before_data.height);
        let images = shown
            .into_iter()
            .map(|(label, pixels)| {
                let image = gi_image::Image::from_pixels(width, height, pixels)?;
                let bytes = gi_image::to_srgb8(&image, exposure);
                let rgb = image::RgbImage::from_raw(width, height, bytes)
                    .context("a tonemapped frame of the wrong size")?;
                Ok((label, rgb))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let title = format!(
            "{name}: the GI term around the change ({}), at the scene's exposure",
            options.change.name()
        );
        crate::suite::plots::strip(path, &title, images)?;
    }
    let last = last.expect("at least two frames");
    // Static pixels; for a move the static ones the node covered before it (its trail).
    let moved = options.change == SettleChange::Move;
    let mask: Vec<bool> = (last.depth.iter().zip(&last.dynamic))
        .zip(&before_data.dynamic)
        .map(|((depth, dynamic), before)| depth.is_finite() && !dynamic && (!moved || *before))
        .collect();
    anyhow::ensure!(
        mask.iter().any(|&m| m),
        "no pixel to measure: {}",
        if moved {
            "the moved node covered no pixel it left (move it within the view)"
        } else {
            "no static surface in view"
        }
    );
    let converged = mean_image(&frames[window..]);
    let noise = frame_to_frame_noise(&frames[window..], &mask);
    let threshold = options.settle_k * noise;
    let errors: Vec<f64> = frames[..window]
        .iter()
        .map(|frame| mean_abs_difference(frame, &converged, &mask))
        .collect();
    let before_window = window.saturating_sub(options.converged_frames as usize);
    let converged_drift = if before_window < window {
        mean_abs_difference(
            &mean_image(&frames[before_window..window]),
            &converged,
            &mask,
        )
    } else {
        0.0
    };
    let black = vec![0.0; converged.len()];
    let floor = error_floor(&errors, options.converged_frames as usize);
    Ok(Settle {
        floor,
        floor_frames: floor.and_then(|floor| frames_to_floor(&errors, floor)),
        scene: name,
        converged_luminance: mean_abs_difference(&converged, &black, &mask),
        light_change: mean_abs_difference(&before, &converged, &mask),
        noise,
        threshold,
        converged_drift,
        settle_frames: settle_frames(&errors, threshold),
        errors,
    })
}

impl StabilityReport {
    pub fn table(&self) -> String {
        let o = &self.options;
        let mut out = format!(
            "{}x{}, {} still warm-up frames, flicker over {} frames; settle: light \
             {}, {} frames, converged = mean of the last {}, threshold = {} x their \
             frame-to-frame noise\n\n",
            o.size.0,
            o.size.1,
            o.warmup,
            o.frames,
            match o.change {
                SettleChange::Turn => format!("turned {} deg", o.light_turn_deg),
                SettleChange::Off => "switched off".to_owned(),
                SettleChange::On => "switched on".to_owned(),
                SettleChange::Move => format!(
                    "unchanged, node '{}' moved away (figures over the pixels it left)",
                    o.move_node.as_deref().unwrap_or("")
                ),
                SettleChange::EmissiveOff => {
                    "unchanged, the brightest emissive material switched off".to_owned()
                }
            },
            o.settle_frames,
            o.converged_frames,
            o.settle_k,
        );
        if o.flicker {
            out += "| tier | case | scene | static pixels | flicker (mean abs dL) | \
                    mean L | relative |\n|---|---|---|---:|---:|---:|---:|\n";
        }
        for run in &self.runs {
            for case in &run.flicker {
                let c = &case.change;
                out += &format!(
                    "| {} | {} | {} | {} | {:.5} | {:.5} | {} |\n",
                    run.variant.name(),
                    case.case,
                    case.scene,
                    c.pixels,
                    c.mean_abs_change(),
                    c.mean_luminance(),
                    c.relative()
                        .map_or("-".to_owned(), |r| format!("{:.2}%", r * 100.0)),
                );
            }
        }
        out += "\n| tier | scene | change | light change | noise | threshold | converged drift | \
                settle frames | error floor | frames to the floor | left after 4 | left after 8 | \
                resolved within 8 |\n\
                |---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for run in &self.runs {
            let s = &run.settle;
            let share = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.0}%", v * 100.0));
            out += &format!(
                "| {} | {} | {} | {:.5} | {:.5} | {:.5} | {:.5} | {} | {} | {} | {} | {} | {} |\n",
                run.variant.name(),
                s.scene,
                o.change.name(),
                s.light_change,
                s.noise,
                s.threshold,
                s.converged_drift,
                s.settle_frames
                    .map_or("not settled".to_owned(), |n| n.to_string()),
                s.floor.map_or("-".to_owned(), |f| format!("{f:.5}")),
                s.floor_frames.map_or("-".to_owned(), |n| n.to_string()),
                share(s.left_after(4)),
                share(s.left_after(8)),
                share(s.resolved_within(8)),
            );
            if s.light_change <= s.threshold {
                out += &format!(
                    "\nwarning ({}): turning the light changed the converged GI by no more \
                     than the threshold; the settle time measures nothing\n",
                    run.variant.name()
                );
            }
            if s.converged_drift > s.threshold {
                out += &format!(
                    "\nwarning ({}): the GI still drifted by more than the threshold between \
                     the converged window and the one before it; the settle time is a lower \
                     bound (raise --settle-frames)\n",
                    run.variant.name()
                );
            }
        }
        out += &format!(
            "\nGI ms per frame around the light change (GPU timestamps, a run of its own with no \
             frame read back): median of the last (up to) {COST_WINDOW} warm-up frames before \
             it, of the first {COST_WINDOW} after it, \
             the most expensive frame after it, the converged window's median, the frames \
             until the time is back within 10% of the frames before for good (elevated) and \
             until the first run above it ends (relighting)\n\n\
             | tier | scene | clock settling | before | first after | peak | converged | frames \
             elevated | relighting |\n|---|---|---|---:|---:|---:|---:|---:|---:|\n"
        );
        for run in &self.runs {
            let (s, c) = (&run.settle, &run.cost);
            out += &format!(
                "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} |\n",
                run.variant.name(),
                s.scene,
                clock_note(&c.clock),
                c.before_ms,
                c.first_ms,
                c.peak_ms,
                c.converged_ms,
                c.elevated_frames
                    .map_or("not back".to_owned(), |n| n.to_string()),
                c.relight_frames
                    .map_or("not back".to_owned(), |n| n.to_string()),
            );
        }
        out
    }

    pub fn json(&self) -> serde_json::Value {
        let o = &self.options;
        serde_json::json!({
            "width": o.size.0,
            "height": o.size.1,
            "warmup": o.warmup,
            "frames": o.frames,
            "depth_tolerance": DEPTH_TOLERANCE,
            "settle_options": {
                "change": o.change.name(),
                "light_turn_deg": o.light_turn_deg,
                "move_node": o.move_node,
                "move_by": o.move_by.map(|v| v.to_array()),
                "settle_frames": o.settle_frames,
                "converged_frames": o.converged_frames,
                "k": o.settle_k,
                "clock_settle_s": o.clock_settle_s,
            },
            "runs": self.runs.iter().map(|run| serde_json::json!({
                "tier": run.variant.tier(),
                "screen_probes": run.variant.screen_probes(),
                "flicker": run.flicker.iter().map(|case| serde_json::json!({
                    "case": case.case,
                    "scene": case.scene,
                    "pixels": case.change.pixels,
                    "mean_abs_change": case.change.mean_abs_change(),
                    "mean_luminance": case.change.mean_luminance(),
                    "relative": case.change.relative(),
                })).collect::<Vec<_>>(),
                "settle": {
                    "scene": run.settle.scene,
                    "converged_luminance": run.settle.converged_luminance,
                    "light_change": run.settle.light_change,
                    "noise": run.settle.noise,
                    "threshold": run.settle.threshold,
                    "converged_drift": run.settle.converged_drift,
                    "settle_frames": run.settle.settle_frames,
                    "floor": run.settle.floor,
                    "floor_frames": run.settle.floor_frames,
                    "left_after_4": run.settle.left_after(4),
                    "left_after_8": run.settle.left_after(8),
                    "resolved_within_8": run.settle.resolved_within(8),
                    "errors": run.settle.errors,
                    "cost_ms": {
                        "clock_settle": {
                            "frames": run.cost.clock.frames,
                            "seconds": run.cost.clock.seconds,
                            "steady": run.cost.clock.steady,
                        },
                        "before": run.cost.before_ms,
                        "first_after": run.cost.first_ms,
                        "peak": run.cost.peak_ms,
                        "converged": run.cost.converged_ms,
                        "elevated_frames": run.cost.elevated_frames,
                        "relight_frames": run.cost.relight_frames,
                        "after": run.cost.after_ms,
                    },
                },
            })).collect::<Vec<_>>(),
        })
    }
}

/// The clock settling's frames and seconds, and whether it ended steady.
fn clock_note(clock: &Settled) -> String {
    if clock.frames == 0 {
        "none".to_owned()
    } else {
        format!(
            "{} frames, {:.1} s{}",
            clock.frames,
            clock.seconds,
            if clock.steady { "" } else { ", NOT steady" }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::{Settle, relight_frames};

    #[test]
    fn the_shares_left_and_resolved_follow_the_errors() {
        let settle = Settle {
            scene: "s".into(),
            converged_luminance: 1.0,
            light_change: 0.5,
            noise: 0.01,
            threshold: 0.02,
            converged_drift: 0.0,
            errors: vec![0.4, 0.3, 0.2, 0.1, 0.08, 0.07, 0.06, 0.05, 0.05],
            settle_frames: Some(5),
            floor: Some(0.05),
            floor_frames: Some(8),
        };
        // Frame 4 after the change: 0.1 of a 0.5 change is left.
        assert!((settle.left_after(4).unwrap() - 0.2).abs() < 1e-12);
        // Frame 8: 0.05 left of the 0.45 that could be resolved: all of it resolved.
        assert!((settle.resolved_within(8).unwrap() - 1.0).abs() < 1e-12);
        assert!((settle.resolved_within(2).unwrap() - 0.2 / 0.45).abs() < 1e-12);
        assert_eq!(settle.left_after(0), None);
        assert_eq!(settle.left_after(10), None);
        let unsettled = Settle {
            floor: None,
            ..settle
        };
        assert_eq!(unsettled.resolved_within(8), None);
    }

    #[test]
    fn the_relighting_ends_with_the_first_run_above_the_limit() {
        // Frame 0 still costs what the frames before did; frames 1-3 relight; frame 6 is a
        // lone noisy frame, which does not lengthen the relighting.
        let after = [1.0, 1.5, 1.6, 1.4, 1.0, 1.05, 1.3, 1.0];
        assert_eq!(relight_frames(&after, 1.1), Some(4));
        assert_eq!(relight_frames(&[1.0, 1.0], 1.1), Some(0));
        assert_eq!(relight_frames(&[1.0, 1.5, 1.5], 1.1), None);
        assert_eq!(relight_frames(&[], 1.1), Some(0));
    }
}
